"""An upright object's top face on its own plane: the face's shape and the 2-D fits.

The fits place a circle (free radius, or a known one) or a rigid polygon nearest points
on the plane of the top face [cm]; :class:`~mearm.vision.pinhole.PerspectiveCamera`
chooses the points (the far side of the outline) and casts them onto that plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np


def _fit_circle(pts: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle through points (N ≥ 3, (N, 2)): centre, radius.

    The algebraic (Kåsa) fit, refined by Gauss–Newton on the geometric distances.
    """
    A = np.column_stack([2 * pts, np.ones(len(pts))])
    b = np.sum(pts**2, axis=1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:2]
    r = math.sqrt(max(sol[2] + c @ c, 1e-18))
    for _ in range(10):
        d = pts - c
        dist = np.linalg.norm(d, axis=1)
        dist = np.where(dist < 1e-12, 1e-12, dist)
        J = np.column_stack([-d / dist[:, None], -np.ones(len(pts))])
        res = dist - r
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        c = c + step[:2]
        r = r + step[2]
        if np.abs(step).max() < 1e-10:
            break
    return c, float(r)


@dataclass(frozen=True)
class TopFace:
    """An upright object's top face seen from above, around its centre [cm].

    Attributes:
        radius_cm: A disc's radius; a polygon's farthest corner from its centre.
        corners_cm: A polygon's corners at no turn, (K, 2); ``None``: a disc.
        symmetry_deg: A polygon looks the same turned by this [deg].
    """

    radius_cm: float
    corners_cm: np.ndarray | None = None
    symmetry_deg: float = 0.0


class TopFit(NamedTuple):
    """An upright object's top face fitted to its outline (:meth:`PerspectiveCamera.fit_top`).

    Attributes:
        centre_cm: Where the object stands, base frame (x, y) [cm], (2,).
        rms_cm: The far side's rms distance from the fitted face [cm] (∞: no fit).
        yaw_deg: A polygon's turn on the table, from the base frame's x axis towards y,
            modulo its symmetry [deg]; ``None`` for a disc or when no fit was made.
    """

    centre_cm: np.ndarray
    rms_cm: float
    yaw_deg: float | None


def _fit_disc(pts: np.ndarray, radius: float, centre: np.ndarray) -> tuple[np.ndarray, float]:
    """The centre of a circle of ``radius`` nearest ``pts`` (Gauss–Newton): centre, rms."""
    c = np.asarray(centre, dtype=float).copy()
    for _ in range(10):
        d = pts - c
        dist = np.maximum(np.linalg.norm(d, axis=1), 1e-12)
        step, *_ = np.linalg.lstsq(-d / dist[:, None], radius - dist, rcond=None)
        c = c + step
        if np.abs(step).max() < 1e-7:
            break
    res = np.linalg.norm(pts - c, axis=1) - radius
    return c, float(math.sqrt(np.mean(res**2)))


def _nearest_on_sides(pts: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Each point's nearest point on the sides of a closed polygon, (N, 2)."""
    a = corners
    ab = np.concatenate([corners[1:], corners[:1]]) - a  # (K, 2)
    ap = pts[:, None, :] - a[None]  # (N, K, 2)
    t = np.clip(np.einsum("nkd,kd->nk", ap, ab) / np.einsum("kd,kd->k", ab, ab), 0.0, 1.0)
    near = a[None] + t[..., None] * ab[None]  # (N, K, 2)
    d2 = np.einsum("nkd,nkd->nk", pts[:, None, :] - near, pts[:, None, :] - near)
    return near[np.arange(len(pts)), np.argmin(d2, axis=1)]


def _fit_polygon(
    pts: np.ndarray, corners: np.ndarray, centre: np.ndarray, yaw0: float
) -> tuple[np.ndarray, float, float]:
    """The pose of a rigid polygon whose sides pass nearest ``pts``: centre, yaw, rms.

    ``corners`` (K, 2) are around its centre at yaw 0; Gauss–Newton on the points'
    distances to their nearest points of the sides (``q``: d|p − q|/dc = −u and
    d|p − q|/dψ = −u · ⊥(q − c), u the unit vector from q to p), step halved while the
    sum of squares does not fall, from ``centre`` and ``yaw0`` [rad].
    """

    def placed(x: np.ndarray) -> np.ndarray:
        c, s = math.cos(x[2]), math.sin(x[2])
        return corners @ np.array([[c, s], [-s, c]]) + x[:2]

    def evaluate(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = _nearest_on_sides(pts, placed(x))
        return q, np.linalg.norm(pts - q, axis=1)

    x = np.array([centre[0], centre[1], yaw0], dtype=float)
    q, res = evaluate(x)
    for _ in range(30):
        u = (pts - q) / np.maximum(res, 1e-12)[:, None]
        r = q - x[:2]
        J = np.column_stack([-u, -(u[:, 0] * -r[:, 1] + u[:, 1] * r[:, 0])])
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        for _ in range(10):
            q_new, trial = evaluate(x + step)
            if float(trial @ trial) <= float(res @ res):
                break
            step = step / 2
        else:
            break
        x, q, res = x + step, q_new, trial
        if np.abs(step).max() < 1e-8:
            break
    return x[:2], float(x[2]), float(math.sqrt(np.mean(res**2)))
