"""What ``mearm sort``'s lines say of how the run ended (new-user walks).

- A sort that sorted every object but could not park exited 1 on a last line that read
  as a success (``sorted 12 of 12 objects``): its last line now says it stopped, not
  parked.
- ``--random 0`` sorted nothing and exited 0 (``sorted 0 of 0 objects``): ``--random N``
  takes 1 to 500 objects, anything else is bad input (exit 2, one line).
- On a simulated rig the count is a simulated figure: the last line says so.
- ``--record DIR`` named its folder ``recording: DIR`` before anything was written; it is
  named ``wrote DIR/ (N episodes, F frames)`` once written, and the outcome stays last.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from badinput import run_in_process

from mearm.config.sections import MAX_SCENE_OBJECTS
from mearm.kinematics.collision import CollisionModel, Contact
from mearm.sort import main as sort_main


def _sort(capsys: pytest.CaptureFixture[str], *argv: object) -> tuple[int, list[str], str]:
    code = sort_main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out.splitlines(), err


def test_a_sort_that_cannot_park_ends_on_a_line_that_says_so(capsys, monkeypatch):
    """Every object sorted, then the way home is not clear: the arm stays where it is.

    No home of a shipped arm is blocked so (the config's checks refuse a home in a bin or
    under the table; the one this test used, the paper arm folded behind the green bin,
    hangs its jaws under the table): the test blocks the way home itself, as a box put
    down there would, and the collision checks see it on every path that ends at home.
    """
    first_contact = CollisionModel.first_contact

    def a_box_at_home(self, path, *args, **kwargs):  # type: ignore[no-untyped-def]
        found = first_contact(self, path, *args, **kwargs)
        path = np.asarray(path, dtype=float)
        if found is None and len(path) and np.allclose(path[-1], self.model.home):
            return Contact("gripper_jaw_left_pad", "a box", -0.1, path[-1], len(path) - 1, None)
        return found

    monkeypatch.setattr(CollisionModel, "first_contact", a_box_at_home)
    code, lines, err = _sort(capsys, "--config", "sim", "--quiet")
    assert code == 1, err
    assert lines[-1].startswith("sorted 12 of 12 objects (simulated); then stopped: not parked: ")
    assert err.strip().splitlines()[-1].startswith("mearm sort: stopped: not parked: "), err


@pytest.mark.parametrize("n", ["0", "-1", str(MAX_SCENE_OBJECTS + 1), "10" * 12])
def test_random_takes_1_to_500_objects(n):
    out = run_in_process(["sort", "--config", "sim", "--quiet", "--random", n])
    assert out.code == 2 and out.stdout == "", out
    assert out.stderr.strip() == (
        "mearm sort: error: --random N lays N objects on the table: N must be 1 to "
        f"{MAX_SCENE_OBJECTS}, got {int(n)}"
    )


@pytest.mark.parametrize("config", ["sim", "sim_mujoco"])
def test_a_simulated_sort_says_its_count_is_simulated(config, capsys, monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    code, lines, err = _sort(capsys, "--config", config, "--random", "1", "--quiet")
    assert (code, lines[-1]) == (0, "sorted 1 of 1 objects (simulated)"), err


def test_objects_left_in_simulation_are_counted_simulated(capsys):
    """The label comes first, the reasons after it, as one parenthesis."""
    code, lines, err = _sort(
        capsys, "--config", "sim", "--quiet", "--random", "2", "--set", "task.pick_retries=0",
        "--set", "servo.error_model.offset_deg.base=8",
    )  # fmt: skip
    assert (code, lines[-1]) == (1, "sorted 0 of 2 objects (simulated; 2 pick failed)"), err
    assert err.strip() == "mearm sort: sorted 0 of 2 objects (simulated; 2 pick failed)"


@pytest.mark.heavy
@pytest.mark.parametrize("quiet", [False, True], ids=["routes", "quiet"])
def test_a_recording_is_named_once_written_and_the_outcome_stays_last(
    quiet, tmp_path: Path, capsys, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    argv = ["--config", "sim", "--random", "1", "--record", "ds", "--record-codec", "h264"]
    code, lines, err = _sort(capsys, *argv, *(["--quiet"] if quiet else []))
    assert code == 0, err
    assert not any(line.startswith("recording:") for line in lines), lines
    wrote = [i for i, line in enumerate(lines) if line.startswith("wrote ")]
    assert len(wrote) == 1, lines
    assert re.fullmatch(r"wrote ds/ \(1 episode, \d+ frames\)", lines[wrote[0]]), lines
    assert (Path("ds") / "meta" / "info.json").is_file()
    # after every route, before the summary: the outcome is the last line
    assert not any(line.startswith(("pick ", "place ")) for line in lines[wrote[0] :])
    assert lines[-1] == "sorted 1 of 1 objects (simulated)", lines
