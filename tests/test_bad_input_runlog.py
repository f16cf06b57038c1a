"""Bad-input corpus: run logs given to ``mearm analyze`` and ``mearm experiment --log``.

Every case goes through :func:`badinput.check_bad_input`: the exit code, one line on
stderr and no traceback, a time bound, and every file it was given left byte for byte as
it was (a log that cannot be resumed is never touched). ``pytest -m bad_input`` runs them.
"""

from __future__ import annotations

import io
import json
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from badinput import check_bad_input, run_in_process

from mearm.config import Config
from mearm.experiment import trial_seed
from mearm.runlog import RunLog

pytestmark = pytest.mark.bad_input

#: Two objects in every trial of the module's experiment log (quick to sort).
SCENE = "- {color: red, x: -10.99, y: 49.70}\n- {color: blue, x: 5.0, y: 45.0}\n"


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A real two-trial experiment log (with ``--scene``) and its scene file."""
    folder = tmp_path_factory.mktemp("made")
    scene = folder / "scene.yaml"
    scene.write_text(SCENE)
    log = folder / "experiment.jsonl"
    saved = sys.stdin
    sys.stdin = io.StringIO("")
    try:
        out = run_in_process(
            ["experiment", "--trials", "2", "--scene", str(scene), "--log", str(log)],
            within_s=120,
        )
    finally:
        sys.stdin = saved
    assert out.code == 0, out.stderr
    return {"log": log, "scene": scene}


def lines_of(path: Path) -> list[bytes]:
    return path.read_bytes().splitlines(keepends=True)


def header_line(**over: object) -> bytes:
    """A valid format-2 header of the built-in config, with fields replaced."""
    obj: dict[str, object] = {
        "type": "header", "format": 2, "mearm_version": "0.2.0",
        "started": "2026-01-02T03:04:05+00:00", "config": {}, "versions": {},
        "trial": 0, "seed": 1,
    }  # fmt: skip
    obj.update(over)
    return json.dumps(obj).encode() + b"\n"


# --------------------------------------------------------------------------- files


def route_edited(m: dict[str, Path], pattern: bytes, new: bytes) -> bytes:
    """The experiment log's first header and its first route with ``pattern`` → ``new``."""
    header, route = lines_of(m["log"])[:2]
    edited = re.sub(pattern, new, route, count=1)
    assert edited != route, pattern
    return header + edited


#: name → the bytes of a log that ``mearm analyze`` refuses (exit 2, one line).
BAD_LOG_BYTES: dict[str, Callable[[dict[str, Path]], bytes]] = {
    "empty": lambda m: b"",
    "blank lines only": lambda m: b"\n\n  \n",
    "not JSON": lambda m: b"hello world\n",
    "JSON array": lambda m: b"[1, 2, 3]\n",
    "JSON string": lambda m: b'"header"\n',
    "JSON null": lambda m: b"null\n",
    "object without a type": lambda m: b'{"format": 2}\n',
    "unknown record type": lambda m: b'{"type": "banana"}\n',
    "unknown format version": lambda m: header_line(format=99),
    "format as a string": lambda m: header_line(format="2"),
    "format as a float": lambda m: header_line(format=2.0),
    "trial as a string": lambda m: header_line(trial="0"),
    "seed as a float": lambda m: header_line(seed=1.5),
    "config as a list": lambda m: header_line(config=[1, 2]),
    "not a time": lambda m: header_line(started="yesterday"),
    "huge format number": lambda m: b'{"type":"header","format":' + b"9" * 5000 + b"}\n",
    "route before any header": lambda m: lines_of(m["log"])[1],
    "NUL bytes": lambda m: b"\x00" * 4096 + b"\n",
    "NUL inside a header": lambda m: lines_of(m["log"])[0].replace(b'"header"', b'"hea\x00der"'),
    "not UTF-8": lambda m: b'{"type": "header", "mearm_version": "\xff\xfe"}\n',
    "UTF-16 text": lambda m: lines_of(m["log"])[0].decode().encode("utf-16"),
    "random bytes": lambda m: bytes(range(256)) * 64,
    "torn first line": lambda m: lines_of(m["log"])[0][:120],
    "a line longer than 4 MiB": lambda m: b'{"type": "header", "x": "' + b"a" * (5 << 20) + b'"}\n',
    "JSON nested 100 000 deep": lambda m: b"[" * 100_000 + b"]" * 100_000 + b"\n",
    "header without routes": lambda m: lines_of(m["log"])[0],
    "header and summary, no route": lambda m: (
        lines_of(m["log"])[0] + lines_of(m["log"])[-1].replace(b'"trial":1', b'"trial":0')
    ),
    "summary of another trial": lambda m: lines_of(m["log"])[0] + lines_of(m["log"])[-1],
    "NaN in a route": lambda m: route_edited(m, rb'"ee_cm":\[[^,]+', b'"ee_cm":[NaN'),
    "Infinity in a route": lambda m: route_edited(m, rb'"motion_s":[^,}]+', b'"motion_s":Infinity'),
    "route of another trial": lambda m: route_edited(m, rb'"trial":0', b'"trial":7'),
    "a boolean as the attempt": lambda m: route_edited(m, rb'"attempt":1', b'"attempt":true'),
    "route without its error": lambda m: route_edited(m, rb'"error_cm"', b'"err_cm"'),
    "another arm's joints": lambda m: route_edited(m, rb'"base"', b'"joint1"'),
    "two runs in one file": lambda m: m["log"].read_bytes() * 2,
}


@pytest.mark.parametrize("name", BAD_LOG_BYTES)
@pytest.mark.heavy
def test_analyze_refuses_a_bad_log(name: str, made: dict[str, Path], tmp_path: Path) -> None:
    log = tmp_path / "bad.jsonl"
    log.write_bytes(BAD_LOG_BYTES[name](made))
    check_bad_input(["analyze", log], keep=[log])


def test_analyze_refuses_a_folder(tmp_path: Path) -> None:
    (tmp_path / "logs").mkdir()
    out = check_bad_input(["analyze", tmp_path / "logs"], keep=[tmp_path])
    assert "not a file" in out.line


def test_analyze_refuses_dev_zero() -> None:
    out = check_bad_input(["analyze", "/dev/zero"])
    assert "not a file" in out.line


def test_analyze_refuses_a_fifo_without_waiting(tmp_path: Path) -> None:
    fifo = tmp_path / "log.fifo"
    os.mkfifo(fifo)
    check_bad_input(["analyze", fifo], within_s=2)


def test_analyze_refuses_a_missing_log(tmp_path: Path) -> None:
    out = check_bad_input(["analyze", tmp_path / "nope.jsonl"], keep=[tmp_path])
    assert "no such run log" in out.line


def test_analyze_refuses_a_link_loop(tmp_path: Path) -> None:
    (tmp_path / "a.jsonl").symlink_to(tmp_path / "b.jsonl")
    (tmp_path / "b.jsonl").symlink_to(tmp_path / "a.jsonl")
    check_bad_input(["analyze", tmp_path / "a.jsonl"])


def test_analyze_names_a_trial_complete_twice(made: dict[str, Path], tmp_path: Path) -> None:
    log = tmp_path / "twice.jsonl"
    log.write_bytes(made["log"].read_bytes() * 2)
    out = check_bad_input(["analyze", log], keep=[log])
    assert "trials 0, 1 are complete more than once" in out.line


def test_analyze_strict_refuses_a_torn_end(made: dict[str, Path], tmp_path: Path) -> None:
    log = tmp_path / "torn.jsonl"
    log.write_bytes(made["log"].read_bytes()[:-20])
    out = check_bad_input(["analyze", log, "--strict"], keep=[log])
    assert "torn last line" in out.line


@pytest.mark.parametrize("where", ["torn end", "garbage in the middle"])
def test_analyze_reads_a_damaged_log_up_to_the_bad_line(
    where: str, made: dict[str, Path], tmp_path: Path
) -> None:
    """Routes before the damage: analysed, exit 0, one warning line."""
    data = made["log"].read_bytes()
    lines = lines_of(made["log"])
    log = tmp_path / "damaged.jsonl"
    damaged = data[:-20] if where == "torn end" else b"".join([*lines[:3], b"}{\n", *lines[3:]])
    log.write_bytes(damaged)
    out = check_bad_input(["analyze", log], code=0, keep=[log], within_s=15)
    assert out.line.startswith("mearm analyze: warning:")


def route_moved(m: dict[str, Path], n: int, x_cm: float) -> bytes:
    """The experiment log with its ``n``-th route's end (and so its error) moved to ``x_cm``."""
    lines = lines_of(m["log"])
    routes = [i for i, line in enumerate(lines) if b'"type":"route"' in line]
    obj = json.loads(lines[routes[n]])
    obj["ee_cm"][0] = x_cm
    obj["error_cm"][0] = x_cm - obj["target_cm"][0]
    lines[routes[n]] = json.dumps(obj).encode() + b"\n"
    return b"".join(lines)


@pytest.mark.parametrize("x_cm", [1e308, -1e300, 1e5])
def test_analyze_strict_refuses_an_absurd_route_naming_its_line(
    x_cm: float, made: dict[str, Path], tmp_path: Path
) -> None:
    """A route that ended 1e308 cm away is not a measurement: strict names its line."""
    log = tmp_path / "absurd.jsonl"
    log.write_bytes(route_moved(made, 1, x_cm))
    line = 1 + [b'"type":"route"' in x for x in lines_of(log)].index(True) + 1
    out = check_bad_input(["analyze", log, "--strict"], keep=[log], within_s=15)
    assert f"line {line}: route record: field 'ee_cm.0'" in out.line
    assert "less than or equal to 10000" in out.line or "greater than or equal to -10000" in (
        out.line
    )
    assert "overflow" not in out.stderr


def test_analyze_reads_up_to_an_absurd_route(made: dict[str, Path], tmp_path: Path) -> None:
    """Without --strict, the routes before it are analysed and the line is named."""
    log = tmp_path / "absurd.jsonl"
    log.write_bytes(route_moved(made, 1, 1e308))
    out = check_bad_input(["analyze", log], code=0, keep=[log], within_s=15)
    assert out.line.startswith("mearm analyze: warning:") and "ee_cm.0" in out.line


def test_analyze_refuses_out_that_is_a_file(made: dict[str, Path], tmp_path: Path) -> None:
    (tmp_path / "report").write_text("keep")
    out = check_bad_input(["analyze", made["log"], "--out", tmp_path / "report"], keep=[tmp_path])
    assert "not a folder" in out.line


def test_analyze_refuses_out_under_a_file(made: dict[str, Path], tmp_path: Path) -> None:
    (tmp_path / "file").write_text("keep")
    argv = ["analyze", made["log"], "--out", tmp_path / "file" / "report"]
    out = check_bad_input(argv, keep=[tmp_path, made["log"]], within_s=15)
    assert f"{tmp_path / 'file'} is a file, not a folder" in out.line  # (before the work)


# --------------------------------------------------------------------------- experiment --log


def experiment_argv(log: Path, scene: Path | None, *more: object) -> list[object]:
    args: list[object] = ["experiment", "--trials", "3", "--log", log]
    return [*args, *(["--scene", scene] if scene is not None else []), *more]


#: name → (the log's bytes, from the module's experiment log, and the words of the line).
BAD_RESUME_LOGS: dict[str, tuple[Callable[[dict[str, Path]], bytes], str]] = {
    "not JSON": (lambda m: b"hello\n", "line 1: not valid JSON"),
    "NUL bytes": (lambda m: b"\x00\x00\x00\n", "not valid JSON"),
    "not UTF-8": (lambda m: b"\xff\xfe\xfd\n", "not UTF-8"),
    "unknown format version": (lambda m: header_line(format=3), "format 3 is not supported"),
    "a line longer than 4 MiB": (lambda m: b"x" * (5 << 20) + b"\n", "longer than 4 MiB"),
    "damage before the last line": (
        lambda m: b"".join([*lines_of(m["log"])[:2], b"garbage\n", *lines_of(m["log"])[2:]]),
        "line 3: not valid JSON",
    ),
    "a torn line then more lines": (
        lambda m: lines_of(m["log"])[0][:50] + b"".join(lines_of(m["log"])[1:]),
        "a damaged log is not resumed",
    ),
    "a sort run": (lambda m: header_line(trial=None), "a sort run (trial null)"),
    "trials out of order": (
        lambda m: b"".join(lines_of(m["log"])).replace(b'"trial":0', b'"trial":1'),
        "trial 1 where trial 0 comes next",
    ),
    "a trial complete twice": (lambda m: m["log"].read_bytes() * 2, "trial 0 where trial 2"),
    "a negative trial number": (lambda m: header_line(trial=-1), "trial -1 where trial 0"),
    "another run's seed": (
        lambda m: header_line(seed=trial_seed(5, 0)),
        f"it was seeded {trial_seed(5, 0)}",
    ),
}


@pytest.mark.parametrize("name", BAD_RESUME_LOGS)
def test_experiment_refuses_to_resume_a_bad_log(
    name: str, made: dict[str, Path], tmp_path: Path
) -> None:
    make, words = BAD_RESUME_LOGS[name]
    log = tmp_path / "trials.jsonl"
    log.write_bytes(make(made))
    out = check_bad_input(experiment_argv(log, made["scene"]), keep=[tmp_path])
    assert words in out.line


@pytest.mark.parametrize(
    ("more", "words"),
    [
        (["--seed", "1"], "--seed 1 seeds it"),
        (["--set", "controller.kp=0.3"], "its config differs at controller.kp"),
        (["--set", "servo.error_model.quantization=degree"], "servo.error_model.quantization"),
        (["--config", "configs/sim_4colours.yaml"], "its config differs at"),
        # (without --scene: the module's scene lies outside this arm's camera view)
        (["--config", "configs/sim_5dof.yaml", "--no-scene"], "its config differs at arm"),
    ],
)
def test_experiment_refuses_a_log_of_another_config_or_seed(
    more: list[str], words: str, made: dict[str, Path], tmp_path: Path
) -> None:
    log = tmp_path / "trials.jsonl"
    log.write_bytes(made["log"].read_bytes())
    scene = None if "--no-scene" in more else made["scene"]
    more = [m for m in more if m != "--no-scene"]
    out = check_bad_input(experiment_argv(log, scene, *more), keep=[tmp_path])
    assert words in out.line and "another run" in out.line


def test_experiment_refuses_a_log_of_another_layout(made: dict[str, Path], tmp_path: Path) -> None:
    """Written with --scene, resumed without it: the layouts differ."""
    log = tmp_path / "trials.jsonl"
    log.write_bytes(made["log"].read_bytes())
    out = check_bad_input(experiment_argv(log, None), keep=[tmp_path])
    assert "its table layout differs" in out.line


def test_experiment_refuses_a_cut_off_log_of_another_run(
    made: dict[str, Path], tmp_path: Path
) -> None:
    """Even a trial without its summary must be this run's to be run again."""
    log = tmp_path / "trials.jsonl"
    log.write_bytes(lines_of(made["log"])[0])
    out = check_bad_input(experiment_argv(log, made["scene"], "--seed", "9"), keep=[tmp_path])
    assert "another run" in out.line


def test_experiment_refuses_a_format_1_log(tmp_path: Path) -> None:
    log = tmp_path / "v1.jsonl"
    with RunLog(log) as w:
        w.header(Config(), trial=0, seed=trial_seed(0, 0))
        w.summary(ok=True)
    v1 = json.loads(lines_of(log)[0])
    v1["format"] = 1
    log.write_bytes(json.dumps(v1).encode() + b"\n" + lines_of(log)[1])
    check_bad_input(experiment_argv(log, None), keep=[tmp_path])


@pytest.mark.parametrize("kind", ["folder", "/dev/zero", "fifo", "under a file", "link loop"])
def test_experiment_refuses_a_log_path_that_is_no_file(kind: str, tmp_path: Path) -> None:
    paths = {
        "folder": tmp_path / "logs",
        "/dev/zero": Path("/dev/zero"),
        "fifo": tmp_path / "log.fifo",
        "under a file": tmp_path / "file" / "trials.jsonl",
        "link loop": tmp_path / "a.jsonl",
    }
    if kind == "folder":
        paths[kind].mkdir()
    elif kind == "fifo":
        os.mkfifo(paths[kind])
    elif kind == "under a file":
        (tmp_path / "file").write_text("keep")
    elif kind == "link loop":
        (tmp_path / "a.jsonl").symlink_to(tmp_path / "b.jsonl")
        (tmp_path / "b.jsonl").symlink_to(tmp_path / "a.jsonl")
    keep = [tmp_path] if kind != "link loop" else []
    check_bad_input(experiment_argv(paths[kind], None), keep=keep, within_s=3)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        {"folder": ["logs"], "/dev/zero": [], "fifo": ["log.fifo"], "under a file": ["file"],
         "link loop": ["a.jsonl", "b.jsonl"]}[kind]
    )  # fmt: skip


def test_experiment_on_a_rig_without_a_terminal_refuses_before_the_log(tmp_path: Path) -> None:
    """A real rig's prompt needs a terminal: exit 2 naming --yes; no log is made."""
    frames = tmp_path / "frames"
    frames.mkdir()
    cfg = tmp_path / "rig.yaml"
    cfg.write_text(f"camera:\n  kind: folder\n  path: {frames}\n")
    log = tmp_path / "trials.jsonl"
    out = check_bad_input(["experiment", "--config", cfg, "--log", log], keep=[tmp_path])
    assert "needs a terminal" in out.line and "--yes" in out.line
    assert not log.exists()
