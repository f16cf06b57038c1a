r"""When PD-PIJ stops short: a solution to aim at, and a joint-space path to it.

PD-PIJ is a local method: from a start against the limits (the arm leaning back at
θ2 = 135°, say) every way closer to the target can leave the joint box, and the solve
stops short. :class:`~mearm.ik.PdPij` then discards its attempt and sends, instead, a
joint-space move from the start to a solution:

- **closed form** (arms that register one): the exact solution the target check computed;
- **multi-start** (any arm, or when the closed form's move is not safe): PD-PIJ run
  again, without the safeguard, from seeds drawn inside the joint box (:func:`seeds`);
  each converged solve gives a solution.

The first solution with a safe move wins (:class:`Recovery`): straight to it, else
through the home pose, else through home with one joint alone moved first or last (an
arm folded low over the table lifts before it swings); in every case never taking the
TCP below the floor — the target box's bottom, or the start or the target if lower. (A
straight joint-space move can swing the TCP through the table that a Cartesian path
between the same points stays above.)

The path. From the start :math:`q_0` to the solution :math:`q^*` along the straight
segment of the actuated joints, passive joints from their coupling:

.. math::
    q_a(k) = q^*_a - \epsilon_k\,(q^*_a - q_{0,a}), \qquad
    \epsilon_{k+1} = \epsilon_k - k_p \epsilon_k - k_d (\epsilon_k - \epsilon_{k-1}),
    \quad \epsilon_{-1} = \epsilon_0 = 1

kept non-increasing and non-negative: the pace of the controller's own updates (the
first moves :math:`k_p` of the way, the rest falls as the PD loop's error does), ending
at the first pose that meets the solver's stopping rule (|e|² below the tolerance, the
approach met). The actuated joints' box is convex and each passive joint an affine
function of them, so every pose between two poses within the limits is within them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from mearm.config import ControllerConfig
from mearm.ik.result import Method
from mearm.ik.solver import couple
from mearm.kinematics import Chain

#: Seeds the multi-start tries before giving up [-].
MULTI_STARTS = 12
#: Seeds are drawn from the middle of each actuated joint's range, this share of it
#: [-]: PD-PIJ stalls most from a start on a limit.
SEED_RANGE = 0.9
#: The multi-start's random generator seed: the same start and target give the same path.
SEED = 0
#: ε below this is taken as 0: the last pose is the solution itself [-].
_END = 1e-12
#: A leg to a waypoint ends with this share of it left, and the next leg starts there [-].
VIA_SHARE = 0.01

#: Evaluate a pose (n,): TCP [m] (3 floats) and whether it meets the stopping rule.
Measure = Callable[[np.ndarray], tuple[list[float], bool]]
#: Run the solver from a seed (n,): its final pose if it converged (else ``None``) and
#: the updates it took.
SolveFrom = Callable[[np.ndarray], tuple[np.ndarray | None, int]]
#: A move: each pose after the start, model units, (n,), and its TCP [m].
Path = tuple[list[np.ndarray], list[list[float]]]


def pd_fractions(kp: float, kd: float) -> Iterator[float]:
    """The share of the way still to go after each update, ε₁, ε₂, … down to 0 (module)."""
    e_prev = e = 1.0
    while e > 0.0:
        step = kp * e + kd * (e - e_prev)
        e_prev, e = e, min(max(e - step, 0.0), e)
        if e < _END:
            e = 0.0
        yield e


def joint_path(
    chain: Chain,
    q_from: np.ndarray,
    q_to: np.ndarray,
    measure: Measure,
    *,
    kp: float,
    kd: float,
    max_steps: int,
    end_share: float = 0.0,
) -> Path | None:
    """The poses after ``q_from`` of the joint-space move to ``q_to`` (module docstring).

    Args:
        chain: The arm's chain (coupling, limits).
        q_from: The start, every joint, model units, within the limits, (n,).
        q_to: The solution, every joint, model units, (n,), within the limits.
        measure: Evaluates a pose: its TCP [m] and whether it meets the stopping rule.
        kp: Proportional gain [-].
        kd: Derivative gain [-].
        max_steps: Give up (``None``) rather than take more updates than this [-].
        end_share: A leg to a waypoint (not a solution): end once the share of the way
            left is at or below this [-], not on the stopping rule.

    Returns:
        ``(q_rows, tcp_rows)``: each pose (n,) and its TCP [m], the first after
        ``q_from``, the last the first to meet the rule (or ``end_share``); ``None`` if
        ``q_to`` breaks the limits or is not reached within ``max_steps``.
    """
    lower, upper = chain.lower, chain.upper
    start = chain.actuated_of(q_from)
    goal = chain.actuated_of(q_to)
    goal_full = couple(chain, goal.tolist())
    if not chain.within_limits(goal_full, 1e-9):
        return None  # custom passive limits the solution breaks
    goal_full = np.clip(goal_full, lower, upper)
    way = goal - start
    q_rows: list[np.ndarray] = []
    tcp_rows: list[list[float]] = []
    for k, e in enumerate(pd_fractions(kp, kd)):
        if k == max_steps:
            return None
        if e == 0.0:
            q = goal_full
        else:
            q = np.clip(couple(chain, (goal - e * way).tolist()), lower, upper)
        tcp, met = measure(q)
        q_rows.append(q)
        tcp_rows.append(tcp)
        if end_share > 0.0:
            if e <= end_share:
                return q_rows, tcp_rows
        elif met:
            return q_rows, tcp_rows
        elif e == 0.0:
            return None  # the solution itself fails the rule: not a solution
    return None  # pragma: no cover (pd_fractions ends at 0)


def path_via(
    chain: Chain,
    q_from: np.ndarray,
    waypoints: list[np.ndarray],
    q_to: np.ndarray,
    measure: Measure,
    *,
    kp: float,
    kd: float,
    max_steps: int,
) -> Path | None:
    """:func:`joint_path` legs through ``waypoints`` (each left at :data:`VIA_SHARE`).

    Returns ``None`` as :func:`joint_path` does, ``max_steps`` counting every leg.
    """
    q_rows: list[np.ndarray] = []
    tcp_rows: list[list[float]] = []
    here = q_from
    for q_next, share in [*((w, VIA_SHARE) for w in waypoints), (q_to, 0.0)]:
        leg = joint_path(
            chain,
            here,
            q_next,
            measure,
            kp=kp,
            kd=kd,
            max_steps=max_steps - len(q_rows),
            end_share=share,
        )
        if leg is None:
            return None
        q_rows += leg[0]
        tcp_rows += leg[1]
        here = q_rows[-1]
    return q_rows, tcp_rows


def seeds(chain: Chain, count: int, seed: int = SEED) -> Iterator[np.ndarray]:
    """Up to ``count`` starts for the multi-start, every joint, model units, (n,).

    Each actuated joint is drawn uniformly from the middle :data:`SEED_RANGE` of its
    range; a draw whose passive joints leave their limits is skipped.
    """
    rng = np.random.default_rng(seed)
    lo, hi = chain.actuated_lower, chain.actuated_upper
    margin = 0.5 * (1.0 - SEED_RANGE) * (hi - lo)
    for _ in range(count):
        q = couple(chain, rng.uniform(lo + margin, hi - margin).tolist())
        if chain.within_limits(q, 0.0):
            yield q


@dataclass(frozen=True)
class RecoveryResult:
    """What a recovery found.

    Attributes:
        path: The move from the start (poses after it and their TCPs [m]), or ``None``.
        method: ``closed_form`` or ``multi_start``: where its solution came from.
        searched: Solver updates run on seeds [-] (not in the path).
        floor_cm: Set when solutions were found, no move to them was safe and some
            went below this floor [cm]; ``None`` when none did (every move was refused
            for not reaching its solution within the iteration cap, say).
    """

    path: Path | None
    method: Method
    searched: int
    floor_cm: float | None = None


class Recovery:
    """Find a solution and a safe joint-space move to it (module docstring).

    Args:
        chain: The arm's chain.
        home: The home pose, the waypoint of the second try, model units, (n,).
        floor_cm: The target box's bottom [cm].
        config: The controller (gains, iteration cap).
    """

    def __init__(self, chain: Chain, home: np.ndarray, floor_cm: float, config: ControllerConfig):
        self.chain = chain
        self.home = home
        self.floor_cm = floor_cm
        self.config = config

    def find(
        self,
        q_start: np.ndarray,
        start_z_cm: float,
        target_z_cm: float,
        q_closed_form: np.ndarray | None,
        measure: Measure,
        solve_from: SolveFrom,
    ) -> RecoveryResult:
        """The first solution with a safe move from ``q_start`` (n,, model units).

        Args:
            q_start: The start, every joint, model units, (n,).
            start_z_cm: The start's TCP height [cm].
            target_z_cm: The target's height [cm].
            q_closed_form: The closed form's solution (it must meet the stopping rule),
                or ``None``.
            measure: Evaluates a pose (TCP [m], stopping rule met).
            solve_from: Runs the solver from a seed.
        """
        floor_cm = min(self.floor_cm, start_z_cm, target_z_cm)
        dipped = False  # a move to a solution was refused for the floor
        if q_closed_form is not None:
            path, dipped = self._safe_move(q_start, q_closed_form, measure, floor_cm)
            if path is not None:
                return RecoveryResult(path, "closed_form", 0)
        searched = 0
        for seed in seeds(self.chain, MULTI_STARTS):
            goal, updates = solve_from(seed)
            searched += updates
            if goal is not None:
                path, below = self._safe_move(q_start, goal, measure, floor_cm)
                if path is not None:
                    return RecoveryResult(path, "multi_start", searched)
                dipped = dipped or below
        return RecoveryResult(None, "multi_start", searched, floor_cm if dipped else None)

    def _safe_move(
        self, q_start: np.ndarray, goal: np.ndarray, measure: Measure, floor_cm: float
    ) -> tuple[Path | None, bool]:
        """The first move to ``goal`` of :meth:`_vias` that stays above the floor.

        Returns:
            ``(path, dipped)``: the move, or ``None`` and whether a move was refused for
            going below the floor. A move that does not reach ``goal`` within the
            iteration cap is refused too, but not for the floor: the failure must not
            blame the table for a cap set too low.
        """
        cfg = self.config
        floor_m = floor_cm / 100.0 - 1e-9
        dipped = False
        for waypoints in self._vias(q_start, goal):
            path = path_via(
                self.chain,
                q_start,
                waypoints,
                goal,
                measure,
                kp=cfg.kp,
                kd=cfg.kd,
                max_steps=cfg.max_iterations,
            )
            if path is None:
                continue  # past the cap, or a waypoint outside the limits
            if min(tcp[2] for tcp in path[1]) >= floor_m:
                return path, False
            dipped = True
        return None, dipped

    def _vias(self, q_start: np.ndarray, goal: np.ndarray) -> Iterator[list[np.ndarray]]:
        """The waypoints of each move :meth:`_safe_move` tries, in turn.

        None; home; then home with one joint alone moved first (the start with that joint
        at its home value, for each actuated joint); then home with one joint alone moved
        last (the goal with that joint at its home value). An arm folded low over the
        table (the 5-DOF arm's TCP 4 mm above it, elbow at its limit) swings through the
        table on its way home unless its shoulder lifts it first, and a goal just above
        the table is reached from above by lowering one joint last; which joint lifts is
        the arm's business, so each is tried. A waypoint whose passive joints leave their
        limits is refused by :func:`joint_path`.
        """
        yield []
        yield [self.home]
        home = self.chain.actuated_of(self.home)
        for q, first in ((q_start, True), (goal, False)):
            ends = self.chain.actuated_of(q)
            for j in np.flatnonzero(ends != home):
                via = ends.copy()
                via[j] = home[j]
                q_via = couple(self.chain, via.tolist())
                yield [q_via, self.home] if first else [self.home, q_via]
