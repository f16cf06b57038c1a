r"""Timing: a planned joint path as servo commands that no servo's speed limit can outrun.

A route's plan (an IK solve, or a straight line in joint space) is a polyline of checked
poses. It is followed as it is, never shortcut: every pose sent lies on that polyline. The
polyline is measured by the time it would take at full speed,

.. math:: d\sigma = \max_i \frac{|dv_i|}{\dot v_{i,max}} \quad [s],

with :math:`v_i` the value servo i turns (its joint :math:`q_i`, or a combination
:math:`\sum_j a_{ij} q_j` such as the MeArm's forearm angle), so along it each servo moves
:math:`|dv_i/d\sigma| \le \dot v_{i,max}`, and a path speed :math:`\dot\sigma \le 1`
keeps every servo within its speed limit (an acceleration limit :math:`\ddot v_{i,max}`
holds along each segment when :math:`|\ddot\sigma| \le \min_i \ddot v_{i,max}/\dot
v_{i,max}`). The time law :math:`\sigma(t)`, from rest to rest, is a one-degree-of-freedom
Ruckig trajectory, its duration a whole number of servo periods; sampling it every period
gives the commands, each step at most :math:`\dot v_{i,max}/f` for every servo (checked
before any is sent).

Why Ruckig (``ruckig``) and not TOPP-RA (``toppra``): Ruckig is one small compiled
extension with no dependencies that imports in about a millisecond, while ``toppra``
imports SciPy's interpolation and Matplotlib (≈ 2 s here, twice the whole sort's CPU
budget); and the speed guarantee needs only a scalar time law along the polyline, which
Ruckig computes exactly (time-optimal under velocity, acceleration and jerk limits, with
a duration discretised to the control period) rather than on a grid. Without an
acceleration limit the law is :math:`\dot\sigma = 1` throughout: each segment at the speed
of its slowest joint, the fastest the servos can follow this path.

Between two commands a servo moves on the chord between them: within the joint limits
(box-shaped limits and linear couplings are convex) and within one step of the polyline.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm import interrupts
from mearm.config import ArmDescription, Tool
from mearm.kinematics import Chain

# Ctrl-C after the import, not in it: pybind11 turns a KeyboardInterrupt raised while
# Ruckig's module sets itself up into a C++ exception nothing catches, and the process
# aborts ("terminate called ... what(): Traceback", seen once in the suite's Ctrl-C at a
# sort's start on a loaded machine) where it should say "interrupted" and exit 130.
with interrupts.signals_deferred():
    import ruckig  # type: ignore[import-not-found]  # a compiled module without stubs

#: Relative slack of the step check (Ruckig's floating-point time law) [-].
STEP_RTOL = 1e-9


@dataclass(frozen=True)
class SpeedLimits:
    """Each joint servo's speed and acceleration limit, model units.

    A servo turns its joint, or a linear combination of the actuated joints (the
    MeArm's elbow servo sets the forearm's angle, shoulder + elbow): its limits hold for
    the value it turns, :attr:`drive` times the actuated joints.

    Attributes:
        velocity: Largest speed of each servo's value [rad/s or m/s], (m,).
        acceleration: Largest acceleration [rad/s² or m/s²], (m,); ``inf`` where the
            config gives none.
        drive: Each servo's value rate per actuated joint rate, (m, m); the identity
            when every servo turns its own joint.
    """

    velocity: np.ndarray
    acceleration: np.ndarray
    drive: np.ndarray | None = None

    @classmethod
    def of_arm(cls, arm: ArmDescription, chain: Chain) -> SpeedLimits:
        """The limits the config's servo calibrations give the chain's actuated joints."""
        scale = chain.scale[chain.actuated_index]
        servos = {j.name: j.servo for j in arm.joints if j.servo is not None}
        column = {name: k for k, name in enumerate(chain.actuated)}
        velocity, acceleration = [], []
        drive = np.eye(len(chain.actuated))
        for i, name in enumerate(chain.actuated):
            servo = servos[name]
            velocity.append(servo.max_speed())
            accel = servo.max_accel()
            acceleration.append(math.inf if accel is None else accel)
            if servo.drives is not None:
                drive[i] = 0.0
                for joint, a in servo.drives.terms.items():  # v = Σ a_j q_j, config units
                    drive[i, column[joint]] = a * scale[i] / scale[column[joint]]
        combined = not np.array_equal(drive, np.eye(len(chain.actuated)))
        return cls(
            np.array(velocity) * scale,
            np.array(acceleration) * scale,
            drive if combined else None,
        )

    def values(self, actuated: np.ndarray) -> np.ndarray:
        """The servos' values (less their offsets) for actuated joints, (..., m)."""
        return actuated if self.drive is None else actuated @ self.drive.T


@dataclass(frozen=True)
class TimedPath:
    """A path sampled at the servo rate.

    Attributes:
        q: The start pose, then one pose per servo period (full joints, model units),
            (k + 1, n); the last is the path's end.
        period_s: Time between two poses [s].
    """

    q: np.ndarray
    period_s: float

    @property
    def duration_s(self) -> float:
        """How long the move takes: one period per command [s]."""
        return (len(self.q) - 1) * self.period_s


def time_path(
    q_path: npt.ArrayLike, chain: Chain, limits: SpeedLimits, rate_hz: float
) -> TimedPath:
    """Sample a planned path at ``rate_hz`` within every servo's speed limit.

    Args:
        q_path: The planned poses, full joints, model units, (k, n); every pose within
            the limits.
        chain: The arm's joints.
        limits: The actuated joints' limits.
        rate_hz: Commands per second [Hz].

    Returns:
        The poses to send: points of the polyline through ``q_path``, from rest to rest.

    Raises:
        ValueError: a pose leaves the joint limits or a step outruns a speed limit (a
            bug: neither can happen to a path of checked poses).
    """
    q = np.asarray(q_path, dtype=float)
    period = 1.0 / rate_hz
    a = chain.actuated_of(q)  # (k, m)
    # time per segment per servo [s]
    seg = np.abs(np.diff(limits.values(a), axis=0)) / limits.velocity
    tau = seg.max(axis=1) if len(a) > 1 else np.zeros(0)
    keep = np.concatenate([[True], tau > 0])
    knots_a = a[keep]
    sigma = np.concatenate([[0.0], np.cumsum(tau[tau > 0])])
    total = float(sigma[-1])
    if total <= 0:
        return TimedPath(q[:1].copy(), period)
    s = _time_law(total, _path_accel(limits), period)
    samples_a = np.stack(
        [np.interp(s, sigma, knots_a[:, i]) for i in range(knots_a.shape[1])], axis=1
    )
    samples = samples_a @ chain.C.T + chain.c
    samples[0] = q[0]
    _check(samples, chain, limits, period)
    return TimedPath(samples, period)


def _path_accel(limits: SpeedLimits) -> float:
    r"""The largest :math:`|\ddot\sigma|` keeping every joint within its acceleration [1/s]."""
    return float(np.min(limits.acceleration / limits.velocity))


def _time_law(total_s: float, accel: float, period_s: float) -> np.ndarray:
    """σ at every period from 0 to the end of the move, (k + 1,), rest to rest.

    A one-DOF Ruckig trajectory from σ = 0 to ``total_s`` with σ̇ ≤ 1 and
    |σ̈| ≤ ``accel``, its duration a whole number of periods.
    """
    otg = ruckig.Ruckig(1, period_s)
    inp = ruckig.InputParameter(1)
    inp.current_position = [0.0]
    inp.target_position = [total_s]
    inp.max_velocity = [1.0]
    inp.max_acceleration = [accel]
    inp.max_jerk = [math.inf]
    inp.duration_discretization = ruckig.DurationDiscretization.Discrete
    trajectory = ruckig.Trajectory(1)
    result = otg.calculate(inp, trajectory)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise ValueError(f"no time law for a {total_s:.4g} s path: Ruckig says {result}")
    k = max(1, round(trajectory.duration / period_s))
    s = np.array([trajectory.at_time(i * period_s)[0][0] for i in range(k + 1)])
    s = np.clip(np.maximum.accumulate(s), 0.0, total_s)  # never back, never beyond
    s[-1] = total_s
    return s


def _check(samples: np.ndarray, chain: Chain, limits: SpeedLimits, period_s: float) -> None:
    """Refuse samples outside the joint limits or a step faster than a speed limit."""
    tol = 1e-6  # every pose at once, as :meth:`Chain.within_limits` checks one (NaN: outside)
    inside = np.all(samples >= chain.lower - tol, axis=1) & np.all(
        samples <= chain.upper + tol, axis=1
    )
    if not inside.all():
        q = samples[int(np.argmin(inside))]
        raise ValueError(f"timed path leaves the limits at {chain.named(q)}")
    step = np.abs(np.diff(limits.values(chain.actuated_of(samples)), axis=0))
    bound = limits.velocity * period_s * (1 + STEP_RTOL) + 1e-12
    if np.any(step > bound):
        k, i = (int(v) for v in np.argwhere(step > bound)[0])
        raise ValueError(
            f"timed path step {k} moves {chain.actuated[i]}'s servo faster than its speed limit "
            f"({step[k, i] / period_s:.4g} > {limits.velocity[i]:.4g} model units/s)"
        )


def tool_move_s(
    tool: Tool,
    before: Mapping[str, float] | None,
    after: Mapping[str, float],
    *,
    before_closed: bool | None,
    after_closed: bool,
) -> float:
    """How long a tool setting takes: its slowest servo's travel, then ``tool.settle_s`` [s].

    Each tool actuator turns at its servo's speed limit, the gripper travels between its
    open and closed openings at its own; nothing changed takes no time.

    Args:
        tool: The tool (actuators, gripper, settle time).
        before: Each tool actuator's value before [deg], or ``None`` if unknown (then
            the setting takes the settle time only).
        before_closed: Whether the gripper was closed, or ``None`` if unknown.
        after: Each tool actuator's value to set [deg].
        after_closed: Whether the gripper closes.
    """
    if before is None or before_closed is None:
        return tool.settle_s
    travel = [0.0]
    for actuator in tool.actuators:
        change = abs(after[actuator.name] - before.get(actuator.name, after[actuator.name]))
        travel.append(change / actuator.servo.max_speed())
    gripper = tool.gripper
    if before_closed != after_closed:
        travel.append(abs(gripper.open_cm - gripper.closed_cm) / gripper.servo.max_speed())
    slowest = max(travel)
    return slowest + tool.settle_s if slowest > 0 else 0.0


@dataclass
class MotionTime:
    """The predicted motion time of a run: what the servos are commanded to do.

    Attributes:
        arm_s: Streamed joint motion at the servos' speed limits [s].
        tool_s: Tool settings: the gripper and tool actuators' travel and settling [s].
        tool_moves: Tool settings that moved something.
        wait_s: Time spent after a move's last command waiting for the measured joints
            to arrive (on a bus that measures them: the twin) [s].
        stream_hz: Commands per second the bus streams at: ``servo.rate_hz``, or fewer
            where the link needs longer for one [Hz].
        rest_s: Time the arm held still while the camera looked again at an object
            found moved, until it lay still (``TableTracking._look_at_rest``) [s].
    """

    stream_hz: float
    arm_s: float = 0.0
    tool_s: float = 0.0
    tool_moves: int = 0
    wait_s: float = 0.0
    rest_s: float = 0.0

    @property
    def total_s(self) -> float:
        """Arm, tool and waits together (none overlaps: the arm holds while the tool moves) [s]."""
        return self.arm_s + self.tool_s + self.wait_s + self.rest_s

    def line(self) -> str:
        """``motion 20.1 s (arm … at the servos' speed limits, …; tool … )``."""
        waits = (
            f"; {self.wait_s:.1f} s waiting for the measured joints to arrive"
            if self.wait_s > 0
            else ""
        )
        if self.rest_s > 0:
            waits += f"; {self.rest_s:.1f} s waiting for a moved object to lie still"
        return (
            f"motion {self.total_s:.1f} s (arm {self.arm_s:.1f} s at the servos' speed limits, "
            f"streamed at {self.stream_hz:.3g} Hz; gripper and tool {self.tool_s:.1f} s for "
            f"{self.tool_moves} settings with settling{waits})"
        )
