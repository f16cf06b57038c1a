r"""Box-bounded least squares for small problems: the step that slides along joint limits.

.. math:: \min_x \|A x - b\|^2 \quad \text{s.t.} \quad l \le x \le u

At the optimum every variable is free or at one of its bounds; with the free ones solving
the least-squares problem left over. With n variables there are 3ⁿ such active sets (27
for three, 729 for six), so all are solved at once and the best feasible one is kept:
exact, with no iteration to tune. Sets with the same free variables share one
pseudoinverse, so it takes 2ⁿ of them (one batched SVD): about 0.1 ms for three
variables and under a millisecond for six. The safeguard of
:class:`~mearm.ik.PdPij` uses it only on the rare updates that touch a limit.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt

_FEASIBLE_SLACK = 1e-12
#: Residuals within this share of |b|² of the best count as equal [-] (rounding is ~1e-16).
_TIE = 1e-12


def _active_sets(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3ⁿ active sets, the 2ⁿ free patterns and each set's pattern.

    Sets: (3ⁿ, n), 0 free, 1 at the lower bound, 2 at the upper bound. Patterns:
    (2ⁿ, n) bool, True where free. Pattern of set k: the row of its free variables.
    """
    sets = np.array(list(itertools.product((0, 1, 2), repeat=n)), dtype=np.int8)
    patterns = np.array(list(itertools.product((False, True), repeat=n)))
    weights = 1 << np.arange(n - 1, -1, -1)  # a pattern's row number, read as binary
    return sets, patterns, (sets == 0).astype(np.int64) @ weights


#: The most variables handled: 3⁶ = 729 active sets.
MAX_VARIABLES = 6
_SETS: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


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
        (n,) the minimiser, within the bounds; among equal residuals (within rounding)
        the one of least norm, so a singular A stays finite and a variable that changes
        nothing stays at 0.
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
    cached = _SETS.get(n)
    if cached is None:
        cached = _SETS[n] = _active_sets(n)
    sets, patterns, pattern_of = cached  # (k, n), (2ⁿ, n), (k,)
    fixed = np.where(sets == 1, lo, np.where(sets == 2, hi, 0.0))  # (k, n)
    A_free = A[None, :, :] * patterns[:, None, :]  # (2ⁿ, m, n), fixed columns zeroed
    rhs = b[None, :] - fixed @ A.T  # (k, m)
    x = fixed + np.einsum("knm,km->kn", np.linalg.pinv(A_free)[pattern_of], rhs)
    feasible = np.all((x >= lo - _FEASIBLE_SLACK) & (x <= hi + _FEASIBLE_SLACK), axis=1)
    residual = np.sum((x @ A.T - b[None, :]) ** 2, axis=1)
    residual[~feasible] = np.inf
    # Ties within rounding (a variable whose column is zero, as a wrist roll's for a
    # position target, fits as well free as on either bound): the least-norm x, which
    # leaves such a variable at 0 as the pseudoinverse does.
    ties = residual <= residual.min() + _TIE * float(b @ b)
    norms = np.where(ties, np.einsum("kn,kn->k", x, x), np.inf)
    best = int(np.argmin(norms))
    return np.clip(x[best], lo, hi)
