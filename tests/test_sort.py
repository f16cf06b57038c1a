"""The sorting task end to end on the simulated rig, for every reference arm, and its faults."""

import json
import signal
import subprocess
import sys
import time

import cv2
import numpy as np
import pytest
import yaml
from badinput import Outcome, run_in_process
from conftest import ROOT, planar_yaw_arm_data
from fakeboard import FakeMearmBoard, MearmFaults

from mearm.backends import open_bus
from mearm.config import SceneObject, config_from_dict, load_config
from mearm.exceptions import MearmError, ServoError
from mearm.runlog import RunLog, read_runlog
from mearm.sim import SimCamera, World
from mearm.task import SortAborted, Sorter, open_rig, random_scene


def _sort(config, scene, log=None):
    with open_rig(config, scene) as rig:
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, log=log, echo=None).run()
        return rig.world, report, rig.bus


@pytest.mark.heavy
def test_cli_sorts_the_paper_layout(tmp_path):
    """mearm sort on the sim rig: 12 objects in their bins, 24 routes logged."""
    log = tmp_path / "run.jsonl"
    r = _sort_cli("--config", "configs/sim.yaml", "--log", log)
    assert r.code == 0, r.stderr
    assert r.stdout.splitlines()[-1] == "sorted 12 of 12 objects (simulated)"
    assert "red          4       4     0" in r.stdout and "blue         4       4     0" in r.stdout
    contents = read_runlog(log)
    assert contents.problem is None and contents.complete
    routes = contents.routes
    assert len(routes) == 24
    assert [r.step for r in routes] == ["pick", "place"] * 12
    assert all(r.success and r.status == "converged" for r in routes)
    # a pick also logs where the TCP was when the jaws closed; a place does not
    assert all((r.grip_ee_cm is not None) == (r.step == "pick") for r in routes)
    # all red first, then green, then blue (the paper's order, the classes' order)
    assert [r.color for r in routes[::2]] == ["red"] * 4 + ["green"] * 4 + ["blue"] * 4
    # each route starts where the last ended (no return home in between)
    for prev, nxt in zip(routes, routes[1:], strict=False):
        assert nxt.start_joints == pytest.approx(prev.end_joints, abs=1e-9)
    summary = contents.trials[0].summary
    assert summary.sorted == {"red": 4, "green": 4, "blue": 4} and summary.ok
    assert summary.objects == {"red": 4, "green": 4, "blue": 4} and summary.left == {}


@pytest.mark.parametrize("seed", range(20))
@pytest.mark.heavy
def test_random_scenes_are_sorted(config, seed):
    """20 random scenes: every object ends in its colour's bin, or is reported with a reason."""
    n = 4 + seed % 9  # 4 to 12 objects
    scene = random_scene(config, n, seed=seed)
    world, report, _ = _sort(config, scene)
    left = [o for o in world.objects if o.bin != o.color]
    assert len(left) == len(report.skipped)
    assert all(s.reason for s in report.skipped)
    assert sum(report.sorted_per_class().values()) == n - len(left)
    assert report.fault is None


def test_unreachable_and_outside_box_objects_are_skipped(tmp_path):
    """An object out of reach, and one outside Table 3's box, are reported; the rest sorted."""
    # an arm whose elbow cannot stretch past -85°, and a camera field reaching y = 64 cm
    config = config_from_dict(
        {
            "calibration": {"homography": [[0.0625, 0, -20.5], [0, -0.0625, 64.0], [0, 0, 1]]},
        },
        overrides=["arm.joints.elbow.limits={min: -160, max: -85}"],
    )
    scene = [
        SceneObject(color="red", x=-5.0, y=40.0),
        SceneObject(color="green", x=0.0, y=57.0),  # needs elbow ≈ −80°: out of reach
        SceneObject(color="blue", x=5.0, y=62.0),  # y > 60: outside the target box
    ]
    with RunLog(tmp_path / "log.jsonl") as log:
        log.header(config)
        world, report, _ = _sort(config, scene, log)
    assert [o.bin for o in world.objects] == ["red", None, None]
    reasons = {s.class_name: s.reason for s in report.skipped}
    assert "elbow" in reasons["green"] and "outside its limits" in reasons["green"]
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
                        update={"offset_deg": {"base": 3.0}}
                    )
                }
            )
        }
    )
    world, report, _ = _sort(cfg, [SceneObject(color="red", x=0.0, y=45.0)])
    picks = [r for r in report.routes if r.step == "pick"]
    assert [r.attempt for r in picks] == [1, 2, 3]
    assert not any(r.success for r in picks)
    assert [(s.object_id, s.class_name, s.reason) for s in report.skipped] == [
        ("red1", "red", "pick failed 3 times")
    ]
    assert world.objects[0].on_table


def test_touching_objects_are_separated_and_sorted(config):
    """Two touching reds form one region; the detector splits it and both are sorted."""
    scene = [
        SceneObject(color="red", x=0.0, y=45.0),
        SceneObject(color="red", x=1.9, y=45.0),
        SceneObject(color="blue", x=-8.0, y=40.0),
    ]
    world, report, _ = _sort(config, scene)
    assert not report.skipped
    assert [o.bin for o in world.objects] == ["red", "red", "blue"]


def test_a_region_that_cannot_be_split_is_reported_not_guessed(config):
    """Two reds drawn overlapping (1.2 cm apart: no neck to cut) form one region the
    detector cannot separate: reported as merged and left alone."""
    scene = [
        SceneObject(color="red", x=0.0, y=45.0),
        SceneObject(color="red", x=1.2, y=45.0),
        SceneObject(color="blue", x=-8.0, y=40.0),
    ]
    world, report, _ = _sort(config, scene)
    assert report.skipped and "touching" in report.skipped[0].reason
    assert [o.bin for o in world.objects] == [None, None, "blue"]


def test_a_region_seen_merged_once_is_picked_when_seen_whole(config):
    """A region the first look takes for touching objects (the arm at home hiding part of
    an object does that in the twin) is not left at once: the next looks, from elsewhere,
    see it whole and it is sorted."""
    import dataclasses  # noqa: PLC0415

    scene = [SceneObject(color="red", x=0.0, y=45.0), SceneObject(color="blue", x=-8.0, y=40.0)]
    with open_rig(config, scene) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None)
        detect, looks = sorter.detector.detect, []

        def first_look_merged(frame):
            found = detect(frame)
            looks.append(found)
            if len(looks) > 1:
                return found
            return [dataclasses.replace(d, merged=d.color == "blue") for d in found]

        sorter.detector.detect = first_look_merged
        report = sorter.run()
    assert not report.skipped
    assert report.sorted_per_class() == {"red": 1, "blue": 1}


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
        home = dict(rig.bus.state.joints)
    assert "no more frames after 2" in exc.value.reason and "parked at home" in exc.value.reason
    assert home == pytest.approx(config.arm.home())
    trial = read_runlog(log_path).trials[0]
    assert len(trial.routes) >= 1 and trial.faults and not trial.summary.ok
    assert "no more frames" in trial.faults[0].reason


@pytest.mark.heavy
def test_servo_link_dropped_mid_route(tmp_path, config):
    """The cable is pulled mid-route: named reason, last acknowledged pose logged, no more sends."""
    with FakeMearmBoard(MearmFaults(drop_at_move=400)) as board:
        cfg = config_from_dict(
            {
                "servo": {
                    "backend": "serial",
                    "port": board.port,
                    # generous: the pulled cable is seen at once (the port closes), and
                    # under load the fake board once answered a move after more than 0.2 s
                    "ack_timeout_s": 5.0,
                    "banner_timeout_s": 1.0,
                    "rate_hz": 1000.0,
                }
            },
            # the tool quick (its holds are waited out in real time: 8 of the 9 s the
            # run took); the route is cut by the board, not by the tool's pace
            overrides=[
                "arm.tool.settle_s=0.01",
                "arm.tool.gripper.servo.seconds_per_60deg=0.02",
                "arm.tool.actuators.gripper_arm.servo.seconds_per_60deg=0.02",
            ],
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
    assert exc.value.last_joints is not None
    outcome = exc.value.outcome  # the summary's counts travel with the error
    assert outcome is not None and outcome.left.get("fault", 0) > 0
    assert outcome.n_objects == outcome.n_sorted + sum(outcome.left.values())
    trial = read_runlog(log_path).trials[0]
    assert trial.routes, "the route before the fault is in the log"
    fault = trial.faults[0]
    assert fault.last_joints is not None and not trial.summary.ok
    assert len(moves) == 400  # the 400th move met the pulled cable; nothing sent after it


def test_a_fault_on_the_way_to_the_bin_leaves_the_pick_unconfirmed(config):
    """The grip is checked over the bin: a servo fault before that is not a failed pick."""
    lines: list[str] = []
    with open_rig(config, [SceneObject(color="red", x=0.0, y=45.0)]) as rig:
        bus = rig.bus
        send = bus._send_move

        def cut_while_holding(command, pulses):  # the link is lost once the jaws hold it
            if bus.world.held_object() is not None and dict(command.joints) != dict(
                bus.state.joints
            ):
                raise ServoError("servo link lost (test)")
            send(command, pulses)

        bus._send_move = cut_while_holding
        with pytest.raises(SortAborted):
            Sorter(config, rig.camera, bus, model=rig.model, echo=lines.append).run()
    (pick,) = [line for line in lines if line.startswith("pick")]
    assert "unconfirmed" in pick and "FAILED" not in pick
    assert any("failed picks 0" in line for line in lines)


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("sig", "status", "named"),
    [
        (signal.SIGINT, 130, "Ctrl-C"),
        (signal.SIGTERM, 143, "SIGTERM"),
        (signal.SIGHUP, 129, "SIGHUP"),
    ],
)
def test_ctrl_c_parks_and_keeps_the_log(tmp_path, sig, status, named):
    """SIGINT mid-run: exit 130, one line on stderr, fault logged, arm parked at home.

    SIGTERM and SIGHUP (``timeout``, ``systemctl stop``, a closed terminal) the same, with
    128 + the signal's number: they ended the process at once, the arm not parked, the
    log without a fault or a summary."""
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
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == status, err
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("mearm sort: note: ")]
    assert len(lines) == 1 and f"interrupted ({named}); arm parked at home" in lines[0]
    assert "Traceback" not in err
    contents = read_runlog(log)
    assert contents.problem is None
    trial = contents.trials[0]
    assert trial.routes and "interrupted" in trial.faults[0].reason
    assert trial.summary is not None and trial.summary.left.get("interrupted", 0) > 0
    assert trial.faults[0].last_joints == pytest.approx(
        {"base": 120, "shoulder": 93, "elbow": -132, "wrist": 39}, abs=1e-9
    )


def _sort_cli(*args: object) -> Outcome:
    """``mearm sort ARGS`` in this process, from the repository's folder (as the paths in
    the arguments are): the Ctrl-C test runs the command as its own process."""
    return run_in_process(["sort", *args], within_s=60, cwd=ROOT)


@pytest.mark.heavy
def test_scene_file_and_random_flags(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: green, x: 0.0, y: 45.0}\n- {color: red, x: -6.0, y: 40.0}\n")
    r = _sort_cli("--scene", scene, "--quiet")
    assert r.code == 0, r.stderr
    assert r.stdout.splitlines()[-1] == "sorted 2 of 2 objects (simulated)"
    r = _sort_cli("--random", "3", "--seed", "4", "--quiet", "--log", tmp_path / "l.jsonl")
    assert r.code == 0, r.stderr
    header = json.loads((tmp_path / "l.jsonl").read_text().splitlines()[0])
    assert len(header["scene"]) == 3 and header["seed"] == 4


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--random", "-1"], "--random N lays N objects on the table: N must be 1 to 500"),
        (["--scene", "missing.yaml"], "scene file not found"),
        (["--config", "configs/lab.yaml", "--random", "3"], "camera is 'device', not 'sim'"),
        (["--random", "3", "--scene", "x.yaml"], "not allowed with argument"),
        (["--hold"], "--hold keeps the view open: use it with --view"),
        (["--seed", "5"], "--seed draws the scene of --random N: use it with --random"),
    ],
)
@pytest.mark.heavy
def test_bad_input_exits_2_with_one_line(args, needle):
    r = _sort_cli(*args)
    assert r.code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


@pytest.mark.heavy
def test_bad_scene_entry_named(tmp_path):
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: purple, x: 0.0, y: 45.0}\n")
    r = _sort_cli("--scene", scene)
    assert r.code == 2 and "[0.color]" in r.stderr and "purple" in r.stderr


@pytest.mark.heavy
def test_random_scene_properties(config):
    """Random scenes: seeded, objects ≥ 1 cm apart edge to edge, reachable, in the field."""
    a = random_scene(config, {"red": 4, "green": 4, "blue": 4}, seed=7)
    assert a == random_scene(config, {"red": 4, "green": 4, "blue": 4}, seed=7)
    assert sorted(o.color for o in a) == sorted(["red", "green", "blue"] * 4)
    xy = np.array([[o.x, o.y] for o in a])
    d = np.linalg.norm(xy[:, None] - xy[None], axis=-1) + np.eye(len(a)) * 99
    assert d.min() >= 3.0 - 1e-9
    with pytest.raises(MearmError, match="could not place 45 objects"):
        random_scene(config, 45, seed=0, max_tries=50)
    # 134 reds would raise their bin's walls into the arm at home: refused before a draw
    with pytest.raises(MearmError, match=r"class red: its bin's walls, .* ask for \d+ or fewer"):
        random_scene(config, 400, seed=0, max_tries=2000)


@pytest.mark.heavy
def test_class_order_from_config(config):
    """The classes are sorted in the order the config lists them."""
    classes = config.task.classes
    cfg = config.model_copy(
        update={"task": config.task.model_copy(update={"classes": [classes[2], *classes[:2]]})}
    )
    _, report, _ = _sort(cfg, None)
    picks = [r.class_name for r in report.routes if r.step == "pick"]
    assert picks == ["blue"] * 4 + ["red"] * 4 + ["green"] * 4


def test_home_at_the_end(config):
    _, _, bus = _sort(config, [SceneObject(color="red", x=0.0, y=45.0)])
    assert dict(bus.state.joints) == pytest.approx(config.arm.home())
    assert not bus.state.gripper_closed


def test_a_table_that_never_clears_is_reported(config):
    """After max_rounds pick attempts the rest is reported, not attempted forever."""
    scene = [SceneObject(color="red", x=-6.0 + 6 * i, y=45.0) for i in range(3)]
    with open_rig(config, scene) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None, max_rounds=1)
        report = sorter.run()
    assert report.sorted_per_class() == {"red": 1}
    assert [s.reason for s in report.skipped] == ["still on the table after 1 pick rounds"] * 2


def test_an_object_knocked_off_the_table_is_reported_as_such(config):
    """An object that leaves the table while another is placed is looked for again from
    home, then left as ``off_table`` with where it was last seen; the rest is sorted."""
    scene = [SceneObject(color="red", x=0.0, y=45.0), SceneObject(color="blue", x=8.0, y=40.0)]
    with open_rig(config, scene) as rig:
        bus = rig.bus
        release = bus._open_gripper

        def knock_off() -> None:  # the first release sweeps the blue object off the table
            release()
            blue = next(o for o in bus.world.objects if o.color == "blue")
            blue.x_cm, blue.y_cm = 300.0, 300.0

        bus._open_gripper = knock_off
        report = Sorter(config, rig.camera, bus, model=rig.model, echo=None).run()
    assert report.sorted_per_class() == {"red": 1}
    (skip,) = report.skipped
    assert (skip.object_id, skip.kind) == ("blue1", "off_table")
    assert skip.reason.startswith("no longer in the work area: last seen at (8.0, 40.0) cm")
    assert report.outcome.left == {"off_table": 1}


@pytest.mark.heavy
def test_camera_that_cannot_open_is_logged(tmp_path):
    """No camera at all: found before any motion, so exit 2 with one line; the log says why
    the sort never started."""
    cfg = tmp_path / "nocam.yaml"
    cfg.write_text("camera:\n  kind: device\n  path: /dev/nonexistent-camera\n")
    log = tmp_path / "run.jsonl"
    r = _sort_cli("--config", cfg, "--log", log)
    assert r.code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "camera" in lines[0], r.stderr
    trial = read_runlog(log).trials[0]
    assert "before the sort started: camera" in trial.faults[0].reason
    assert trial.summary is not None and not trial.summary.ok


@pytest.mark.parametrize("name", ["sim_mearm_v1", "sim_5dof", "sim_4colours"])
@pytest.mark.heavy
def test_reference_arms_sort_every_object(name, tmp_path):
    """Each reference config sorts every object into its class's bin, exit 0."""
    config = load_config(ROOT / "configs" / f"{name}.yaml")
    log = tmp_path / "run.jsonl"
    r = _sort_cli("--config", f"configs/{name}.yaml", "--log", log)
    assert r.code == 0, r.stderr
    trial = read_runlog(log).trials[0]
    expected = {
        c.name: sum(o.color == c.name for o in config.task.scene) for c in config.task.classes
    }
    assert trial.summary.sorted == expected and trial.summary.ok
    assert not trial.skips and all(r.success for r in trial.routes)
    assert set(trial.routes[0].start_joints) == {j.name for j in config.arm.joints}


def test_five_joint_arm_picks_pointing_down():
    """The 5-joint arm's plans end with the tool's approach axis straight down."""
    from mearm.kinematics import ArmModel

    config = load_config(ROOT / "configs" / "sim_5dof.yaml")
    world, report, _ = _sort(config, config.task.scene[:2])
    assert all(o.bin == o.color for o in world.objects)
    model = ArmModel(config.arm)
    for route in report.routes:
        np.testing.assert_allclose(model.approach(route.plan.q), [0, 0, -1], atol=0.01)


def test_an_arm_defined_in_the_test_sorts_a_small_scene():
    """A new arm and two new classes, written here as data, sort a scene: no code change."""
    data = {
        "arm": planar_yaw_arm_data(),
        "calibration": {"homography": [[0.05, 0, -16.0], [0, -0.05, 28.0], [0, 0, 1]]},
        "camera": {"table": "grey"},
        "task": {
            "classes": [
                {
                    "name": "orange",
                    "hue_bands_deg": [{"lo_deg": 15, "hi_deg": 40}],
                    "draw_rgb": [240, 130, 20],
                    "bin_cm": [-14.0, 8.0, 10.0],
                    "grip_height_cm": 1.0,
                },
                {
                    "name": "violet",
                    "hue_bands_deg": [{"lo_deg": 260, "hi_deg": 300}],
                    "draw_rgb": [130, 40, 210],
                    "bin_cm": [14.0, 8.0, 10.0],
                    "grip_height_cm": 1.0,
                },
            ],
            "scene": [
                {"color": "violet", "x": -4.0, "y": 14.0},
                {"color": "orange", "x": 5.0, "y": 16.0},
                {"color": "violet", "x": 2.0, "y": 11.0},
            ],
        },
    }
    # the claw points along the forearm (its jaws open level): pointing along the joint
    # axis, they would open up and down, and the lower jaw would hit the table
    data["arm"]["tool"]["approach_axis"] = [1.0, 0.0, 0.0]
    config = config_from_dict(data)
    world, report, bus = _sort(config, None)
    assert [(o.color, o.bin) for o in world.objects] == [
        ("violet", "violet"),
        ("orange", "orange"),
        ("violet", "violet"),
    ]
    assert report.sorted_per_class() == {"orange": 1, "violet": 2}
    picks = [r.class_name for r in report.routes if r.step == "pick"]
    assert picks == ["orange", "violet", "violet"]  # the classes' order
    assert dict(bus.state.joints) == pytest.approx(config.arm.home())
