"""``mearm dataset check`` checks ``meta/mearm_starts.json`` and ``meta/mearm_servos/``.

What a replay of an episode per pick needs besides its scene: the episode of its sort it
continues, and the servo calibration its sort made at its start. The check passed any of
it, damaged or not: a starts file cut short or naming a later episode, a servo file gone
or of another arm, episodes that continue one of another sort. The replay and
``--resume`` then refused it (or replayed from the wrong start), with "`mearm dataset
check DIR` lists what is wrong" while the check said the dataset passed. Each is now a
broken ``mearm`` rule, as a damaged ``meta/mearm_episodes.json`` is.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from badinput import ROOT, check_bad_input  # noqa: E402
from conftest import record_by_hand  # noqa: E402

from mearm.config import load_config  # noqa: E402
from mearm.config.servo_file import (  # noqa: E402
    ActuatorFit,
    ServoCalibrationFile,
    save_servo_calibration,
    servo_of,
)
from mearm.dataset.format_check import check_dataset  # noqa: E402

STARTS = "meta/mearm_starts.json"
TAGS = "meta/mearm_episodes.json"
SERVOS = "meta/mearm_servos/episode-000000.servos.yaml"
OTHER = "meta/mearm_servos/episode-000002.servos.yaml"


def _calibration(arm_name: str) -> ServoCalibrationFile:
    """A servo calibration of configs/sim.yaml's base servo (as a sort's at its start)."""
    arm = load_config(ROOT / "configs" / "sim.yaml").arm
    base = servo_of(arm, "base")
    fit = ActuatorFit("base", "deg", base, (), 0.0, replaces=base)
    return ServoCalibrationFile(arm_name, "test", "", "2026-01-01T00:00:00+00:00", (fit,))


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Three picks of one sort (each after the one before), which calibrated its servos
    at its start: each names the sort's servo file, as the recorder writes them."""
    root = record_by_hand(tmp_path_factory.mktemp("starts") / "ds", episodes=3, frames=20)
    starts = json.loads((root / STARTS).read_text())["episodes"]
    assert [s.get("after") for s in starts] == [None, 0, 1]
    for start in starts:
        start["servos"] = SERVOS
    (root / STARTS).write_text(json.dumps({"episodes": starts}))
    arm_name = json.loads((root / "meta/info.json").read_text())["robot_type"]
    save_servo_calibration(root / SERVOS, _calibration(arm_name))
    assert check_dataset(root, videos=False) == []
    return root


def _changed(root: Path, tmp_path: Path, change: Callable[[Path], None]) -> list[str]:
    """The check's findings on a copy of ``root`` that ``change`` altered."""
    copy = tmp_path / "dsx"
    shutil.copytree(root, copy)
    change(copy)
    return check_dataset(copy, videos=False)


def _entries(change: Callable[[list[dict[str, Any]]], None]) -> Callable[[Path], None]:
    """A change to the starts file's entries."""

    def alter(root: Path) -> None:
        data = json.loads((root / STARTS).read_text())
        change(data["episodes"])
        (root / STARTS).write_text(json.dumps(data))

    return alter


def _tags(tags: list[list[Any]]) -> Callable[[Path], None]:
    def alter(root: Path) -> None:
        (root / TAGS).write_text(json.dumps({"episodes": tags}))

    return alter


def _set(k: int, **entry: Any) -> Callable[[list[dict[str, Any]]], None]:
    return lambda entries: entries[k].update(entry)


#: Each damage, and what the check says of it.
DAMAGE: dict[str, tuple[Callable[[Path], None], str]] = {
    "cut short": (
        lambda root: (root / STARTS).write_text((root / STARTS).read_text()[:30]),
        f"mearm: {STARTS}: not valid JSON (line 1)",
    ),
    "a later episode": (_entries(_set(1, after=2)), f"mearm: {STARTS}: entry 1 is"),
    "itself": (_entries(_set(2, after=2)), f"mearm: {STARTS}: entry 2 is"),
    "an episode that does not exist": (
        _entries(lambda e: e.append({"after": 2, "gap_frames": 0})),
        f"mearm: {STARTS}: holds 4 entries for the 3 episodes of the dataset",
    ),
    "a gap before nothing": (_entries(_set(0, gap_frames=3)), f"mearm: {STARTS}: entry 0 is"),
    "a servo file outside": (
        _entries(_set(1, servos="../elsewhere.servos.yaml")),
        f"mearm: {STARTS}: entry 1 is",
    ),
    "a missing servo file": (
        lambda root: (root / SERVOS).unlink(),
        f"mearm: episode 0: its servo calibration {SERVOS} is missing",
    ),
    "a servo file that is not one": (
        lambda root: (root / SERVOS).write_text("format: something else\n"),
        f"mearm: episode 0: {SERVOS}: not a mearm servo calibration",
    ),
    "a servo file of another arm": (
        lambda root: (root / SERVOS).write_text(_calibration("another_arm").text()),
        f"mearm: episode 0: {SERVOS} is a servo calibration of the arm 'another_arm'",
    ),
    "a servo file no episode names": (
        lambda root: shutil.copy(root / SERVOS, root / "meta/mearm_servos/stray.servos.yaml"),
        f"mearm: meta/mearm_servos/stray.servos.yaml belongs to no episode (no entry of {STARTS}",
    ),
    "other servos than the pick before": (
        lambda root: (
            shutil.copy(root / SERVOS, root / OTHER),
            _entries(_set(2, servos=OTHER))(root),
        ),
        f"mearm: {STARTS}: episode 2 continues episode 1, which ran other servos ({SERVOS}, "
        f"not {OTHER})",
    ),
    "not the trial's pick before": (
        _tags([[5, 0], [5, 1], [6, 1]]),
        f"mearm: {STARTS}: episode 2 continues episode 1, but {TAGS} tags them [6, 1] and "
        "[5, 1]: not one sort's picks in a row",
    ),
    "a trial's second pick at the reset": (
        lambda root: (
            _tags([[5, 0], [5, 1], [5, 2]])(root),
            _entries(lambda e: e[1].update(after=None) or e[1].pop("gap_frames"))(root),
        ),
        f"mearm: {STARTS}: episode 1, pick 1 of its trial, starts where the reset leaves the arm",
    ),
    "another scene": (
        _tags([[None, None], [None, None, {"seed": 7, "objects": 3, "config": None, "set": []}],
               [None, None, {"seed": 7, "objects": 3, "config": None, "set": []}]]),
        f"mearm: {STARTS}: episode 1 continues episode 0, which sorts another scene ({TAGS})",
    ),
}  # fmt: skip


@pytest.mark.parametrize("damage", DAMAGE)
def test_the_check_reports_a_damaged_or_inconsistent_start(
    calibrated: Path, tmp_path: Path, damage: str
) -> None:
    """Each is one finding of the ``mearm`` rule naming the file and the episode; before,
    the dataset passed."""
    change, said = DAMAGE[damage]
    found = _changed(calibrated, tmp_path, change)
    assert len(found) == 1 and found[0].startswith(said), found


def test_a_trials_picks_in_a_row_pass(calibrated: Path, tmp_path: Path) -> None:
    """One trial's picks 0, 1, 2, each of the sort's scene and servos: no finding (the
    rule does not refuse what the recorder writes)."""
    scene = {"seed": 7, "objects": 3, "config": None, "set": []}
    assert _changed(calibrated, tmp_path, _tags([[5, p, scene] for p in range(3)])) == []


@pytest.mark.bad_input
def test_dataset_check_exits_1_naming_the_servo_file(calibrated: Path, tmp_path: Path) -> None:
    """The command: exit 1, the finding on stderr in one line (before: exit 0, "passes")."""
    copy = tmp_path / "dsx"
    shutil.copytree(calibrated, copy)
    (copy / SERVOS).unlink()
    out = check_bad_input(["dataset", "check", copy], code=1, keep=[copy], within_s=10.0)
    assert f"mearm: episode 0: its servo calibration {SERVOS} is missing" in out.line
