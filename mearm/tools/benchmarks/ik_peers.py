"""The IK peers: mearm's solvers beside Robotics Toolbox's ``ik_LM`` on seeded targets."""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, against, difference_row

if TYPE_CHECKING:
    from mearm.config import Config


#: Targets of the peer comparison, their seed and the tolerance every solver is held to.
PEER_TARGETS = 500
PEER_SEED = 16
PEER_TOLERANCE_CM = 0.01
#: Targets the NumPy port of the paper's loop solves (about 5 ms each): the first ones.
PORT_TARGETS = 50
#: mearm's fastest solve over RTB ``ik_LM``'s, from the same start, must stay at or below
#: this [×].
FASTEST_OVER_RTB_TARGET = 0.25


def reachable_targets(config: Config, n: int, seed: int) -> np.ndarray:
    """``n`` targets uniform in the arm's target box that the arm reaches, (n, 3) [cm].

    Reachable: the closed form solves it within the limits, or, for an arm without one,
    it is the TCP of joints drawn uniformly within the limits (kept when in the box).
    """
    from mearm.kinematics import ArmModel, closed_form_for  # noqa: PLC0415
    from mearm.kinematics.errors import UnreachableTargetError  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    box = config.arm.target_box
    lo = np.array([box.x_cm.min, box.y_cm.min, box.z_cm.min])
    hi = np.array([box.x_cm.max, box.y_cm.max, box.z_cm.max])
    closed_form = closed_form_for(config.arm)
    model = ArmModel(config.arm)
    chain = model.chain
    out: list[np.ndarray] = []
    while len(out) < n:
        if closed_form is not None:
            t = rng.uniform(lo, hi)
            try:
                closed_form.solve(t)
            except UnreachableTargetError:
                continue
        else:
            t = model.fk_cm(chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper)))
            if np.any(t < lo) or np.any(t > hi):
                continue
        out.append(t)
    return np.array(out)


def rtb_ets(config: Config) -> tuple[Any, str]:
    r"""The arm's TCP position kinematics as a Robotics Toolbox ETS, and a note.

    ``(None, why)`` when ``roboticstoolbox-python`` is not installed (the ``bench``
    extra) or the arm has no 3-joint ETS here: only the ``planar_wrist`` arms, whose
    levelled wrist makes the TCP offset a constant along the yawed radial direction,

    .. math:: R_z(q_0)\,t_z(d_1)\,t_x(a_1 + a_4 + t_x)\,R_x(\alpha_1)\,t_y(t_y)\,
              R_z(q_1)\,t_x(a_2)\,R_z(q_2)\,t_x(a_3)

    in centimetres: the same map from the 3 actuated joints to the TCP position, with
    the same limits (the bench checks FK against mearm's on random joints).
    """
    try:
        import roboticstoolbox as rtb  # noqa: PLC0415
    except ImportError:
        return None, "roboticstoolbox-python not installed (pip install 'mearm[bench]')"
    arm = config.arm
    if arm.closed_form != "planar_wrist":
        return None, f"no 3-joint ETS for arm {arm.name!r} (only planar_wrist arms)"
    from mearm.kinematics import Chain  # noqa: PLC0415

    chain = Chain.from_description(arm)
    lo, hi = chain.actuated_lower, chain.actuated_upper
    base, shoulder, elbow, wrist = (j.dh for j in arm.joints)
    tx, ty, _ = arm.tool.tcp_cm
    ET = rtb.ET
    ets = (
        ET.Rz(qlim=[lo[0], hi[0]])
        * ET.tz(base.d_cm)
        * ET.tx(base.a_cm + wrist.a_cm + tx)
        * ET.Rx(np.radians(base.alpha_deg))
        * ET.ty(ty)
        * ET.Rz(qlim=[lo[1], hi[1]])
        * ET.tx(shoulder.a_cm)
        * ET.Rz(qlim=[lo[2], hi[2]])
        * ET.tx(elbow.a_cm)
    )
    return ets, f"roboticstoolbox-python {rtb.__version__}, ETS built once"


def ik_peer_rows(config: Config, options: BenchOptions, n_targets: int = PEER_TARGETS) -> list[Row]:
    """The fastest solve mearm ships, its generic solve and PD-PIJ next to RTB ``ik_LM``.

    Every solver starts from home and is held to |e| < :data:`PEER_TOLERANCE_CM` on the
    same :data:`PEER_TARGETS` seeded reachable targets; a solve counts as a success when
    an independent FK (Pinocchio) of its joints is that close and they are within the
    limits. Rounds are interleaved; each solver's best round is kept.
    """
    peers = _peers(config, n_targets)
    runs = _mearm_runs(peers)
    rtb_run, rtb_note = _rtb_run(peers)
    if rtb_run is not None:
        runs["RTB ik_LM"] = rtb_run
    best, out = _best_rounds(runs, options.repeat)
    n, n_port = len(peers.targets), len(peers.port_targets)
    per_solve = {k: best[k] / (n_port if k == "numpy port" else n) for k in runs}
    timed = _Timed(best, per_solve, _successes(peers, out), out)
    rows = _solver_rows(peers, timed, options.repeat, rtb_note)
    solved_all = timed.success["fastest"] == n  # a target is met by solves that succeed
    rows += _ratio_rows(per_solve, fastest_solved_all=solved_all)
    if rtb_run is None:  # the target is not dropped: it was not measured, so not met
        bound = FASTEST_OVER_RTB_TARGET
        unmeasured = Row(
            "ik", "mearm fastest / RTB ik_LM, per solve", math.nan, "×",
            f"target ≤ {bound:g}×; not measured: {rtb_note}",
        )  # fmt: skip
        rows.append(against(unmeasured, f"≤ {bound:g}×", at_most=bound))
    return rows


@dataclass(frozen=True)
class _Peers:
    """mearm's solvers of the comparison and the targets they solve.

    Attributes:
        config: The arm.
        model: Its :class:`~mearm.kinematics.ArmModel`.
        targets: The seeded reachable targets, (n, 3) [cm].
        port_targets: The first of them, for the slow NumPy port, (n_port, 3) [cm].
        controller: PD-PIJ's controller, held to the tolerance.
        fast: :func:`mearm.ik.fastest_solver` for the arm.
        newton: The generic solve.
        pdpij: PD-PIJ.
    """

    config: Config
    model: Any
    targets: np.ndarray
    port_targets: np.ndarray
    controller: Any
    fast: Any
    newton: Any
    pdpij: Any


@dataclass(frozen=True)
class _Timed:
    """What the rounds measured: best round [s], per solve [s], successes, last outputs."""

    best: dict[str, float]
    per_solve: dict[str, float]
    success: dict[str, int]
    out: dict[str, list[Any]]


def _peers(config: Config, n_targets: int) -> _Peers:
    from mearm.ik import NewtonIK, PdPij, fastest_solver  # noqa: PLC0415
    from mearm.kinematics import ArmModel  # noqa: PLC0415

    model = ArmModel(config.arm)
    targets = reachable_targets(config, n_targets, PEER_SEED)
    # PD-PIJ stops when |e|² < tolerance: just under 0.01² so that |e| < 0.01 cm
    controller = config.controller.updated(tolerance_cm2=PEER_TOLERANCE_CM**2 * (1 - 1e-9))
    return _Peers(
        config,
        model,
        targets,
        targets[: min(PORT_TARGETS, len(targets))],
        controller,
        fast=fastest_solver(model),
        newton=NewtonIK(model, tolerance_cm=PEER_TOLERANCE_CM),
        pdpij=PdPij(model, controller),
    )


def _mearm_runs(p: _Peers) -> dict[str, Callable[[], list[Any]]]:
    """One call of each of mearm's solvers on every target (the port: its share)."""
    from mearm.ik.batch import solve_batch  # noqa: PLC0415
    from mearm.ik.paper_port import numpy_port_solve  # noqa: PLC0415

    model, fast, pdpij, newton, targets = p.model, p.fast, p.pdpij, p.newton, p.targets
    home = model.home
    port_controller = p.controller.updated(mode="paper")
    # a solve that starts at its own target: no iteration, the fixed cost alone
    on_target = [(q, model.fk_cm(q)) for q in (fast.solve(t).q for t in targets)]
    # each solve from the one before's solution: a new start every call, as in a sort
    chained = list(zip(targets, [home] + [np.array(q) for q, _ in on_target[:-1]], strict=True))
    return {
        "fastest": lambda: [fast.solve(t, home) for t in targets],
        "fastest chained": lambda: [fast.solve(t, q) for t, q in chained],
        "batch": lambda: [solve_batch(model, targets, tolerance_cm=PEER_TOLERANCE_CM)],
        "generic": lambda: [newton.solve(t) for t in targets],
        "PD-PIJ": lambda: [pdpij.solve(t, home) for t in targets],
        "PD-PIJ at target": lambda: [pdpij.solve(t, q) for q, t in on_target],
        "numpy port": lambda: [
            numpy_port_solve(home, t, p.config.arm, port_controller) for t in p.port_targets
        ],
    }


def _rtb_run(p: _Peers) -> tuple[Callable[[], list[Any]] | None, str]:
    """RTB ``ik_LM`` on every target, and its note; ``None`` and why when it cannot run.

    Its ETS must give mearm's FK on random joints before it is timed.
    """
    ets, note = rtb_ets(p.config)
    if ets is None:
        return None, note
    chain = p.model.chain
    rng = np.random.default_rng(0)
    for q in rng.uniform(chain.actuated_lower, chain.actuated_upper, (20, chain.m)):
        gap = float(np.abs(ets.fkine(q).t - p.model.fk_cm(chain.full(q))).max())
        if not gap < 1e-9:
            return None, f"its ETS is not this arm's kinematics (FK off by {gap:.3g} cm)"
    q0 = chain.actuated_of(p.model.home)
    poses = []
    for t in p.targets:
        T = np.eye(4)
        T[:3, 3] = t
        poses.append(T)
    mask = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    # ik_LM stops when E = ½ eᵀ W e < tol: ½ · 0.01² for |e| < 0.01 cm
    tol = 0.5 * PEER_TOLERANCE_CM**2 * (1 - 1e-9)
    ik_lm = ets.ik_LM
    return (lambda: [ik_lm(T, q0=q0, tol=tol, mask=mask, joint_limits=True) for T in poses]), note


def _best_rounds(
    runs: dict[str, Callable[[], list[Any]]], repeat: int
) -> tuple[dict[str, float], dict[str, list[Any]]]:
    """Each run's best wall time [s] over ``repeat`` interleaved rounds, and its output."""
    from tqdm import tqdm  # noqa: PLC0415

    best = dict.fromkeys(runs, float("inf"))
    out: dict[str, list[Any]] = {}
    with tqdm(
        total=repeat * len(runs), desc="ik peers", unit="run", file=sys.stderr, disable=None
    ) as bar:
        for _ in range(repeat):
            for key, fn in runs.items():
                t0 = time.perf_counter()
                out[key] = fn()
                best[key] = min(best[key], time.perf_counter() - t0)
                bar.update()
    return best, out


def _successes(p: _Peers, out: dict[str, list[Any]]) -> dict[str, int]:
    """Per solver, the solves whose joints are within the limits and reach their target."""
    chain, model = p.model.chain, p.model
    act = chain.actuated_of

    def reached(q_act: np.ndarray, t: np.ndarray) -> bool:
        q = chain.full(q_act)
        return bool(
            chain.within_limits(q) and np.linalg.norm(model.fk_cm(q) - t) < PEER_TOLERANCE_CM
        )

    def converged(key: str) -> int:
        pairs = zip(out[key], p.targets, strict=True)
        return sum(r.converged and reached(act(r.q), t) for r, t in pairs)

    batch = out["batch"][0]
    success = {key: converged(key) for key in ("fastest", "fastest chained")}
    success["batch"] = sum(
        bool(ok) and reached(act(q), t)
        for q, ok, t in zip(batch.q, batch.reached, p.targets, strict=True)
    )
    success["generic"] = converged("generic")
    success["PD-PIJ"] = converged("PD-PIJ")
    success["numpy port"] = sum(
        r[0] == "converged" and reached(act(r[1][-1]), t)
        for r, t in zip(out["numpy port"], p.port_targets, strict=True)
    )
    if "RTB ik_LM" in out:
        success["RTB ik_LM"] = sum(
            bool(s.success) and reached(np.asarray(s.q), t)
            for s, t in zip(out["RTB ik_LM"], p.targets, strict=True)
        )
    return success


def _solver_rows(p: _Peers, timed: _Timed, repeat: int, rtb_note: str) -> list[Row]:
    """The setting, then each solver's time per solve and successes, PD-PIJ's costs."""
    n, n_port = len(p.targets), len(p.port_targets)
    note = (
        f"{n} seeded reachable targets (seed {PEER_SEED}), from home, |e| < "
        f"{PEER_TOLERANCE_CM} cm; best of {repeat} interleaved rounds"
    )
    rows = [Row("ik", "peers: setting", 0.0, "", note)]

    def solve_row(key: str, label: str, extra: str = "") -> None:
        count = n if key != "numpy port" else n_port
        text = f"success {timed.success[key]}/{count}" + (f"; {extra}" if extra else "")
        rows.append(Row("ik", f"{label}: per solve", timed.per_solve[key] * 1e6, "µs", text))

    if "RTB ik_LM" in timed.per_solve:
        solve_row("RTB ik_LM", "RTB ik_LM (C++)", rtb_note)
    else:
        # not measured: no figure (``—``, null in the JSON), never a time of 0
        rows.append(Row("ik", "RTB ik_LM (C++)", math.nan, "", f"skipped: {rtb_note}"))
    closed = p.fast.closed_form is not None
    kind = "closed form" if closed else p.fast.name
    solve_row("fastest", f"mearm fastest ({kind})", "fastest_solver(model).solve(target, home)")
    solve_row(
        "fastest chained",
        f"mearm fastest ({kind}), a new start each",
        "each from the one before's solution: every start checked",
    )
    solve_row(
        "batch",
        f"mearm batch ({'closed form' if closed else 'Gauss-Newton on arrays'})",
        f"solve_batch(model, targets): all {n} in one call, per target",
    )
    solve_row("generic", f"mearm generic ({p.newton.name})", "NewtonIK, for arms without one")
    solve_row("PD-PIJ", f"PD-PIJ {p.controller.mode}", "the route generator, the paper's loop")
    rows += _pdpij_rows(p.controller.mode, timed, n)
    port_iterations = sum(len(r[1]) - 1 for r in timed.out["numpy port"])
    solve_row(
        "numpy port",
        "numpy port (paper mode)",
        f"the first {n_port} targets, {port_iterations / n_port:.1f} iterations each",
    )
    return rows


def _pdpij_rows(mode: str, timed: _Timed, n: int) -> list[Row]:
    r"""PD-PIJ's iterations per solve, fixed cost per solve and cost per iteration.

    .. math:: t_{it} = (t_{solve} - n\,t_{fixed}) / \sum iterations

    with :math:`t_{fixed}` a converged solve started on its own target.
    """
    iterations = sum(r.iterations + r.search_iterations for r in timed.out["PD-PIJ"])
    fixed = timed.per_solve["PD-PIJ at target"]
    per_it = (timed.best["PD-PIJ"] - n * fixed) / iterations
    return [
        Row("ik", f"PD-PIJ {mode}: iterations per solve", iterations / n, ""),
        Row(
            "ik",
            f"PD-PIJ {mode}: fixed cost per solve",
            fixed * 1e6,
            "µs",
            "a converged solve started on its target: checks, 1 FK, the record",
        ),
        difference_row(
            "ik",
            f"PD-PIJ {mode}: per iteration",
            per_it * 1e6,
            "µs",
            "(solve − fixed cost) / iterations",
            "the solves took no longer than their fixed cost (more --repeat rounds may resolve it)",
        ),
    ]


def _ratio_rows(per_solve: dict[str, float], *, fastest_solved_all: bool = True) -> list[Row]:
    """Each of mearm's solvers over RTB ``ik_LM`` (when it ran), and PD-PIJ over the fastest.

    The fastest solve's ratio is held to :data:`FASTEST_OVER_RTB_TARGET`; not met when
    it failed a target (``fastest_solved_all`` false).
    """
    rows = []
    if "RTB ik_LM" in per_solve:
        rtb = per_solve["RTB ik_LM"]
        bound = FASTEST_OVER_RTB_TARGET
        for key, label, target in (
            ("fastest", "mearm fastest", f"target ≤ {bound:g}×, the same start (home)"),
            ("fastest chained", "mearm fastest, a new start each", ""),
            ("batch", "mearm batch", ""),
            ("generic", "mearm generic", ""),
            ("PD-PIJ", "PD-PIJ", ""),
            ("numpy port", "numpy port", ""),
        ):
            row = Row("ik", f"{label} / RTB ik_LM, per solve", per_solve[key] / rtb, "×", target)
            if target:
                row = against(row, f"≤ {bound:g}×", at_most=bound, valid=fastest_solved_all)
            rows.append(row)
    rows.append(
        Row(
            "ik",
            "PD-PIJ / mearm fastest, per solve",
            per_solve["PD-PIJ"] / per_solve["fastest"],
            "×",
        )
    )
    return rows
