"""Sweeps in worker processes: the same seeds give the same outcomes whatever --jobs."""

import re

import pytest
from conftest import run_cli


def twin_scenes(*args: str) -> tuple[int, list[str], str]:
    r = run_cli(
        "-m", "mearm", "twin-scenes", "--config", "configs/sim_mujoco.yaml", *args, timeout=300
    )  # fmt: skip
    return r.returncode, r.stdout.splitlines(), r.stderr


def test_twin_scenes_in_two_workers_print_what_one_process_prints():
    """Three seeded scenes of three objects: every outcome line identical, in seed order."""
    sweep = ("--scenes", "3", "--objects", "3", "--first-seed", "4")
    code1, serial, err1 = twin_scenes(*sweep, "--jobs", "1")
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


@pytest.mark.parametrize("jobs", ["0", "-1", "two"])
def test_twin_scenes_refuses_a_bad_number_of_workers(jobs):
    code, out, err = twin_scenes("--scenes", "1", "--jobs", jobs)
    assert code == 2 and not out
    assert len(err.strip().splitlines()) == 1 and "--jobs" in err and "workers" in err
