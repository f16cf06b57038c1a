"""urdf, analyze and preview: an existing output is replaced only with --force, never an
input, never a shipped reference URDF with another arm's; the regeneration the docs give
(``python tools/dh_to_urdf.py``) keeps working.

The reference-URDF cases run ``mearm urdf`` in a copy of the checkout (its own
``robot_description/``), so a regression cannot damage this one; a copy whose configs are
a real folder, not a link, is an installed wheel (:func:`mearm.data.source_checkout`).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from badinput import check_bad_input, run_in_process
from conftest import ROOT, browser_or_skip

from mearm.analysis.synthetic import write_synthetic_log

ENV = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
PRECIOUS = "precious\n"


def _precious(path: Path) -> Path:
    path.write_text(PRECIOUS)
    return path


def _one_line(stderr: str) -> str:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


# --------------------------------------------------------------------------- copies


def _copy_package(dest: Path, *, wheel: bool) -> Path:
    """``dest/mearm`` (and for a checkout ``configs/``, ``robot_description/``, the script)."""
    shutil.copytree(ROOT / "mearm", dest / "mearm", symlinks=True,
                    ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    for name in ("configs", "robot_description"):
        if wheel:  # the wheel's copies, inside the package
            link = dest / "mearm" / "data" / name
            link.unlink()
            shutil.copytree(ROOT / name, link)
        else:  # the checkout's folders, which the package's links lead to
            shutil.copytree(ROOT / name, dest / name)
    if not wheel:
        (dest / "tools").mkdir()
        shutil.copy2(ROOT / "tools" / "dh_to_urdf.py", dest / "tools")
    return dest


@pytest.fixture(scope="module")
def checkout(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _copy_package(tmp_path_factory.mktemp("checkout"), wheel=False)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _copy_package(tmp_path_factory.mktemp("wheel"), wheel=True)


def _run(root: Path, *args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """``python ARGS`` with the package at ``root`` first on the path (not this checkout's)."""
    env = {**ENV, "PYTHONPATH": str(root)}
    return subprocess.run(
        [sys.executable, *map(str, args)], capture_output=True, text=True, env=env,
        cwd=cwd or root, timeout=120,
    )  # fmt: skip


def _urdf(root: Path, *args: object, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return _run(root, "-m", "mearm", "urdf", *args, cwd=cwd)


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


# --------------------------------------------------------------------------- urdf


def test_urdf_replaces_an_existing_output_only_with_force(tmp_path: Path) -> None:
    keep = _precious(tmp_path / "keep.urdf")
    out = check_bad_input(["urdf", "--config", "sim", "--output", keep], keep=[tmp_path])
    assert out.line.endswith(f"--output {keep}: exists; pass --force to replace it")
    r = run_in_process(["urdf", "--config", "sim", "--output", keep, "--force"])
    assert r.code == 0, r.stderr
    assert '<robot name="mearm_paper"' in keep.read_text()


@pytest.mark.parametrize(
    ("output", "said"),
    [
        ("", "argument --output: the value is empty: give the path of a .urdf file"),
        ("{tmp}/arm.png", "arm.png: a URDF file's name ends in .urdf (got .png)"),
        ("{tmp}/arm", "arm: a URDF file's name ends in .urdf (got no suffix)"),
        ("{tmp}/arm2.yaml", "arm2.yaml: a URDF file's name ends in .urdf (got .yaml)"),
        ("{tmp}/own.urdf", "own.urdf: is the --config file"),
        ("{tmp}/base.urdf", "base.urdf: is the extends file"),
    ],
)
def test_urdf_refuses_an_output_that_is_no_urdf_or_an_input(
    tmp_path: Path, output: str, said: str
) -> None:
    """Even with --force: the config (by name or link), what it extends, a .png, ''."""
    shutil.copy2(ROOT / "configs" / "sim.yaml", tmp_path / "base.urdf")
    (tmp_path / "arm2.yaml").write_text("extends: base.urdf\n")
    (tmp_path / "own.urdf").symlink_to(tmp_path / "arm2.yaml")
    argv = ["urdf", "--config", tmp_path / "arm2.yaml", "--output", output.format(tmp=tmp_path)]
    out = check_bad_input([*argv, "--force"], keep=[tmp_path])
    assert said in out.line
    assert " . " not in out.line  # '' was shown as the current folder


@pytest.mark.heavy
def test_urdf_never_replaces_a_reference_urdf_with_another_arms(checkout: Path) -> None:
    """By its own path or a link, with --force or not; the default output neither."""
    folder = checkout / "robot_description"
    before = _snapshot(folder)
    link = checkout / "mine.urdf"
    link.symlink_to(folder / "mearm_v1.urdf")
    for output in (folder / "mearm_v1.urdf", link):
        r = _urdf(checkout, "--config", "sim", "--set", "arm.name=mearm_v1", "--output", output,
                  "--force")  # fmt: skip
        assert r.returncode == 2, r.stderr
        line = _one_line(r.stderr)
        assert "is the URDF of the reference arm 'mearm_v1'" in line and "write elsewhere" in line
    changed = ["--config", "sim_mearm_v1", "--set", "arm.joints.shoulder.limits.max=120"]
    r = _urdf(checkout, *changed, "--force")
    assert r.returncode == 2 and "this config changes that arm" in _one_line(r.stderr)
    assert _snapshot(folder) == before
    # its own URDF again (the same text) is no replacement: no --force needed
    r = _urdf(checkout, "--config", "sim_mearm_v1", "--output", link)
    assert r.returncode == 0, r.stderr
    assert _snapshot(folder) == before


@pytest.mark.heavy
def test_the_documented_regeneration_works_on_a_fresh_clone(checkout: Path) -> None:
    """``python tools/dh_to_urdf.py`` (the README's) and ``make urdf``'s command rewrite
    the reference URDFs as the generator writes them now, with no --force: a stale one is
    brought up to date, the others stay as they were."""
    folder = checkout / "robot_description"
    expected = {p.name: p.read_bytes() for p in (ROOT / "robot_description").glob("*.urdf")}
    (folder / "mearm_v1.urdf").write_text("<robot name='stale'/>\n")
    r = _run(checkout, "tools/dh_to_urdf.py")
    assert r.returncode == 0, r.stderr
    assert _snapshot(folder) == expected
    r = _run(checkout, "tools/dh_to_urdf.py", "--config", "configs/lab.yaml")
    assert r.returncode == 0, r.stderr
    assert _snapshot(folder) == expected


@pytest.mark.heavy
def test_a_second_arm_under_the_same_name_needs_force(checkout: Path) -> None:
    """The default output robot_description/my_arm.urdf: written once, then kept."""
    mine = checkout / "robot_description" / "my_arm.urdf"
    try:
        r = _urdf(checkout, "--config", "sim", "--set", "arm.name=my_arm")
        assert r.returncode == 0, r.stderr
        first = mine.read_text()
        r = _urdf(checkout, "--config", "sim_5dof", "--set", "arm.name=my_arm")
        assert r.returncode == 2
        assert _one_line(r.stderr).endswith(f"{mine}: exists; pass --force to replace it")
        assert mine.read_text() == first
        r = _urdf(checkout, "--config", "sim_5dof", "--set", "arm.name=my_arm", "--force")
        assert r.returncode == 0, r.stderr
        assert mine.read_text() != first
    finally:
        mine.unlink(missing_ok=True)


@pytest.mark.heavy
def test_an_installed_urdf_needs_output(wheel: Path, tmp_path: Path) -> None:
    """No checkout: nothing is written into the package (site-packages); --output works."""
    shipped = wheel / "mearm" / "data" / "robot_description"
    before = _snapshot(shipped)
    for args in ([], ["--config", "sim"], ["--set", "arm.name=mine"]):
        r = _urdf(wheel, *args, cwd=tmp_path)
        assert r.returncode == 2, r.stderr
        line = _one_line(r.stderr)
        assert "no source checkout" in line and "give" in line and "--output FILE" in line
    assert _snapshot(shipped) == before and not list(tmp_path.iterdir())
    r = _urdf(wheel, "--config", "sim", "--output", "arm.urdf", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "arm.urdf").read_bytes() == before["mearm_paper.urdf"]


@pytest.mark.heavy
def test_the_script_without_mearm_installed_says_so_in_one_line(tmp_path: Path) -> None:
    """A Python that has no mearm (``python3 tools/dh_to_urdf.py`` outside the venv)."""
    r = subprocess.run(
        [sys.executable, "-I", "-S", str(ROOT / "tools" / "dh_to_urdf.py")],
        capture_output=True, text=True, cwd=tmp_path, timeout=60,
    )  # fmt: skip
    assert r.returncode == 2
    line = _one_line(r.stderr)
    assert "is not installed: use .venv/bin/python" in line


# --------------------------------------------------------------------------- analyze


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("analyze") / "run.jsonl"
    write_synthetic_log(path, n_routes=24, seed=1)
    return path


@pytest.mark.parametrize(
    ("argv", "there"),
    [
        (["{log}"], "report.md"),
        (["{log}"], "joint_angles.png"),
        (["--gains", "--kp", "0.5", "--kd", "0"], "gains_kd.png"),
    ],
)
def test_analyze_refuses_to_replace_what_out_holds(
    log: Path, tmp_path: Path, argv: list[str], there: str
) -> None:
    """Before any work: the folder as it was (no plot written beside the kept file)."""
    _precious(tmp_path / there)
    argv = ["analyze", *(a.format(log=log) for a in argv), "--out", tmp_path]
    out = check_bad_input(argv, keep=[tmp_path], within_s=15)
    assert out.line.endswith(f"--out {tmp_path / there}: exists; pass --force to replace it")
    assert [p.name for p in tmp_path.iterdir()] == [there]


@pytest.mark.heavy
def test_analyze_force_replaces_but_never_the_log(log: Path, tmp_path: Path) -> None:
    """--force replaces the notes; a report.md that is the log (a link) is refused even so."""
    notes = _precious(tmp_path / "report.md")
    r = run_in_process(["analyze", log, "--out", tmp_path, "--force"], within_s=30)
    assert r.code == 0, r.stderr
    assert "Table 8" in notes.read_text()
    out_dir = tmp_path / "linked"
    out_dir.mkdir()
    (out_dir / "report.md").symlink_to(log)
    kept = log.read_bytes()
    out = check_bad_input(["analyze", log, "--out", out_dir, "--force"], keep=[log, out_dir])
    assert "report.md: is the run log file" in out.line
    assert log.read_bytes() == kept


# --------------------------------------------------------------------------- preview


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--screenshot", "{png}"], "--screenshot {png}: exists; pass --force to replace it"),
        (["--screenshot", "{png}", "--joints", "base=90,base=100"], "names 'base' twice"),
        (["--screenshot", ""], "argument --screenshot: the value is empty"),
        (["--config", "{png}", "--screenshot", "{png}", "--force"], "is the --config file"),
    ],
)
def test_preview_refuses_before_serving(tmp_path: Path, argv: list[str], said: str) -> None:
    png = tmp_path / "p.png"
    shutil.copy2(ROOT / "configs" / "sim.yaml", png)  # a config too, for the last case
    out = check_bad_input(["preview", *(a.format(png=png) for a in argv)], keep=[tmp_path])
    assert said.format(png=png) in out.line


@pytest.mark.heavy
def test_preview_force_replaces_the_screenshot(tmp_path: Path) -> None:
    browser_or_skip()
    png = _precious(tmp_path / "p.png")
    r = run_in_process(["preview", "--screenshot", png, "--force", "--port", "0"], within_s=12)
    assert r.code == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.heavy
def test_a_write_error_names_the_target_not_its_temporary_file() -> None:
    """/proc takes no new file: the reason is said for the path given, not '.x.png.*.tmp'."""
    browser_or_skip()
    line = check_bad_input(["preview", "--screenshot", "/proc/x.png", "--port", "0"]).line
    assert "/proc/x.png: cannot write: " in line and ".tmp" not in line
    out = check_bad_input(["urdf", "--config", "sim", "--output", "/proc/x.urdf"])
    assert "/proc/x.urdf" in out.line and ".tmp" not in out.line
