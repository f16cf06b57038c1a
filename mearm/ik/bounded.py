r"""Box-bounded least squares for small problems: the step that slides along joint limits.

.. math:: \min_x \|A x - b\|^2 \quad \text{s.t.} \quad l \le x \le u

At the optimum every variable is free or at one of its bounds; with the free ones solving
the least-squares problem left over. With n variables there are 3ⁿ such active sets (27
for three, 729 for six), so all are solved at once (one batched pseudoinverse) and the
best feasible one is kept: exact, with no iteration to tune, in a few tenths of a
millisecond for three variables and a few milliseconds for six. The safeguard of
:class:`~mearm.ik.PdPij` uses it only on the rare updates that touch a limit.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt

_FEASIBLE_SLACK = 1e-12


def _active_sets(n: int) -> np.ndarray:
    # (3**n, n): 0 free, 1 at the lower bound, 2 at the upper bound
    return np.array(list(itertools.product((0, 1, 2), repeat=n)), dtype=np.int8)


#: The most variables handled: 3⁶ = 729 active sets.
MAX_VARIABLES = 6
_SETS: dict[int, np.ndarray] = {}


def bounded_lstsq(
    A: npt.ArrayLike, b: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike
) -> np.ndarray:
    """Solve ``min |A x − b|`` with ``lower <= x <= upper`` exactly (n ≤ 6 variables).

    Args:
        A: (m, n) matrix.
        b: (m,) right-hand side.
        lower: (n,) lower bounds, each ≤ 0 ≤ upper (x = 0 is feasible).
        upper: (n,) upper bounds.

    Returns:
        (n,) the minimiser, within the bounds; among equal residuals the one with the
        smallest norm of its free part (pseudoinverse), so a singular A stays finite.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    lo = np.asarray(lower, dtype=float)
    hi = np.asarray(upper, dtype=float)
    n = A.shape[1]
    if not 1 <= n <= MAX_VARIABLES:
        raise ValueError(f"bounded_lstsq handles 1 to {MAX_VARIABLES} variables, got {n}")
    if not (np.all(lo <= 0.0) and np.all(hi >= 0.0)):
        raise ValueError("x = 0 must be feasible: lower <= 0 <= upper")
    sets = _SETS.get(n)
    if sets is None:
        sets = _SETS[n] = _active_sets(n)  # (k, n)
    free = sets == 0
    fixed = np.where(sets == 1, lo, np.where(sets == 2, hi, 0.0))  # (k, n)
    A_free = A[None, :, :] * free[:, None, :]  # (k, m, n), fixed columns zeroed
    rhs = b[None, :] - fixed @ A.T  # (k, m)
    x = fixed + np.einsum("knm,km->kn", np.linalg.pinv(A_free), rhs)
    feasible = np.all((x >= lo - _FEASIBLE_SLACK) & (x <= hi + _FEASIBLE_SLACK), axis=1)
    residual = np.sum((x @ A.T - b[None, :]) ** 2, axis=1)
    residual[~feasible] = np.inf
    best = int(np.argmin(residual))  # the all-free set comes first: ties keep it
    return np.clip(x[best], lo, hi)
