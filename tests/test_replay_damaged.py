"""The replay refuses a dataset ``mearm dataset check`` fails, before any step (exit 2).

A dataset whose files all read, but with an action set to NaN, crashed the replay
halfway ("unexpected error: ValueError ... an action must be finite", exit 1); one whose
last episode was torn (rows cut off its data file) replayed the rows left of it without
saying so. Both are refused as ``mearm dataset show`` refuses them: one line naming the
first broken rule.
"""

from __future__ import annotations

import contextlib
import shutil
import subprocess
from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT, one_stderr_line, run_main

pytest.importorskip("pyarrow")
pytest.importorskip("av")

import pyarrow as pa  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402

from mearm.envs.replay import main as replay_main  # noqa: E402
from mearm.envs.replay import plan_replay  # noqa: E402

DATA = "data/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def sorted_picks(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``mearm sort --random 2 --seed 7 --record`` in the twin: two picks."""
    ds = tmp_path_factory.mktemp("replay_damaged") / "ds"
    with contextlib.chdir(ROOT):
        out = run_in_process(
            ["sort", "--config", "configs/sim_mujoco.yaml", "--random", "2", "--seed", "7",
             "--record", ds, "--record-codec", "h264", "--quiet"],
            within_s=30,
        )  # fmt: skip
    assert out.code == 0, out.stderr
    plan_replay(ds, 1)  # whole: not refused
    return ds


def _edited(ds: Path, tmp_path: Path, edit: str) -> Path:
    """A copy whose data file has episode 1's frame 3 action NaN, or its last 2 rows cut."""
    copy = tmp_path / "dsx"
    shutil.copytree(ds, copy)
    table = pq.read_table(copy / DATA)
    if edit == "nan":
        episodes = table["episode_index"].to_pylist()
        actions = table["action"].to_pylist()
        actions[episodes.index(1) + 3][0] = float("nan")
        at = table.schema.get_field_index("action")
        table = table.set_column(at, "action", pa.array(actions, table.schema.field("action").type))
    else:
        table = table.slice(0, table.num_rows - 2)
    pq.write_table(table, copy / DATA)
    return copy


@pytest.mark.parametrize(
    ("edit", "says"),
    [
        ("nan", f"data: episode 1 in {DATA}: action is not finite (NaN or inf) at frame 3"),
        ("torn", f"data: episode 1 is torn: {DATA} holds "),
    ],
)
def test_the_replay_refuses_a_dataset_the_check_fails(
    sorted_picks: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: str, says: str
) -> None:
    copy = _edited(sorted_picks, tmp_path, edit)
    code, out, err = run_main(capsys, replay_main, copy, "--episode", "1")
    line = one_stderr_line(subprocess.CompletedProcess([], code, out, err), 2)
    assert f"{copy}: {says}" in line and "the dataset is damaged" in line, line
    assert out == ""
