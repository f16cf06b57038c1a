"""A resumed trial's first recorded pick continues the held episode of the pick before it.

``mearm experiment --resume`` runs a trial cut off by a kill again from its start and
records only the picks the dataset does not hold. The pick after the held ones starts
where the held pick before it left the arm, but the dataset said ``{}`` (not known) for
it, and its replay started from the reset. The run now times the held picks it runs
again (:class:`~mearm.dataset.sampler.Rerun`) and, when they ran as recorded, says the
pick continues the held episode, the gap counted as an uninterrupted run counts it. When
it cannot, the entry says why and the replay prints that.

In-process, on the kinematic rig of configs/sim.yaml: a "kill" is a run that stops after
its first picks (what a kill leaves: the episodes written, none after); the real kill and
the replay in the twin are in tests/test_resume_starts_replay.py.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from conftest import ROOT  # noqa: E402

from mearm.config import Config, load_config  # noqa: E402
from mearm.dataset import reading  # noqa: E402
from mearm.dataset.format_check import check_dataset  # noqa: E402
from mearm.dataset.recorder import DatasetRecorder  # noqa: E402
from mearm.dataset.sampler import EpisodeCapture, EpisodeSampler  # noqa: E402
from mearm.envs import replay  # noqa: E402
from mearm.envs.replay import plan_replay  # noqa: E402
from mearm.hardware.command import ArmCommand  # noqa: E402
from mearm.task import open_rig  # noqa: E402

pytestmark = pytest.mark.heavy

STARTS = "meta/mearm_starts.json"
#: The trial's seed (its tag), and its picks.
SEED, PICKS = 11, 3
CONFIG = ROOT / "configs" / "sim.yaml"
CALIBRATED = ("arm.joints.base.servo.zero_us=610",)


def _config(overrides: tuple[str, ...] = ()) -> Config:
    return load_config(CONFIG, overrides)


def _run(
    sampler: EpisodeSampler,
    *,
    picks: int = PICKS,
    vary: int | None = None,
    calibrated: tuple[str, ...] | None = None,
    short: int | None = None,
) -> None:
    """One trial of ``picks`` picks on the kinematic rig, the same each time.

    Each pick is 12 moves, with 3 moves between picks (the sort looking at the table).
    ``vary``: that pick runs otherwise (its moves 1° off). ``calibrated``: the sort says
    it calibrated its servos to these ``--set`` values at its start. ``short``: that
    pick sends nothing (an episode of fewer than 2 frames, not recorded).
    """
    config = _config()
    home = ArmCommand.home(config.arm)
    sampler.start_trial(SEED)
    with open_rig(config, []) as rig, rig.bus:
        sampler.attach(rig.bus, rig.camera)
        if calibrated is not None:
            sampler.servos_calibrated(config, _config(calibrated))
        for pick in range(picks):
            for k in range(3):
                look = {**home.joints, "base": home.joints["base"] + k}
                rig.bus.move(ArmCommand(look, home.tool, gripper_closed=False))
            sampler.begin("red")
            off = 1.0 if pick == vary else 0.0
            for k in range(0 if pick == short else 12):
                joints = {n: v + np.sin(k / 4 + pick) + off for n, v in home.joints.items()}
                rig.bus.move(ArmCommand(joints, home.tool, gripper_closed=k > 6))
            sampler.end()
        sampler.end_run()
        sampler.detach()


def _record(root: Path, *, resume: bool = False, **trial: object) -> None:
    recorder = DatasetRecorder(root, _config(), fps=10, codec="h264", resume=resume)
    try:
        _run(recorder, **trial)  # type: ignore[arg-type]
    finally:
        recorder.close()


def _starts(root: Path) -> list[dict[str, object]]:
    return json.loads((root / STARTS).read_text())["episodes"]


@pytest.fixture(scope="module")
def whole(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The trial recorded uninterrupted: each pick after the one before it."""
    root = tmp_path_factory.mktemp("whole") / "ds"
    _record(root)
    starts = _starts(root)
    assert [s.get("after") for s in starts] == [None, 0, 1]
    assert all(s.get("gap_frames", 0) > 0 for s in starts[1:])  # the looks between picks
    return root


@pytest.fixture(scope="module")
def killed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The same trial cut off after its first two picks were written."""
    root = tmp_path_factory.mktemp("killed") / "ds"
    _record(root, picks=2)
    return root


def _copy(root: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "ds"
    shutil.copytree(root, copy)
    return copy


def test_a_resumed_pick_continues_the_held_one_as_the_uninterrupted_run(whole, killed, tmp_path):
    """The trial run again records its third pick only: it continues the held second
    pick's episode, with the uninterrupted run's gap. Before: ``{}``, not known."""
    ds = _copy(killed, tmp_path)
    _record(ds, resume=True)
    assert _starts(ds) == _starts(whole)
    assert check_dataset(ds, videos=False) == []
    plan = plan_replay(ds, 2, seed=0, objects=1, config="sim_mujoco")
    assert plan.start_known and plan.why_not_known == ""
    assert len(plan.lead) == len(plan_replay(whole, 2, seed=0, objects=1).lead) > 0


def test_a_worker_trial_run_again_continues_the_held_one(whole, killed, tmp_path):
    """``--jobs N``: a worker records the whole trial again, and the command writes only
    the pick the dataset lacks: it continues the held one. Before: ``{}``."""
    ds = _copy(killed, tmp_path)
    capture = EpisodeCapture(_config(), fps=10, per="pick", codec="h264")
    try:
        _run(capture)
    finally:
        capture.close()
    recorder = DatasetRecorder(ds, _config(), fps=10, codec="h264", resume=True)
    try:
        recorder.write_episodes(capture.episodes)
    finally:
        recorder.close()
    assert recorder.episodes_skipped == 2
    assert _starts(ds) == _starts(whole)


def test_a_held_pick_that_runs_otherwise_says_why(killed, tmp_path, capsys):
    """The held pick before ran otherwise when the trial ran again: the start is not
    known, and the entry, the replay plan and the replay command's note say why."""
    ds = _copy(killed, tmp_path)
    _record(ds, resume=True, vary=1)
    entry = _starts(ds)[2]
    assert set(entry) == {"why_not_known"}
    why = entry["why_not_known"]
    assert "pick 1 of its trial, before it (episode 1, an earlier run's)" in why
    # frame 0 is the look before the pick, the same; the pick's first move is not
    assert "sent another action at its frame 1 when its trial ran again" in why
    assert check_dataset(ds, videos=False) == []
    plan = plan_replay(ds, 2, seed=0, objects=1, config="sim_mujoco")
    assert not plan.start_known and plan.why_not_known == why and len(plan.lead) == 0
    args = [str(ds), "--episode", "2", "--seed", "0", "--objects", "1", "--config", "sim_mujoco"]
    replay.main(args)
    note = capsys.readouterr().err
    assert note == (
        "python -m mearm.envs.replay: note: episode 2 is a pick whose start the dataset "
        "does not keep: "
        f"{why}; replayed from where the environment's reset leaves the arm\n"
    )


def test_servos_calibrated_the_same_keep_the_held_file(tmp_path):
    """A sort that calibrates its servos at its start: the resumed pick names the held
    episode's servo file (the same calibration, made again), no second file."""
    ds = tmp_path / "ds"
    _record(ds, picks=2, calibrated=CALIBRATED)
    _record(ds, resume=True, calibrated=CALIBRATED)
    servos = "meta/mearm_servos/episode-000000.servos.yaml"
    starts = _starts(ds)
    assert [s.get("after") for s in starts] == [None, 0, 1]
    assert {s["servos"] for s in starts} == {servos}
    assert sorted(p.name for p in (ds / "meta/mearm_servos").iterdir()) == [Path(servos).name]
    assert check_dataset(ds, videos=False) == []


def test_servos_calibrated_otherwise_say_why(killed, tmp_path):
    """The trial ran again calibrated its servos, the killed run had not: not known,
    said, and the resumed sort's own servo file is kept."""
    ds = _copy(killed, tmp_path)
    _record(ds, resume=True, calibrated=CALIBRATED)
    entry = _starts(ds)[2]
    assert (
        "ran other servos (the config's own) than its trial's calibration" in entry["why_not_known"]
    )
    assert entry["servos"] == "meta/mearm_servos/episode-000002.servos.yaml"
    assert check_dataset(ds, videos=False) == []


def test_a_pick_after_one_not_recorded_says_why(tmp_path):
    """A trial's pick whose pick before sent nothing (not recorded): not known, said."""
    ds = tmp_path / "ds"
    _record(ds, short=1)
    starts = _starts(ds)
    assert starts[:1] == [{"after": None}]
    assert "pick 1 of its trial, before it, is not in the dataset" in starts[1]["why_not_known"]


def test_an_older_datasets_starts_say_why(killed, tmp_path):
    """No starts file (an older mearm's): each start not known, because of that; a run
    that resumes it keeps that reason in the file it writes, its own pick after the
    held one, and a replay of that pick says the held one's start is not known."""
    ds = _copy(killed, tmp_path)
    (ds / STARTS).unlink()
    older = reading.NO_STARTS_KEPT
    assert [s.why for s in reading.read_starts(ds, 2)] == [older] * 2
    assert plan_replay(ds, 1, seed=0, objects=1).why_not_known == older
    _record(ds, resume=True)
    starts = _starts(ds)
    assert starts[:2] == [{"why_not_known": older}] * 2
    assert starts[2]["after"] == 1
    why = plan_replay(ds, 2, seed=0, objects=1).why_not_known
    assert why == f"it continues episode 1 of its sort, whose start is not known: {older}"


def test_a_start_without_a_reason_and_a_chain_through_it(whole, tmp_path):
    """``{}`` (a mearm that kept no reason) reads as that; an episode after it says it
    continues one whose start is not known, and why."""
    ds = _copy(whole, tmp_path)
    unsaid = replay.NO_REASON_KEPT
    starts = _starts(ds)
    starts[1] = {}
    (ds / STARTS).write_text(json.dumps({"episodes": starts}))
    assert plan_replay(ds, 1, seed=0, objects=1).why_not_known == unsaid
    why = plan_replay(ds, 2, seed=0, objects=1).why_not_known
    assert why == f"it continues episode 1 of its sort, whose start is not known: {unsaid}"


@pytest.mark.parametrize(
    "entry",
    [{"why_not_known": ""}, {"why_not_known": 3}, {"after": None, "why_not_known": "x"}],
)
def test_a_damaged_reason_is_named(whole, tmp_path, entry):
    """A reason that is not a sentence, or one beside a known start: damaged, named."""
    ds = _copy(whole, tmp_path)
    starts = _starts(ds)
    starts[1] = entry
    (ds / STARTS).write_text(json.dumps({"episodes": starts}))
    (finding,) = check_dataset(ds, videos=False)
    assert finding.startswith(f"mearm: {STARTS}: entry 1 is ")
