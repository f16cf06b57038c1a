"""An injected fault is said, struck or never struck; twin settings the twin does not run are too.

From a twin walk (2026-12-06): ``--set "twin.faults=[{kind: limp_servo, at_s: 3000, ...}]"``
on the twin sorted 12 of 12, exit 0, the fault's "never struck" a log record only
``--debug`` showed; on ``sim`` (the kinematic rig) every ``twin.*`` setting did nothing,
with no word. A test of fault handling whose fault never came tested nothing.
"""

from __future__ import annotations

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.task.check import twin_only_warning


def test_a_fault_timed_after_the_run_is_said_on_stderr() -> None:
    argv = ["sort", "--config", "sim_mujoco", "--quiet", "--set",
            "task.scene=[{color: red, x: -5, y: 45}]", "--set",
            "twin.faults=[{kind: limp_servo, at_s: 3000, joint: shoulder}]"]  # fmt: skip
    done = run_in_process(argv, within_s=120)
    assert done.code == 0, done.stderr
    said = [ln for ln in done.stderr.splitlines() if "never struck" in ln]
    assert len(said) == 1, done.stderr
    assert said[0].startswith(
        "mearm sort: warning: twin: fault limp_servo joint=shoulder at_s = 3000 s never "
        "struck: the run ended at t = "
    ), said


@pytest.mark.parametrize(
    ("overrides", "named"),
    [
        (["twin.faults=[{kind: camera_black, at_s: 1.0}]"], "twin.faults: "),
        (["twin.kit={seed: 3}", "twin.faults=[{kind: camera_black, at_s: 1.0}]"],
         "twin.faults, twin.kit: "),
    ],
)  # fmt: skip
def test_twin_settings_on_the_kinematic_rig_are_said_to_do_nothing(overrides, named) -> None:
    warning = twin_only_warning(load_config("sim", overrides))
    assert warning is not None and warning.startswith(named)
    assert warning.endswith(
        "this config's simulator is kinematic: "
        + ("it does nothing here" if "," not in named else "they do nothing here")
    )
    assert twin_only_warning(load_config("sim_mujoco", overrides)) is None
    assert twin_only_warning(load_config("sim")) is None


def test_a_step_of_camera_accuracy_that_fails_is_the_runs_failure() -> None:
    """Under an unlit lamp calibrate-intrinsics found no board on the renders (its exit 2)
    and camera-accuracy exited 2 after the work, as if its input were bad: exit 1 now,
    naming the renders."""
    from mearm.tools.camera_accuracy import StepFailed, _tool

    with pytest.raises(StepFailed) as info:
        _tool("fk", "--config", "sim", "--joints", "1,2")
    assert info.value.exit_status == 1
    assert str(info.value).startswith("mearm fk failed (2) on the twin's renders")
