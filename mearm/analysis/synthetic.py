"""Synthetic run logs with a known error distribution, to check the analysis against.

Every route's error vector has a uniformly random direction and a Euclidean length
drawn from a Weibull distribution (paper §5's by default: scale 0.7059 cm, shape 2.045),
so a correct analysis must recover that Weibull. Picks with an error under
``bound_cm`` always succeed; above it each fails with probability ``fail_above``
(paper §5: 1.2 cm and about one half). Places always succeed.

Targets, joint values and poses are real: objects are the configured scene jittered by
up to 2 cm, picks at their class's grip height, places at their class's bin, joint values
from the arm's closed form (PD-PIJ for an arm without one), each route starting where the
last one ended. Routes are written in the current run-log format: joint values by the
names of ``config.arm``'s joints [deg or cm], ``color`` a name of ``config.task.classes``.
The solver figures (iterations, final error) are drawn in the paper's ranges and are not
computed: this is a test fixture, not a simulation.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from mearm.analysis import paper
from mearm.config import Config
from mearm.kinematics import Chain, closed_form_for
from mearm.runlog import RunLog


def weibull_error_vectors(
    n: int, *, shape: float, scale: float, rng: np.random.Generator
) -> np.ndarray:
    """Error vectors [cm], (n, 3): uniform directions, Weibull(shape, scale) lengths."""
    direction = rng.normal(size=(n, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return direction * (scale * rng.weibull(shape, size=n))[:, None]


def _ik(config: Config) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """(start, target [cm]) → end pose, full model-unit vectors (n,)."""
    closed_form = closed_form_for(config.arm)
    if closed_form is not None:
        return lambda _start, target: closed_form.solve(target)
    from mearm.ik import make_solver
    from mearm.kinematics import ArmModel

    solver = make_solver(ArmModel(config.arm), config.controller)
    return lambda start, target: np.asarray(solver.solve(target, start).q, dtype=float)


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
    """Write a log of exactly ``n_routes`` routes in trials of the configured scene.

    A failed pick is retried once (attempt 2); a retry that fails too is logged as a
    skip. Each trial has a header and, unless cut short by ``n_routes``, a summary.

    Args:
        path: The log to write (appended to if it exists: trials are numbered from 0
            again, so a second run into one file is refused by ``mearm analyze``).
        n_routes: Routes to write.
        shape: Weibull shape of the error lengths [-].
        scale: Weibull scale of the error lengths [cm].
        bound_cm: Picks with a smaller error always succeed [cm].
        fail_above: Probability that a pick at or above ``bound_cm`` fails [-].
        seed: Seed of everything random.
        config: Arm, classes and scene (default: the simulated rig's, the paper's).
        fsync: ``fsync`` per record (off: fixtures write thousands).

    Returns:
        The error vectors written, in order [cm], (n_routes, 3).
    """
    config = config or Config()
    rng = np.random.default_rng(seed)
    errors = weibull_error_vectors(n_routes, shape=shape, scale=scale, rng=rng)
    chain = Chain.from_description(config.arm)
    ik = _ik(config)
    tcp_above_grip_cm = config.arm.tool.tcp_above_grip_cm
    written = 0
    trial = 0
    with RunLog(path, fsync=fsync) as log:
        while written < n_routes:
            log.header(config, trial=trial, seed=seed, synthetic=True)
            q = chain.home.copy()
            counts: dict[str, int] = {}
            for obj in config.task.scene:
                if written >= n_routes:
                    break
                cls = config.task.class_named(obj.color)
                counts[cls.name] = counts.get(cls.name, 0) + 1
                object_id = f"{cls.name}{counts[cls.name]}"
                xy = np.array([obj.x, obj.y]) + rng.uniform(-2.0, 2.0, size=2)
                pick_z = cls.grip_z_cm + tcp_above_grip_cm
                steps = [("pick", (xy[0], xy[1], pick_z), 1)]
                while steps and written < n_routes:
                    step, target, attempt = steps.pop(0)
                    e = errors[written]
                    success = step == "place" or bool(
                        np.linalg.norm(e) < bound_cm or rng.random() >= fail_above
                    )
                    target_cm = np.asarray(target, dtype=float)
                    end = ik(q, target_cm)
                    _route(
                        log,
                        chain,
                        object_id=object_id,
                        class_name=cls.name,
                        step=step,
                        attempt=attempt,
                        target_cm=target_cm,
                        q_start=q,
                        q_end=end,
                        error_cm=e,
                        success=success,
                        rng=rng,
                    )
                    q = end
                    written += 1
                    if step == "pick" and success:
                        steps.append(("place", cls.bin_cm, 1))
                    elif step == "pick" and attempt == 1:
                        steps.append(("pick", target, 2))
                    elif step == "pick":
                        log.skip(
                            object_id=object_id,
                            color=cls.name,
                            target_cm=target,
                            reason="pick retries exhausted",
                        )
            else:
                log.summary()
            trial += 1
    return errors


def _route(
    log: RunLog,
    chain: Chain,
    *,
    object_id: str,
    class_name: str,
    step: str,
    attempt: int,
    target_cm: np.ndarray,
    q_start: npt.ArrayLike,
    q_end: npt.ArrayLike,
    error_cm: np.ndarray,
    success: bool,
    rng: np.random.Generator,
) -> None:
    start_joints = chain.named(q_start)
    start_ee_cm = chain.arm.tcp_cm(start_joints)
    log.route(
        object_id=object_id,
        color=class_name,
        step=step,
        attempt=attempt,
        target_cm=target_cm,
        start_joints=start_joints,
        end_joints=chain.named(q_end),
        iterations=int(rng.integers(73, 94)),
        status="converged",
        initial_error_cm=float(np.linalg.norm(target_cm - start_ee_cm)),
        final_error_cm=float(rng.uniform(0.0297, 0.0315)),
        ee_cm=target_cm + error_cm,
        error_cm=error_cm,
        success=success,
        elapsed_s=float(rng.uniform(0.01, 0.05)),
        motion_s=float(rng.uniform(5.0, 7.0)),
    )
