"""docs/learning.md walked as a new user: `mearm eval-policy`'s step limit and its pool's stop."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from mearm.envs.errors import EnvOptionError
from mearm.tools.eval_policy import env_options

ROOT = Path(__file__).resolve().parent.parent

#: A policy that keeps the arm at home and takes 2 s an action, noting each worker it ran in.
SLOW_POLICY = """
import os
import pathlib
import time

import numpy as np

HOME = np.array([120.0, 93.0, -132.0, 60.0, 0.0], dtype=np.float32)

def slow(observation):
    pathlib.Path(os.environ["WALK2_MARKS"], str(os.getpid())).touch()
    time.sleep(2)
    return HOME
"""


@pytest.mark.parametrize("value", ["0", "-3", "true", "2.5", "abc"])
def test_a_step_limit_that_is_not_a_whole_number_of_at_least_one_is_refused(value):
    """0 and -3 crashed in Gymnasium (exit 1, "unexpected error"); true ran one step."""
    with pytest.raises(EnvOptionError, match="max_episode_steps must be a whole number"):
        env_options([f"max_episode_steps={value}"])


def test_a_step_limit_of_null_or_a_whole_number_passes():
    assert env_options(["max_episode_steps=7"]) == {"max_episode_steps": 7}
    assert env_options(["max_episode_steps=null"]) == {"max_episode_steps": None}


def test_a_zero_step_limit_is_one_line_and_exit_2():
    proc = subprocess.run(
        [sys.executable, "-m", "mearm", "eval-policy", "--episodes", "1", "--jobs", "1",
         "--env-option", "obs_type=state", "--env-option", "max_episode_steps=0"],
        capture_output=True, text=True, cwd=ROOT, timeout=120, check=False,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.splitlines() == [
        "mearm eval-policy: error: --env-option max_episode_steps must be a whole number "
        "of at least 1, got 0"
    ]
    assert proc.stdout == ""


class _SecondCtrlC(Exception):
    """What this test's Ctrl-C handler raises (not a KeyboardInterrupt: pytest would stop)."""


def test_a_second_ctrl_c_does_not_cut_the_pool_shutdown_in_two(tmp_path, monkeypatch):
    """A Ctrl-C while the pool waits for its workers is taken once they have ended.

    It escaped the wait, leaving the workers busy and never sent their end: the parent of
    `mearm eval-policy` then waited for them at exit forever (two SIGINTs 10 ms apart).
    """
    from mearm.envs.evaluate import Job, _in_worker, _Pool  # noqa: PLC0415

    (tmp_path / "walk2_policies.py").write_text(textwrap.dedent(SLOW_POLICY))
    marks = tmp_path / "marks"
    marks.mkdir()
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setenv("WALK2_MARKS", str(marks))
    job = Job(
        "mearm/PickPlace-v0", {"config": "sim_mujoco", "obs_type": "state"}, "walk2_policies:slow"
    )
    pool = _Pool(2, job)

    def second_ctrl_c(signum: int, frame: object) -> None:
        raise _SecondCtrlC

    previous = signal.signal(signal.SIGINT, second_ctrl_c)
    try:
        for i, seed in enumerate((0, 1)):
            pool.submit(_in_worker, seed, i)
        deadline = time.monotonic() + 120  # a hang bound: both workers in their episodes
        while len(list(marks.iterdir())) < 2:
            assert time.monotonic() < deadline, "the workers never started their episodes"
            time.sleep(0.05)
        workers = list(pool._processes.values())
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        with pytest.raises(_SecondCtrlC):
            pool.shutdown(wait=True, cancel_futures=True)
        assert [w.exitcode for w in workers] == [0, 0], "the Ctrl-C left the workers running"
    finally:
        signal.signal(signal.SIGINT, previous)
        pool.shutdown(wait=True, cancel_futures=True)  # after a failure: end them
