"""Routes solved again with the PD-PIJ solver, for the path plots (SPEC §3, §5).

A run log keeps where each route started and where it aimed, not the path in between;
the path is reproduced by solving the same route again on the ideal kinematics with the
trial's configuration. The solver is always PD-PIJ (the paper's), whatever
``controller.solver`` says, with the configured mode, gains and tolerance.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import ValidationError

from mearm.config import Config, ControllerConfig
from mearm.exceptions import AnalysisError
from mearm.ik.result import path_deviation_cm
from mearm.kinematics import ArmModel
from mearm.runlog import RouteRecord


@dataclass(frozen=True)
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
        q_path_rad: Joints after every update [rad], (N+1, 4).
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
    q_path_rad: np.ndarray
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


def solve_route(
    config: Config,
    q_start_rad: npt.ArrayLike,
    target_cm: npt.ArrayLike,
    *,
    label: str,
    kp: float | None = None,
    kd: float | None = None,
    model: ArmModel | None = None,
) -> SolvedRoute:
    """Solve one route with PD-PIJ, optionally with other gains than the config's.

    Args:
        config: Robot and controller settings.
        q_start_rad: Start joints (θ1..θ4) [rad], (4,).
        target_cm: Target (x, y, z) [cm], (3,).
        label: Legend text.
        kp: Proportional gain [-] (default: ``config.controller.kp``).
        kd: Derivative gain [-] (default: ``config.controller.kd``).
        model: A model of ``config.robot`` to reuse (built if ``None``).

    Raises:
        AnalysisError: A gain out of its range (kp > 0, kd ≥ 0).
        MearmError: The solver's own errors (bad target, start outside the limits, ...).
    """
    from mearm.ik import PdPij  # the solver sits beside this layer; loaded only when plotting

    update: dict[str, float] = {}
    if kp is not None:
        update["kp"] = kp
    if kd is not None:
        update["kd"] = kd
    try:  # validated, unlike model_copy(update=...): kp > 0, kd >= 0
        controller = ControllerConfig.model_validate({**config.controller.model_dump(), **update})
    except ValidationError as exc:
        err = exc.errors()[0]
        name = ".".join(str(p) for p in err["loc"])
        raise AnalysisError(f"{name} = {err.get('input')!r}: {err['msg']}") from None
    solver = PdPij(model or ArmModel(config.robot), controller)
    result = solver.solve(np.asarray(q_start_rad, dtype=float), np.asarray(target_cm, dtype=float))
    return SolvedRoute(
        label=label,
        kp=controller.kp,
        kd=controller.kd,
        mode=controller.mode,
        status=str(result.status),
        iterations=int(result.iterations),
        target_cm=np.asarray(target_cm, dtype=float),
        q_path_rad=np.asarray(result.q_path_rad, dtype=float),
        ee_path_cm=np.asarray(result.ee_path_cm, dtype=float),
        error_path_cm=np.asarray(result.error_path_cm, dtype=float),
    )


def resolve_logged_route(
    route: RouteRecord, config: Config, *, model: ArmModel | None = None
) -> SolvedRoute:
    """Solve a logged route again from its start joints to its target.

    The result keeps the log's ``ee_cm`` (where the arm really ended) for comparison.
    """
    solved = solve_route(
        config,
        np.radians(route.start_joints_deg),
        route.target_cm,
        label=f"{route.step} {route.object_id}",
        model=model,
    )
    return SolvedRoute(**{**solved.__dict__, "logged_ee_cm": np.asarray(route.ee_cm, dtype=float)})


def gain_sweep(
    config: Config,
    q_start_rad: npt.ArrayLike,
    target_cm: npt.ArrayLike,
    gains: Sequence[tuple[float, float]],
    *,
    vary: str = "kp",
) -> list[SolvedRoute]:
    """The same route solved with each (kp, kd) pair (SPEC §3: kp = 0.01, 0.1, 0.5).

    Args:
        config: Robot and controller settings.
        q_start_rad: Start joints (θ1..θ4) [rad], (4,).
        target_cm: Target [cm], (3,).
        gains: (kp, kd) pairs.
        vary: Which gain the legend names, ``"kp"`` or ``"kd"``.
    """
    model = ArmModel(config.robot)
    return [
        solve_route(
            config,
            q_start_rad,
            target_cm,
            label=f"{vary} = {kp if vary == 'kp' else kd:g}",
            kp=kp,
            kd=kd,
            model=model,
        )
        for kp, kd in gains
    ]
