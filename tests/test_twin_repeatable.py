"""A twin sort is repeatable: the same scene, sorted twice, moves the same and ends the same.

Comparisons of twin sweeps (before and after a change, twin-scenes against a script that
calls ``run_sort``) are only worth anything if a scene's sort depends on its seed and
kit alone: not on whether its lines are printed, nor on the sorts run before it in the
process (``twin-scenes --jobs 1`` sorts every scene in one). The wall clock only times
the routes for the report.
"""

from __future__ import annotations

from typing import Any

import pytest

from mearm.config import load_config
from mearm.hardware.bus import ServoBus
from mearm.sim.twin.twin_bus import TwinArm
from mearm.task.rig import run_sort
from mearm.task.scene import random_scene

#: A kit whose servos are off (a high claw, a sluggish one) and a scene with a pick
#: beside a bin's wall: the looks, the retries and the grips all take part.
KIT, SEED, OBJECTS = 21, 1710, 4


def _sort(monkeypatch: pytest.MonkeyPatch, echo: Any) -> tuple[list[str], str, list[str]]:
    """Sort the scene: every command sent, the outcome and where the twin left each body."""
    config = load_config(
        "configs/sim_mujoco_kits.yaml", ["twin.kit.per_trial=false", f"twin.kit.seed={KIT}"]
    )
    moves: list[str] = []
    end: list[str] = []
    move, close = ServoBus.move, TwinArm._close

    def recorded_move(bus: ServoBus, command: Any) -> None:
        moves.append(f"{bus.clock_s!r} {command!r}")
        move(bus, command)

    def recorded_close(bus: TwinArm) -> None:
        end.extend(f"{o} {bus.object_pose(o)!r}" for o in bus.object_ids)
        end.append(f"{bus.actual_joints!r} {bus.clock_s!r}")
        close(bus)

    monkeypatch.setattr(ServoBus, "move", recorded_move)
    monkeypatch.setattr(TwinArm, "_close", recorded_close)
    out = run_sort(config, scene=random_scene(config, OBJECTS, seed=SEED), echo=echo).outcome
    monkeypatch.undo()
    return moves, f"{out.sorted} {out.left} {out.in_bins}", end


@pytest.mark.heavy
def test_a_twin_sort_is_the_same_printed_or_silent_and_run_twice(monkeypatch):
    """Silent, then printing its lines in the same process: the same commands at the same
    twin times, the same outcome, every body where it was."""
    lines: list[str] = []
    silent = _sort(monkeypatch, None)
    printed = _sort(monkeypatch, lines.append)
    assert lines, "the second sort printed nothing"
    assert len(silent[0]) > 100  # a sort that moved, not two empty ones
    assert printed[1] == silent[1]
    assert printed[2] == silent[2]
    assert printed[0] == silent[0]
