"""The sorting task end to end on the simulated rig, and its faults (SPEC §1)."""

import json
import signal
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest
import yaml
from conftest import ROOT, run_cli
from fakeboard import FakeMearmBoard, MearmFaults

from mearm.config import COLORS, SceneObject, config_from_dict
from mearm.exceptions import MearmError
from mearm.hardware import open_bus
from mearm.runlog import RunLog, read_runlog
from mearm.task import SortAborted, Sorter, open_rig, random_scene
from mearm.vision import SimCamera
from mearm.world import World


def _sort(config, scene, log=None):
    with open_rig(config, scene) as rig:
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, log=log, echo=None).run()
        return rig.world, report, rig.bus


def test_cli_sorts_the_paper_layout(tmp_path):
    """python -m mearm.sort on the sim rig: 12 objects in their bins, 24 routes logged."""
    log = tmp_path / "run.jsonl"
    r = run_cli("-m", "mearm.sort", "--config", "configs/sim.yaml", "--log", str(log))
    assert r.returncode == 0, r.stderr
    assert "red          4        0" in r.stdout and "blue         4        0" in r.stdout
    contents = read_runlog(log)
    assert contents.problem is None and contents.complete
    routes = contents.routes
    assert len(routes) == 24
    assert [r.step for r in routes] == ["pick", "place"] * 12
    assert all(r.success and r.status == "converged" for r in routes)
    # all red first, then green, then blue (SPEC §1)
    assert [r.color for r in routes[::2]] == ["red"] * 4 + ["green"] * 4 + ["blue"] * 4
    # each route starts where the last ended (no return home in between)
    for prev, nxt in zip(routes, routes[1:], strict=False):
        np.testing.assert_allclose(nxt.start_joints_deg, prev.end_joints_deg, atol=1e-9)
    summary = contents.trials[0].summary
    assert summary.sorted == {"red": 4, "green": 4, "blue": 4} and summary.ok


@pytest.mark.parametrize("seed", range(20))
def test_random_scenes_are_sorted(config, seed):
    """20 random scenes: every object ends in its colour's bin, or is reported with a reason."""
    n = 4 + seed % 9  # 4 to 12 objects
    scene = random_scene(config, n, seed=seed)
    world, report, _ = _sort(config, scene)
    left = [o for o in world.objects if o.bin != o.color]
    assert len(left) == len(report.skipped)
    assert all(reason for _, _, reason in report.skipped)
    assert sum(report.sorted_per_color().values()) == n - len(left)
    assert report.fault is None


def test_unreachable_and_outside_box_objects_are_skipped(tmp_path):
    """An object out of reach, and one outside Table 3's box, are reported; the rest sorted."""
    # an arm whose elbow cannot stretch past -85°, and a camera field reaching y = 64 cm
    config = config_from_dict(
        {
            "robot": {"joint_limits_deg": {"joint3": {"min": -160, "max": -85}}},
            "calibration": {"homography": [[0.0625, 0, -20.5], [0, -0.0625, 64.0], [0, 0, 1]]},
        }
    )
    scene = [
        SceneObject(color="red", x=-5.0, y=40.0),
        SceneObject(color="green", x=0.0, y=57.0),  # needs θ3 ≈ −80°: out of reach
        SceneObject(color="blue", x=5.0, y=62.0),  # y > 60: outside the target box
    ]
    with RunLog(tmp_path / "log.jsonl") as log:
        log.header(config)
        world, report, _ = _sort(config, scene, log)
    assert [o.bin for o in world.objects] == ["red", None, None]
    reasons = {color: reason for _, color, reason in report.skipped}
    assert "joint3" in reasons["green"] and "outside its limits" in reasons["green"]
    assert "y = 62 is outside the target box" in reasons["blue"]
    skips = read_runlog(tmp_path / "log.jsonl").trials[0].skips
    assert {s.color for s in skips} == {"green", "blue"}


def test_failed_pick_is_retried_then_skipped(config):
    """A pick that misses (a 2 cm joint offset) is retried pick_retries times, then skipped."""
    cfg = config.model_copy(
        update={
            "servo": config.servo.model_copy(
                update={
                    "error_model": config.servo.error_model.model_copy(
                        update={"offset_deg": (3.0, 0.0, 0.0)}
                    )
                }
            )
        }
    )
    world, report, _ = _sort(cfg, [SceneObject(color="red", x=0.0, y=45.0)])
    picks = [r for r in report.routes if r["step"] == "pick"]
    assert [r["attempt"] for r in picks] == [1, 2, 3]
    assert not any(r["success"] for r in picks)
    assert report.skipped == [("red1", "red", "pick failed 3 times")]
    assert world.objects[0].on_table


def test_touching_objects_are_reported_not_guessed(config):
    """Two touching reds form one region: reported as merged and left alone."""
    scene = [
        SceneObject(color="red", x=0.0, y=45.0),
        SceneObject(color="red", x=1.9, y=45.0),
        SceneObject(color="blue", x=-8.0, y=40.0),
    ]
    world, report, _ = _sort(config, scene)
    assert report.skipped and "touching" in report.skipped[0][2]
    assert [o.bin for o in world.objects] == [None, None, "blue"]


def test_camera_that_stops_delivering_frames(tmp_path, config):
    """The camera dies mid-run: the arm parks at home, the fault is logged, nothing lost."""
    world = World.from_config(config)
    sim = SimCamera(config, world)
    frames = tmp_path / "frames"
    frames.mkdir()
    for i in range(2):  # two frames, then nothing more
        cv2.imwrite(str(frames / f"{i}.png"), sim.read())
    cfg = config.model_copy(
        update={"camera": config.camera.model_copy(update={"kind": "folder", "path": str(frames)})}
    )
    log_path = tmp_path / "run.jsonl"
    with RunLog(log_path) as log, open_rig(cfg) as rig:
        log.header(cfg)
        with pytest.raises(SortAborted) as exc:
            Sorter(cfg, rig.camera, rig.bus, model=rig.model, log=log, echo=None).run()
        home = rig.bus.state.joints_deg
    assert "no more frames after 2" in exc.value.reason and "parked at home" in exc.value.reason
    np.testing.assert_allclose(home, config.robot.home_deg)
    trial = read_runlog(log_path).trials[0]
    assert len(trial.routes) >= 1 and trial.faults and not trial.summary.ok
    assert "no more frames" in trial.faults[0].reason


def test_servo_link_dropped_mid_route(tmp_path, config):
    """The cable is pulled mid-route: named reason, last acknowledged pose logged, no more sends."""
    with FakeMearmBoard(MearmFaults(drop_at_move=90)) as board:
        cfg = config_from_dict(
            {
                "servo": {
                    "backend": "serial",
                    "port": board.port,
                    "ack_timeout_s": 0.2,
                    "banner_timeout_s": 1.0,
                    "rate_hz": 1000.0,
                }
            }
        )
        world = World.from_config(cfg)
        log_path = tmp_path / "run.jsonl"
        with RunLog(log_path) as log, SimCamera(cfg, world) as camera:
            log.header(cfg)
            bus = open_bus(cfg)
            try:
                with pytest.raises(SortAborted) as exc:
                    Sorter(cfg, camera, bus, log=log, echo=None).run()
            finally:
                bus.close()
        moves = [line for line in board.received if line.split()[1:2] == [b"M"]]
    assert "nothing more sent to the servos" in exc.value.reason
    assert exc.value.last_joints_deg is not None
    trial = read_runlog(log_path).trials[0]
    assert trial.routes, "the route before the fault is in the log"
    fault = trial.faults[0]
    assert fault.last_joints_deg is not None and not trial.summary.ok
    assert len(moves) == 90  # the 90th move met the pulled cable; nothing sent after it


def test_ctrl_c_parks_and_keeps_the_log(tmp_path):
    """SIGINT mid-run: exit 130, one line on stderr, fault logged, arm parked at home."""
    cfg = tmp_path / "slow.yaml"
    cfg.write_text(yaml.safe_dump({"servo": {"sim_realtime": True, "rate_hz": 200.0}}))
    log = tmp_path / "run.jsonl"
    proc = subprocess.Popen(
        [sys.executable, "-m", "mearm.sort", "--config", str(cfg), "--log", str(log)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if log.exists() and '"type": "route"' in log.read_text().replace(
            '"type":"route"', '"type": "route"'
        ):
            break
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "interrupted (Ctrl-C); arm parked at home" in lines[0]
    assert "Traceback" not in err
    contents = read_runlog(log)
    assert contents.problem is None
    trial = contents.trials[0]
    assert trial.routes and "interrupted" in trial.faults[0].reason
    np.testing.assert_allclose(trial.faults[0].last_joints_deg, [120, 93, -132, 39], atol=1e-9)


def test_scene_file_and_random_flags(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: green, x: 0.0, y: 45.0}\n- {color: red, x: -6.0, y: 40.0}\n")
    r = run_cli("-m", "mearm.sort", "--scene", str(scene), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "red          1" in r.stdout and "green        1" in r.stdout
    r = run_cli(
        "-m",
        "mearm.sort",
        "--random",
        "3",
        "--seed",
        "4",
        "--quiet",
        "--log",
        str(tmp_path / "l.jsonl"),
    )
    assert r.returncode == 0, r.stderr
    header = json.loads((tmp_path / "l.jsonl").read_text().splitlines()[0])
    assert len(header["scene"]) == 3 and header["seed"] == 4


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--random", "-1"], "--random needs a number of objects ≥ 0"),
        (["--scene", "missing.yaml"], "scene file not found"),
        (["--config", "configs/lab.yaml", "--random", "3"], "camera is 'device', not 'sim'"),
        (["--random", "3", "--scene", "x.yaml"], "not allowed with argument"),
        (["--hold"], "--hold keeps the view open: use it with --view"),
    ],
)
def test_bad_input_exits_2_with_one_line(args, needle):
    r = run_cli("-m", "mearm.sort", *args)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_bad_scene_entry_named(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: purple, x: 0.0, y: 45.0}\n")
    r = run_cli("-m", "mearm.sort", "--scene", str(scene))
    assert r.returncode == 2 and "[0.color]" in r.stderr and "purple" in r.stderr


def test_random_scene_properties(config):
    """Random scenes: seeded, objects ≥ 1 cm apart edge to edge, reachable, in the field."""
    a = random_scene(config, {"red": 4, "green": 4, "blue": 4}, seed=7)
    assert a == random_scene(config, {"red": 4, "green": 4, "blue": 4}, seed=7)
    assert sorted(o.color for o in a) == sorted(["red", "green", "blue"] * 4)
    xy = np.array([[o.x, o.y] for o in a])
    d = np.linalg.norm(xy[:, None] - xy[None], axis=-1) + np.eye(len(a)) * 99
    assert d.min() >= 3.0 - 1e-9
    with pytest.raises(MearmError, match="could not place 400 objects"):
        random_scene(config, 400, seed=0, max_tries=2000)


def test_colour_order_from_config(config):
    cfg = config.model_copy(
        update={"task": config.task.model_copy(update={"color_order": ["blue", "red", "green"]})}
    )
    _, report, _ = _sort(cfg, None)
    picks = [r["color"] for r in report.routes if r["step"] == "pick"]
    assert picks == ["blue"] * 4 + ["red"] * 4 + ["green"] * 4
    assert set(COLORS) == set(picks)


def test_home_at_the_end(config):
    _, _, bus = _sort(config, [SceneObject(color="red", x=0.0, y=45.0)])
    assert bus.state.joints_deg == tuple(config.robot.home_deg)
    assert not bus.state.gripper_closed


def test_a_table_that_never_clears_is_reported(config):
    """After max_rounds pick attempts the rest is reported, not attempted forever."""
    scene = [SceneObject(color="red", x=-6.0 + 6 * i, y=45.0) for i in range(3)]
    with open_rig(config, scene) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None, max_rounds=1)
        report = sorter.run()
    assert len(report.sorted_per_color()) == 1 and report.sorted_per_color()["red"] == 1
    assert [r for _, _, r in report.skipped] == ["still on the table after 1 pick rounds"] * 2


def test_camera_that_cannot_open_is_logged(tmp_path):
    """No camera at all: exit 1 with one line, and the log says why the sort never started."""
    cfg = tmp_path / "nocam.yaml"
    cfg.write_text("camera:\n  kind: device\n  path: /dev/nonexistent-camera\n")
    log = tmp_path / "run.jsonl"
    r = run_cli("-m", "mearm.sort", "--config", str(cfg), "--log", str(log))
    assert r.returncode == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "camera" in lines[0], r.stderr
    trial = read_runlog(log).trials[0]
    assert "before the sort started: camera" in trial.faults[0].reason
    assert trial.summary is not None and not trial.summary.ok
