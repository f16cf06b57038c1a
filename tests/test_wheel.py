"""The wheel is the whole product: built, installed outside the checkout, it sorts and plots.

The wheel is built from a copy of what the build reads (pyproject.toml, README.md, mearm/
and the top-level data folders its links point to) and installed into a fresh virtual
environment in a temporary folder, without system site-packages. So that the test takes
seconds and needs no network, that environment sees the dependencies of this one through
a ``.pth`` file naming a *view* of this environment's site-packages: a folder of links to
every entry except mearm's own (its editable finder and metadata). pip then installs
``mearm[analysis]`` from the wheel with ``--no-index``: it must find every dependency
already there (else it fails), and the only mearm it can import is the wheel's. Every
command runs with its working folder outside the checkout.

Skipped when ``MEARM_SKIP_WHEEL=1`` (and not in CI: there it always runs).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from built_once import built_once
from conftest import ROOT

from mearm.__main__ import SUBCOMMANDS

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(
        os.environ.get("MEARM_SKIP_WHEEL") == "1" and os.environ.get("CI") != "true",
        reason="MEARM_SKIP_WHEEL=1: the wheel is not built (CI always builds it)",
    ),
]

#: What the build reads: the package (with its data links) and the folders they point to.
BUILD_INPUTS = ("pyproject.toml", "README.md", "mearm", "configs", "robot_description", "docs")
FIRMWARE = Path("tools") / "arduino"
#: Left out of the copy: caches and build outputs.
IGNORED = shutil.ignore_patterns("__pycache__", "*.pyc", "build", "*.egg-info")


@dataclass(frozen=True)
class Installed:
    """The fresh environment with the wheel installed."""

    python: Path
    mearm: Path
    wheel: Path
    work: Path
    """A folder outside the checkout to run the commands in."""
    seconds: dict[str, float]


#: Left out of the commands' environment. ``PYTHONPYCACHEPREFIX`` (``make soak`` keeps its
#: bytecode under .venv; a user may set it) would key the bytecode of the installed package and of
#: its dependencies (reached through ``deps/``, links into the test environment) by this
#: run's temporary paths: every run compiled all of them again, about 6 s of CPU, and left
#: about 45 MB of bytecode behind under .venv. Without it the dependencies' own
#: ``__pycache__`` is found through the links, and the wheel's is written into its venv.
_NOT_PASSED = ("PYTHONPATH", "PYTHONHOME", "PYTHONPYCACHEPREFIX")


def _run(cmd: list[str | Path], cwd: Path, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in _NOT_PASSED}
    env["PIP_DISABLE_PIP_VERSION_CHECK"] = "1"
    return subprocess.run(
        [str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
    )


def _copy_sources(dest: Path) -> None:
    for name in BUILD_INPUTS:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dest / name, symlinks=True, ignore=IGNORED)
        else:
            shutil.copy2(src, dest / name)
    shutil.copytree(ROOT / FIRMWARE, dest / FIRMWARE, ignore=IGNORED)


def _site_view(dest: Path) -> Path:
    """Links to every entry of this environment's site-packages but mearm's own."""
    dest.mkdir()
    purelib = Path(sysconfig.get_paths()["purelib"])
    for entry in purelib.iterdir():
        if "mearm" in entry.name.lower():  # the editable finder, its .pth, the dist-info
            continue
        (dest / entry.name).symlink_to(entry)
    return dest


def _build_and_install(base: Path) -> None:
    """Build the wheel from a copy of the sources and install it into ``base / "venv"``;
    the build's and the install's seconds go to ``base / "seconds.json"``."""
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    src = base / "src"
    src.mkdir()
    _copy_sources(src)
    dist = base / "dist"
    r = _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", dist, src],
        cwd=base,
        timeout=300,
    )
    assert r.returncode == 0, r.stderr
    (wheel,) = dist.glob("mearm-*.whl")
    seconds["build"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    venv = base / "venv"
    r = _run([sys.executable, "-m", "venv", "--without-pip", venv], cwd=base)
    assert r.returncode == 0, r.stderr
    python = venv / "bin" / "python"
    site = Path(
        _run(
            [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"], base
        ).stdout.strip()
    )
    view = _site_view(base / "deps")
    (site / "00-deps-of-the-test-environment.pth").write_text(f"{view}\n")
    for pth in view.glob("*.pth"):  # e.g. cmeel's, which puts Pinocchio on the path
        shutil.copy2(pth, site / pth.name)
    r = _run(
        [sys.executable, "-m", "pip", "--python", python, "install", "--no-index",
         f"{wheel}[analysis]"],
        cwd=base,
        timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stdout + r.stderr
    seconds["install"] = time.perf_counter() - t0
    (base / "seconds.json").write_text(json.dumps(seconds))


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Installed:
    """The wheel, installed once per test run; each worker runs it in its own folder."""
    base = built_once(tmp_path_factory, "wheel", _build_and_install)
    (wheel,) = (base / "dist").glob("mearm-*.whl")
    venv = base / "venv"
    seconds = json.loads((base / "seconds.json").read_text())
    work = tmp_path_factory.mktemp("wheel-work")
    return Installed(venv / "bin" / "python", venv / "bin" / "mearm", wheel, work, seconds)


def test_the_wheel_ships_the_data(installed: Installed) -> None:
    """The wheel holds every config, reference arm, calibration file, URDF and the firmware."""
    import zipfile

    names = set(zipfile.ZipFile(installed.wheel).namelist())
    for folder, pattern in (
        ("configs", "*.yaml"),
        ("configs/arms", "*.yaml"),
        ("configs/calibration", "*.yaml"),
        ("robot_description", "*.urdf"),
    ):
        for path in (ROOT / folder).glob(pattern):
            assert f"mearm/data/{folder}/{path.name}" in names, path
    for path in (ROOT / FIRMWARE).rglob("*"):
        if path.is_file() and "build" not in path.parts and path.name != ".gitignore":
            rel = path.relative_to(ROOT / FIRMWARE).as_posix()
            assert f"mearm/data/firmware/{rel}" in names, path
    for path in (ROOT / "docs").glob("*.md"):
        assert f"mearm/data/docs/{path.name}" in names, path
    assert "mearm/py.typed" in names
    assert not any(n.startswith(("tests/", "tools/", "configs/")) for n in names)


def test_the_package_is_the_wheels(installed: Installed) -> None:
    """Inside the fresh environment mearm is imported from the wheel, not the checkout."""
    r = _run(
        [installed.python, "-c",
         "import mearm, mearm.data as d; print(mearm.__file__); "
         "print(d.CONFIGS_DIR.is_symlink(), d.source_checkout())"],
        cwd=installed.work,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    where, links = r.stdout.splitlines()
    assert Path(where).is_relative_to(installed.python.parent.parent), where
    assert not Path(where).is_relative_to(ROOT)
    assert links == "False None"


def test_sort_by_config_name_from_the_wheel(installed: Installed) -> None:
    """``mearm sort --config sim`` sorts 12 of 12 with exit 0 from a folder outside."""
    t0 = time.perf_counter()
    r = _run([installed.mearm, "sort", "--config", "sim", "--log", "run.jsonl"], installed.work)
    installed.seconds["sort"] = time.perf_counter() - t0
    assert r.returncode == 0, r.stderr
    assert "sorted 12 of 12 objects" in r.stdout


def test_unknown_config_name_lists_the_shipped_ones(installed: Installed) -> None:
    r = _run([installed.mearm, "sort", "--config", "simm"], installed.work)
    assert r.returncode == 2
    line = r.stderr.strip()
    assert "\n" not in line and "no packaged config is named 'simm'" in line
    assert "sim, " in line and "lab" in line


def test_help_lists_every_subcommand(installed: Installed) -> None:
    r = _run([installed.mearm, "--help"], installed.work)
    assert r.returncode == 0
    for name in SUBCOMMANDS:
        assert f"\n  {name} " in r.stdout, name


def test_the_docs_the_commands_point_at_are_installed(installed: Installed) -> None:
    """``mearm --help`` and init-config's steps name the maker's path: from the wheel, the
    page the wheel installed (there is no docs/ folder beside a user's work)."""
    r = _run([installed.mearm, "--help"], installed.work)
    (line,) = [x for x in r.stdout.splitlines() if x.startswith("First time?")]
    page = Path(line.removesuffix(".").rsplit(" then ", 1)[1])
    assert page.is_absolute() and page.name == "maker-path.md", line
    assert page.is_relative_to(installed.python.parent.parent), page
    assert (ROOT / "docs" / "maker-path.md").read_text() == page.read_text()
    r = _run(
        [installed.mearm, "init-config", "--arm", "mearm_v1", "--rig", "uno", "docs_arm.yaml"],
        installed.work,
    )
    assert r.returncode == 0, r.stderr
    assert f"({page})" in r.stdout


#: Run inside the fresh environment: every subcommand's ``--help``, in one process.
HELP_OF_EVERY_SUBCOMMAND = """
import contextlib, io, sys
from mearm.__main__ import SUBCOMMANDS, _load
bad = []
for name, (target, _) in SUBCOMMANDS.items():
    sys.argv = [f"mearm {name}"]
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out):
            _load(target)(["--help"])
        bad.append(f"{name}: --help did not exit")
    except SystemExit as exc:
        if exc.code != 0 or not out.getvalue().startswith("usage: "):
            bad.append(f"{name}: exit {exc.code}, {out.getvalue()[:60]!r}")
print("; ".join(bad) or "ok")
"""


def test_every_subcommand_runs_from_the_wheel(installed: Installed) -> None:
    """``mearm X --help`` works for every X: each command module ships and imports."""
    r = _run([installed.python, "-c", HELP_OF_EVERY_SUBCOMMAND], installed.work)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "ok"


def test_urdf_of_a_packaged_config(installed: Installed) -> None:
    out = installed.work / "arm.urdf"
    r = _run([installed.mearm, "urdf", "--config", "sim_5dof", "--output", out], installed.work)
    assert r.returncode == 0, r.stderr
    assert out.read_text() == (ROOT / "robot_description" / "desk_5dof.urdf").read_text()


def test_analyze_writes_the_plots_with_the_extra(installed: Installed) -> None:
    """``mearm analyze LOG --out DIR`` with ``mearm[analysis]``: the plots are written."""
    log = installed.work / "run.jsonl"
    if not log.exists():
        r = _run([installed.mearm, "sort", "--config", "sim", "--log", log], installed.work)
        assert r.returncode == 0, r.stderr
    t0 = time.perf_counter()
    r = _run([installed.mearm, "analyze", log, "--out", "plots"], installed.work)
    installed.seconds["analyze"] = time.perf_counter() - t0
    assert r.returncode == 0, r.stderr
    pngs = sorted(p.name for p in (installed.work / "plots").glob("*.png"))
    assert pngs, "no plot written"
    for png in pngs:
        assert (installed.work / "plots" / png).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    print(f"wheel test timings [s]: {installed.seconds}", file=sys.stderr)
