"""``mearm jog``: move the arm with the keyboard, in joint space or in x/y/z.

    mearm jog --config my.yaml [--port /dev/ttyACM0] [--servo-calibration my.servos.yaml]

The arm first goes home (as the sort's first move does). Then:

- joint space: ``1``…``9`` or ←/→ select an actuated joint; ``+``/↑ and ``-``/↓ move it
  by the step;
- Cartesian: ``x``/``X``, ``y``/``Y``, ``z``/``Z`` move the TCP by −/+ the step along
  the base frame's axis, solved with the config's IK (``controller.solver``); steps in a
  row aim at the previous target, so small IK errors do not add up; a step that would
  cross a bound (the target box, the reach, a joint's limit, a servo's pulse range)
  stops at the last point of its line the checks pass, to within
  :data:`TCP_ON_BOUND_CM`, and says how far it went and what lies past it; a step from
  there on is refused;
- ``[``/``]`` make the step smaller/larger (joints 0.5–10°, or cm for a prismatic joint;
  TCP 0.2–5 cm); a joint step that would cross a bound it is checked on — a joint's
  limit (the selected joint's, or a passive joint's that follows it) or the end of a
  servo's pulse range (below) — stops on the first it reaches, so every bound is reached
  exactly whatever the step, and only a step from a bound onwards is refused; ``g``
  opens/closes the gripper; ``h`` goes home; ``?`` lists the keys;
- ``q`` goes home and quits; ``Q`` quits and leaves the arm where it is (holding); Ctrl-C
  stops at once and leaves the arm where it is (exit 130).

After every key the screen shows every joint's value and its distance to each limit
(passive joints too), the TCP's position by forward kinematics and the step. A servo that
turns a combination of joints (its ``drives``: the MeArm's elbow servo turns the
forearm's angle to the table, shoulder + elbow) gets a line of its own: the
combination's value and its distance to each end of the servo's pulse range, which
bounds the combination, not a joint — moving the shoulder moves the forearm's angle too:
a joint step stops on either end, and a move past it is refused.

Every move goes through the sort's checks before anything is sent: a joint move is a
straight line in joint space planned in full and checked against every limit
(:meth:`~mearm.task.Executor.joint_path`); a Cartesian move is a route planned in full by
the sort's :class:`~mearm.task.Planner` (target box, reach, convergence, every pose within
the limits) and sent only if it is :attr:`~mearm.task.Route.planned`; every pose's pulses
are checked against the servos' ranges, and the whole path against the table and the
bins with the sort's collision model (:mod:`mearm.kinematics.collision`: no arm shape
below the table, ``task.clearance_cm`` from every bin), before the first is sent. Every
move (a joint step, a TCP step, going home) is streamed as the sort's are: timed in full
first (:meth:`~mearm.task.Executor.timed`), one command a bus period and no servo turning
faster than its ``seconds_per_60deg`` allows, and a route's commands checked again
against the collision model as the servos follow them, chord by chord
(:meth:`~mearm.task.Executor.stream`: timed slower where a chord comes too close, and
refused, nothing sent, if even the slowest does). The
jog has no camera: objects on the table are not known, and not avoided. A Cartesian step
cut short (a collision included) sends the route of the length found, which passed all
of them; a joint step into a collision is refused whole (a smaller step goes nearer). A
refused move prints why and sends nothing.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from mearm import interrupts
from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    run,
)
from mearm.config import Config
from mearm.config.servo_file import apply_servo_calibration_file
from mearm.errors import MearmError
from mearm.hardware import ArmCommand, ServoBus
from mearm.hardware.errors import ServoError
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.maker.calibrate_servos import open_arm_bus
from mearm.maker.keys import KeyReader, require_terminal
from mearm.maker.servo_output import hold_arm
from mearm.sim.table_collision import collision_model
from mearm.task import Executor, Planner, Route
from mearm.task.execute import CollisionError, Phase

#: Joint steps [deg, or cm for a prismatic joint] and TCP steps [cm] the keys choose from.
JOINT_STEPS = (0.5, 1.0, 2.0, 5.0, 10.0)
CARTESIAN_STEPS_CM = (0.2, 0.5, 1.0, 2.0, 5.0)
#: The tool settings while jogging: the tool actuators at home.
PHASE: Phase = "home"
AXES = {"x": 0, "y": 1, "z": 2}
#: Closer than this to a bound (a joint's limit [rad or m], the end of a servo's pulse
#: range [deg or cm]) a move starts on it: a step past it is refused, not shortened to a
#: rounding error's length.
ON_BOUND = 1e-9
#: A TCP step the checks refuse stops within this of where they start refusing along its
#: line [cm] (under what a 1 µs pulse moves the TCP at the arms' reach); closer than this, a
#: step is refused, not crept along.
TCP_ON_BOUND_CM = 0.01

HELP = (
    "keys: 1-9 or ←/→ select joint, +/↑ -/↓ move it; x/X y/Y z/Z move the TCP -/+; "
    "[ ] step; g gripper; h home; q home and quit; Q quit here; Ctrl-C stop"
)


class Refused(MearmError):
    """A move failed a check before anything was sent."""


class Jogger:
    """Keyboard teleoperation on a connected servo bus.

    Args:
        config: The whole configuration.
        bus: The servo bus, connected.
        out: Where the screen goes.
    """

    def __init__(self, config: Config, bus: ServoBus, out: TextIO):
        self.config = config
        self.bus = bus
        self.out = out
        self.model = ArmModel(config.arm)
        self.chain = self.model.chain
        self.planner = Planner(config, self.model)
        #: The table and the bins, as the sort's planner sees them (no objects: no
        #: camera); checked along every path before it is sent (:meth:`_contact_problem`).
        #: Not the planner's: a step into a bin is cut short, not detoured over it.
        self.collision = collision_model(config, self.model, clearance_cm=config.task.clearance_cm)
        #: Streams every move as the sort's does: timed within the servos' speed limits
        #: (:meth:`~mearm.task.Executor.timed`), a route's chords between its commands
        #: checked against the same collision model (:meth:`~mearm.task.Executor.stream`).
        self.executor = Executor(config, bus, self.model, collision=self.collision)
        self.selected = 0
        self.step_index = 2
        self.closed = False
        self.target_cm: np.ndarray | None = None

    # ----------------------------------------------------------------- readout

    def say(self, text: str) -> None:
        """Print a line."""
        self.out.write(text + "\n")
        self.out.flush()

    def readout(self) -> None:
        """Every joint with its distance to each limit, the TCP, the step."""
        q = self.executor.q_now()
        c = self.chain
        values = c.to_config_units(q)
        lower, upper = c.to_config_units(c.lower), c.to_config_units(c.upper)
        lines = []
        for i, name in enumerate(c.names):
            mark = "*" if i == c.actuated_index[self.selected] else " "
            kind = "" if i in c.actuated_index else " (passive)"
            unit = c.unit(i)
            lines.append(
                f"{mark} {name:<12} {values[i]:9.3f} {unit}   to limits "
                f"-{values[i] - lower[i]:.3f} / +{upper[i] - values[i]:.3f} {unit}{kind}"
            )
        x, y, z = (float(v) for v in self.model.fk_cm(q))
        lines.append(f"  TCP x {x:.3f}  y {y:.3f}  z {z:.3f} cm")
        named = c.named_actuated(q)
        for j in self.bus.servo_map.joints:
            if not j.combined:
                continue
            v = j.servo_value(named)
            lo, hi = j.pulse_limits
            lines.append(
                f"  {j.servo_text}: {v:.3f} {j.unit}   to its pulse range "
                f"-{v - lo:.3f} / +{hi - v:.3f} {j.unit}"
            )
        js = JOINT_STEPS[self.step_index]
        cs = CARTESIAN_STEPS_CM[self.step_index]
        lines.append(
            f"  step {js:g} {c.unit(int(c.actuated_index[self.selected]))} / {cs:g} cm   "
            f"gripper {'closed' if self.closed else 'open'}"
        )
        self.say("\n".join(lines))

    # ----------------------------------------------------------------- checks

    def _check_pulses(self, poses: np.ndarray, *, closed: bool) -> None:
        """Refuse if any pose's pulses leave a servo's range (nothing sent yet)."""
        tool = self.executor.tool_settings(PHASE)
        for q in poses:
            try:
                self.bus.servo_map.check(ArmCommand(self.chain.named_actuated(q), tool, closed))
            except MearmError as exc:
                raise Refused(str(exc)) from None

    def _contact_problem(self, path: np.ndarray) -> str | None:
        """Why ``path`` may not be sent, or ``None`` if it keeps clear all along.

        Where it first touches the table or comes within ``task.clearance_cm`` of a bin.
        """
        contact = self.collision.first_contact(path)
        if contact is None:
            return None
        text = "collision: " + contact.describe(self.chain.names, self.chain.scale)
        if contact.obstacle != "table":  # the table gets no margin, the bins the clearance
            text += f" (task.clearance_cm: {self.config.task.clearance_cm:g} cm)"
        return text

    def _limit_problem(self, q: np.ndarray) -> str | None:
        c = self.chain
        values = c.to_config_units(q)
        lower, upper = c.to_config_units(c.lower), c.to_config_units(c.upper)
        for i, name in enumerate(c.names):
            if not lower[i] - 1e-9 <= values[i] <= upper[i] + 1e-9:
                return (
                    f"{name} would be at {values[i]:.4g} {c.unit(i)}, outside its limits "
                    f"[{lower[i]:.4g}, {upper[i]:.4g}] {c.unit(i)}"
                )
        return None

    # ----------------------------------------------------------------- moves

    def move_joint(self, sign: int) -> None:
        """Move the selected joint by one step (a straight joint-space path).

        A step that would cross a bound the move is checked on before anything is sent
        stops on the first it reaches (:meth:`_stop_on_first_bound`), so every bound is
        reachable whatever the step; a step from a bound onwards is refused
        (:meth:`_go_joints`).
        """
        c = self.chain
        k = self.selected
        a_from = c.actuated_of(self.executor.q_now())
        a = a_from.copy()
        a[k] += sign * JOINT_STEPS[self.step_index] * c.scale[int(c.actuated_index[k])]
        a[k] = self._stop_on_first_bound(a_from, a, k)
        self._go_joints(c.full(a))
        self.target_cm = None

    def _bounded(self, q: np.ndarray) -> np.ndarray:
        """What a joint move is checked on, at the full pose ``q``.

        Every joint [model units], then every joint servo's value [deg or cm]: the
        joint's, or the combination it turns.
        """
        named = self.chain.named_actuated(q)
        servos = [j.servo_value(named) for j in self.bus.servo_map.joints]
        return np.concatenate([q, servos])

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The lower and upper bounds of :meth:`_bounded`.

        The joints' limits, then the values each joint servo's pulse range allows.
        """
        ranges = np.array([j.pulse_limits for j in self.bus.servo_map.joints]).reshape(-1, 2)
        c = self.chain
        return np.concatenate([c.lower, ranges[:, 0]]), np.concatenate([c.upper, ranges[:, 1]])

    def _stop_on_first_bound(self, a_from: np.ndarray, a_to: np.ndarray, k: int) -> float:
        """Where moving actuated joint ``k`` from ``a_from`` to ``a_to`` first reaches a bound.

        Returns joint ``k``'s value there [model units], or ``a_to[k]`` if the move (of
        that joint alone) reaches none. The bounds are those the move is checked on
        before it is sent (:meth:`_bounded`): the joints' limits (the selected joint's,
        or a passive joint's coupled to it) and the ends of the joint servos' pulse
        ranges — for a servo that turns a combination of joints, a bound on the
        combination (the MeArm v1's elbow servo holds shoulder + elbow within ±75°),
        which the shoulder reaches too. All are linear along the move. A step that goes on
        past a bound the start is on (within :data:`ON_BOUND`) or past is left whole, for
        the checks to refuse (not stopped on a bound farther along, past that one).
        """
        c = self.chain
        lower, upper = self._bounds()
        v0, v1 = self._bounded(c.full(a_from)), self._bounded(c.full(a_to))
        way = np.sign(v1 - v0)
        bound = np.where(way > 0, upper, lower)
        past = (way != 0) & (way * (v1 - bound) > 0)  # the bounds the whole step ends past
        if not past.any() or (way * (bound - v0) <= ON_BOUND)[past].any():
            # none, or the step goes on from one the start is on (or past): refused whole
            return float(a_to[k])
        fraction = np.full(len(v0), np.inf)
        fraction[past] = (bound - v0)[past] / (v1 - v0)[past]
        first = int(np.argmin(fraction))  # a tie: a joint's limit, listed first
        if first == int(c.actuated_index[k]):
            return float(bound[first])  # the selected joint's own limit, exactly
        landed = float(a_from[k] + fraction[first] * (a_to[k] - a_from[k]))
        a = a_from.copy()
        while True:  # rounding may land a hair past the bound: back onto it, ulp by ulp
            a[k] = landed
            if way[first] * (self._bounded(c.full(a))[first] - bound[first]) <= 0:
                return landed
            landed = float(np.nextafter(landed, a_from[k]))

    def _go_joints(self, q_to: np.ndarray) -> None:
        problem = self._limit_problem(q_to)
        if problem is not None:
            raise Refused(problem)
        path = self.executor.joint_path(q_to)
        # the commands as the servos can follow them (as the sort's): points of the line,
        # one per bus period, no servo faster than its seconds_per_60deg
        commands = self.executor.timed(path, carrying=self.closed).q
        self._check_pulses(path, closed=self.closed)
        self._check_pulses(commands, closed=self.closed)
        # the line, and the chords between the commands (on it: checked all the same)
        problem = self._contact_problem(path) or self._contact_problem(commands)
        if problem is not None:
            raise Refused(problem)
        # the same line, timed the same way: what was checked is what is sent
        self.executor.move_joints(q_to, PHASE, closed=self.closed)

    def move_tcp(self, axis: int, sign: int) -> None:
        """Move the TCP one step along a base axis: a route planned in full, then sent.

        A step the checks refuse (:meth:`_tcp_route`) stops at the last point along its
        line they pass (:meth:`_last_passed`), and says so: every bound is reached
        whatever the step, as a joint step's. A step that cannot go
        :data:`TCP_ON_BOUND_CM` (the TCP on a bound already) is refused whole, with the
        whole step's reason.
        """
        q0 = self.executor.q_now()
        start = self.target_cm if self.target_cm is not None else self.model.fk_cm(q0)
        start = np.array(start, dtype=float)
        way = np.zeros(3)
        way[axis] = sign
        step = CARTESIAN_STEPS_CM[self.step_index]
        route, problem = self._tcp_route(q0, start + step * way)
        length, beyond = step, None
        if route is None:
            assert problem is not None
            length, route, beyond = self._last_passed(q0, start, way, step, problem)
            if route is None:
                raise Refused(problem)
        try:  # timed as the sort's routes, its chords checked; a refusal sends nothing
            self.executor.stream(route, PHASE, closed=self.closed)
        except CollisionError as exc:
            raise Refused(str(exc)) from None
        self.target_cm = start + length * way
        if beyond is not None:
            along = f"{'+' if sign > 0 else '-'}{'xyz'[axis]}"
            self.say(f"stopped after {length:.2f} of the {step:g} cm step along {along}: {beyond}")

    def _tcp_route(self, q0: np.ndarray, target_cm: np.ndarray) -> tuple[Route | None, str | None]:
        """The route from ``q0`` to put the TCP at ``target_cm``, or why it is refused.

        Planned in full by the sort's planner (target box, reach, convergence, every pose
        within the limits), then every pose's pulses checked against the servos' ranges
        and the path against the table and the bins (:meth:`_contact_problem`); nothing
        is sent.
        """
        approach = self.config.arm.tool.pick_approach
        route = Route("", "", "approach", 1, IKTarget(tuple(target_cm), approach))
        route = self.planner.plan(route, q0)
        if not route.planned:
            return None, route.failure or "no plan"
        assert route.plan is not None
        try:
            self._check_pulses(route.plan.q_path, closed=self.closed)
        except Refused as exc:
            return None, str(exc)
        problem = self._contact_problem(route.plan.q_path)
        if problem is not None:
            return None, problem
        return route, None

    def _last_passed(
        self, q0: np.ndarray, start: np.ndarray, way: np.ndarray, step: float, problem: str
    ) -> tuple[float, Route | None, str]:
        """How far along ``way`` from ``start`` a refused step of ``step`` cm can go.

        Bisection on the length, each probe through :meth:`_tcp_route`'s checks: the
        shorter end always passes (at first 0, where the step starts), the longer never
        (at first the whole step, refused for ``problem``), until they are within
        :data:`TCP_ON_BOUND_CM`. If the checks refuse past a point of the line and pass
        before it (a bound crossed: the box, the reach, a limit), that point is found.

        Returns:
            The length [cm] and its route, and why the checks refuse the nearest length
            past it; the length 0 and no route when under :data:`TCP_ON_BOUND_CM` passes
            (the TCP on the bound: a step from there is refused, not crept along).
        """
        passed, refused = 0.0, step
        route: Route | None = None
        beyond = problem
        while refused - passed > TCP_ON_BOUND_CM:
            length = 0.5 * (passed + refused)
            probe, why = self._tcp_route(q0, start + length * way)
            if probe is None:
                assert why is not None
                refused, beyond = length, why
            else:
                passed, route = length, probe
        if passed < TCP_ON_BOUND_CM:
            return 0.0, None, beyond
        return passed, route, beyond

    def home(self) -> None:
        """Go home along a planned joint path, gripper as it is."""
        self._go_joints(self.model.home)
        self.target_cm = None

    def toggle_gripper(self) -> None:
        """Open or close the gripper where the arm is."""
        q = self.executor.q_now()
        self._check_pulses(q[None, :], closed=not self.closed)
        self.closed = not self.closed
        self.executor.set_tool(PHASE, closed=self.closed)

    # ----------------------------------------------------------------- keys

    def handle(self, key: str) -> bool:
        """Act on one key; ``False`` when the session should end (``q``, ``Q``)."""
        m = self.chain.m
        if key.isdigit() and 1 <= int(key) <= min(9, m):
            self.selected = int(key) - 1
        elif key in ("right", "tab"):
            self.selected = (self.selected + 1) % m
        elif key == "left":
            self.selected = (self.selected - 1) % m
        elif key in ("+", "=", "up"):
            self.move_joint(+1)
        elif key in ("-", "_", "down"):
            self.move_joint(-1)
        elif key.lower() in AXES:
            self.move_tcp(AXES[key.lower()], +1 if key.isupper() else -1)
        elif key == "[":
            self.step_index = max(0, self.step_index - 1)
        elif key == "]":
            self.step_index = min(len(JOINT_STEPS) - 1, self.step_index + 1)
        elif key == "g":
            self.toggle_gripper()
        elif key == "h":
            self.home()
        elif key == "q":
            self.say("going home")
            self.home()
            if self.closed:
                self.toggle_gripper()
            return False
        elif key == "Q":
            return False
        else:
            self.say(HELP)
            return True
        return True

    def session(self, keys: KeyReader) -> None:
        """Go home, then read keys until ``q`` or ``Q``."""
        self.executor.home_pose()
        self.say(HELP)
        self.readout()
        while True:
            key = keys.read()
            try:
                going_on = self.handle(key)
            except Refused as exc:
                self.say(f"refused: {exc}; nothing sent")
                continue
            if not going_on:
                return
            self.readout()


def build_parser() -> ArgumentParser:
    """The command's arguments."""
    parser = ArgumentParser(
        prog="mearm jog",
        description=(
            "Move the arm with the keyboard, joint by joint or the TCP along x/y/z, with a "
            "live readout of the joints, their limits and the TCP. Every move is checked "
            "as the sort's are before anything is sent."
        ),
    )
    add_config_argument(parser)
    parser.add_argument("--port", default=None, help="serial port (default: servo.port)")
    parser.add_argument(
        "--servo-calibration",
        type=Path,
        default=None,
        metavar="FILE",
        help="use the servo calibrations in FILE (written by mearm calibrate-servos)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command (see the module docstring); returns the exit status.

    SIGTERM and SIGHUP (the terminal closed) stop it as Ctrl-C does: the arm held.
    """
    with interrupts.stop_signals_as_ctrl_c():
        return _jog(argv)


def _jog(argv: Sequence[str] | None) -> int:
    args = build_parser().parse_args(argv)
    config = config_from_args(args)
    if args.servo_calibration is not None:
        config = apply_servo_calibration_file(config, args.servo_calibration)
    require_terminal("jog")
    out = sys.stdout
    bus = open_arm_bus(config, args.port)
    # connected before the keys are taken: a port that cannot be opened (or a board that
    # does not answer) is bad input, said in one line (exit 2) before anything moves
    bus.connect()
    try:
        with bus, KeyReader() as keys:
            jogger = Jogger(config, bus, out)
            try:
                jogger.session(keys)
            except KeyboardInterrupt:
                out.write("\ninterrupted: the arm stays where it is\n")
                hold_arm(bus)
                raise
            except EOFError:
                hold_arm(bus)
                print("mearm jog: the terminal closed; the arm stays where it is", file=sys.stderr)
                return EXIT_FAILURE
            hold_arm(bus)
    except ServoError as exc:
        print(f"mearm jog: servo fault: {exc}", file=sys.stderr)
        return EXIT_FAILURE
    jogger.say("done")
    return EXIT_OK


if __name__ == "__main__":
    run(main)
