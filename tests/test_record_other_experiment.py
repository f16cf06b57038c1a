"""Another experiment resumed into a dataset is refused, not taken for the one it holds.

A resumed experiment records only the picks its dataset lacks, each known by its trial's
seed and number. Trial seeds come from ``--seed`` (0 unless given), so another
experiment's trials (another ``--scene``, ``--set`` or config) had the same tags: all its
episodes were dropped as "already there", and the run exited 0 having recorded nothing.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT

from mearm.dataset.format_check import check_dataset

pytestmark = pytest.mark.heavy

SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"
OTHER = "- {color: red, x: -8.0, y: 47.0}\n- {color: blue, x: 5.0, y: 45.0}\n"


def _episodes(root: Path) -> int:
    return int(json.loads((root / "meta/info.json").read_text())["total_episodes"])


def test_another_experiments_trials_are_refused_and_the_same_ones_resume(tmp_path: Path) -> None:
    """A second experiment of other tables or --set: exit 2 before anything runs, naming
    what differs, the dataset as it was; the same experiment, its config named another
    way, resumes and appends its next trial."""
    (tmp_path / "a.yaml").write_text(SCENE)
    (tmp_path / "b.yaml").write_text(OTHER)
    root = tmp_path / "ds"
    record = ["--record", str(root), "--record-codec", "h264", "--record-fps", "5"]

    def experiment(config: str, scene: str, log: str, *more: str) -> object:
        argv = ["experiment", "--config", config, "--scene", str(tmp_path / scene)]
        argv += ["--log", str(tmp_path / log), *record, *more]
        return run_in_process(argv, within_s=30, cwd=ROOT)

    first = experiment("sim", "a.yaml", "a.jsonl", "--trials", "1")
    assert first.code == 0, first.stderr
    assert _episodes(root) == 2
    held = {p: p.read_bytes() for p in root.rglob("*") if p.is_file()}

    for scene, more, said in (
        ("b.yaml", (), "its table differs"),
        ("a.yaml", ("--set", "task.clearance_cm=0.4"), "it was sorted with --set []"),
    ):
        other = experiment("sim", scene, "b.jsonl", "--trials", "1", "--resume", *more)
        assert other.code == 2, other.stderr
        assert other.line.startswith("mearm experiment: error: ")
        assert "another experiment's trial of seed" in other.line and said in other.line
        assert "give this experiment another --seed" in other.line
        assert {p: p.read_bytes() for p in root.rglob("*") if p.is_file()} == held
        assert not (tmp_path / "b.jsonl").exists()

    again = experiment("configs/sim.yaml", "a.yaml", "a.jsonl", "--trials", "2", "--resume")
    assert again.code == 0, again.stderr
    assert _episodes(root) == 4
    assert check_dataset(root) == []
