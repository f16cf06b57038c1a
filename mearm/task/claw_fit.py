r"""Each joint servo's true pulse mapping, fitted to where the camera sees the claw's marker.

A hobby servo turns its shaft by its own zero and scale, not the datasheet's; over the arm
those errors add up to centimetres at the claw. The camera measures them: with the arm
held at a pose, the pulses sent to each joint servo :math:`p_k` are known, and the
calibrated camera sees the four corners of the claw's marker (:mod:`mearm.vision.claw_marker`).
Each servo :math:`k` turns its value (its joint, or the MeArm elbow servo's combination)
to

.. math:: v_k = (p_k - z_k) / s_k

with :math:`z_k` its zero pulse and :math:`s_k` its signed µs per unit (direction ×
``us_per_unit``). The actuated joints follow, :math:`q_a = A^{-1}(v - a)`
(:attr:`~mearm.hardware.mapping.ServoMap.combination`), the marker's corners
:math:`X_j(q)` from the forward kinematics and the marker's place on the tool, and the
fit is the least-squares one over every pose and corner of the pixel residuals

.. math:: r_{ij} = \pi\big(X_j(q(p_i; z, s))\big) - u_{ij}

(:math:`\pi` the calibrated camera's projection, distortion included). Residuals in
pixels weigh each corner as the camera measures it; no depth is taken from the marker's
apparent size alone. With few poses only the zeros are fitted (``scales=False``): one
pose's eight numbers settle the zeros of three servos, and scales need poses spread over
each joint's range.

**The marker's apparent side.** The camera looks down on the marker, so its height is
its depth along the ray, and one view tells depth mostly by the marker's apparent size:
a marker seen 0.5 % smaller (0.19 px on a 35 px half-diagonal) is placed 0.15 cm lower.
The print's scale and the detector's corners (on the twin's renders 0.13–0.19 px inside
the black square's edges, kits 32, 36, 37, 41) make it look smaller or larger by about
that much at every pose; fitted with the printed side, the servos take the difference
for a shoulder and elbow error (the fit's weakest direction: the shoulder's zero and
slope against the elbow's zero), and picks lower and farther out than the poses end
0.06–0.13 cm high. So a calibration (``fit_side``) fits with the scales one more
parameter, the side as a factor :math:`\sigma` of the printed one (corners
:math:`c + \sigma (X_j - c)` about the marker's centre :math:`c`), within
:data:`SIDE_RANGE`; a fit of the zeros alone keeps the side last found (:meth:`use_side`).

The result is a servo calibration in the same terms as the keyboard procedure's
(:mod:`mearm.config.servo_file`): ``zero_us`` = :math:`z_k`, ``direction`` = sign
:math:`s_k`, ``us_per_unit`` = :math:`|s_k|`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from mearm.hardware.mapping import ActuatorMap, ServoMap
from mearm.kinematics import ArmModel
from mearm.vision.claw_marker import square_corners
from mearm.vision.pinhole import PerspectiveCamera

#: The largest change of a servo's µs per unit a fit may make, as a fraction of the
#: datasheet's: real units span 8.1–11.5 µs/° against 10 (servo_kit's sourced ranges),
#: so a fit beyond ±35 % has found something other than the servo (a slipped horn, the
#: wrong marker).
MAX_SCALE_CHANGE = 0.35
#: How far the marker's apparent side may be from its printed one, a factor [-]: a
#: print's scale and a detector's edge bias (a pixel at most on a 40 px side) stay well
#: inside 5 %; more is a wrong ``size_cm``.
SIDE_RANGE = (0.95, 1.05)


@dataclass(frozen=True)
class Sighting:
    """The claw marker seen at one pose.

    Attributes:
        pulses_us: The pulse each joint servo held, by actuated joint name [µs].
        corners_px: The marker's corners in the frame (TL, TR, BR, BL), (4, 2) [px].
    """

    pulses_us: Mapping[str, float]
    corners_px: np.ndarray


@dataclass(frozen=True)
class ServoFit:
    """A fitted set of joint servo mappings.

    Attributes:
        servos: Each joint servo's mapping with the fitted zero, direction and µs per unit.
        residuals_px: Each sighting's RMS corner residual [px], (N,).
        rms_px: The RMS over every corner [px].
        scales: Whether the scales were fitted (else only the zeros).
        side: The marker's apparent side the fit used or found, a factor of its printed
            side [-] (module docstring).
    """

    servos: tuple[ActuatorMap, ...]
    residuals_px: np.ndarray
    rms_px: float
    scales: bool
    side: float = 1.0


class ClawCamera:
    """Where the calibrated camera sees the claw's marker for given joint servo mappings.

    Args:
        model: The arm's kinematic model.
        servo_map: The arm's servo mapping (its joint servos' combinations and the
            starting guess of each mapping).
        marker_in_tcp: The marker's face in the TCP frame, (4, 4) [m]
            (:func:`~mearm.kinematics.bodies.marker_in_tcp`).
        side_cm: The marker's printed side [cm].
        camera: The calibrated camera.
        fit_side: Fit the marker's apparent side with the scales (module docstring).

    Attributes:
        side: The apparent side the predictions use, a factor of the printed one [-]
            (1 until a fit that found one is used: :meth:`use_side`).
    """

    def __init__(
        self,
        model: ArmModel,
        servo_map: ServoMap,
        marker_in_tcp: np.ndarray,
        side_cm: float,
        camera: PerspectiveCamera,
        *,
        fit_side: bool = False,
    ):
        self.model = model
        self.fit_side = fit_side
        self.side = 1.0
        self.servo_map = servo_map
        self.camera = camera
        corners = square_corners(side_cm) / 100.0  # m
        self._corners_tcp = corners @ marker_in_tcp[:3, :3].T + marker_in_tcp[:3, 3]
        self._centre_tcp = self._corners_tcp.mean(axis=0)
        combo = servo_map.combination
        m = len(servo_map.joints)
        A, a = combo if combo is not None else (np.eye(m), np.zeros(m))
        self._a: np.ndarray = a
        self._A_inv: np.ndarray = np.linalg.inv(A)

    @property
    def names(self) -> tuple[str, ...]:
        """The joint servos' (actuated joints') names, chain order."""
        return self.servo_map.joint_names

    def start(self) -> np.ndarray:
        """The mapping the servo map holds, as fit parameters (z_0, s_0, z_1, s_1, …)."""
        return np.array(
            [v for j in self.servo_map.joints for v in (j.zero_us, j.direction * j.us_per_unit)]
        )

    def joints(self, pulses_us: Mapping[str, float], params: np.ndarray) -> np.ndarray:
        """The full joint vector (model units) the pulses turn servos of ``params`` to."""
        p = np.array([pulses_us[n] for n in self.names], dtype=float)
        z, s = params[0::2], params[1::2]
        values = (p - z) / s
        chain = self.model.chain
        q_a = self._A_inv @ (values - self._a) * chain.scale[chain.actuated_index]
        return chain.full(q_a)

    def corners_cm(self, q: np.ndarray, side: float | None = None) -> np.ndarray:
        """The marker's corners in the base frame at joints ``q`` [cm], (4, 3).

        ``side``: its apparent side, a factor of the printed one (default :attr:`side`).
        """
        side = self.side if side is None else side
        c = self._corners_tcp
        if side != 1.0:
            c = self._centre_tcp + (c - self._centre_tcp) * side
        p, R = self.model.tcp_pose(q)
        return (c * 100.0) @ R.T + p

    def centre_cm(self, q: np.ndarray) -> np.ndarray:
        """The marker's centre in the base frame at joints ``q`` [cm], (3,)."""
        return self.corners_cm(q).mean(axis=0)

    def pixels(self, q: np.ndarray) -> np.ndarray:
        """Where the camera sees the marker's corners at joints ``q`` [px], (4, 2)."""
        return self.camera.project(self.corners_cm(q))

    def residuals(
        self, sightings: Sequence[Sighting], params: np.ndarray, side: float | None = None
    ) -> np.ndarray:
        """Every sighting's corner residuals, flattened [px], (8 N,).

        ``side``: the marker's apparent side, a factor of the printed one (default
        :attr:`side`).
        """
        return np.concatenate(
            [
                (
                    self.camera.project(self.corners_cm(self.joints(s.pulses_us, params), side))
                    - s.corners_px
                ).ravel()
                for s in sightings
            ]
        )

    def use_side(self, fit: ServoFit) -> None:
        """Predict with the side ``fit`` found (a fit of the zeros keeps the present one)."""
        if fit.scales:
            self.side = fit.side

    def servo_maps(self, params: np.ndarray) -> tuple[ActuatorMap, ...]:
        """The joint servos' maps with the mapping of ``params``."""
        out = []
        for k, j in enumerate(self.servo_map.joints):
            z, s = float(params[2 * k]), float(params[2 * k + 1])
            out.append(
                dataclasses.replace(j, zero_us=z, direction=1 if s > 0 else -1, us_per_unit=abs(s))
            )
        return tuple(out)

    def fit(
        self, sightings: Sequence[Sighting], *, scales: bool, start: np.ndarray | None = None
    ) -> ServoFit:
        """The mappings that best explain ``sightings`` (module docstring).

        Args:
            sightings: At least one; with ``scales``, poses spread over each joint.
            scales: Fit each servo's µs per unit too (else only its zero), and with them
                the marker's apparent side where :attr:`fit_side`.
            start: Parameters to start from (default: the servo map's).
        """
        from scipy.optimize import least_squares  # lazy: scipy costs 0.7 s to import

        # the servos' (zero, scale) pairs, then the marker's side
        x0 = np.append(self.start() if start is None else np.asarray(start, dtype=float),
                       self.side)  # fmt: skip
        n = len(x0) - 1
        free = np.ones(len(x0), dtype=bool)
        if not scales:
            free[1:n:2] = False
        free[n] = scales and self.fit_side
        s0 = x0[1:n:2]
        lo, hi = np.full(len(x0), -np.inf), np.full(len(x0), np.inf)
        ref = np.abs(self.start()[1::2])
        lo[1:n:2] = np.where(s0 > 0, ref * (1 - MAX_SCALE_CHANGE), -ref * (1 + MAX_SCALE_CHANGE))
        hi[1:n:2] = np.where(s0 > 0, ref * (1 + MAX_SCALE_CHANGE), -ref * (1 - MAX_SCALE_CHANGE))
        lo[n], hi[n] = SIDE_RANGE

        def full(x: np.ndarray) -> np.ndarray:
            out = x0.copy()
            out[free] = x
            return out

        x_scale = np.where(np.arange(len(x0)) % 2 == 0, 10.0, 0.5)
        x_scale[n] = 0.01
        result = least_squares(
            lambda x: self.residuals(sightings, full(x)[:n], full(x)[n]),
            np.clip(x0[free], lo[free], hi[free]),
            bounds=(lo[free], hi[free]),
            x_scale=x_scale[free],
            method="trf",
        )
        x = full(result.x)
        params, side = x[:n], float(x[n])
        r = self.residuals(sightings, params, side).reshape(len(sightings), 4, 2)
        per = np.sqrt(np.mean(np.sum(r**2, axis=2), axis=1))
        rms = float(np.sqrt(np.mean(np.sum(r**2, axis=2))))
        return ServoFit(self.servo_maps(params), per, rms, scales, side)

    def params_of(self, servos: Sequence[ActuatorMap]) -> np.ndarray:
        """Fit parameters of joint servo maps (the inverse of :meth:`servo_maps`)."""
        return np.array([v for j in servos for v in (j.zero_us, j.direction * j.us_per_unit)])


def with_joint_servos(servo_map: ServoMap, servos: Sequence[ActuatorMap]) -> ServoMap:
    """``servo_map`` with its joint servos replaced by ``servos`` (same names, same order)."""
    names = tuple(s.name for s in servos)
    if names != servo_map.joint_names:
        raise ValueError(f"joint servos {names} are not the map's {servo_map.joint_names}")
    return dataclasses.replace(servo_map, joints=tuple(servos))
