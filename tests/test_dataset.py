"""Recording sorts as LeRobotDataset v3.0 (``--record``) and ``mearm dataset check/show``.

One twin sort of three objects is recorded once per test run (``mearm sort``, in the
test's process) and read back with pyarrow and PyAV only, independently of the checker.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import av
import cv2
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from badinput import Outcome, run_in_process
from built_once import built_once
from conftest import ROOT, interrupted

from mearm.dataset.contact_sheet import THUMB_WIDTH_PX
from mearm.dataset.format_check import RULES, check_dataset
from mearm.dataset.recorder import SCENE_TASK, task_sentence

TWIN = ROOT / "configs" / "sim_mujoco.yaml"
SORT = ["--config", TWIN, "--random", "3", "--seed", "1", "--quiet"]
KEY = "observation.images.table"

pytestmark = pytest.mark.heavy


def _mearm(*args: object) -> Outcome:
    """``mearm ARGS`` in this process, in the checkout (the tests of the command's own
    process are the Ctrl-C one here and that of what it imports)."""
    return run_in_process(args, within_s=30, cwd=ROOT)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A twin sort recorded (and its log), and the same sort's log without recording (run
    once per test run; nothing may write into them: copy the dataset to change it)."""

    def sort(d: Path) -> None:
        rec = _mearm("sort", *SORT, "--log", d / "rec.jsonl", "--record", d / "ds")
        assert rec.code == 0, rec.stderr
        plain = _mearm("sort", *SORT, "--log", d / "plain.jsonl")
        assert plain.code == 0, plain.stderr

    d = built_once(tmp_path_factory, "recorded-twin-sort", sort)
    return {"root": d / "ds", "log": d / "rec.jsonl", "plain": d / "plain.jsonl"}


def _episodes(root: Path) -> list[dict]:
    return pq.read_table(root / "meta/episodes/chunk-000/file-000.parquet").to_pylist()


def _routes(log: Path) -> list[dict]:
    records = [json.loads(line) for line in log.read_text().splitlines()]
    return [r for r in records if r["type"] == "route"]


def test_a_recorded_twin_sort_passes_the_check(recorded: dict[str, Path]) -> None:
    """Every rule of the format holds for a recorded sort."""
    assert check_dataset(recorded["root"]) == []


def test_recording_does_not_change_the_run(recorded: dict[str, Path]) -> None:
    """The sort's routes (joints, errors, outcomes) are the same with and without --record."""

    def strip(r: dict) -> dict:
        return {k: v for k, v in r.items() if k != "elapsed_s"}

    assert [strip(r) for r in _routes(recorded["log"])] == [
        strip(r) for r in _routes(recorded["plain"])
    ]


def test_parquet_rows_equal_the_frames_decoded_from_the_videos(recorded: dict[str, Path]) -> None:
    """Read with pyarrow and PyAV only: each episode's rows are its video's frames, in time."""
    root = recorded["root"]
    data = pq.read_table(root / "data/chunk-000/file-000.parquet")
    assert data.schema.field("observation.state").type == pa.list_(pa.float32(), 5)
    with av.open(str(root / f"videos/{KEY}/chunk-000/file-000.mp4")) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name in ("libdav1d", "av1", "libaom-av1")
        assert stream.pix_fmt == "yuv420p"
        times = np.array([float(f.pts * f.time_base) for f in container.decode(stream)])
    episodes = _episodes(root)
    assert len(episodes) == 3
    assert len(times) == data.num_rows == sum(e["length"] for e in episodes)
    for ep in episodes:
        rows = data.slice(ep["dataset_from_index"], ep["length"])
        assert rows["episode_index"].to_pylist() == [ep["episode_index"]] * ep["length"]
        t0 = ep[f"videos/{KEY}/from_timestamp"]
        in_span = times[(times >= t0 - 1e-4) & (times < ep[f"videos/{KEY}/to_timestamp"] - 1e-4)]
        np.testing.assert_allclose(
            in_span - t0, rows["timestamp"].to_numpy(), atol=1e-4, err_msg=f"episode {ep}"
        )
        np.testing.assert_array_equal(rows["frame_index"].to_numpy(), np.arange(ep["length"]))


def test_states_and_actions_match_the_run_log(recorded: dict[str, Path]) -> None:
    """Each episode is one pick-and-place of the log: its task names the object's class,
    the pick's last command is among its actions, the place's last is its last action,
    and the measured joints there are within 2° of it."""
    root = recorded["root"]
    info = json.loads((root / "meta/info.json").read_text())
    names = info["features"]["observation.state"]["names"]
    joints = [n for n in names if n in ("base", "shoulder", "elbow")]
    cols = [names.index(n) for n in joints]
    data = pq.read_table(root / "data/chunk-000/file-000.parquet")
    actions = np.array(data["action"].to_pylist())
    states = np.array(data["observation.state"].to_pylist())
    routes = _routes(recorded["log"])
    picks = [r for r in routes if r["step"] == "pick"]
    places = [r for r in routes if r["step"] == "place"]
    episodes = _episodes(root)
    assert len(episodes) == len(picks) == len(places) == 3
    for ep, pick, place in zip(episodes, picks, places, strict=True):
        assert ep["tasks"] == [task_sentence(pick["color"])]
        span = slice(ep["dataset_from_index"], ep["dataset_to_index"])
        a, s = actions[span][:, cols], states[span][:, cols]
        pick_end = np.array([pick["end_joints"][n] for n in joints])
        place_end = np.array([place["end_joints"][n] for n in joints])
        assert np.min(np.max(np.abs(a - pick_end), axis=1)) < 1e-3
        np.testing.assert_allclose(a[-1], place_end, atol=1e-3)
        np.testing.assert_allclose(s[-1], place_end, atol=2.0)


def test_info_stats_and_tasks_follow_lerobot(recorded: dict[str, Path]) -> None:
    """info.json's totals and templates, stats.json's shapes, tasks.parquet as pandas reads it."""
    root = recorded["root"]
    info = json.loads((root / "meta/info.json").read_text())
    assert info["codebase_version"] == "v3.0"
    assert info["data_path"] == "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    assert info["total_episodes"] == 3 and info["splits"] == {"train": "0:3"}
    assert info["features"][KEY]["dtype"] == "video"
    stats = json.loads((root / "meta/stats.json").read_text())
    assert np.shape(stats[KEY]["mean"]) == (3, 1, 1)
    assert stats["observation.state"]["count"] == [info["total_frames"]]
    tasks = pq.read_table(root / "meta/tasks.parquet")
    assert json.loads(tasks.schema.metadata[b"pandas"])["index_columns"] == ["task"]
    assert sorted(tasks["task"].to_pylist()) == sorted(
        task_sentence(c) for c in ("red", "green", "blue")
    )


def test_resume_appends_a_scene_as_one_episode(recorded: dict[str, Path], tmp_path: Path) -> None:
    """--resume appends; --record-per scene records the whole sort as one episode."""
    root = tmp_path / "ds"
    shutil.copytree(recorded["root"], root)
    out = _mearm("sort", "--config", TWIN, "--random", "2", "--seed", "2", "--quiet",
                 "--record", root, "--resume", "--record-per", "scene")  # fmt: skip
    assert out.code == 0, out.stderr
    info = json.loads((root / "meta/info.json").read_text())
    assert info["total_episodes"] == 4
    episodes = _episodes(root)
    assert [e["episode_index"] for e in episodes] == list(range(4))
    assert episodes[-1]["tasks"] == [SCENE_TASK]
    assert episodes[-1]["length"] > max(e["length"] for e in episodes[:3])
    frames = sum(e["length"] for e in episodes)
    said = f"wrote {root}/ (1 episode, {episodes[-1]['length']} frames; it holds 4 episodes, "
    assert f"{said}{frames} frames)" in out.stdout, out.stdout
    assert check_dataset(root) == []


def test_check_finds_a_torn_last_episode(recorded: dict[str, Path], tmp_path: Path) -> None:
    """Rows of the last episode cut off the data file: the check names the episode."""
    root = tmp_path / "ds"
    shutil.copytree(recorded["root"], root)
    path = root / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    pq.write_table(table.slice(0, table.num_rows - 4), path)
    problems = check_dataset(root)
    assert problems[0].startswith("data: episode 2 is torn"), problems


def test_check_finds_rows_after_the_last_episode(recorded: dict[str, Path], tmp_path: Path) -> None:
    """A data file with rows no episode claims (killed while an episode was written)."""
    root = tmp_path / "ds"
    shutil.copytree(recorded["root"], root)
    path = root / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    pq.write_table(pa.concat_tables([table, table.slice(0, 2)]), path)
    problems = check_dataset(root, videos=False)
    assert any("2 rows after its last episode (2)" in p for p in problems), problems


@pytest.mark.parametrize("videos", [True, False])
def test_check_finds_a_missing_video_file_with_or_without_decoding(
    recorded: dict[str, Path], tmp_path: Path, videos: bool
) -> None:
    """The episodes rule names the missing MP4, once, whether or not videos are decoded
    (``--no-videos`` passed such a dataset)."""
    root = tmp_path / "ds"
    shutil.copytree(recorded["root"], root)
    rel = f"videos/{KEY}/chunk-000/file-000.mp4"
    (root / rel).unlink()
    problems = check_dataset(root, videos=videos)
    assert problems == [f"episodes: episode 0: its file {rel} is missing"], problems


def test_show_prints_episodes_and_saves_a_contact_sheet(
    recorded: dict[str, Path], capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    """show lists every episode with its task and writes a PNG of frames with their states."""
    from mearm.dataset.__main__ import main

    sheet = tmp_path / "sheet.png"
    assert main(["show", str(recorded["root"]), "--sheet", str(sheet)]) == 0
    out = capsys.readouterr().out
    assert task_sentence("red") in out and "observation.state" in out
    assert sheet.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "9 frames)" in out
    image = cv2.imread(str(sheet))
    assert image.shape[1] == 3 * THUMB_WIDTH_PX


def test_every_rule_is_documented() -> None:
    """docs/datasets.md names every rule check applies."""
    text = (ROOT / "docs" / "datasets.md").read_text()
    assert all(f"`{name}`" in text for name in RULES)


def test_sort_without_record_imports_neither_pyarrow_nor_av() -> None:
    """The recording's libraries load only for --record."""
    code = (
        "import sys, mearm.sort, mearm.experiment; "
        "print(sorted(m for m in ('pyarrow', 'av') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)  # fmt: skip
    assert out.stdout.strip() == "[]", out.stderr


@pytest.mark.slow
def test_ctrl_c_keeps_every_finished_episode(tmp_path: Path) -> None:
    """Ctrl-C after the first episode: exit 130, the finished episodes pass the check.

    Six objects, six episodes at most: the encoder may run an episode or two behind the
    sort (its ring holds 24 frames), so the run is stopped well before its end."""
    root = tmp_path / "ds"
    six = [*SORT[:3], "6", *SORT[4:]]  # --random 6
    cmd = [sys.executable, "-m", "mearm", "sort", *map(str, six), "--record", str(root),
           "--set", "servo.sim_realtime=true"]  # fmt: skip
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if (root / "meta/info.json").exists():
            break
        time.sleep(0.01)
    interrupted(proc)
    assert proc.returncode == 130
    assert check_dataset(root) == []
    episodes = json.loads((root / "meta/info.json").read_text())["total_episodes"]
    assert 1 <= episodes < 6
    assert not (root / ".recording").exists()
