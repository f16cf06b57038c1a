r"""Box-bounded least squares for small problems: the step that slides along joint limits.

.. math:: \min_x \|A x - b\|^2 \quad \text{s.t.} \quad l \le x \le u

At the optimum every variable is free or at one of its bounds; with the free ones solving
the least-squares problem left over. An active-set walk finds that set in a few small
least-squares solves (:func:`_active_set`, after Lawson and Hanson and Stark and
Parker's BVLS): from x = 0, solve for the free variables; if that leaves the box, go
as far as the box allows and fix the variables that reach a bound; once inside, free
the fixed variable whose gradient points into the box. It stops when the KKT conditions
hold — then x is *the* optimum, the problem being convex — or after a bounded number of
solves. About 20–40 µs for three variables. A variable whose column is nought to
rounding (it moves nothing) stays at 0, the least-norm choice, and the walk solves the
others.

Where it cannot certify an answer (A without full column rank, where the minimiser is
not unique, or a walk that does not settle) every one of the 3ⁿ active sets is solved at
once and the best feasible one kept (27 for three, 729 for six; sets with the same free
variables share one pseudoinverse, one batched SVD): exact, about 0.1 ms for three
variables and under a millisecond for six. The safeguard of :class:`~mearm.ik.PdPij`
uses it only on the updates that touch a limit.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt

_FEASIBLE_SLACK = 1e-12
#: A pivot below this share of the largest diagonal of AᵀA counts as zero [-].
_RANK_TOL = 1e-10
#: Residuals within this share of |b|² of the best count as equal [-] (rounding is ~1e-16).
_TIE = 1e-12
#: A column under this share of the longest one's norm moves nothing [-]: a wrist roll's
#: column, for a target of a position and an approach axis, is 1e-16 of it (rounding).
_DEAD_COLUMN = 1e-12


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
    x = _active_set(A, b, lo, hi)
    if x is not None:
        return x
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


def _solve_spd(G: list[list[float]], r: list[float], idx: list[int]) -> list[float] | None:
    """Solve ``G[idx, idx] z = r`` by Gaussian elimination with partial pivoting.

    ``None`` if the block is singular to working precision.
    """
    k = len(idx)
    M = [[G[i][j] for j in idx] + [r[a]] for a, i in enumerate(idx)]
    big = max(abs(M[a][a]) for a in range(k))
    for col in range(k):
        piv = max(range(col, k), key=lambda a: abs(M[a][col]))
        if not abs(M[piv][col]) > _RANK_TOL * big:
            return None
        M[col], M[piv] = M[piv], M[col]
        row = M[col]
        for a in range(col + 1, k):
            f = M[a][col] / row[col]
            if f:
                Ma = M[a]
                for j in range(col, k + 1):
                    Ma[j] -= f * row[j]
    z = [0.0] * k
    for a in range(k - 1, -1, -1):
        row = M[a]
        v = row[k]
        for j in range(a + 1, k):
            v -= row[j] * z[j]
        z[a] = v / row[a]
    return z


def _active_set(A: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray | None:
    """The box-bounded least-squares optimum by an active-set walk, or ``None``.

    Works on the normal equations :math:`G = A^T A`, :math:`c = A^T b` in Python floats
    (n ≤ 6: a NumPy call costs more than the arithmetic). ``None`` when it cannot certify
    the answer: a free set whose columns are not independent (the optimum need not be
    unique, and the caller's tie rule decides), or more than ``3 n + 3`` solves.
    """
    n = A.shape[1]
    G = (A.T @ A).tolist()
    c = (A.T @ b).tolist()
    L, U = lo.tolist(), hi.tolist()
    scale = max(max(abs(v) for v in row) for row in G) * (max(map(abs, c)) + 1.0)
    tol = 1e-12 * scale
    x = [0.0] * n
    # a variable whose column is nought to rounding fits as well anywhere in its box: it
    # stays at 0 (the least-norm choice) and is never freed (its gradient is nought too)
    longest = max(G[i][i] for i in range(n))
    free = [G[i][i] > _DEAD_COLUMN**2 * longest for i in range(n)]
    for _ in range(3 * n + 3):
        idx = [i for i in range(n) if free[i]]
        z = list(x)
        if idx:
            rhs = [c[i] - sum(G[i][j] * x[j] for j in range(n) if not free[j]) for i in idx]
            sol = _solve_spd(G, rhs, idx)
            if sol is None:
                return None
            for a, i in enumerate(idx):
                z[i] = sol[a]
        alpha, first = 1.0, -1
        for i in idx:  # as far towards z as the box allows
            d = z[i] - x[i]
            if z[i] < L[i] and d < 0:
                step = (L[i] - x[i]) / d
            elif z[i] > U[i] and d > 0:
                step = (U[i] - x[i]) / d
            else:
                continue
            if step < alpha or first < 0:
                alpha, first = min(max(step, 0.0), 1.0), i
        if first >= 0:
            for i in idx:  # fix the variables that reach the bound they were heading for
                x[i] = min(max(x[i] + alpha * (z[i] - x[i]), L[i]), U[i])
                below = z[i] < L[i] and (i == first or x[i] <= L[i] + _FEASIBLE_SLACK)
                above = z[i] > U[i] and (i == first or x[i] >= U[i] - _FEASIBLE_SLACK)
                if below or above:
                    x[i], free[i] = (L[i] if below else U[i]), False
            continue
        x = z
        # a fixed variable may leave its bound when the gradient points into the box
        best, pull = -1, tol
        for i in range(n):
            if free[i]:
                continue
            g = sum(G[i][j] * x[j] for j in range(n)) - c[i]
            into = -g if x[i] <= L[i] else g if x[i] >= U[i] else 0.0
            if into > pull:
                best, pull = i, into
        if best < 0:
            return np.array([min(max(v, L[i]), U[i]) for i, v in enumerate(x)])
        free[best] = True
    return None
