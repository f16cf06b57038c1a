"""``mearm dataset show`` reads back what the recorder wrote, as docs/datasets.md says.

Found walking the page a third time:
- an episode of a table laid as it is (an experiment's trial, a ``--scene`` sort, the
  config's own table) was listed as ``(--random 12 --seed None)``, a command that draws
  another table, where the page promises the trial's seed and pick;
- a damaged ``meta/mearm_starts.json``, which ``--resume`` refuses, was shown, exit 0;
- an episode half written (the process killed among its renames, its journal there) was
  shown as if whole, exit 0, its sheet drawn from files that disagree.
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from badinput import check_bad_input, run_in_process  # noqa: E402
from conftest import record_by_hand  # noqa: E402

import mearm.dataset.recorder as recorder_module  # noqa: E402
from mearm.config import SceneObject  # noqa: E402
from mearm.dataset import lerobot_format as L  # noqa: E402
from mearm.dataset.format_check import check_dataset  # noqa: E402
from mearm.dataset.reading import RecordedScene, read_json, tags_json  # noqa: E402

TABLE = [
    SceneObject(color="red", x=-10.0, y=45.0, yaw_deg=0.0),
    SceneObject(color="green", x=5.0, y=50.0, yaw_deg=0.0),
]


@pytest.fixture(scope="module")
def laid(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two short H.264 episodes of a laid table (as a ``--scene`` sort keeps it)."""
    root = tmp_path_factory.mktemp("walk3_q10") / "ds"
    scene = RecordedScene.laid(TABLE, "sim", [])
    record_by_hand(root, episodes=2, frames=8, codec="h264", scene=scene)
    assert check_dataset(root) == []
    return root


def _episode_lines(root: Path, sheet: Path) -> list[str]:
    out = run_in_process(["dataset", "show", str(root), "--sheet", str(sheet)])
    assert out.code == 0, out.stderr
    return [line for line in out.stdout.splitlines() if re.match(r" +\d+ +\d+ +[\d.]+  put", line)]


def test_a_laid_table_is_not_shown_as_a_random_draw(laid: Path, tmp_path: Path) -> None:
    lines = _episode_lines(laid, tmp_path / "s.png")
    assert len(lines) == 2, lines
    for line in lines:
        assert "--seed None" not in line and "--random" not in line, line
        assert line.endswith("(a table of 2 objects, as laid)"), line


def test_a_trial_shows_its_seed_and_pick(laid: Path, tmp_path: Path) -> None:
    """As an experiment records a trial: its tag and its laid table with its noise seed."""
    copy = tmp_path / "ds"
    shutil.copytree(laid, copy)
    scene = RecordedScene.laid(TABLE, "sim", [], noise_seed=7)
    (copy / L.TAGS_PATH).write_text(tags_json([(7, 0), (7, 1)], [scene, scene]))
    assert check_dataset(copy) == []
    lines = _episode_lines(copy, tmp_path / "s.png")
    assert [line[line.index("(") :] for line in lines] == [
        "(trial seed 7, pick 0)",
        "(trial seed 7, pick 1)",
    ]


@pytest.mark.bad_input
def test_show_refuses_a_damaged_starts_file(laid: Path, tmp_path: Path) -> None:
    copy = tmp_path / "dsx"
    shutil.copytree(laid, copy)
    (copy / L.STARTS_PATH).write_text('{"episodes": [{"after": null}')  # cut short
    sheet = tmp_path / "s.png"
    out = check_bad_input(["dataset", "show", copy, "--sheet", sheet], keep=[copy])
    assert out.line.startswith(f"mearm dataset: error: {copy / L.STARTS_PATH}: not valid JSON")
    assert out.stdout == ""
    assert not sheet.exists()


def _killed_among_renames(root: Path) -> None:
    """As a process killed after its episode's first rename: the journal is left, the
    video's fragment appended and the data file in place, the rest still staged."""
    journal = read_json(root, L.JOURNAL_PATH)
    for rel, append in journal.get("append", {}).items():
        with open(root / rel, "r+b") as f:
            f.truncate(append["size"])
            f.seek(0, os.SEEK_END)
            f.write((root / append["from"]).read_bytes())
        (root / append["from"]).unlink()
    final, staged = next(iter(journal["replace"].items()))
    os.replace(root / staged, root / final)


@pytest.mark.bad_input
def test_show_refuses_a_half_written_episode(
    laid: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    copy = tmp_path / "dsx"
    shutil.copytree(laid, copy)
    finish = recorder_module.finish_journal

    def cut_off(root: Path) -> bool:
        if not (root / L.JOURNAL_PATH).exists():
            return finish(root)
        _killed_among_renames(root)
        return True

    monkeypatch.setattr(recorder_module, "finish_journal", cut_off)
    record_by_hand(copy, episodes=1, frames=8, codec="h264", resume=True)
    monkeypatch.undo()
    assert (copy / L.JOURNAL_PATH).exists()
    assert any(p.startswith("journal: ") for p in check_dataset(copy))
    sheet = tmp_path / "s.png"
    out = check_bad_input(["dataset", "show", copy, "--sheet", sheet], keep=[copy])
    assert out.line == (
        f"mearm dataset: error: {copy / L.JOURNAL_PATH}: an episode was being written when "
        f"the recorder stopped: record into {copy} with --resume to finish writing it, "
        "then show it"
    )
    assert out.stdout == ""
    assert not sheet.exists()
    # and --resume does finish it: the dataset then passes and shows its four episodes
    record_by_hand(copy, episodes=1, frames=8, codec="h264", resume=True)
    assert check_dataset(copy) == []
    assert len(_episode_lines(copy, sheet)) == 4  # the half-written one among them
