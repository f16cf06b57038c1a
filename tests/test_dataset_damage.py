"""A damaged dataset: every reader names the file and what is wrong (exit 2), none crashes.

Each file of a small dataset cut to half its size: ``mearm dataset show`` and ``mearm
sort --record DIR --resume`` refuse it in one line naming the file (nothing written),
``mearm dataset check`` fails it. ``meta/mearm_episodes.json`` (mearm's own) is checked
too: JSON, its shape, one entry per episode; a dataset without it (older, or another
tool's) stays readable.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from badinput import ROOT, check_bad_input  # noqa: E402
from conftest import record_by_hand  # noqa: E402

from mearm.dataset.format_check import check_dataset  # noqa: E402
from mearm.dataset.reading import RecordedScene, read_tags  # noqa: E402

SIM = ROOT / "configs" / "sim.yaml"

#: Each file of the dataset, cut to half.
FILES = [
    "meta/info.json",
    "meta/tasks.parquet",
    "meta/mearm_episodes.json",
    "meta/episodes/chunk-000/file-000.parquet",
    "data/chunk-000/file-000.parquet",
    "videos/observation.images.table/chunk-000/file-000.mp4",
]


def _record(root: Path, episodes: int = 2, scene: RecordedScene | None = None) -> None:
    record_by_hand(root, episodes=episodes, frames=20, resume=root.exists(), scene=scene)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two episodes on the kinematic rig."""
    root = tmp_path_factory.mktemp("damage") / "ds"
    _record(root)
    assert check_dataset(root) == []
    return root


def _cut(dataset: Path, tmp_path: Path, rel: str) -> Path:
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    path = copy / rel
    with path.open("r+b") as f:
        f.truncate(path.stat().st_size // 2)
    return copy


@pytest.mark.bad_input
@pytest.mark.parametrize("rel", FILES)
def test_show_and_resume_name_a_file_cut_short(dataset: Path, tmp_path: Path, rel: str) -> None:
    """Exit 2, one line naming the file and the damage, the dataset untouched (it was
    "unexpected error: JSONDecodeError/ArrowInvalid", exit 1, after the sort began)."""
    copy = _cut(dataset, tmp_path, rel)
    out = check_bad_input(["dataset", "show", copy, "--sheet", tmp_path / "s.png"], keep=[copy])
    assert f"{copy / rel}: " in out.line and "the dataset is damaged" in out.line, out.line
    argv = ["sort", "--config", SIM, "--random", "1", "--record", copy, "--resume"]
    out = check_bad_input(argv, keep=[copy], within_s=10.0)
    assert f"{copy / rel}: " in out.line and "the dataset is damaged" in out.line, out.line
    assert "mearm dataset check" in out.line


def test_check_fails_a_cut_tags_file(dataset: Path, tmp_path: Path) -> None:
    """``mearm_episodes.json`` cut short passed the check, then crashed ``--resume``."""
    copy = _cut(dataset, tmp_path, "meta/mearm_episodes.json")
    out = check_bad_input(["dataset", "check", copy], code=1, keep=[copy], within_s=10.0)
    assert "mearm: meta/mearm_episodes.json: not valid JSON (line 1)" in out.line


@pytest.mark.parametrize(
    ("tags", "says"),
    [
        ({"episodes": [[None, None]]}, "holds 1 entries for the 2 episodes"),
        ({"episodes": [[None, None], [None, None], [1, 0]]}, "holds 3 entries for the 2"),
        ([[None, None], [None, None]], 'not an object {"episodes": [...]}'),
        ({"episodes": [[None, None], ["x", 0]]}, 'entry 1 is ["x", 0]'),
        ({"episodes": [[None, None], [None, None, {"seed": 7}]]}, "entry 1 is"),
    ],
)
def test_check_fails_a_tags_file_of_another_shape(
    dataset: Path, tmp_path: Path, tags: object, says: str
) -> None:
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    (copy / "meta/mearm_episodes.json").write_text(json.dumps(tags))
    problems = check_dataset(copy, videos=False)
    assert len(problems) == 1 and problems[0].startswith("mearm: meta/mearm_episodes.json: ")
    assert says in problems[0], problems[0]


@pytest.mark.bad_input
def test_show_refuses_a_video_damaged_inside_before_its_report(
    dataset: Path, tmp_path: Path
) -> None:
    """Bytes flipped inside the video, its boxes whole: the report was printed, then exit 2
    (the docs: refused before it prints anything)."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    video = copy / "videos/observation.images.table/chunk-000/file-000.mp4"
    data = bytearray(video.read_bytes())
    for i in range(2000, len(data) - 100, 997):
        data[i] ^= 0xFF
    video.write_bytes(bytes(data))
    sheet = tmp_path / "s.png"
    out = check_bad_input(["dataset", "show", copy, "--sheet", sheet], keep=[copy])
    assert f"{video}: cannot be decoded" in out.line and "the dataset is damaged" in out.line
    assert out.stdout == "" and not sheet.exists()


@pytest.mark.parametrize(
    ("journal", "finishable"), [("{}", False), ("not json", False), ('{"replace": {}}', True)]
)
def test_a_journal_resume_cannot_finish_is_not_sent_to_resume(
    dataset: Path, tmp_path: Path, journal: str, finishable: bool
) -> None:
    """A damaged journal read 'record with --resume to finish writing it', and --resume
    then refused it as damaged: check and show now say --resume cannot finish it."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    (copy / "meta/.commit.json").write_text(journal)
    (problem,) = [p for p in check_dataset(copy, videos=False) if p.startswith("journal: ")]
    out = check_bad_input(["dataset", "show", copy, "--sheet", tmp_path / "s.png"], keep=[copy])
    if finishable:
        assert "(record with --resume to finish writing it)" in problem
        assert "with --resume to finish writing it, then show it" in out.line
    else:
        assert "is there and damaged (" in problem and "--resume cannot finish it" in problem
        assert "--resume cannot finish it: the dataset is damaged" in out.line, out.line


@pytest.mark.parametrize("fps", [-10, 0, 10.0, True, "10"])
def test_check_says_the_least_fps_there_is(dataset: Path, tmp_path: Path, fps: object) -> None:
    """fps ≥ 1 (as the docs say), whatever was wrong: -10 read "a whole number ≥ 0"."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    info = json.loads((copy / "meta/info.json").read_text())
    (copy / "meta/info.json").write_text(json.dumps({**info, "fps": fps}))
    problems = check_dataset(copy, videos=False)
    assert problems == [f"info: fps is {fps!r}: a whole number ≥ 1 is needed"], problems


@pytest.mark.bad_input
def test_a_mearm_dataset_that_lost_its_tags_file_is_damaged(dataset: Path, tmp_path: Path) -> None:
    """``mearm_episodes.json`` deleted, ``mearm_starts.json`` there (mearm keeps both): the
    check fails it and a resume refuses it. Until 2026-12-06 it read as another tool's
    dataset, untagged, and an experiment's --resume recorded the picks it held again."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    (copy / "meta/mearm_episodes.json").unlink()
    problems = check_dataset(copy, videos=False)
    assert len(problems) == 1, problems
    assert problems[0].startswith("mearm: meta/mearm_episodes.json: missing, though ")
    argv = ["sort", "--config", SIM, "--random", "1", "--record", copy, "--resume"]
    out = check_bad_input(argv, keep=[copy], within_s=10.0)
    assert f"{copy / 'meta/mearm_episodes.json'}: missing" in out.line, out.line


def test_a_dataset_without_tags_or_scenes_stays_readable(dataset: Path, tmp_path: Path) -> None:
    """No tags file nor starts (another tool's), or entries of two (mearm before scenes):
    it passes, and a resume keeps the old entries and adds its episodes' scenes."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    (copy / "meta/mearm_episodes.json").unlink()
    (copy / "meta/mearm_starts.json").unlink()
    assert check_dataset(copy, videos=False) == []
    assert read_tags(copy, 2) == ([(None, None)] * 2, [None] * 2)
    scene = RecordedScene(seed=7, objects=2, config="sim_mujoco", overrides=("a.b=1",))
    _record(copy, episodes=1, scene=scene)
    assert check_dataset(copy) == []
    tags = json.loads((copy / "meta/mearm_episodes.json").read_text())["episodes"]
    want = {"seed": 7, "objects": 2, "config": "sim_mujoco", "set": ["a.b=1"]}
    assert tags == [[None, None], [None, None], [None, None, want]]
    assert read_tags(copy, 3)[1] == [None, None, scene]


def _rows_cut(dataset: Path, tmp_path: Path, keep: int) -> Path:
    """A copy whose data file keeps its first ``keep`` rows (negative: all but so many),
    or (``keep`` past its end) its last row twice: a Parquet file still whole."""
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    path = copy / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    if keep > table.num_rows:
        table = pa.concat_tables([table, table.slice(table.num_rows - 1)])
    else:
        table = table.slice(0, keep % table.num_rows)
    pq.write_table(table, path)
    return copy


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("keep", "says"),
    [(-3, "episode 1 is torn: the file holds "), (10**6, "holds 1 rows after its last episode")],
)
def test_resume_refuses_a_data_file_whose_rows_are_not_its_episodes(
    dataset: Path, tmp_path: Path, keep: int, says: str
) -> None:
    """Rows cut off the last episode (or one added), the Parquet file whole: the check
    failed it, but --resume appended after them, exit 0, and the indices of every
    episode from the torn one on were wrong. Now refused, exit 2, nothing written."""
    copy = _rows_cut(dataset, tmp_path, keep)
    assert [p.split(":")[0] for p in check_dataset(copy, videos=False)] == ["data"]
    argv = ["sort", "--config", SIM, "--random", "1", "--record", copy, "--resume"]
    out = check_bad_input(argv, keep=[copy], within_s=10.0)
    rel = "data/chunk-000/file-000.parquet"
    assert f"{copy / rel}: {says}" in out.line and "the dataset is damaged" in out.line, out.line


@pytest.mark.bad_input
def test_show_refuses_a_torn_episode_before_its_report(dataset: Path, tmp_path: Path) -> None:
    """Rows cut off the last episode, every file readable: the check failed it, and show
    drew the report, then crashed in the sheet ("unexpected error: IndexError", exit 1)."""
    copy = _rows_cut(dataset, tmp_path, -3)
    sheet = tmp_path / "s.png"
    out = check_bad_input(["dataset", "show", copy, "--sheet", sheet], keep=[copy])
    assert out.line.startswith(f"mearm dataset: error: {copy}: data: episode 1 is torn: "), out.line
    assert "the dataset is damaged" in out.line and f"mearm dataset check {copy}" in out.line
    assert out.stdout == "" and not sheet.exists()


@pytest.mark.bad_input
def test_show_refuses_totals_the_episodes_disagree_with(dataset: Path, tmp_path: Path) -> None:
    """``total_frames`` 5 more than the episodes hold: show printed it as the dataset's
    size, exit 0; the check's stats rule said ``not [total_frames]``, not the number."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    info = json.loads((copy / "meta/info.json").read_text())
    frames, info["total_frames"] = info["total_frames"], info["total_frames"] + 5
    (copy / "meta/info.json").write_text(json.dumps(info))
    problems = check_dataset(copy, videos=False)
    assert f"stats: action count is [{frames}], not [{frames + 5}] (total_frames)" in problems
    sheet = tmp_path / "s.png"
    out = check_bad_input(["dataset", "show", copy, "--sheet", sheet], keep=[copy])
    says = f"{copy}: episodes: the episodes hold {frames} frames, info.json says {frames + 5} ("
    assert says in out.line and "the dataset is damaged" in out.line, out.line
    assert out.stdout == "" and not sheet.exists()


def _one_value(dataset: Path, tmp_path: Path, column: str, row: int, value: float) -> Path:
    """A copy whose data file has ``value`` as the first number of ``column`` in ``row``."""
    import pyarrow as pa  # noqa: PLC0415
    import pyarrow.parquet as pq  # noqa: PLC0415

    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    path = copy / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    values = table[column].to_pylist()
    values[row][0] = value
    at = table.schema.get_field_index(column)
    table = table.set_column(at, column, pa.array(values, table.schema.field(column).type))
    pq.write_table(table, path)
    return copy


@pytest.mark.parametrize(
    ("column", "value", "frame"),
    [
        ("action", float("nan"), 2),
        ("observation.state", float("-inf"), 2),
        ("action", float("nan"), 0),  # its other numbers known: not a frame before any command
    ],
)
def test_check_names_a_value_that_is_not_finite(
    dataset: Path, tmp_path: Path, column: str, value: float, frame: int
) -> None:
    """A NaN action passed the check (exit 0), and the replay then crashed on it ("unexpected
    error: ValueError ... an action must be finite"). NaN in a frame 0 whose action is
    all NaN (the recorder's, before the bus's first command: episode 0's here) passes."""
    import pyarrow.parquet as pq  # noqa: PLC0415

    first = pq.read_table(dataset / "meta/episodes/chunk-000/file-000.parquet")
    row = int(first["dataset_from_index"][1].as_py()) + frame  # episode 1's
    copy = _one_value(dataset, tmp_path, column, row, value)
    assert check_dataset(copy, videos=False) == [
        f"data: episode 1 in data/chunk-000/file-000.parquet: {column} is not finite (NaN or "
        f"inf) at frame {frame}"
    ]
