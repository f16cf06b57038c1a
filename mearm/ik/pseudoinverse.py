r"""The Moore–Penrose pseudoinverse by SVD (paper §3, eq. 13), and its damped variant.

With :math:`J = U \Sigma V^T`,

.. math::
    J^+ b = \sum_i f(\sigma_i)\, v_i\, u_i^T b, \qquad
    f(\sigma) = \begin{cases} 0 & \sigma \le c\,\sigma_{\max} \\
    1/\sigma & \text{plain} \\ \sigma / (\sigma^2 + \lambda^2) & \text{damped} \end{cases}

The cutoff ``c`` (relative, like ``numpy.linalg.pinv``'s ``rcond``) makes a true
singularity (e.g. the EE on the base axis, where θ1 moves nothing) drop a direction
instead of dividing by zero. The damped form, :math:`J^T (J J^T + \lambda^2 I)^{-1} b`,
bounds the step near singular poses at the cost of a slower approach.

The SVD is Eigen's Householder-preconditioned Jacobi SVD through eigenpy (Pinocchio's own
binding): on a 3×4 matrix it costs about 2 µs, a fifth of ``numpy.linalg.svd``'s call
overhead, and this runs once per solver iteration.
"""

from __future__ import annotations

import eigenpy
import numpy as np

_THIN_UV = int(eigenpy.DecompositionOptions.ComputeThinU) | int(
    eigenpy.DecompositionOptions.ComputeThinV
)


class PseudoInverse:
    r"""Solve :math:`\Delta\theta = J^+ b` for a fixed matrix size.

    Args:
        rows: Rows of J.
        cols: Columns of J.
        cutoff: Singular values at or below ``cutoff`` × the largest count as zero [-].
        damping: λ of damped least squares, in J's units; 0 for the plain pseudoinverse.
    """

    def __init__(self, rows: int, cols: int, cutoff: float, damping: float = 0.0):
        if not cutoff > 0:
            raise ValueError(f"cutoff must be > 0, got {cutoff!r}")
        if not damping >= 0:
            raise ValueError(f"damping must be >= 0, got {damping!r}")
        self.cutoff = float(cutoff)
        self.damping = float(damping)
        svd_type = eigenpy.NoPrecondJacobiSVD if rows == cols else eigenpy.HhJacobiSVD
        #: Eigen's SVD object; ``svd.compute(J); svd.solve(b)`` is the plain J⁺ b.
        self.svd = svd_type(rows, cols, _THIN_UV)
        # Eigen treats σ as zero when σ <= threshold·σ_max: the same rule as the cutoff.
        self.svd.setThreshold(self.cutoff)
        self._lam2 = self.damping**2
        self.solve = self._solve_damped if self.damping > 0 else self._solve_plain

    def _solve_plain(self, J: np.ndarray, b: np.ndarray) -> np.ndarray:
        svd = self.svd
        svd.compute(J)
        return svd.solve(b)

    def _solve_damped(self, J: np.ndarray, b: np.ndarray) -> np.ndarray:
        svd = self.svd
        svd.compute(J)
        s = svd.singularValues()
        keep = s > self.cutoff * s[0]
        f = np.where(keep, s / (s * s + self._lam2), 0.0)
        return svd.matrixV() @ (f * (svd.matrixU().T @ b))

    def singular_values(self, J: np.ndarray) -> np.ndarray:
        """Singular values of J, largest first."""
        self.svd.compute(J)
        return np.array(self.svd.singularValues())
