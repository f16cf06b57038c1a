"""`mearm experiment` tells the truth: objects left exit 1, and a trial Ctrl-C stopped is
not finished (the same command runs it again, and `mearm analyze` leaves the stopped
attempt out)."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from badinput import Outcome, run_in_process
from conftest import ROOT, interrupted

from mearm.config import load_config
from mearm.runlog import RunLog, read_runlog
from mearm.runlog.errors import RepeatedTrialError
from mearm.task.sorter import SortAborted

#: One object: a quick trial (about 2 s of wall time when the servos run in real time).
ONE = "- {color: red, x: -10.99, y: 49.70}\n"
#: Two objects, one of them a blue the camera never sees (left in every trial: see LEFT).
CUT = "- {color: blue, x: 5, y: 40}\n- {color: red, x: 0, y: 45}\n"
#: Blue objects too small for the detector (under vision.min_area_px).
LEFT = ("--set", "task.classes.blue.diameter_cm=0.5")
#: The servos move in wall-clock time: a Ctrl-C sent during a trial lands inside it.
REALTIME = ("--set", "servo.sim_realtime=true")
#: Three objects, about 5 s of real-time servo motion a trial: a signal sent once trial 0
#: has logged its first route lands inside it even on a loaded machine (with ONE, a signal
#: delayed by about a second under a loaded CI run landed after the place).
THREE = ONE + "- {color: red, x: 0, y: 45}\n- {color: blue, x: 8, y: 40}\n"


def experiment(*args: object) -> Outcome:
    """``mearm experiment ARGS`` in this process."""
    return run_in_process(["experiment", *map(str, args)], within_s=120)


def scene(folder: Path, text: str) -> Path:
    path = folder / "scene.yaml"
    path.write_text(text)
    return path


def attempts(log: Path) -> list[tuple[int | None, str]]:
    """(trial number, how it ended) of every attempt in the log, in file order."""
    return [
        (t.number, "finished" if t.finished else "interrupted" if t.interrupted else "cut off")
        for t in read_runlog(log).trials
    ]


# --------------------------------------------------------------------------- exit status


def test_objects_left_exit_1_and_the_totals_say_why(tmp_path):
    """As `mearm sort`: objects left are exit 1, the totals line repeated on stderr; a
    second run over the finished log says the same."""
    log = tmp_path / "trials.jsonl"
    cut = scene(tmp_path, CUT)
    totals = "sorted 2 of 4 objects over 2 trials (2 never seen by the camera)"
    r = experiment("--trials", 2, "--scene", cut, "--log", log, *LEFT)
    assert r.code == 1, r.stderr
    assert r.stdout.splitlines()[-1] == totals
    assert r.stderr.strip().splitlines() == [f"mearm experiment: {totals}"]
    before = log.read_bytes()
    r = experiment("--trials", 2, "--scene", cut, "--log", log, *LEFT)
    assert r.code == 1 and "nothing to run" in r.stdout, r.stderr
    assert r.stdout.splitlines()[-1] == totals
    assert log.read_bytes() == before


def test_a_log_that_holds_more_trials_says_so(tmp_path):
    """--trials 1 over a log of 2: the totals are the first's, and the line says the log
    holds more (its docs said every trial in the log was totalled)."""
    log = tmp_path / "trials.jsonl"
    one = scene(tmp_path, ONE)
    assert experiment("--trials", 2, "--scene", one, "--log", log).code == 0
    r = experiment("--trials", 1, "--scene", one, "--log", log)
    assert r.code == 0, r.stderr
    assert r.stdout.splitlines() == [
        f"{log} already holds 2 complete trials (--trials 1): nothing to run; the totals "
        "are of the first 1 (mearm analyze reads them all)",
        "sorted 1 of 1 objects over 1 trial",
    ]


def test_a_clean_experiment_exits_0(tmp_path):
    r = experiment("--trials", 1, "--scene", scene(tmp_path, ONE), "--log", tmp_path / "t.jsonl")
    assert r.code == 0 and not r.stderr.strip(), r.stderr
    assert r.stdout.splitlines()[-1] == "sorted 1 of 1 objects over 1 trial"


def test_objects_left_in_the_resumed_trials_count_too(tmp_path):
    """A resumed run whose own trials all sort still exits 1 for the trials before it."""
    log, one = tmp_path / "trials.jsonl", scene(tmp_path, ONE)
    assert experiment("--trials", 1, "--scene", one, "--log", log).code == 0
    lines = log.read_text().splitlines(keepends=True)
    summary = json.loads(lines[-1])
    assert summary["type"] == "summary"
    summary.update(sorted={"red": 0, "green": 0, "blue": 0}, left={"pick_failed": 1})
    log.write_text("".join(lines[:-1]) + json.dumps(summary) + "\n")  # trial 0 left its object
    r = experiment("--trials", 2, "--scene", one, "--log", log)
    assert r.code == 1, r.stderr
    assert "1 trial written" in r.stdout and "0 stopped early" in r.stdout
    assert r.stdout.splitlines()[-1] == "sorted 1 of 2 objects over 2 trials (1 pick failed)"


# --------------------------------------------------------------------------- Ctrl-C


def interrupted_in_trial_0(log: Path, args: list[object]) -> tuple[int, str]:
    """``mearm experiment ARGS`` (servos in real time), Ctrl-C to its process group as soon
    as trial 0 has logged a route, in the middle of its sort: (exit status, stderr)."""
    cmd = [sys.executable, "-m", "mearm", "experiment", *map(str, args)]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if log.exists() and b'"type":"route"' in log.read_bytes():
            break
        time.sleep(0.01)
    _, err = interrupted(proc)
    return proc.returncode, err.decode(errors="replace")


@pytest.mark.heavy
def test_a_trial_stopped_by_ctrl_c_is_run_again_and_analysed_once(tmp_path):
    """Ctrl-C in trial 0: exit 130 under the command's name; the same command runs trial 0
    again (not on to trial 1 with trial 0 counted), exits 0 once every object is sorted,
    and `mearm analyze` reads the finished attempt only."""
    log, one = tmp_path / "trials.jsonl", scene(tmp_path, THREE)
    args: list[object] = ["--trials", 2, "--scene", one, "--log", log, *REALTIME]
    code, err = interrupted_in_trial_0(log, args)
    assert code == 130, err
    assert "mearm experiment: stopped: interrupted (Ctrl-C)" in err
    assert f"; 0 of 2 trials complete in {log}: the same command runs the rest" in err
    assert "mearm.experiment" not in err
    assert attempts(log) == [(0, "interrupted")]
    stopped = log.read_bytes()

    r = experiment(*args)
    assert r.code == 0, r.stdout + r.stderr
    assert "running trials 0..1; trial 0 again, it was interrupted\n" in r.stdout
    assert r.stdout.splitlines()[-1] == "sorted 6 of 6 objects over 2 trials"
    assert log.read_bytes().startswith(stopped)
    assert attempts(log) == [(0, "interrupted"), (0, "finished"), (1, "finished")]

    r = run_in_process(["analyze", log, "--json"], within_s=30)
    assert r.code == 0, r.stderr
    assert json.loads(r.stdout)["analysis"]["trials"] == 2
    assert "left out 1 interrupted attempt(s) of trial(s) 0 (header line(s) 1)" in r.stderr

    # a log written before interrupted trials were run again: its run went on to trial 1.
    # It still resumes (nothing to run), and the interrupted objects are exit 1.
    old = tmp_path / "old.jsonl"
    trials = read_runlog(log).trials
    lines = log.read_bytes().splitlines(keepends=True)
    old.write_bytes(b"".join(lines[: trials[1].line - 1] + lines[trials[2].line - 1 :]))
    assert attempts(old) == [(0, "interrupted"), (1, "finished")]
    before = old.read_bytes()
    r = experiment("--trials", 2, "--scene", one, "--log", old, *REALTIME)
    assert r.code == 1, r.stdout + r.stderr
    assert "nothing to run" in r.stdout
    last = r.stdout.splitlines()[-1]
    assert "over 2 trials" in last and "interrupted)" in last and last.endswith("1 stopped early")
    assert old.read_bytes() == before
    r = run_in_process(["analyze", old, "--json"], within_s=30)
    assert r.code == 0 and "left out" not in r.stderr, r.stderr


@pytest.mark.heavy
def test_sigterm_stops_a_trial_as_ctrl_c_does(tmp_path):
    """SIGTERM to the command alone (as ``timeout`` and ``systemctl stop`` send it): the arm
    parks, the trial is logged as interrupted (run again on resuming), exit 143. It used
    to end the process at once, the log cut mid-trial."""
    log, one = tmp_path / "trials.jsonl", scene(tmp_path, THREE)
    cmd = [sys.executable, "-m", "mearm", "experiment", "--trials", "2", "--scene", str(one)]
    proc = subprocess.Popen(
        [*cmd, "--log", str(log), *map(str, REALTIME)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if log.exists() and b'"type":"route"' in log.read_bytes():
            break
        time.sleep(0.01)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert b"mearm experiment: stopped: interrupted (SIGTERM); arm parked at home" in err
    assert attempts(log) == [(0, "interrupted")]
    assert out.decode().splitlines() == [f"wrote {log}"]  # it wrote the log: it says so


def test_a_ctrl_c_between_two_trials_says_what_the_log_holds(tmp_path, monkeypatch):
    """A Ctrl-C that lands after a trial's summary and before the next sort starts (about
    one in ten at a random moment) ended with "mearm experiment: interrupted" alone; it now
    gets the stopped line that counts what the log holds, as one inside a sort does."""
    from mearm.experiment import commandline

    real = commandline.run_trials

    def one_then_ctrl_c(config, trials, *args, **kwargs):  # trial 0, then Ctrl-C
        real(config, 1, *args, **kwargs)
        raise KeyboardInterrupt

    log = tmp_path / "e.jsonl"
    monkeypatch.setattr(commandline, "run_trials", one_then_ctrl_c)
    out = experiment("--config", "sim", "--scene", scene(tmp_path, ONE), "--trials", "2",
                     "--log", log)  # fmt: skip
    assert out.code == 130, out.stderr
    assert out.line == (
        f"mearm experiment: stopped: interrupted (Ctrl-C) between trials; 1 of 2 trials "
        f"complete in {log}: the same command runs the rest"
    )


def test_workers_append_no_trial_after_an_interrupted_one(tmp_path):
    """In worker processes, trial 1 interrupted while trial 2 finished: the log ends with
    trial 1, as the serial run leaves it (trial 2 after it would leave trial 1 a gap)."""
    from concurrent.futures import Future

    from mearm.experiment import TrialResult, Workers, _append_in_order

    def done(k: int) -> Future:
        fut: Future = Future()
        stopped = k == 1
        fut.set_result(
            TrialResult(
                k, reason="interrupted (Ctrl-C)" if stopped else None, interrupted=stopped,
                records=f'{{"trial":{k}}}\n'.encode(),
            )
        )  # fmt: skip
        return fut

    log = tmp_path / "trials.jsonl"
    with pytest.raises(SortAborted) as stopped:
        _append_in_order(Workers(done, (), 2, "workers"), range(4), log, None)
    assert stopped.value.interrupted
    assert log.read_bytes() == b'{"trial":0}\n{"trial":1}\n'


# --------------------------------------------------------------------------- reading


def test_an_interrupted_attempt_is_not_finished_and_gives_way(tmp_path, config):
    """Ctrl-C (or a stop signal taken as one) in the fault's reason, or objects left as
    interrupted: not finished. A fault of the rig is the trial's result: finished."""
    log = tmp_path / "run.jsonl"
    with RunLog(log, fsync=False) as w:
        for k, reason, left in [
            (0, "interrupted (Ctrl-C); arm parked at home", {"interrupted": 1}),
            (0, "before the sort started: interrupted (SIGTERM)", {}),
            (0, None, {}),
            (1, "camera: no frame for 2 s", {"fault": 1}),
        ]:
            w.header(config, trial=k)
            if reason is not None:
                w.fault(reason, trial=k)
            w.summary(trial=k, objects={"red": sum(left.values())}, left=left)
    contents = read_runlog(log)
    assert attempts(log) == [
        (0, "interrupted"),
        (0, "interrupted"),
        (0, "finished"),
        (1, "finished"),
    ]
    assert [t.number for t in contents.superseded] == [0, 0]
    assert [t.line for t in contents.latest().trials] == [7, 9]

    with RunLog(log, fsync=False) as w:  # trial 1 finished twice: two runs in one file
        w.header(config, trial=1)
        w.summary(trial=1)
    with pytest.raises(RepeatedTrialError):
        read_runlog(log).latest()


def test_the_last_interrupted_attempt_is_kept_when_none_finished(tmp_path):
    log = tmp_path / "run.jsonl"
    config = load_config("configs/sim.yaml")
    with RunLog(log, fsync=False) as w:
        for _ in range(2):
            w.header(config, trial=0)
            w.fault("interrupted (Ctrl-C); arm parked at home", trial=0)
            w.summary(trial=0)
        w.header(config, trial=0)  # cut off
    contents = read_runlog(log)
    assert [t.line for t in contents.latest().trials] == [4]
