"""Shared fixtures."""

from __future__ import annotations

import contextlib
import io
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NoReturn

import pytest
from hypothesis import settings

from mearm.config import Config, load_config
from mearm.kinematics import ArmModel

# CI (MEARM_REQUIRE_TOOLS=1) draws the same property-test examples every run, so a red run
# can be reproduced and a green one is not luck; locally each run explores new ones.
settings.register_profile("ci", derandomize=True)
if os.environ.get("MEARM_REQUIRE_TOOLS") == "1":
    settings.load_profile("ci")

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True, scope="session")
def _crash_log_in_tmp(tmp_path_factory: pytest.TempPathFactory) -> None:
    """Unexpected errors' tracebacks go to a temporary state dir, not the user's home."""
    os.environ["MEARM_STATE_DIR"] = str(tmp_path_factory.mktemp("state"))


@pytest.fixture(autouse=True)
def _program_name_kept() -> Any:
    """Each test starts with the worker's own ``sys.argv``: a command run in this process
    through the ``mearm`` dispatcher renames the program (``mearm fk``), and a later
    in-process test would read that name as its own (the commands' error prefixes do)."""
    saved = sys.argv[:]
    yield
    sys.argv = saved


@pytest.fixture(autouse=True)
def _scheduling_kept() -> Any:
    """Each test leaves the worker's scheduling as it found it. SVT-AV1, opened as root,
    left a worker at ``SCHED_FIFO`` 99, and every process the worker started afterwards
    ran realtime: a busy virtual Uno held a core, and the full suite's virtual-Uno sort
    ran past its 300 s timeout, far from the test that changed it."""
    if not hasattr(os, "sched_getscheduler"):  # not Linux: no such policies to leave
        yield
        return
    before = (os.sched_getscheduler(0), os.sched_getparam(0))
    yield
    after = (os.sched_getscheduler(0), os.sched_getparam(0))
    if after != before:
        os.sched_setscheduler(0, *before)
        pytest.fail(f"the test left this process at scheduling policy {after[0]}, not {before[0]}")


@pytest.fixture(scope="session")
def config() -> Config:
    return Config()


@pytest.fixture(scope="session")
def lab_config() -> Config:
    return load_config(ROOT / "configs" / "lab.yaml")


@pytest.fixture(scope="session")
def model(config: Config) -> ArmModel:
    return ArmModel(config.arm)


#: The reference configs, each a different arm or class set (their arms' URDFs are in
#: robot_description/).
REFERENCE_CONFIGS = ("sim.yaml", "sim_mearm_v1.yaml", "sim_5dof.yaml", "sim_4colours.yaml")


@pytest.fixture(scope="session", params=REFERENCE_CONFIGS)
def reference_config(request: pytest.FixtureRequest) -> Config:
    return load_config(ROOT / "configs" / request.param)


@pytest.fixture(scope="session")
def frame_png(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The simulated rig's 12 objects (``sim``) on the grey table, rendered once (640x480)."""
    import cv2

    from mearm.sim import TableRenderer, class_discs
    from mearm.vision import Calibration

    config = Config()
    layout = [(o.color, o.x, o.y) for o in config.task.scene]
    r = TableRenderer(Calibration.from_config(config.calibration), 640, 480, table="grey")
    path = tmp_path_factory.mktemp("frames") / "frame.png"
    cv2.imwrite(str(path), r.render(class_discs(config.task.classes, layout)))
    return path


def yourdfpy_urdf(text: str, **kwargs: Any) -> Any:
    """``text`` read by yourdfpy, without meshes (imported here: with trimesh it takes 0.6 s,
    which only the workers that run its tests should pay, not every worker's collection)."""
    import yourdfpy

    return yourdfpy.URDF.load(io.StringIO(text), load_meshes=False, **kwargs)


def planar_yaw_arm_data(*, rail: bool = False) -> dict:
    """A new arm written in the test itself: base yaw + two planar links (+ a rail).

    With ``rail`` a prismatic joint lifts the whole arm first (a linear rail).
    """

    def servo(channel: int, zero_us: float, k: float = 10.0) -> dict:
        return {"channel": channel, "zero_us": zero_us, "us_per_unit": k}

    joints = [
        {
            "name": "yaw",
            "dh": {"alpha_deg": 90.0, "d_cm": 10.0},
            "limits": {"min": 10.0, "max": 170.0},
            "home": 90.0,
            "servo": servo(0, 600.0),
        },
        {
            "name": "upper",
            "dh": {"a_cm": 14.0},
            "limits": {"min": 0.0, "max": 150.0},
            "home": 80.0,
            "servo": servo(1, 600.0),
        },
        {
            "name": "fore",
            "dh": {"a_cm": 12.0},
            "limits": {"min": -150.0, "max": -5.0},
            "home": -100.0,
            "servo": servo(2, 2400.0),
        },
    ]
    if rail:
        joints.insert(
            0,
            {
                "name": "rail",
                "type": "prismatic",
                "dh": {"alpha_deg": 0.0},
                "limits": {"min": 0.0, "max": 10.0},
                "home": 2.0,
                "servo": servo(6, 1000.0, 100.0),
            },
        )
    return {
        "name": "planar_yaw",
        "joints": joints,
        "tool": {
            "gripper": {
                "servo": {"channel": 4, "zero_us": 2200.0, "direction": -1, "us_per_unit": 300.0},
                "open_cm": 4.0,
                "closed_cm": 1.0,
            },
        },
        "target_box": {
            "x_cm": {"min": -30, "max": 30},
            "y_cm": {"min": 0, "max": 30},
            "z_cm": {"min": 0, "max": 40},
        },
    }


#: ``--set`` arguments that make the paper arm's servos ten times quicker (0.015 s per 60°)
#: and its tool settle in 10 ms. A serial link (a fake or a simulated Uno) is paced in
#: real or simulated time, and a 12-object sort at the real speeds spends most of its
#: half a minute waiting for servo travel; a test about what reaches the board, and
#: what comes back, proves the same with quick servos.
QUICK_SERVOS = [
    arg
    for key in (
        *(f"arm.joints.{j}.servo" for j in ("base", "shoulder", "elbow")),
        "arm.tool.gripper.servo",
        "arm.tool.actuators.gripper_arm.servo",
    )
    for arg in ("--set", f"{key}.seconds_per_60deg=0.015")
] + ["--set", "arm.tool.settle_s=0.01"]


def rays_at_each_looks_height(monkeypatch: pytest.MonkeyPatch) -> None:
    """Picks that look meet each look's ray at the height that look saw, as they did when
    a traced scene was recorded (they now meet it at the height the looks nearby saw:
    ``ClawEye.look``), so that the scene goes as it was traced."""
    from mearm.task.claw_loop import ClawEye

    monkeypatch.setattr(ClawEye, "_height_error_cm", lambda self, planned_cm, seen_cm: seen_cm)


def run_cli(*args: str, timeout: float = 60, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """Run ``python <args>`` as a user would, capturing text output."""
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd
    )


def mearm_cli(*args: object, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    """``python -m mearm ARGS`` in a process of its own, in ``cwd``, rendering offscreen.

    ``timeout`` bounds a hang only.
    """
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run(
        [sys.executable, "-m", "mearm", *map(str, args)],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout, check=False,
    )  # fmt: skip


def mearm_here(*args: object, cwd: Path) -> subprocess.CompletedProcess[str]:
    """:func:`mearm_cli` in this process, in ``cwd`` (``main`` under the guard every command
    shares, without an interpreter's start): for a test not about the process itself."""
    from badinput import run_in_process  # noqa: PLC0415

    out = run_in_process(args, within_s=30, cwd=cwd)
    return subprocess.CompletedProcess(["mearm", *map(str, args)], out.code, out.stdout, out.stderr)


def run_main(
    capsys: pytest.CaptureFixture[str], main: Callable[..., int], *args: object
) -> tuple[int, str, str]:
    """``main(ARGS)`` in this process as the ``mearm`` command runs it (:func:`mearm.cli.run`:
    its exit statuses and error lines): exit code, stdout, stderr."""
    from mearm.cli import run  # noqa: PLC0415

    with pytest.raises(SystemExit) as info:
        run(main, [str(a) for a in args])
    out, err = capsys.readouterr()
    return int(info.value.code), out, err


def one_stderr_line(proc: subprocess.CompletedProcess[str], code: int) -> str:
    """The one line ``proc`` said on stderr, once it is checked that it exited ``code``,
    said exactly one line and printed no traceback."""
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == code and len(lines) == 1, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr + proc.stdout
    return lines[0]


def processes_under(folder: Path) -> list[int]:
    """The processes whose command line names ``folder``: a browser and its helpers a
    test started with its profile there, still running or not."""
    out = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if str(folder).encode() in cmdline:
            out.append(int(entry.name))
    return out


def record_by_hand(root: Path, *, episodes: int = 2, frames: int = 40, **options: Any) -> Path:
    """A small dataset at ``root``: ``episodes`` of ``frames`` moves each on the kinematic
    rig of configs/sim.yaml, the jaws closing halfway; ``options`` go to the recorder
    (``codec``, ``resume``, ``scene``)."""
    import numpy as np  # noqa: PLC0415  (the dataset tests only)

    from mearm.dataset.recorder import DatasetRecorder  # noqa: PLC0415
    from mearm.hardware.command import ArmCommand  # noqa: PLC0415
    from mearm.task import open_rig  # noqa: PLC0415

    config = load_config(ROOT / "configs" / "sim.yaml")
    recorder = DatasetRecorder(root, config, fps=10, **options)
    home = ArmCommand.home(config.arm)
    with open_rig(config, []) as rig, rig.bus:
        recorder.attach(rig.bus, rig.camera)
        for episode in range(episodes):
            recorder.begin("red")
            for k in range(frames):
                joints = {n: v + np.sin(k / 10 + episode) for n, v in home.joints.items()}
                rig.bus.move(ArmCommand(joints, home.tool, k > frames // 2))
            recorder.end()
        recorder.close()
    return root


#: The start of every skip reason for a system tool that is not installed; the summary
#: gathers them (pytest_terminal_summary) and `make system-deps` installs them all.
MISSING = "needs a system tool: "


def interrupted_experiment(args: list[object], log: Path, after: int = 2) -> tuple[int, str]:
    """``mearm experiment ARGS`` in a session of its own, Ctrl-C to its whole process group
    (its workers too, as a terminal sends it) once ``after`` trials are in ``log``:
    (exit status, stderr). Bounded by generous timeouts: a hang is the failure."""
    cmd = [sys.executable, "-m", "mearm", "experiment", *map(str, args)]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if log.exists() and log.read_bytes().count(b'"type":"summary"') >= after:
            break
        time.sleep(0.01)
    _, err = interrupted(proc)
    return proc.returncode, err.decode(errors="replace")


def interrupted(proc: subprocess.Popen, timeout: float = 120) -> tuple[bytes, bytes]:
    """Ctrl-C to the process group of ``proc`` (started in a session of its own), and its
    output once it has ended. A run still going ``timeout`` s later has lost the signal,
    the test's failure: its group is killed first, so that it does not run on beside the
    rest of the suite (a lost Ctrl-C once left a 10,000-trial experiment on a core)."""
    os.killpg(proc.pid, signal.SIGINT)
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise


@contextlib.contextmanager
def tmpfs(path: Path, size: str) -> Iterator[Path]:
    """A tmpfs of ``size`` at ``path``, unmounted afterwards; skip where none can be made."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("a full disk is a small tmpfs: mounting one needs root")
    path.mkdir(parents=True, exist_ok=True)
    made = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if made.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {made.stderr.strip()}")
    try:
        yield path
    finally:
        if subprocess.run(["umount", str(path)], check=False).returncode != 0:
            subprocess.run(["umount", "-l", str(path)], check=False)


def missing_tool(what: str) -> NoReturn:
    """Skip a test for a missing system tool (``what``: which, and where it comes from);
    in CI (``MEARM_REQUIRE_TOOLS=1``) the test fails instead."""
    if os.environ.get("MEARM_REQUIRE_TOOLS") == "1":
        pytest.fail(f"{what} is not installed, and MEARM_REQUIRE_TOOLS=1 says it must be")
    pytest.skip(MISSING + what)


def require_tool(*names: str) -> str:
    """Path of the first tool found; skip (or fail in CI, MEARM_REQUIRE_TOOLS=1) if none."""
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    missing_tool(" or ".join(names))


def require_file(path: Path, package: str) -> None:
    """Skip (or fail in CI) unless ``path``, which Debian's ``package`` installs, exists."""
    if not Path(path).is_file():
        missing_tool(f"{package} ({path} missing)")


def browser_or_skip() -> str:
    """The headless browser the view tests drive; skip (or fail in CI) without one."""
    from mearm.exceptions import BrowserNotFoundError
    from mearm.view import find_browser

    try:
        return find_browser()
    except BrowserNotFoundError as exc:
        missing_tool(f"chromium ({exc})")


def pytest_configure(config: pytest.Config) -> None:
    """Before xdist starts its workers, the controller does once what each of them would
    do at its start in a fresh clone: rewrite the test modules' asserts
    (:func:`rewrite_test_modules_once`) and compile the package's bytecode (each worker
    imports most of it to collect; 0.6 s of CPU, on a warm tree a look at each header).

    A suite started in the background by a shell (``nohup make test &``) inherits Ctrl-C
    ignored, and so would every program it starts: the Ctrl-C tests would see the signal
    lost for a reason outside the code. Python's own handler is put back here, before the
    workers start, so each program under test starts with Ctrl-C as a terminal gives it.
    """
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if not hasattr(config, "workerinput") and config.getoption("numprocesses", None):
        # pytest's internals: whatever another release does to them, the workers rewrite
        with contextlib.suppress(Exception):
            rewrite_test_modules_once(config)
        if not sys.dont_write_bytecode:
            import compileall

            compileall.compile_dir(ROOT / "mearm", quiet=1)


def rewrite_test_modules_once(config: pytest.Config) -> None:
    """Write pytest's rewritten bytecode of every test module that lacks it, in this process.

    Each xdist worker imports every test module to collect it, and pytest rewrites a
    module's asserts (parse, rewrite, compile) unless its cache holds them for the same
    source. In a fresh clone the workers start together, find no cache and each rewrite
    all of them (a worker's collection took 7-9 s of CPU, 3.5 s with the cache), three
    times in ``make test``. Done here first, the workers find the cache; on a warm tree
    this only reads each module's header.
    The cache is pytest's own (an internal API, behind a fallback: if it has changed,
    the workers rewrite as before).
    """
    import importlib.util

    try:
        from _pytest.assertion.rewrite import (
            PYC_TAIL,
            _rewrite_test,
            _write_pyc,
            assertstate_key,
            get_cache_dir,
            try_makedirs,
        )

        state = config.stash[assertstate_key]
    except (ImportError, KeyError):  # another pytest, or --assert=plain
        return
    if sys.dont_write_bytecode:
        return
    stale = []
    for fn in _test_modules_named(config):
        pyc = get_cache_dir(fn) / (fn.name[:-3] + PYC_TAIL)
        source = fn.read_bytes()
        with contextlib.suppress(OSError), pyc.open("rb") as f:
            # a checked-hash pyc (PEP 552): magic, flags 3, the source's hash
            header = importlib.util.MAGIC_NUMBER + b"\x03\x00\x00\x00"
            if f.read(16) == header + importlib.util.source_hash(source)[:8]:
                continue
        stale.append((fn, pyc))

    def rewrite(fn: Path, pyc: Path) -> None:
        if try_makedirs(pyc.parent):
            try:
                source_hash, code = _rewrite_test(fn, config)
            except SyntaxError:
                return  # the workers report it, as a collection error
            _write_pyc(state, code, source_hash, pyc)

    in_parts(stale, rewrite)


def in_parts(work: list[tuple[Path, Path]], do: Callable[[Path, Path], None]) -> None:
    """``do(*item)`` for each item of ``work``, shared by this process and one forked
    process per further core it may use.

    The controller does this before any worker starts: in a fresh clone, rewriting the
    ~160 test modules on one core took 5 s of the run's wall time while the other core
    waited. A forked process ends without a word; anything it left undone the workers
    do themselves as they collect.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    parts = min(cores, len(work) // 8) if hasattr(os, "fork") else 1
    children = []
    for k in range(1, parts):
        with warnings.catch_warnings():  # a newer Python warns of fork() beside threads
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:  # the child: its share, then out, whatever happened
            try:
                for item in work[k::parts]:
                    do(*item)
            finally:
                os._exit(0)
        children.append(pid)
    try:
        for item in work[0 : len(work) : max(parts, 1)]:
            do(*item)
    finally:
        for pid in children:
            os.waitpid(pid, 0)


def _test_modules_named(config: pytest.Config) -> list[Path]:
    """The test modules of this folder that the command line's paths name or hold."""
    here = Path(__file__).resolve().parent
    out: set[Path] = set()
    for arg in config.args:
        path = (config.invocation_params.dir / arg.split("::")[0]).resolve()
        if path.is_dir() and (path == here or here.is_relative_to(path)):
            out.update(here.glob("test_*.py"))
        elif path.parent == here and path.name.startswith("test_") and path.suffix == ".py":
            out.add(path)
    return sorted(out)


#: A test's rough cost by its marker [s] (unmarked: 0.01 s), to order the modules by.
MARKER_COST_S = {"slow": 8.0, "heavy": 1.0}


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Leave out the soak tests unless the ``-m`` expression names them (``make soak``);
    then order whole modules costliest first (:func:`costliest_modules_first`)."""
    if "soak" not in (config.getoption("markexpr", "") or ""):
        soak = [item for item in items if item.get_closest_marker("soak") is not None]
        if soak:
            config.hook.pytest_deselected(items=soak)
            items[:] = [item for item in items if item.get_closest_marker("soak") is None]
    costliest_modules_first(items)


def costliest_modules_first(items: list[pytest.Item]) -> None:
    """Sort ``items`` by their module's costliest test, then its summed cost (both by
    :data:`MARKER_COST_S`), costliest first, each module's tests together and in order.

    xdist's work stealing hands each worker a run of the collection and lets idle ones take
    the back half of a busy one's queue: with the long tests at the front they start early,
    and the run ends on short ones on every worker, not on one long test on one worker.
    """
    most: dict[Path, float] = {}
    cost: dict[Path, float] = {}
    first: dict[Path, int] = {}
    for i, item in enumerate(items):
        marker = next((m for m in MARKER_COST_S if item.get_closest_marker(m)), "")
        seconds = MARKER_COST_S.get(marker, 0.01)
        most[item.path] = max(most.get(item.path, 0.0), seconds)
        cost[item.path] = cost.get(item.path, 0.0) + seconds
        first.setdefault(item.path, i)
    items.sort(key=lambda item: (-most[item.path], -cost[item.path], first[item.path]))


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """What a full run needs that this machine lacks, how many bad-input promises the run
    checked and kept (tests/badinput.py), and with ``--cpu-top N`` where its CPU went."""
    needs: dict[str, int] = {}
    for report in terminalreporter.stats.get("skipped", []):
        reason = str(report.longrepr[2]) if isinstance(report.longrepr, tuple) else ""
        if MISSING in reason:
            what = reason.split(MISSING, 1)[1]
            needs[what] = needs.get(what, 0) + 1
    if needs:
        terminalreporter.write_sep("-", "not a full run", yellow=True)
        terminalreporter.write_line(
            f"{sum(needs.values())} tests skipped for system tools this machine lacks "
            "(`make system-deps` installs them on Debian, as root; README: Tests):"
        )
        for what, count in sorted(needs.items()):
            terminalreporter.write_line(f"  {count:4d}  {what}")
    kept = _bad_input_kept(terminalreporter.config)
    if kept["checks"]:
        terminalreporter.write_line(
            f"bad-input corpus: {kept['promises']} promises kept in {kept['checks']} checks "
            "(exit code, one stderr line, no traceback, time bound, files intact)"
        )
    _write_cpu_top(terminalreporter)


#: The bad-input counts the xdist workers reported, on the controller's config.
_WORKERS_KEPT = pytest.StashKey[dict[str, int]]()


def _bad_input_kept(config: pytest.Config) -> dict[str, int]:
    """The bad-input promises kept in this session: this process's (tests/badinput.py),
    plus those each xdist worker reported when it finished (:func:`pytest_testnodedown`)."""
    badinput = sys.modules.get("badinput")
    own = badinput.KEPT if badinput is not None else {}
    workers = config.stash.get(_WORKERS_KEPT, {})
    return {k: own.get(k, 0) + workers.get(k, 0) for k in ("checks", "promises")}


def pytest_sessionfinish(session: pytest.Session) -> None:
    """An xdist worker hands its bad-input counts and its CPU by test file to the controller
    (its workeroutput)."""
    workeroutput = getattr(session.config, "workeroutput", None)
    badinput = sys.modules.get("badinput")
    if workeroutput is not None and badinput is not None:
        workeroutput["bad_input_kept"] = dict(badinput.KEPT)
    if workeroutput is not None:
        workeroutput["cpu_by_file"] = session.config.stash.get(_CPU_BY_FILE, {})


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: object) -> None:
    """The xdist controller adds up the counts and the CPU each worker reported as it
    finished."""
    kept = getattr(node, "workeroutput", {}).get("bad_input_kept", {})
    total = node.config.stash.setdefault(_WORKERS_KEPT, {"checks": 0, "promises": 0})
    for k in total:
        total[k] += kept.get(k, 0)
    cpu = node.config.stash.setdefault(_CPU_BY_FILE, {})
    for path, row in getattr(node, "workeroutput", {}).get("cpu_by_file", {}).items():
        cpu[path] = [a + b for a, b in zip(cpu.get(path, [0.0, 0.0, 0]), row, strict=True)]


# ------------------------------------------------------------------- where the CPU goes

#: Per test file: CPU seconds in the test's process, CPU seconds of the child processes it
#: waited for, and the tests run (``--cpu-top``).
_CPU_BY_FILE = pytest.StashKey[dict[str, list[float]]]()


def pytest_addoption(parser: pytest.Parser) -> None:
    """``--cpu-top N``: where the suite's CPU went, by test file (``make test``: 15)."""
    parser.addoption(
        "--cpu-top",
        type=int,
        default=0,
        metavar="N",
        help="after the run, the N test files that used the most CPU: in the test's own "
        "process and in the child processes it waited for (0: none)",
    )


def _cpu_now() -> tuple[float, float]:
    """This process's CPU time and that of the child processes it waited for [s]."""
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time(), kids.ru_utime + kids.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Iterator[None]:
    """With ``--cpu-top``: add the test's CPU (setup, call and teardown) to its file's.

    On 2 cores the suite's wall time follows its CPU, not each test's wall time (a test
    that waits for a board or a signal leaves the cores to the other workers), so this is
    the measure to cut by (the ``make test`` line of issue 41: at most 4 minutes).
    """
    if not item.config.getoption("cpu_top"):
        yield
        return
    before = _cpu_now()
    yield
    after = _cpu_now()
    row = item.config.stash.setdefault(_CPU_BY_FILE, {}).setdefault(item.location[0], [0.0, 0.0, 0])
    row[0] += after[0] - before[0]
    row[1] += after[1] - before[1]
    row[2] += 1


def _write_cpu_top(terminalreporter: pytest.TerminalReporter) -> None:
    """The ``--cpu-top`` table: the files that used the most CPU, and the run's total."""
    top = terminalreporter.config.getoption("cpu_top")
    cpu = terminalreporter.config.stash.get(_CPU_BY_FILE, {})
    if not top or not cpu:
        return
    own = sum(row[0] for row in cpu.values())
    kids = sum(row[1] for row in cpu.values())
    terminalreporter.write_sep("=", f"CPU by test file, the {min(top, len(cpu))} that used most")
    terminalreporter.write_line(
        f"{own + kids:.1f} s of CPU in {sum(int(row[2]) for row in cpu.values())} tests: "
        f"{own:.1f} s in the tests' processes, {kids:.1f} s in the child processes they "
        "waited for (collection and xdist's own work not counted)"
    )
    ranked = sorted(cpu.items(), key=lambda kv: -(kv[1][0] + kv[1][1]))[:top]
    for path, (mine, theirs, count) in ranked:
        terminalreporter.write_line(
            f"{mine + theirs:7.1f} s  ({mine:6.1f} + {theirs:5.1f} in children)  "
            f"{int(count):4d} tests  {path}"
        )


# --------------------------------------------------------------------------- the firmware

#: The firmware's sources (its Makefile builds the sketch and the simavr runner).
ARDUINO = ROOT / "tools" / "arduino"
#: Debian's Arduino core (arduino-core-avr) and simavr's headers (libsimavr-dev).
CORE_H = Path("/usr/share/arduino/hardware/arduino/avr/cores/arduino/Arduino.h")
SIMAVR_H = Path("/usr/include/simavr/sim_avr.h")


def _make_once(factory: pytest.TempPathFactory, name: str, *targets: str) -> Path:
    """``make TARGETS`` of the firmware into a folder built once per test run and shared by
    the workers (read only: a test that builds into a folder makes its own)."""
    from built_once import built_once

    def build(folder: Path) -> None:
        result = subprocess.run(
            ["make", "-C", str(ARDUINO), f"BUILD_DIR={folder}", *targets],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]

    return built_once(factory, name, build)


def firmware_build(factory: pytest.TempPathFactory) -> Path:
    """The sketch built from the checkout (``mearm_servo.elf`` and ``.hex``): the folder."""
    require_tool("make")
    require_tool("avr-gcc")
    require_file(CORE_H, "arduino-core-avr")
    return _make_once(factory, "firmware", "all")


def simulator_build(factory: pytest.TempPathFactory) -> Path:
    """The sketch and its simavr runner (``mearm_sim``) built from the checkout: the folder."""
    firmware_build(factory)  # the same requirements first, then the runner's
    require_tool("cc", "gcc")
    require_file(SIMAVR_H, "libsimavr-dev")
    return _make_once(factory, "firmware-sim", "all", "sim")
