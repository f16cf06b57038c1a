"""Sweeps in worker processes: the same seeds give the same outcomes whatever --jobs."""

import contextlib
import json
import re
import subprocess
from pathlib import Path

import pytest
from badinput import Outcome, run_in_process
from built_once import built_once
from conftest import ROOT, interrupted_experiment, run_cli

from mearm.runlog import read_runlog


def twin_scenes(*args: str) -> tuple[int, list[str], str]:
    r = run_cli(
        "-m", "mearm", "twin-scenes", "--config", "configs/sim_mujoco.yaml", *args, timeout=300
    )  # fmt: skip
    return r.returncode, r.stdout.splitlines(), r.stderr


@pytest.mark.heavy
def test_twin_scenes_in_two_workers_print_what_one_process_prints():
    """Three seeded scenes of three objects: every outcome line identical, in seed order.
    The serial run is this process's (the workers' run is a real command's)."""
    sweep = ("--scenes", "3", "--objects", "3", "--first-seed", "4")
    one = here("twin-scenes", "--config", "configs/sim_mujoco.yaml", *sweep, "--jobs", "1")
    code1, serial, err1 = one.code, one.stdout.splitlines(), one.stderr
    code2, parallel, err2 = twin_scenes(*sweep, "--jobs", "2")
    assert code1 == code2 == 0, err1 + err2
    total = re.compile(
        r"(twin, 3 scenes of 3: sorted \d+ of 9 objects \([\d.]+ %\)) in \d+ s, "
        r"[\d.]+ scenes/min \((1 process|2 workers)\)"
    )
    heads = []
    for lines in (serial, parallel):
        [i] = [i for i, line in enumerate(lines) if line.startswith("twin, ")]
        match = total.fullmatch(lines[i])
        assert match, lines[i]
        heads.append(match.group(1))
        lines[i] = ""
    assert [line.split(":")[0] for line in serial if line.startswith("seed")] == [
        "seed   4", "seed   5", "seed   6"
    ]  # fmt: skip
    assert parallel == serial
    assert heads[0] == heads[1]


@pytest.mark.heavy
def test_sigterm_stops_twin_scenes_and_its_workers(tmp_path):
    """SIGTERM to the command alone (as a supervisor sends it), while two workers sort:
    exit 143, and no worker left behind (they used to wait for ever, orphaned)."""
    import signal
    import sys
    import time

    def children(pid: int) -> set[int]:
        out = set()
        for stat in Path("/proc").glob("[0-9]*/stat"):
            with contextlib.suppress(OSError):  # a process that ended meanwhile
                fields = stat.read_text().rsplit(")", 1)[1].split()
                if int(fields[1]) == pid:
                    out.add(int(stat.parent.name))
        return out

    cmd = [sys.executable, "-m", "mearm", "twin-scenes", "--config", "configs/sim_mujoco.yaml",
           "--scenes", "20", "--jobs", "2"]  # fmt: skip
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(children(proc.pid)) < 2:  # the workers started
        time.sleep(0.05)
    workers = children(proc.pid)
    assert len(workers) >= 2
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 143, err
    assert b"interrupted" in err
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and any(Path(f"/proc/{w}").exists() for w in workers):
        time.sleep(0.1)
    assert not [w for w in workers if Path(f"/proc/{w}").exists()], "workers left behind"


@pytest.mark.heavy
@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_signal_stops_twin_scenes_in_one_process(sig: str) -> None:
    """With --jobs 1 the sort took the signal as an interrupted sort and the sweep went on
    to the next scene: all 40 sorted, exit 0. It now stops after that scene's line, exit
    130 or 143 as the signal says."""
    import signal
    import sys
    import time

    cmd = [sys.executable, "-u", "-m", "mearm", "twin-scenes", "--config", "sim_mujoco",
           "--scenes", "40", "--objects", "3", "--jobs", "1"]  # fmt: skip
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None
    first = proc.stdout.readline()  # a scene sorted: the next one is under way
    assert first.startswith(b"seed   0: sorted"), first
    time.sleep(0.3)
    proc.send_signal(getattr(signal, sig))
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 128 + getattr(signal, sig), err
    assert err.decode().strip().endswith("mearm twin-scenes: interrupted")
    lines = [first, *out.splitlines()]
    assert len(lines) < 40 and b"twin, 40 scenes" not in out, out


def here(*args: object) -> Outcome:
    """``mearm ARGS`` in this process, from the checkout: for refusals before any work and
    for the serial runs the workers' runs are compared with (the runs of workers start
    real processes, whose exit codes they check)."""
    return run_in_process(args, within_s=10, cwd=ROOT)


@pytest.mark.parametrize("jobs", ["0", "-1", "two"])
def test_twin_scenes_refuses_a_bad_number_of_workers(jobs):
    r = here("twin-scenes", "--config", "configs/sim_mujoco.yaml", "--scenes", 1, "--jobs", jobs)
    assert r.code == 2 and not r.stdout
    assert len(r.stderr.strip().splitlines()) == 1 and "--jobs" in r.stderr
    assert "workers" in r.stderr


# --------------------------------------------------------------------------- experiment


def records(log: Path) -> list[dict]:
    """The log's records without the two wall-clock fields (start time, time per route)."""
    out = []
    for line in log.read_text().splitlines():
        record = json.loads(line)
        record.pop("started", None)
        record.pop("elapsed_s", None)
        out.append(record)
    return out


def experiment(*args: object, timeout: float = 300) -> subprocess.CompletedProcess:
    return run_cli("-m", "mearm", "experiment", *map(str, args), timeout=timeout)


#: One object of each class on sim.yaml's table: an experiment's random trials lay as
#: many of each class as the config's table holds (mearm/experiment/trials.py,
#: ``trial_counts``), so each trial sorts 3 objects, not the paper's 12. The sweeps
#: below are about which records the workers write, not how many.
ONE_PER_CLASS = (
    "--set",
    "task.scene=[{color: red, x: -4, y: 45}, {color: green, x: 4, y: 45}, "
    "{color: blue, x: 0, y: 40}]",
)
#: Objects a trial of :data:`ONE_PER_CLASS` sorts.
OBJECTS = 3
#: The seeded sweep that runs in workers and on Dask (tests/test_experiment_cluster.py).
SWEEP = ("--config", "configs/sim.yaml", *ONE_PER_CLASS, "--seed", 5)
#: The trials of its serial log (five are compared with, six cover most Ctrl-C resumes).
SERIAL_TRIALS = 6


def serial_log(factory: pytest.TempPathFactory) -> Path:
    """:data:`SWEEP`'s trials run in one process (``--jobs 1``, this test's): the log every
    other way of running them must write. Run once per test run and shared by the workers."""

    def run(folder: Path) -> None:
        log = folder / "serial.jsonl"
        r = here("experiment", *SWEEP, "--trials", SERIAL_TRIALS, "--log", log, "--jobs", 1)
        assert r.code == 0, r.stderr
        n, objects = SERIAL_TRIALS, OBJECTS * SERIAL_TRIALS
        assert re.search(rf"{n} trials written to .* \([\d.]+ trials/min, 1 process\)", r.stdout)
        assert f"sorted {objects} of {objects} objects over {n} trials" in r.stdout

    return built_once(factory, "serial-sweep", run) / "serial.jsonl"


def serial_prefix(factory: pytest.TempPathFactory, trials: int, folder: Path) -> Path:
    """The serial log's first ``trials`` trials as a log of their own, written in ``folder``
    (a log is only ever appended to: the first trials of a longer run are a shorter run)."""
    lines = serial_log(factory).read_text().splitlines(keepends=True)
    path = folder / f"serial-{trials}.jsonl"
    path.write_text("".join(line for line in lines if json.loads(line)["trial"] < trials))
    return path


def serial_records(factory: pytest.TempPathFactory, trials: int) -> list[dict]:
    """The serial log's records of the first ``trials`` trials (see :func:`records`)."""
    out = [r for r in records(serial_log(factory)) if r["trial"] < trials]
    assert len(out) > trials * 2 * OBJECTS  # a header, two routes an object and a summary
    return out


@pytest.mark.heavy
def test_experiment_in_two_workers_writes_the_serial_log(tmp_path, tmp_path_factory):
    """Same trials, same records in the same order; analyze reads it; then it resumes, to
    the serial log of all five."""
    log = tmp_path / "jobs2.jsonl"
    r = experiment(*SWEEP, "--trials", 3, "--log", log, "--jobs", 2)
    assert r.returncode == 0, r.stderr
    assert re.search(r"3 trials written to .* \([\d.]+ trials/min, 2 workers\)", r.stdout)
    assert f"sorted {3 * OBJECTS} of {3 * OBJECTS} objects over 3 trials" in r.stdout
    assert records(log) == serial_records(tmp_path_factory, 3)
    r = here("analyze", log, "--json")
    assert r.code == 0 and json.loads(r.stdout), r.stderr
    before = log.read_bytes()
    r = experiment(*SWEEP, "--trials", 5, "--log", log, "--jobs", 2)
    assert r.returncode == 0 and "running trials 3..4" in r.stdout, r.stdout + r.stderr
    assert log.read_bytes().startswith(before)
    assert [t.number for t in read_runlog(log).trials] == [0, 1, 2, 3, 4]
    assert records(log) == serial_records(tmp_path_factory, 5)


@pytest.mark.heavy
def test_ctrl_c_keeps_every_finished_trial_in_order_and_the_log_resumes(tmp_path):
    """Ctrl-C (to the whole process group, as a terminal sends it) in a run of two workers:
    exit 130, every trial in the log complete and in order, and the same command resumes it."""
    log, trials = tmp_path / "trials.jsonl", 100
    # signalled once 2 trials are in the log; on a loaded machine the workers run ahead of
    # the writing process (a slow first trial holds the others back, then all are written
    # at once), so leave them room: 8 and 16 trials of 12 objects were each once all done
    # first. A trial of 3 objects takes a third of one of 12: 100 leave the room 30 did.
    args = ["--trials", trials, "--log", log, "--jobs", 2, "--config", "configs/sim.yaml",
            *ONE_PER_CLASS]  # fmt: skip
    code, err = interrupted_experiment(args, log)
    assert code == 130
    contents = read_runlog(log)
    assert contents.problem is None
    got = [(t.number, t.complete) for t in contents.trials]
    assert 2 <= len(got) < trials, "the run was not stopped mid-way"
    assert got == [(k, True) for k in range(len(got))]
    # the last line says how the trial Ctrl-C stopped ended, as its log does (it said only
    # "interrupted (Ctrl-C)" where the log had "…; arm parked at home")
    last = contents.trials[-1]
    ended = last.faults[-1].reason.partition("; ")[2] if last.faults else ""
    if last.interrupted and ended:  # (one stopped before its sort started moved nothing)
        said = [ln for ln in err.splitlines() if ": stopped: " in ln]
        assert said and f"; {ended}; " in said[-1], err
    # the last trial may be the one Ctrl-C stopped: written, and run again on resuming
    assert all(t.finished for t in contents.trials[:-1])
    done = sum(t.finished for t in contents.trials)
    written = log.read_bytes()
    # resumed to two trials past the stop (running all 100 would prove no more)
    more = len(got) + 2
    r = experiment("--trials", more, *args[2:])
    assert r.returncode == 0 and f"running trials {done}..{more - 1}" in r.stdout, r.stderr
    assert log.read_bytes().startswith(written)
    assert [t.number for t in read_runlog(log).latest().trials] == list(range(more))


@pytest.mark.heavy
@pytest.mark.parametrize("jobs", ["0", "-2", "many"])
def test_experiment_refuses_a_bad_number_of_workers(jobs, tmp_path):
    r = here("experiment", "--trials", 1, "--log", tmp_path / "t.jsonl", "--jobs", jobs)
    assert r.code == 2 and not (tmp_path / "t.jsonl").exists()
    assert len(r.stderr.strip().splitlines()) == 1 and "workers" in r.stderr


@pytest.mark.heavy
def test_a_real_rig_runs_one_trial_at_a_time(tmp_path):
    rig = tmp_path / "rig.yaml"
    rig.write_text(f"camera:\n  kind: folder\n  path: {tmp_path}\n")
    r = here(
        "experiment", "--config", rig, "--trials", 2, "--log", tmp_path / "t.jsonl", "--jobs", 2
    )
    assert r.code == 2 and not (tmp_path / "t.jsonl").exists()
    assert len(r.stderr.strip().splitlines()) == 1 and "one trial at a time" in r.stderr


def test_a_worker_that_saw_ctrl_c_first_stops_the_run(tmp_path):
    """Ctrl-C reaches the workers before this process polls its own: a worker's trial comes
    back not run, already done. The run stops as interrupted (it returned as finished, and
    `mearm experiment` exited 0 with trials missing), and the trials before it are kept."""
    from concurrent.futures import Future

    from mearm.experiment import TrialResult, Workers, _append_in_order
    from mearm.task.sorter import SortAborted

    def done(k: int) -> Future:
        fut: Future = Future()
        record = f'{{"trial":{k}}}\n'.encode()
        fut.set_result(TrialResult(k, ran=k < 2, records=record if k < 2 else b""))
        return fut

    log = tmp_path / "trials.jsonl"
    with pytest.raises(SortAborted) as stopped:
        _append_in_order(Workers(done, (), 2, "workers"), range(6), log, None)
    assert stopped.value.interrupted
    assert log.read_bytes() == b'{"trial":0}\n{"trial":1}\n'


def test_ctrl_c_stops_a_run_whose_trials_are_all_done_when_reached(tmp_path):
    """Workers faster than the writing: every future is done when the loop reaches it.
    A Ctrl-C once trial 2 is written still stops the run (it went on to the end, the
    writing process never waiting long enough to see it)."""
    import os
    import signal
    from concurrent.futures import Future

    from mearm.experiment import AHEAD_PER_WORKER, TrialResult, Workers, _append_in_order
    from mearm.task.sorter import SortAborted

    def done(k: int) -> Future:
        if k == 2 + 2 * AHEAD_PER_WORKER:  # submitted once trial 2 is written
            os.kill(os.getpid(), signal.SIGINT)
        fut: Future = Future()
        fut.set_result(TrialResult(k, ran=True, records=f'{{"trial":{k}}}\n'.encode()))
        return fut

    log = tmp_path / "trials.jsonl"
    with pytest.raises(SortAborted) as stopped:
        _append_in_order(Workers(done, (), 2, "workers"), range(30), log, None)
    assert stopped.value.interrupted
    written = log.read_bytes().splitlines()
    assert 2 <= len(written) < 30 and written[0] == b'{"trial":0}'


def test_twin_scenes_below_require_says_why_last(monkeypatch, capsys) -> None:
    """Under ``--require`` the exit is 1 and the last line says so (until 2026-12-06 the
    command ended on its counts alone, as when it met the share); at or above it, 0."""
    from mearm.tools import twin_scenes as ts

    def swept(config, objects, seeds, jobs):  # 12 seen, 11 sorted and in their bins
        return [(12, 12, 11, 11, {"pick_failed": 1}, None, []) for _ in seeds]

    monkeypatch.setattr(ts, "sweep", swept)
    argv = ["--config", "sim_mujoco", "--scenes", "1", "--objects", "12", "--jobs", "1"]
    assert ts.main([*argv, "--require", "0.99"]) == 1
    out, err = capsys.readouterr()
    assert "sorted 11 of 12 objects (91.6 %)" in out
    assert err.splitlines()[-1] == (
        "mearm twin-scenes: sorted 91.6 % is below --require 0.99 (99.0 %)"
    )
    assert ts.main([*argv, "--require", "0.9"]) == 0
    assert capsys.readouterr().err == ""
