"""Routes solved again with the PD-PIJ solver, for the path plots (paper §3, §5).

A run log keeps where each route started and where it aimed, not the path in between;
the path is reproduced by solving the same route again on the ideal kinematics with the
trial's configuration. The solver is always PD-PIJ (the paper's), whatever
``controller.solver`` says, with the configured mode, gains and tolerance, and the
tool's ``pick_approach`` when the arm has one (as the sort solves its routes).

Joint vectors here are full chain vectors in model units (rad, or m for a prismatic
joint), as :class:`~mearm.kinematics.Chain` orders them; a logged route's named joints
[deg or cm] are converted with :meth:`Chain.from_named`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt
from pydantic import ValidationError

from mearm.analysis.errors import AnalysisError
from mearm.config import Config, ControllerConfig
from mearm.ik.result import joint_units, path_deviation_cm
from mearm.kinematics import ArmModel
from mearm.runlog import RouteRecord


@dataclass(frozen=True, eq=False)  # arrays inside
class SolvedRoute:
    """One solved route, ready to plot.

    Attributes:
        label: Legend text, e.g. ``"pick red1"`` or ``"kp = 0.1"``.
        kp: Proportional gain used [-].
        kd: Derivative gain used [-].
        mode: PD-PIJ mode used, ``"paper"`` or ``"coupled"``.
        status: The solver's status.
        iterations: Updates applied [-].
        target_cm: Target [cm], (3,).
        q_path: Every joint after every update, model units (rad, or m), (N+1, n).
        joint_names: The chain's joint names, the columns of ``q_path``, (n,).
        scale: Model units per config unit of each joint (π/180 or 0.01), (n,).
        ee_path_cm: EE after every update [cm], (N+1, 3).
        error_path_cm: |e| after every update [cm], (N+1,).
        logged_ee_cm: Where the arm really ended according to the log [cm], (3,), or
            ``None`` for a route that is not from a log.
    """

    label: str
    kp: float
    kd: float
    mode: str
    status: str
    iterations: int
    target_cm: np.ndarray
    q_path: np.ndarray
    joint_names: tuple[str, ...]
    scale: np.ndarray
    ee_path_cm: np.ndarray
    error_path_cm: np.ndarray
    logged_ee_cm: np.ndarray | None = None

    @property
    def final_error_cm(self) -> float:
        """|e| after the last update [cm]."""
        return float(self.error_path_cm[-1])

    @property
    def path_deviation_cm(self) -> float:
        """Largest distance of the EE path from the straight segment start → target [cm]."""
        return path_deviation_cm(self.ee_path_cm, self.target_cm)

    @property
    def joint_path(self) -> np.ndarray:
        """Every joint after every update in config units (deg, or cm), (N+1, n)."""
        return np.asarray(self.q_path, dtype=float) / self.scale

    @property
    def joint_units(self) -> tuple[str, ...]:
        """``"deg"`` or ``"cm"`` (a prismatic joint) per joint, (n,): fk's and ik's rule."""
        return tuple(joint_units(self.joint_names, self.scale).values())

    @property
    def start_joints(self) -> dict[str, float]:
        """The start pose by joint name [deg or cm]."""
        return dict(zip(self.joint_names, self.joint_path[0].tolist(), strict=True))


def _controller(config: Config, kp: float | None, kd: float | None) -> ControllerConfig:
    update: dict[str, object] = {"solver": "pdpij"}
    if kp is not None:
        update["kp"] = kp
    if kd is not None:
        update["kd"] = kd
    try:  # validated, unlike model_copy(update=...): kp > 0, kd >= 0, a stable loop
        return ControllerConfig.model_validate({**config.controller.model_dump(), **update})
    except ValidationError as exc:
        err = exc.errors()[0]
        name = ".".join(str(p) for p in err["loc"])
        gains = f"kp = {update.get('kp', config.controller.kp):g}, kd = "
        gains += f"{update.get('kd', config.controller.kd):g}"
        where = f"{name} = {err.get('input')!r}: " if name else f"{gains}: "
        raise AnalysisError(f"{where}{err['msg'].removeprefix('Value error, ')}") from None


def solve_route(
    config: Config,
    q_start: npt.ArrayLike,
    target_cm: npt.ArrayLike,
    *,
    label: str,
    kp: float | None = None,
    kd: float | None = None,
    model: ArmModel | None = None,
) -> SolvedRoute:
    """Solve one route with PD-PIJ, optionally with other gains than the config's.

    Args:
        config: Arm and controller settings.
        q_start: Start pose, every joint (n,) or the actuated ones (m,), model units.
        target_cm: Target (x, y, z) [cm], (3,); the tool's ``pick_approach`` is added
            when the arm has one.
        label: Legend text.
        kp: Proportional gain [-] (default: ``config.controller.kp``).
        kd: Derivative gain [-] (default: ``config.controller.kd``).
        model: A model of ``config.arm`` to reuse (built if ``None``).

    Raises:
        AnalysisError: A gain out of its range (kp > 0, 0 ≤ kd < 1, kp + 2·kd < 2).
        MearmError: The solver's own errors (bad target, start outside the limits, ...).
    """
    from mearm.ik import IKTarget, make_solver  # the solver sits beside this layer

    controller = _controller(config, kp, kd)
    model = model or ArmModel(config.arm)
    target = np.asarray(target_cm, dtype=float)
    approach = config.arm.tool.pick_approach
    result = make_solver(model, controller).solve(
        IKTarget(tuple(target), approach), np.asarray(q_start, dtype=float)
    )
    return SolvedRoute(
        label=label,
        kp=controller.kp,
        kd=controller.kd,
        mode=controller.mode,
        status=str(result.status),
        iterations=int(result.iterations),
        target_cm=target,
        q_path=np.asarray(result.q_path, dtype=float),
        joint_names=model.chain.names,
        scale=np.asarray(model.chain.scale, dtype=float),
        ee_path_cm=np.asarray(result.ee_path_cm, dtype=float),
        error_path_cm=np.asarray(result.error_path_cm, dtype=float),
    )


def resolve_logged_route(
    route: RouteRecord, config: Config, *, model: ArmModel | None = None
) -> SolvedRoute:
    """Solve a logged route again from its start joints to its target.

    The result keeps the log's ``ee_cm`` (where the arm really ended) for comparison.

    Raises:
        InvalidJointsError: The route's start joints are not the arm's (by name).
        MearmError: The solver's own errors.
    """
    model = model or ArmModel(config.arm)
    solved = solve_route(
        config,
        model.chain.from_named(route.start_joints),
        route.target_cm,
        label=f"{route.step} {route.object_id}",
        model=model,
    )
    return replace(solved, logged_ee_cm=np.asarray(route.ee_cm, dtype=float))


def gain_sweep(
    config: Config,
    q_start: npt.ArrayLike,
    target_cm: npt.ArrayLike,
    gains: Sequence[tuple[float, float]],
    *,
    vary: str = "kp",
    model: ArmModel | None = None,
) -> list[SolvedRoute]:
    """The same route solved with each (kp, kd) pair (paper §3: kp = 0.01, 0.1, 0.5).

    Args:
        config: Arm and controller settings.
        q_start: Start pose, every joint (n,) or the actuated ones (m,), model units.
        target_cm: Target [cm], (3,).
        gains: (kp, kd) pairs.
        vary: Which gain the legend names, ``"kp"`` or ``"kd"``.
        model: A model of ``config.arm`` to reuse (built if ``None``).
    """
    model = model or ArmModel(config.arm)
    return [
        solve_route(
            config,
            q_start,
            target_cm,
            label=f"{vary} = {kp if vary == 'kp' else kd:g}",
            kp=kp,
            kd=kd,
            model=model,
        )
        for kp, kd in gains
    ]
