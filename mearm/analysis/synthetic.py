"""Synthetic run logs with a known error distribution, to check the analysis against.

Every route's error vector has a uniformly random direction and a Euclidean length
drawn from a Weibull distribution (SPEC §5's by default: scale 0.7059 cm, shape 2.045),
so a correct analysis must recover that Weibull. Picks with an error under
``bound_cm`` always succeed; above it each fails with probability ``fail_above``
(SPEC §5: 1.2 cm and about one half). Places always succeed.

Targets, joint angles and poses are real: objects are the paper's layout jittered by up
to 2 cm, picks at the pick height, places at the colour's bin, joint angles from the
closed form, each route starting where the last one ended. The solver figures
(iterations, final error) are drawn in the paper's ranges and are not computed: this is
a test fixture, not a simulation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from mearm.analysis import paper
from mearm.config import Config, RobotConfig
from mearm.kinematics import analytic_ik_deg, dh_fk
from mearm.runlog import RunLog


def weibull_error_vectors(
    n: int, *, shape: float, scale: float, rng: np.random.Generator
) -> np.ndarray:
    """Error vectors [cm], (n, 3): uniform directions, Weibull(shape, scale) lengths."""
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return direction * (scale * rng.weibull(shape, size=n))[:, None]


def write_synthetic_log(
    path: str | Path,
    *,
    n_routes: int = 2400,
    shape: float = paper.WEIBULL_SHAPE,
    scale: float = paper.WEIBULL_SCALE_CM,
    bound_cm: float = paper.SUCCESS_BOUND_CM,
    fail_above: float = 0.5,
    seed: int = 0,
    config: Config | None = None,
    fsync: bool = False,
) -> np.ndarray:
    """Write a log of exactly ``n_routes`` routes in trials of the 12 paper objects.

    A failed pick is retried once (attempt 2); a retry that fails too is logged as a
    skip. Each trial has a header and, unless cut short by ``n_routes``, a summary.

    Args:
        path: The log to write (appended to if it exists).
        n_routes: Routes to write.
        shape: Weibull shape of the error lengths [-].
        scale: Weibull scale of the error lengths [cm].
        bound_cm: Picks with a smaller error always succeed [cm].
        fail_above: Probability that a pick at or above ``bound_cm`` fails [-].
        seed: Seed of everything random.
        config: Robot, bins and scene (default: the simulated rig's).
        fsync: ``fsync`` per record (off: fixtures write thousands).

    Returns:
        The error vectors written, in order [cm], (n_routes, 3).
    """
    config = config or Config()
    rng = np.random.default_rng(seed)
    errors = weibull_error_vectors(n_routes, shape=shape, scale=scale, rng=rng)
    robot = config.robot
    home_deg = np.array(robot.home_joints_deg)
    pick_z = robot.gripper.pick_height_cm
    written = 0
    trial = 0
    with RunLog(path, fsync=fsync) as log:
        while written < n_routes:
            log.header(config, trial=trial, seed=seed, synthetic=True)
            q_deg = home_deg
            counts: dict[str, int] = {}
            for obj in config.task.scene:
                if written >= n_routes:
                    break
                counts[obj.color] = counts.get(obj.color, 0) + 1
                object_id = f"{obj.color}{counts[obj.color]}"
                xy = np.array([obj.x, obj.y]) + rng.uniform(-2.0, 2.0, size=2)
                steps = [("pick", (xy[0], xy[1], pick_z), 1)]
                while steps and written < n_routes:
                    step, target, attempt = steps.pop(0)
                    e = errors[written]
                    success = step == "place" or bool(
                        np.linalg.norm(e) < bound_cm or rng.random() >= fail_above
                    )
                    q_deg = _route(
                        log,
                        object_id,
                        obj.color,
                        step,
                        attempt,
                        target,
                        q_deg,
                        e,
                        success,
                        robot,
                        rng,
                    )
                    written += 1
                    if step == "pick" and success:
                        steps.append(("place", config.task.bins_cm[obj.color], 1))
                    elif step == "pick" and attempt == 1:
                        steps.append(("pick", target, 2))
                    elif step == "pick":
                        log.skip(
                            object_id=object_id,
                            color=obj.color,
                            target_cm=target,
                            reason="pick retries exhausted",
                        )
            else:
                log.summary()
            trial += 1
    return errors


def _route(
    log: RunLog,
    object_id: str,
    color: str,
    step: str,
    attempt: int,
    target_cm: npt.ArrayLike,
    start_deg: np.ndarray,
    error_cm: np.ndarray,
    success: bool,
    robot: RobotConfig,
    rng: np.random.Generator,
) -> np.ndarray:
    target = np.asarray(target_cm, dtype=float)
    end_deg = analytic_ik_deg(target, robot)
    start_ee = dh_fk(np.radians(start_deg), robot.dh)
    log.route(
        object_id=object_id,
        color=color,
        step=step,
        attempt=attempt,
        target_cm=target,
        start_joints_deg=start_deg,
        end_joints_deg=end_deg,
        iterations=int(rng.integers(73, 94)),
        status="converged",
        initial_error_cm=float(np.linalg.norm(target - start_ee)),
        final_error_cm=float(rng.uniform(0.0297, 0.0315)),
        ee_cm=target + error_cm,
        error_cm=error_cm,
        success=success,
        elapsed_s=float(rng.uniform(0.01, 0.05)),
        motion_s=float(rng.uniform(5.0, 7.0)),
    )
    return end_deg
