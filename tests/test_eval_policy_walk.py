"""Walk 5's eval-policy and Gym-env findings: outputs kept without --force, a NaN action
as an episode's error, SIGTERM ending the workers too, env options refused at make()."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from badinput import check_bad_input, run_in_process

import mearm.envs  # noqa: F401  (registers the environments)
from mearm.config import load_config
from mearm.envs import EnvOptionError
from mearm.envs.twin_env import max_objects

pytestmark = pytest.mark.heavy

ROOT = Path(__file__).resolve().parent.parent

POLICIES = """
import numpy as np

HOME = np.array([120.0, 93.0, -132.0, 60.0, 0.0], dtype=np.float32)

class NanInFirstEpisode:
    '''Good actions, but NaN from the 4th step of the first episode it runs.'''
    def __init__(self):
        self.episodes = self.calls = 0
    def reset(self):
        self.episodes += 1
        self.calls = 0
    def __call__(self, observation):
        self.calls += 1
        return HOME * np.nan if self.episodes == 1 and self.calls > 3 else HOME
"""

#: eval-policy's quickest run: no pixels, a few steps.
QUICK = ["--env-option", "obs_type=state", "--env-option", "max_episode_steps=5"]
#: The signal tests' episodes: 30 steps (a quarter of a second with a video, where the
#: default's 500 took three), a run of 200 of them far from done when the signal comes.
SHORT = ["--env-option", "obs_type=state", "--env-option", "image_size=[24, 32]",
         "--env-option", "max_episode_steps=30"]  # fmt: skip


def _eval_policy(*argv: object, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    """``python -m mearm eval-policy ARGV`` in a real process (policies importable from cwd)."""
    env = {**os.environ, "PYTHONPATH": f"{cwd}:{ROOT}", "MUJOCO_GL": "egl"}
    return subprocess.run(
        [sys.executable, "-m", "mearm", "eval-policy", *map(str, argv)],
        capture_output=True, text=True, env=env, cwd=cwd, timeout=timeout,
    )  # fmt: skip


# ------------------------------------------------------------------- outputs and --force


def test_an_out_that_exists_is_refused_without_force_and_replaced_with_it(tmp_path):
    """It was replaced silently; now exit 2 before any episode, the file intact; --force
    replaces it."""
    out = tmp_path / "ev.json"
    out.write_text("precious\n")
    argv = ["eval-policy", "--policy", "random", "--episodes", "1", "--jobs", "1", *QUICK,
            "--out", out]  # fmt: skip
    r = check_bad_input(argv, within_s=10, keep=[out])
    assert r.line.endswith(f"--out {out}: exists; pass --force to replace it")
    assert "episode" not in r.stdout
    r = run_in_process([*map(str, argv), "--force"], within_s=60)
    assert r.code == 0, r.stderr
    assert json.loads(out.read_text())["n_episodes"] == 1


def test_a_video_that_exists_is_refused_without_force_and_replaced_with_it(tmp_path):
    """An episode_*.mp4 the run would write (the user's own): refused before any episode;
    --force replaces it with the episode's video, and leaves no temporary file."""
    videos = tmp_path / "videos"
    videos.mkdir()
    mine = videos / "episode_001_seed_8.mp4"  # the second of seeds 7, 8
    mine.write_text("mine\n")
    argv = ["eval-policy", "--policy", "random", "--episodes", "2", "--first-seed", "7",
            "--videos", "2", "--jobs", "1", *QUICK, "--env-option", "image_size=[24, 32]",
            "--out", tmp_path / "v.json"]  # fmt: skip
    r = check_bad_input(argv, within_s=10, keep=[videos])
    assert r.line.endswith(f"--videos {mine}: exists; pass --force to replace it")
    assert not (tmp_path / "v.json").exists() and sorted(videos.iterdir()) == [mine]
    r = run_in_process([*map(str, argv), "--force"], within_s=60)
    assert r.code == 0, r.stderr
    assert mine.read_bytes()[4:8] == b"ftyp"  # an MP4 now
    assert sorted(p.name for p in videos.iterdir()) == [
        "episode_000_seed_7.mp4", "episode_001_seed_8.mp4"
    ]  # fmt: skip


def test_a_file_named_videos_is_refused_before_any_episode(tmp_path):
    """It crashed with FileExistsError (exit 1) after the first episode."""
    (tmp_path / "videos").write_text("notadir\n")
    r = check_bad_input(
        ["eval-policy", "--policy", "random", "--episodes", "1", "--videos", "1",
         "--jobs", "1", *QUICK, "--out", tmp_path / "v.json"],
        within_s=10, keep=[tmp_path / "videos"],
    )  # fmt: skip
    assert f"--videos: {tmp_path / 'videos'} is a file, not a folder" in r.line
    assert "episode" not in r.stdout


# ----------------------------------------------------------- a NaN action mid-episode


def test_a_nan_action_mid_episode_fails_that_episode_and_the_run_goes_on(tmp_path):
    """It aborted the whole evaluation, exit 2 (bad input) and no --out. Now, as for a
    policy that raises: the episode records the error, the next one runs, --out is
    written, exit 1 (an episode failed), in the workers too."""
    (tmp_path / "walk_policies.py").write_text(textwrap.dedent(POLICIES))
    out = tmp_path / "nan.json"
    r = _eval_policy("--policy", "walk_policies:NanInFirstEpisode", "--episodes", "3",
                     "--jobs", "2", *QUICK, "--out", out, cwd=tmp_path)  # fmt: skip
    assert r.returncode == 1, r.stderr
    episodes = json.loads(out.read_text())["per_episode"]
    assert [e["seed"] for e in episodes] == [0, 1, 2]
    nan = [e for e in episodes if e["error"]]
    # each worker's first episode: seed 0's, and seed 1's too if the other worker took it
    assert episodes[0] in nan and 1 <= len(nan) <= 2
    for e in nan:
        assert e["error"].startswith("the policy's action is not finite: [nan,")
        assert e["steps"] == 3 and not e["success"]
    good = [e for e in episodes if not e["error"]]
    assert good and all(e["steps"] == 5 for e in good)
    (line,) = r.stderr.strip().splitlines()
    assert f"{len(nan)} of 3 episodes ended on an error (the first, seed 0: the policy's" in line


# ------------------------------------------------------------------------ signals


def _workers(pid: int) -> set[int]:
    """The live (not zombie) child processes of ``pid``."""
    out = set()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError, IndexError):  # a process that ended meanwhile
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == pid and fields[0] != "Z":
                out.add(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return False
    return fields[0] != "Z"


@pytest.mark.parametrize(
    ("sig", "code", "said"),
    [(signal.SIGTERM, 143, ["mearm eval-policy: interrupted"]),  # SIGHUP: the same handler
     (signal.SIGKILL, -signal.SIGKILL, [])],
)  # fmt: skip
def test_a_stop_signal_to_eval_policy_ends_its_workers_too(tmp_path, sig, code, said):
    """SIGTERM (or SIGHUP) to the command alone, as a supervisor sends it, mid-episode:
    exit 143 (129) with "interrupted", and no worker left behind. They used to run on,
    orphaned, one writing a video after the parent had gone. The episodes stopped write
    no video and leave no temporary file. Killed outright (SIGKILL), the parent can do
    nothing: its workers see it gone and end by themselves."""
    out, errors = tmp_path / "progress.txt", tmp_path / "stderr.txt"
    cmd = [sys.executable, "-m", "mearm", "eval-policy", "--policy", "random",
           "--episodes", "200", "--jobs", "2", "--videos", "200", "--out", tmp_path / "t.json",
           *SHORT]  # fmt: skip
    # faulthandler: on a hang, SIGABRT has each process print where its threads are
    env = {**os.environ, "MUJOCO_GL": "egl", "PYTHONFAULTHANDLER": "1"}
    with out.open("w") as progress, errors.open("w") as stderr:  # files: orphans hold pipes
        proc = subprocess.Popen(
            list(map(str, cmd)), cwd=ROOT, env=env, stdout=progress, stderr=stderr,
            start_new_session=True,
        )  # fmt: skip
    workers: set[int] = set()
    try:
        deadline = time.monotonic() + 300  # the first episode has ended: both are at work
        while time.monotonic() < deadline and "episode   1/200" not in out.read_text():
            assert proc.poll() is None, errors.read_text()
            time.sleep(0.05)
        workers = _workers(proc.pid)
        assert len(workers) == 2
        proc.send_signal(sig)
        assert _wait_or_dump(proc, workers, errors) == code, errors.read_text()
        assert errors.read_text().strip().splitlines() == said
        deadline = time.monotonic() + 120  # a hang (orphans at work) is the failure
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.1)
        assert not [w for w in workers if _alive(w)], "workers left behind"
        videos = sorted(p.name for p in (tmp_path / "videos").iterdir())
        assert videos and all(v.startswith("episode_") and v.endswith(".mp4") for v in videos)
        assert len(videos) < 200
    finally:  # on a failure: end what this test started and still runs, by its ids
        for pid in [w for w in workers if _alive(w)] + [proc.pid] * (proc.poll() is None):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        proc.wait()


def _wait_or_dump(proc: subprocess.Popen, workers: set[int], errors: Path) -> int:
    """``proc``'s exit status; if it has not ended within 300 s (a hang), fail with
    where each of its processes' threads are (faulthandler, on SIGABRT).

    Once, on a loaded machine, the parent had not ended 300 s after SIGTERM; its stderr
    held only an AV1 encoder's errors, which did not say which process waited on what.
    """
    try:
        return proc.wait(timeout=300)
    except subprocess.TimeoutExpired:
        alive = [w for w in workers if _alive(w)]
        states = {pid: _state(pid) for pid in [proc.pid, *alive]}
        for pid in [proc.pid, *alive]:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGABRT)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=10)
        time.sleep(1)  # the workers' dumps
        pytest.fail(f"no exit 300 s after the signal; states {states}; stderr:\n"
                    f"{errors.read_text()}")  # fmt: skip


def _state(pid: int) -> str:
    """``pid``'s state and what its threads wait in (``/proc``), e.g. ``S futex_wait``."""
    with contextlib.suppress(OSError):
        tasks = sorted(Path(f"/proc/{pid}/task").iterdir())
        waits = [(t / "wchan").read_text() for t in tasks]
        return f"{Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]} {waits}"
    return "gone"


def test_a_worker_sees_its_parent_killed_while_its_sibling_is_stuck(tmp_path):
    """SIGKILL to the parent while the younger worker is stopped (SIGSTOP: stuck in a
    driver, say): the older one still ends. With ``fork`` the younger holds the parent's
    end of the older's sentinel pipe, so the older waited for its sibling to end first."""
    cmd = [sys.executable, "-m", "mearm", "eval-policy", "--policy", "random",
           "--episodes", "200", "--jobs", "2", "--out", tmp_path / "t.json", *SHORT]  # fmt: skip
    out, errors = tmp_path / "progress.txt", tmp_path / "stderr.txt"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    with out.open("w") as progress, errors.open("w") as stderr:  # files: orphans hold pipes
        proc = subprocess.Popen(
            list(map(str, cmd)), cwd=ROOT, env=env, stdout=progress, stderr=stderr,
            start_new_session=True,
        )  # fmt: skip
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and "episode   1/200" not in out.read_text():
            assert proc.poll() is None, errors.read_text()
            time.sleep(0.05)
        workers = sorted(_workers(proc.pid), key=_started)
        assert len(workers) == 2
        older, younger = workers
        os.kill(younger, signal.SIGSTOP)
        proc.kill()
        proc.wait()
        deadline = time.monotonic() + 120  # a hang (the orphan at work) is the failure
        while time.monotonic() < deadline and _alive(older):
            time.sleep(0.1)
        assert not _alive(older), "the older worker outlived its parent"
    finally:
        for pid in [w for w in workers if _alive(w)] + [proc.pid] * (proc.poll() is None):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        proc.wait()


def _started(pid: int) -> tuple[int, int]:
    """When ``pid`` started [clock ticks since boot], then ``pid``: the order of two forks.

    Two workers forked in one clock tick (a hundredth of a second) have the same start;
    the later fork has the higher process id (ids are handed out in turn). Without it the
    older of such two was taken by the order of a set, and the test stopped the wrong one.
    """
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[19]), pid


#: A parent that forks two workers of eval-policy's as its pool does (``fork``) and
#: prints their ids: the older starts (``_start_worker``) only once its parent is gone,
#: as on a machine that kept it waiting until then; the younger, forked after it, holds
#: the parent's end of the older's sentinel pipe and never ends (stuck in a driver, say).
LATE_WORKER = """
import multiprocessing, os, threading, time
from mearm.envs.evaluate import Job, _start_worker

def late(parent):
    while os.getppid() == parent:
        time.sleep(0.01)
    _start_worker(Job("mearm/PickPlace-v0", {"obs_type": "state"}, "random"), None)
    threading.Event().wait()  # idle: waits for work that will never come

def stuck():
    threading.Event().wait()

if __name__ == "__main__":
    fork = multiprocessing.get_context("fork")
    older = fork.Process(target=late, args=(os.getpid(),))
    older.start()
    younger = fork.Process(target=stuck)
    younger.start()
    print(older.pid, younger.pid, flush=True)
    threading.Event().wait()
"""


def test_a_worker_that_starts_after_its_parent_was_killed_still_ends(tmp_path):
    """A worker that begins to watch its parent only once the parent is dead (SIGKILL
    while the machine kept the new worker waiting), beside a stuck younger sibling: it
    took the id of the process it had been given to for its parent's, which never
    changed, and the sentinel stays open while the sibling lives, so it waited for work
    for ever. It ends now, the sibling still there (the parent's id did it)."""
    (tmp_path / "late_worker.py").write_text(LATE_WORKER)
    out, errors = tmp_path / "pids.txt", tmp_path / "stderr.txt"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MUJOCO_GL": "egl"}
    with out.open("w") as pids, errors.open("w") as stderr:  # files: orphans hold pipes
        proc = subprocess.Popen(
            [sys.executable, "late_worker.py"], cwd=tmp_path, env=env, stdout=pids,
            stderr=stderr, start_new_session=True,
        )  # fmt: skip
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 120
        # the whole line: print writes "older", " ", "younger" and "\n" one by one (strace),
        # and a read between them saw one pid of the two (CI, 2026-12-02)
        while time.monotonic() < deadline and not out.read_text().endswith("\n"):
            assert proc.poll() is None, errors.read_text()
            time.sleep(0.05)
        older, younger = workers = [int(pid) for pid in out.read_text().split()]
        proc.kill()
        proc.wait()
        deadline = time.monotonic() + 120  # a hang (the orphan waiting for work) is the failure
        while time.monotonic() < deadline and _alive(older):
            time.sleep(0.1)
        assert not _alive(older), f"the worker outlived its parent: {errors.read_text()}"
        assert _alive(younger)
    finally:
        for pid in [w for w in workers if _alive(w)] + [proc.pid] * (proc.poll() is None):
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
        proc.wait()


# ----------------------------------------------------------------- the env's options


@pytest.fixture(scope="module")
def most() -> int:
    """What sim_mujoco's bins hold."""
    return max_objects(load_config("sim_mujoco"))


def test_objects_up_to_what_the_bins_hold_reset_and_one_more_is_refused_at_make(most):
    """objects=40 passed make() and failed at reset() with a ModelError about bin walls
    that did not say `objects`; 1000 with a SceneError. The bound is the bins' (21 on
    sim_mujoco: 7 of each of 3 classes), exactly: that many build and reset."""
    assert 1 < most < 500
    env = gym.make("mearm/Sort-v0", config="sim_mujoco", objects=most, obs_type="state")
    try:
        env.reset(seed=0)
    finally:
        env.close()
    for n in (most + 1, 1000):
        with pytest.raises(EnvOptionError, match=rf"objects must be at least 1 and at most "
                           rf"{most}, got {n}: .*the bins of this config hold"):  # fmt: skip
            gym.make("mearm/Sort-v0", config="sim_mujoco", objects=n, obs_type="state")


@pytest.mark.parametrize("name", ["sim_mearm_v1_mujoco", "sim_mearm_v1_mujoco_kits"])
def test_the_default_objects_are_what_smaller_bins_hold(name: str) -> None:
    """The MeArm v1's bins hold 6: Sort-v0 with no `objects` makes 6 (it refused its own
    default of 12 on these configs until 2026-12-06); 12 asked for is still refused."""
    from mearm.envs import TwinEnv

    most = max_objects(load_config(name))
    assert most < 12
    env = TwinEnv(config=name, task="sort", obs_type="state")
    try:
        assert env.objects == most
    finally:
        env.close()
    with pytest.raises(EnvOptionError, match=rf"objects must be at least 1 and at most {most}"):
        gym.make("mearm/Sort-v0", config=name, objects=12, obs_type="state")


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"objects": 2.5}, "objects must be a whole number, got 2.5"),
        ({"objects": True}, "objects must be a whole number, got True"),
        ({"fps": 25.0}, "fps must be a whole number, got 25.0"),
        ({"image_size": (1, 2, 3)}, r"image_size must be two numbers, \(height, width\)"),
        ({"image_size": "96x128"}, r"image_size must be \(height, width\) in px, got '96x128'"),
        ({"image_size": (48.5, 64)}, "image_size's height must be a whole number"),
        ({"overrides": "servo.rate_hz=50"},
         r"overrides must be a list .*\(one override: overrides=\['servo.rate_hz=50'\]\)"),
        ({"overrides": ["servo.rate_hz=50", 3]}, "overrides must be a list of"),
        ({"expert": "no"}, "expert must be True or False, got 'no'"),
    ],
)  # fmt: skip
def test_options_of_the_wrong_type_are_refused_at_make(options, words):
    """Each was truncated, split into characters, taken as true or a ValueError of its
    own: now EnvOptionError naming the option and what it takes, from gym.make."""
    with pytest.raises(EnvOptionError, match=words):
        gym.make("mearm/Sort-v0", config="sim_mujoco", obs_type="state", **options)


def test_overrides_with_a_loaded_config_are_refused():
    """They were ignored: the loaded config is not reloaded."""
    with pytest.raises(EnvOptionError, match="overrides apply to a config loaded by name"):
        gym.make("mearm/PickPlace-v0", config=load_config("sim_mujoco"),
                 overrides=["servo.rate_hz=25"])  # fmt: skip


def test_reset_refuses_options_it_would_ignore():
    """reset(options={"bogus": 1}) was ignored silently; {} and None still reset."""
    env = gym.make("mearm/PickPlace-v0", config="sim_mujoco", obs_type="state")
    try:
        with pytest.raises(EnvOptionError, match=r"reset\(\) takes no options .*\['bogus'\]"):
            env.reset(seed=0, options={"bogus": 1})
        env.reset(seed=0, options={})
        env.reset(seed=0)
    finally:
        env.close()


def test_a_step_after_success_warns_once_as_gymnasiums_envs_do():
    """It stepped on without a word (Gymnasium: undefined behaviour; its CartPole warns)."""
    env = gym.make("mearm/PickPlace-v0", config="sim_mujoco", obs_type="state", expert=True)
    try:
        obs, info = env.reset(seed=0)
        terminated = truncated = False
        while not (terminated or truncated):
            obs, _, terminated, truncated, info = env.step(info["expert_action"])
        assert terminated and info["is_success"]
        action = np.asarray(info["expert_action"])
        with pytest.warns(UserWarning, match=r"step\(\) after the episode returned terminated"):
            env.step(action)
        with warnings_taken("error"):
            env.step(action)  # once per episode
        env.reset(seed=1)
    finally:
        env.close()


@contextlib.contextmanager
def warnings_taken(action: str):
    """Warnings inside the block are taken as ``action`` ("error", "ignore")."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter(action)
        yield


def _refused_action(inner) -> np.ndarray:
    """A target within the limits whose straight way meets the table or a bin."""
    rng = np.random.default_rng(0)
    for _ in range(200):
        action = rng.uniform(inner.action_space.low, inner.action_space.high)
        if inner._refusal(inner.spec_actions.command(action)) is not None:
            return action.astype(np.float32)
    pytest.fail("no refused target among 200 random ones")


@pytest.mark.parametrize("refused", [False, True])
def test_a_step_after_a_fault_is_refused(tmp_path, monkeypatch, refused):
    """A diverged twin ends the episode on info["fault"] (also when the step's target was
    refused and the arm held: that raised the twin's ServoError out of step()). A step
    after it drove the faulted twin on; now RuntimeError: call reset() (which works)."""
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warning to MUJOCO_LOG.TXT here
    env = gym.make("mearm/PickPlace-v0", config="sim_mujoco", obs_type="state")
    try:
        obs, _ = env.reset(seed=0)
        inner = env.unwrapped
        action = _refused_action(inner) if refused else obs["agent_pos"]  # or: hold still
        inner.twin.data.qvel[:] = np.nan  # as a diverged physics step leaves it
        with warnings_taken("ignore"):  # the checker: the diverged step's observation
            *_, terminated, _, info = env.step(action)
        assert terminated and "diverged" in info["fault"]
        assert bool(info["refused"]) == refused
        with pytest.raises(RuntimeError, match=r"ended on a fault: .*call reset\(\) first"):
            env.step(action)
        env.reset(seed=0)
        env.step(action)
    finally:
        env.close()
