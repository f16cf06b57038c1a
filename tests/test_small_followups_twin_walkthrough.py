"""docs/calibration.md's "Try it on the twin", run from a folder of one's own.

The walkthrough once had the user copy the twin's config into the package's own
``configs/`` folder (a copy elsewhere does not load: its relative calibration paths are
looked for beside it). It now has them write a small config in their own folder,
``extends: sim_mujoco_perspective`` and the keys they change; here that file is taken
from the page, the page's commands are run beside it (one board view instead of 15, and
the shipped intrinsics in place of a fit to them), and what the page quotes is what they
print and write.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pytest
from badinput import ROOT, run_in_process

from mearm.config import load_config

PAGE = ROOT / "docs" / "calibration.md"


def _passage() -> str:
    text = PAGE.read_text(encoding="utf-8")
    start = text.index("## Try it on the twin")
    return text[start : text.index("\n## ", start + 1)]


def _walkthrough() -> str:
    """The passage's first shell block: the walkthrough's commands."""
    return re.search(r"^```sh\n(.*?)^```", _passage(), re.M | re.S).group(1)


def test_the_walkthrough_leaves_the_packages_configs_alone() -> None:
    """No command of the walkthrough names ``configs/``: the user's files go in their folder."""
    lines = [line for line in _walkthrough().splitlines() if not line.startswith("#")]
    assert not [line for line in lines if "configs/" in line]
    assert "mkdir my_twin && cd my_twin" in lines


@pytest.mark.heavy
def test_the_walkthroughs_own_config_works_from_its_own_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The page's config file, written in a folder outside the repository, is the twin's
    config; render-calibration prints what the page quotes; calibrate-camera leaves the
    file as the page shows it, pointed at the files beside it."""
    walk = _walkthrough()
    heredoc = re.search(r"^cat > (\S+) <<'EOF'\n(.*?)^EOF$", walk, re.M | re.S)
    assert heredoc, "the walkthrough writes no config file of its own"
    name, text = heredoc.groups()
    work = tmp_path / "my_twin"
    work.mkdir()
    (work / name).write_text(text, encoding="utf-8")
    monkeypatch.chdir(work)
    assert load_config(name) == load_config("sim_mujoco_perspective")

    render = next(line for line in walk.splitlines() if line.startswith("mearm render-"))
    res = run_in_process([*shlex.split(render)[1:], "--views", "1"], within_s=60)
    assert res.code == 0, res.stderr
    quoted = re.search(r"^#  (wrote .*)$", walk, re.M).group(1)
    assert res.stdout.strip() == quoted.replace("wrote 15 board views", "wrote 1 board views")

    shutil.copy(ROOT / "configs" / "calibration" / "twin_intrinsics.yaml", "intrinsics.yaml")
    markers = Path("calib/sheet_markers.txt").read_text(encoding="utf-8").split()
    res = run_in_process(
        ["calibrate-camera", "--intrinsics", "intrinsics.yaml", "--out", "pose.yaml",
         "--image", "calib/sheet.png", *markers, "--config", name],
        within_s=30,
    )  # fmt: skip
    assert res.code == 0, res.stderr
    shown = re.search(r"It now reads:\n\n```yaml\n(.*?)^```", _passage(), re.M | re.S)
    assert (work / name).read_text(encoding="utf-8") == shown.group(1)
    monkeypatch.chdir(tmp_path)  # the files are found beside the config, from anywhere
    calibration = load_config(work / name).calibration
    assert calibration.model == "perspective"
    assert Path(calibration.intrinsics_file) == work / "intrinsics.yaml"
    assert Path(calibration.extrinsics_file) == work / "pose.yaml"
