"""An object that slips out of the twin's jaws on the way and falls into its own bin is
sorted: the world has it in its class's bin.

``mearm sort --config sim_mujoco --random 3 --seed 16499 --set
task.classes.blue.diameter_cm=1`` (found by a fresh-seed sweep, as seeds 16504 and 16507
of 12): the 1 cm blue disc slips out of the jaws before the arm is over the blue bin and
falls into it. The place read the empty jaws as a failure ("… it was lost on the way and
fell into the blue bin"), the object was left as no longer in the work area, and the sort
said "sorted 2 of 3" and exited 1, its run log ``"sorted": {"blue": 0}`` with the twin
counting it in its bin. One that falls into another class's bin, or anywhere else, is
still not sorted, with its reason.
"""

from __future__ import annotations

import pytest
from conftest import ROOT, run_main

from mearm import sort
from mearm.runlog import read_runlog
from mearm.task.pick_place import LOST_INTO_ITS_BIN, place_failure, place_note

CONFIG = ROOT / "configs" / "sim_mujoco.yaml"
LOST = "over the bin the jaws held nothing of its class: it was lost on the way and "


@pytest.mark.heavy
def test_a_disc_lost_into_its_own_bin_is_sorted(tmp_path, capsys) -> None:
    log = tmp_path / "run.jsonl"
    code, out, err = run_main(
        capsys, sort.main, "--config", CONFIG, "--random", 3, "--seed", 16499,
        "--set", "task.classes.blue.diameter_cm=1", "--log", log,
    )  # fmt: skip
    (place,) = (line for line in out.splitlines() if line.startswith("place blue1"))
    assert " ok " in place and place.endswith(f" ms: {LOST_INTO_ITS_BIN}"), place
    assert "not sorted" not in out and "skip " not in out, out
    assert out.strip().endswith("sorted 3 of 3 objects (simulated)"), out
    assert code == 0, err
    (trial,) = read_runlog(log, strict=True).trials
    assert not trial.skips
    (route,) = (r for r in trial.routes if r.object_id == "blue1" and r.step == "place")
    assert (route.success, route.why_failed, route.note) == (True, None, LOST_INTO_ITS_BIN)
    assert trial.summary is not None and trial.summary.ok
    assert trial.summary.sorted == {"red": 1, "green": 1, "blue": 1}
    assert trial.summary.left == {}


class _Twin:
    """A twin's bus as a place reads it: the jaws empty, ``blue1`` where ``bins`` has it."""

    def __init__(self, bins: dict[str, str]):
        self.bins = bins

    def held_ids(self) -> frozenset[str]:
        return frozenset()

    def where(self, object_id: str) -> str:
        name = self.bins.get(object_id)
        return f"fell into the {name} bin" if name else "is on the table at (1.0, 2.0) cm"

    def in_own_bin(self, object_id: str) -> str | None:
        return "blue" if self.bins.get(object_id) == "blue" else None


@pytest.mark.parametrize(
    ("bins", "why"),
    [
        ({"blue1": "blue"}, None),
        ({"blue1": "red"}, LOST + "fell into the red bin"),
        ({}, LOST + "is on the table at (1.0, 2.0) cm"),
    ],
    ids=["its own bin", "another bin", "the table"],
)
def test_only_its_own_bin_counts_an_object_lost_on_the_way(bins, why) -> None:
    bus = _Twin(bins)
    got = place_failure(bus, "blue", held=False, gripped=frozenset({"blue1"}))  # type: ignore[arg-type]
    assert got == why
    note = place_note(held=False, success=got is None)
    assert note == (LOST_INTO_ITS_BIN if why is None else None)
    assert place_note(held=True, success=True) is None  # an ordinary place says only ok
