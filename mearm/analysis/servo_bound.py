r"""The bound a kit's servos set at the picks: what no servo calibration removes.

A hobby servo ignores a target within its dead band :math:`d_i` of where its
potentiometer says it is (the twin: :mod:`mearm.sim.twin.twin_bus`, step 2), and the bus's
pulses come in whole µs. A pick that looks (:mod:`mearm.task.claw_loop`) aims the arm
off by the error :math:`e` it sees: the joint is asked to move by :math:`2e` from where it
is, and ignores it while :math:`|2e_i| \le d_i`. So even at its true calibration each joint
may end anywhere within :math:`\pm d_i/2` of its command (:math:`\pm d_i` where no look
corrects it), plus :math:`\pm q_i` (half a µs), and the TCP by

.. math:: \delta s = J_c(q)\,\delta q, \qquad
    \delta q_i \sim U(-d_i/2, d_i/2) + U(-q_i, q_i)

(:math:`J_c` the Jacobian over the actuated joints at the pick's pose; the draws are
uniform because nothing says where in its band a joint stops, so the figure is an
estimate of the mean, not a hard limit). The bound is the mean of :math:`|\delta s|`
over the picks' poses and draws of :math:`\delta q` (:func:`tcp_error_bound`). The play
is left out: a calibration that knows it (the camera's measures it, ``--truth`` writes
it) has the bus send each pulse half of it further the way it moved
(:class:`~mearm.hardware.mapping.PlayCompensation`).

    python -m mearm.analysis.servo_bound --config C [--set …] LOG

prints each joint servo's dead band and the bound at the pick poses a run log records
(the twin's kit, ``twin.kit``, as the config draws it).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, plain_int, run
from mearm.config import ArmDescription, Config
from mearm.config.arm import US_PER_SERVO_DEG
from mearm.errors import MearmError
from mearm.kinematics.model import ArmModel
from mearm.runlog.reader import read_runlog
from mearm.runlog.records import RouteRecord

__all__ = [
    "QUANTUM_US",
    "ServoBound",
    "kit_half_widths",
    "main",
    "pick_jacobians",
    "tcp_error_bound",
]

#: The bus's pulse step [µs]: a command is off by up to half of it.
QUANTUM_US = 1.0


@dataclass(frozen=True)
class ServoBound:
    r"""The TCP error the servos leave at a set of poses.

    Attributes:
        mean_cm: Mean :math:`|J_c\,\delta q|` over the poses and draws [cm].
        rms_cm: Its root mean square [cm].
        per_pose_cm: Each pose's mean over the draws [cm], (P,).
    """

    mean_cm: float
    rms_cm: float
    per_pose_cm: np.ndarray


def tcp_error_bound(
    jacobians: npt.ArrayLike,
    half_widths: npt.ArrayLike,
    *,
    samples: int = 4000,
    seed: int = 0,
) -> ServoBound:
    r"""Mean TCP error from independent uniform joint errors (module docstring).

    Args:
        jacobians: Each pose's Jacobian over the actuated joints, (P, 3, m) [cm per
            joint unit].
        half_widths: Each source's half width per joint, (S, m) or (m,) [joint unit]:
            :math:`\delta q_i` is the sum over the sources of :math:`U(-h_{si}, h_{si})`.
        samples: Draws per pose.
        seed: The draws' seed.

    Raises:
        ValueError: shapes that do not match, a negative or non-finite half width, or
            fewer than one sample.
    """
    J = np.asarray(jacobians, dtype=float)
    h = np.atleast_2d(np.asarray(half_widths, dtype=float))
    if J.ndim != 3 or J.shape[1] != 3 or h.ndim != 2 or h.shape[1] != J.shape[2]:
        raise ValueError(
            f"jacobians (P, 3, m) and half widths (S, m) must agree, got {J.shape} and {h.shape}"
        )
    if not (np.all(np.isfinite(h)) and np.all(h >= 0)) or samples < 1:
        raise ValueError(
            f"half widths must be finite and ≥ 0, samples ≥ 1: {h.tolist()}, {samples}"
        )
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1.0, 1.0, size=(samples, *h.shape))  # (N, S, m)
    dq = np.einsum("nsm,sm->nm", u, h)  # (N, m)
    ds = np.einsum("pij,nj->pni", J, dq)  # (P, N, 3)
    norms = np.linalg.norm(ds, axis=2)
    return ServoBound(float(norms.mean()), float(np.sqrt(np.mean(norms**2))), norms.mean(axis=1))


def pick_jacobians(arm: ArmDescription, routes: Sequence[RouteRecord]) -> np.ndarray:
    """The Jacobians over the actuated joints at the picks' end poses, (P, 3, m).

    Per degree (or cm) of each actuated joint, as the half widths are given.
    """
    model = ArmModel(arm)
    chain = model.chain
    actuated = set(chain.actuated)
    out = []
    for r in routes:
        if r.step != "pick":
            continue
        q = chain.from_named({n: v for n, v in r.end_joints.items() if n in actuated})
        out.append(model.coupled_jacobian(q) * chain.scale[chain.actuated_index])
    if not out:
        raise MearmError("the run log records no pick: nothing to bound")
    return np.array(out)


def kit_half_widths(config: Config) -> dict[str, tuple[float, float]]:
    """Each actuated joint's (dead band, half a µs) as the twin's kit has them [deg or cm].

    Raises:
        MearmError: a config with no ``twin.kit`` or not the twin, or a servo that turns
            a combination of joints (its error is not one joint's).
    """
    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415 (MuJoCo only when asked)

    if config.simulator != "mujoco" or config.twin.kit is None:
        raise MearmError("the servos' bound reads the MuJoCo twin's kit: set twin.kit")
    joints = set(config.arm.joint_limits())
    out = {}
    for s in TwinArm(config).servos:
        if s.name not in joints:
            continue  # the gripper: not on the TCP's path
        if s.offset != 0.0 or len(s.pot_qpos) != 1:
            raise MearmError(f"{s.name}: a servo over a combination of joints is not bounded")
        k = s.physical.us_per_unit
        if s.unit is not None:
            k *= s.unit.us_per_deg / US_PER_SERVO_DEG  # the unit's own µs per joint unit
        out[s.name] = (s.deadband / s.scale, QUANTUM_US / 2.0 / k)
    return out


#: Most draws per pose ``--samples`` allows (memory: 8 bytes a joint a draw a pose).
MAX_SAMPLES = 1_000_000


def main(argv: Sequence[str] | None = None) -> int:
    """Print the kit's dead bands and the bound at a run log's picks."""
    parser = ArgumentParser(prog="python -m mearm.analysis.servo_bound")
    add_config_argument(parser)
    parser.add_argument("log", help="run log whose picks' poses are bounded")
    parser.add_argument("--samples", type=plain_int, default=4000, help="draws per pose")
    args = parser.parse_args(argv)
    if not 1 <= args.samples <= MAX_SAMPLES:
        parser.error(f"--samples must be in [1, {MAX_SAMPLES}], got {args.samples}")
    config = config_from_args(args)
    widths = kit_half_widths(config)
    names = [n for n in ArmModel(config.arm).chain.actuated if n in widths]
    J = pick_jacobians(config.arm, read_runlog(args.log).routes)
    h = np.array([[widths[n][s] for n in names] for s in (0, 1)])
    for n in names:
        print(f"{n}: dead band d = {widths[n][0]:.3f}, half a µs {widths[n][1]:.3f} [deg]")
    # after the looks a joint keeps up to half its band; with no look, all of it
    for share, what in ((0.5, "±d/2 (the looks' bound)"), (1.0, "±d (no look)")):
        hs = h * np.array([[share], [1.0]])
        band = tcp_error_bound(J, hs[:1], samples=args.samples)
        both = tcp_error_bound(J, hs, samples=args.samples)
        print(f"{len(J)} picks, each joint uniform in {what}: mean TCP error "
              f"{band.mean_cm:.3f} cm; with half a µs {both.mean_cm:.3f} cm "
              f"(rms {both.rms_cm:.3f})")  # fmt: skip
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    run(main)
