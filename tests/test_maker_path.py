"""The maker's path for a MeArm v1, walked without hardware, each command as the page prints it.

docs/maker-path.md is read, not copied: the test takes the commands of its steps from the
page's code blocks and runs each in-process in a fresh folder. What needs hardware (the
port, the upload, the keyboard calibration, the camera) is left out; the camera's snapshot
is made here instead: the printed markers laid where the page says, seen by a camera whose
pixel → table map is the simulated MeArm v1's.
"""

from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

import cv2
import numpy as np
import pytest

from mearm.__main__ import SUBCOMMANDS, _load
from mearm.cli import run
from mearm.config import load_config
from mearm.vision.aruco import marker_image

ROOT = Path(__file__).resolve().parent.parent
PAGE = (ROOT / "docs" / "maker-path.md").read_text(encoding="utf-8")
#: Steps that need the board, a terminal or the camera: not run here.
NEEDS_HARDWARE = ("find-port", "calibrate-servos", "jog", "find-camera", "virtual")


def page_commands() -> list[str]:
    """The page's commands, in order: ``mearm …`` lines of its bash blocks, joined."""
    out = []
    for block in re.findall(r"^```bash\n(.*?)^```", PAGE, re.M | re.S):
        for line in re.sub(r"\\\n\s*", " ", block).splitlines():
            if line.startswith("mearm "):
                out.append(line)
    return out


def mearm(line: str) -> tuple[int, str]:
    """Run one ``mearm …`` line in this process: its exit status and what it printed."""
    words = shlex.split(line, comments=True)
    main = _load(SUBCOMMANDS[words[1]][0])
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as exc:
        run(main, words[2:])
    return int(exc.value.code or 0), out.getvalue()


def table_snapshot(path: Path, markers_cm: dict[int, tuple[float, float]], side_cm: float) -> None:
    """A 640×480 snapshot of a plain table with ``markers_cm`` lying on it, upright (+y up).

    The camera is the simulated MeArm v1's: its homography maps pixel (u, v) to
    table (0.0375 u − 12, 24 − 0.0375 v) cm.
    """
    H = np.array(load_config("sim_mearm_v1").calibration.homography)
    to_px = np.linalg.inv(H)
    frame = np.full((480, 640, 3), 200, np.uint8)
    for marker_id, (x, y) in markers_cm.items():
        margin_cm = side_cm / 4  # the white border the page says to cut the marker with
        m = side_cm / 2 + margin_cm
        corners_cm = np.array([[x - m, y + m], [x + m, y + m], [x + m, y - m], [x - m, y - m]])
        uvw = (to_px @ np.c_[corners_cm, np.ones(4)].T).T
        dst = (uvw[:, :2] / uvw[:, 2:]).astype(np.float32)
        n = 400
        face = np.full((n, n), 255, np.uint8)
        inner = round(n * side_cm / (side_cm + 2 * margin_cm))
        start = (n - inner) // 2
        face[start : start + inner, start : start + inner] = marker_image(marker_id, inner)
        src = np.array([[0, 0], [n, 0], [n, n], [0, n]], np.float32)
        warp = cv2.getPerspectiveTransform(src, dst)
        patch = cv2.warpPerspective(face, warp, (640, 480), flags=cv2.INTER_AREA, borderValue=0)
        mask = cv2.warpPerspective(np.full((n, n), 255, np.uint8), warp, (640, 480)) > 127
        frame[mask] = patch[mask, None]
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), frame)


def test_the_page_shows_every_step_of_the_path() -> None:
    """From the config to the first sort, each step a command on the page."""
    names = [shlex.split(c)[1] for c in page_commands()]
    for step in ("init-config", "find-port", "flash", "calibrate-servos", "jog", "find-camera",
                 "aruco-sheet", "calibrate-camera", "sort"):  # fmt: skip
        assert step in names, step
    assert names.index("find-port") < names.index("flash") < names.index("calibrate-servos")


@pytest.mark.heavy
def test_a_mearm_v1_walks_the_path_without_hardware(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every step that needs no hardware runs as printed and does what the page says."""
    monkeypatch.chdir(tmp_path)
    commands = [c for c in page_commands() if not any(f" {h}" in c for h in NEEDS_HARDWARE)]
    ran = []
    for line in commands:
        if "calibrate-camera" in line:
            markers = {
                int(i): (float(x), float(y))
                for i, x, y in re.findall(r"--marker (\d+):(-?[\d.]+),(-?[\d.]+)", line)
            }
            side_cm = float(re.search(r"--marker-side-cm ([\d.]+)", line).group(1))  # type: ignore[union-attr]
            image = re.search(r"--image (\S+)", line).group(1)  # type: ignore[union-attr]
            table_snapshot(tmp_path / image, markers, side_cm)
        if ("flash" in line and "--dry-run" not in line) or line.startswith(
            "mearm sort --config my_arm.yaml"
        ):
            continue  # the upload and the real sort need the board
        code, out = mearm(line)
        assert code == 0, f"`{line}` exited {code}: {out[-300:]}"
        ran.append((line, out))

    def printed(start: str) -> str:
        return next(out for line, out in ran if line.startswith(start))

    assert "sorted 6 of 6 objects" in printed("mearm sort --config sim_mearm_v1")
    assert (tmp_path / "sheet.png").is_file()
    fitted = np.array(load_config(tmp_path / "my_arm.yaml").calibration.homography)
    truth = np.array(load_config("sim_mearm_v1").calibration.homography)
    corners_px = np.array([[0, 0, 1], [639, 0, 1], [0, 479, 1], [639, 479, 1]]).T
    seen, real = fitted @ corners_px, truth @ corners_px
    assert np.abs(seen[:2] / seen[2] - real[:2] / real[2]).max() < 0.2  # cm, over the view
    assert "sorted 6 of 6 objects" in printed("mearm sort --config my_twin.yaml")
    assert "fitted" in printed("mearm calibrate-camera")
    # the one-off form of the page: the maker's own file on the simulated rig
    code, out = mearm(
        "mearm sort --config my_arm.yaml --set servo.backend=sim --set camera.kind=sim --quiet"
    )
    assert code == 0 and "sorted 6 of 6 objects" in out


def test_a_makers_typo_reads_in_their_words(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A near-miss key: the joint by name, the arm file in use, the key meant; exit 2."""
    monkeypatch.chdir(tmp_path)
    mearm("mearm init-config --arm mearm_v1 --rig uno my_arm.yaml")
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code, _ = mearm(
            "mearm fk --config my_arm.yaml --joints 90,90,-90 --set arm.joints.shoulder.dh.a_mc=8"
        )
    line = err.getvalue().strip()
    assert code == 2 and len(line.splitlines()) == 1
    assert "arm.joints.shoulder.dh.a_mc: unknown key; did you mean a_cm?" in line
    assert "configs/arms/mearm_v1.yaml shows every key" in line


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("extend: sim\n", "extend: unknown key; did you mean extends?"),
        ("arm:\n  uses: mearm_v1\n", "arm.uses: unknown key; did you mean use?"),
    ],
)
def test_a_typo_of_the_keys_that_compose_a_config_is_told_the_key(
    text: str, words: str, tmp_path: Path
) -> None:
    """``extends`` and ``arm.use`` are read away before the keys are checked: a typo of
    either got no suggestion (the file the message names does not show them)."""
    from mearm.config import load_config
    from mearm.errors import ConfigError

    path = tmp_path / "mine.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=words):
        load_config(path)


def test_a_config_that_drops_a_class_is_told_to_give_its_scene(tmp_path: Path) -> None:
    """A file extending sim with two of its three classes took sim's scene, blues and all:
    the error named task.scene.8, a scene the file never wrote, and no way out."""
    from mearm.config import load_config
    from mearm.errors import ConfigError

    path = tmp_path / "two.yaml"
    path.write_text(
        "extends: sim\ntask:\n  classes:\n"
        "    - {name: red, hue_bands_deg: [{lo_deg: 330, hi_deg: 15}], draw_rgb: [200, 30, 35],"
        " bin_cm: [-20, 35, 20]}\n"
        "    - {name: green, hue_bands_deg: [{lo_deg: 75, hi_deg: 165}], draw_rgb: [30, 160, 60],"
        " bin_cm: [-20, 45, 20]}\n"
    )
    with pytest.raises(ConfigError, match=r"gives its own task\.scene, or task\.scene: \[\]"):
        load_config(path)
    assert load_config(path, ["task.scene=[]"]).task.scene == []


def test_a_bad_value_names_the_joint_not_its_index() -> None:
    """Errors inside a list of named items say the item's name."""
    from mearm.errors import ConfigError

    with pytest.raises(ConfigError, match=r"arm\.joints\.elbow\.limits: min \(400\)"):
        load_config("sim_mearm_v1", ["arm.joints.elbow.limits.min=400"])
    with pytest.raises(ConfigError, match=r"task\.classes\.green\.hue_bandz: unknown key; did you"):
        load_config("sim", ["task.classes.green.hue_bandz=1"])


def test_lengths_in_millimetres_get_a_hint() -> None:
    """Links written in mm: a hint naming them, first; no reference arm sets it off."""
    from mearm.config.loader import millimetre_hint

    mm = load_config(
        "sim_mearm_v1", ["arm.joints.shoulder.dh.a_cm=80", "arm.joints.elbow.dh.a_cm=80"]
    )
    hint = millimetre_hint(mm.model_dump(mode="json"))
    assert hint is not None and "shoulder.dh.a_cm = 80" in hint and "look like mm" in hint
    for name in ("sim", "sim_mearm_v1", "sim_5dof", "lab"):
        assert millimetre_hint(load_config(name).model_dump(mode="json")) is None, name
