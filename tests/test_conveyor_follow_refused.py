"""A follow the servos cannot keep up with is refused before the catch sends anything."""

from __future__ import annotations

from conftest import ROOT

from mearm.config import config_from_dict, load_config
from mearm.hardware.command import ArmCommand
from mearm.task.conveyor import ConveyorSorter
from mearm.task.rig import open_rig

KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"


def test_a_follow_the_servos_cannot_keep_up_with_leaves_the_object():
    """Servos that accelerate at 100 deg/s^2 (the least a config allows) on a 10 cm/s belt.

    The arm reaches the object well enough, but following it while the jaws close (18
    bus periods, 0.36 s) takes their time law 0.44 s from the pick's standstill: the
    follow is refused, the object left missed on the belt for it, and nothing of the
    catch is sent (a follow that lagged behind its commands would close the jaws
    behind the object).
    """
    data = load_config(KINEMATIC).model_dump(mode="json")
    data["belt"]["speed_cm_s"] = 10.0
    data["belt"]["arrivals"]["count"] = 1
    data["belt"]["arrivals"]["seed"] = 49501
    for joint in data["arm"]["joints"]:
        if joint.get("servo") is not None:
            joint["servo"]["max_accel_deg_s2"] = 100.0
    report, catches = _sort_one(data)
    assert catches == [0], f"the refused catch sent {catches} commands"
    assert len(report.skipped) == 1, report.skipped
    skip = report.skipped[0]
    assert skip.kind == "missed_belt", skip
    assert skip.reason.startswith("missed on the belt: the servos take"), skip.reason
    assert "to follow it" in skip.reason and "while the jaws close" in skip.reason, skip.reason
    assert not any(r.object_id == skip.object_id for r in report.routes), report.routes
    assert not report.complete
    assert report.outcome.n_sorted == 0, report.outcome.line()
    assert report.outcome.left == {"missed_belt": 1}, report.outcome.line()
    assert "1 missed on the belt" in report.outcome.line(), report.outcome.line()


def _reversed_belt(seed: int) -> dict:  # type: ignore[type-arg]
    """The kinematic belt turned round: from x = -4 cm towards +x, away from home, at 5 cm/s.

    One object (``seed``); the arm follows it away from the bins' side, where a joint
    limit or a wall can stop the follow after the pick was planned clear of both.
    """
    data = load_config(KINEMATIC).model_dump(mode="json")
    belt = data["belt"]
    belt["start_cm"], belt["heading_deg"], belt["length_cm"] = [-4.0, 47.0], 0.0, 20.0
    belt["speed_cm_s"] = 5.0
    belt["arrivals"]["count"], belt["arrivals"]["seed"] = 1, seed
    return data


def _sort_one(data: dict):  # type: ignore[no-untyped-def,type-arg]
    """Sort ``data``'s belt; the report and the commands each catch sent."""
    config = config_from_dict(data)
    with open_rig(config) as rig:
        sorter = ConveyorSorter(
            config, rig.camera, rig.bus, model=rig.model, echo=None, in_bins=rig.in_bins
        )
        sent: list[ArmCommand] = []
        move = rig.bus.move

        def recorded(command: ArmCommand) -> None:
            move(command)
            sent.append(command)

        rig.bus.move = recorded  # type: ignore[method-assign]
        catches: list[int] = []
        catch = sorter._catch

        def counted(obj, tid) -> None:  # type: ignore[no-untyped-def]
            before = len(sent)
            catch(obj, tid)
            catches.append(len(sent) - before)

        sorter._catch = counted  # type: ignore[method-assign]
        return sorter.run(), catches


def _the_one_refusal(data: dict, kind: str) -> str:  # type: ignore[type-arg]
    """Sort ``data``'s one object: its catch refused, nothing sent, it left for ``kind``;
    the reason it was left."""
    report, catches = _sort_one(data)
    assert catches == [0], catches
    assert len(report.skipped) == 1, report.skipped
    skip = report.skipped[0]
    assert skip.kind == kind, skip
    assert report.outcome.left == {kind: 1}, report.outcome.line()
    return str(skip.reason)


def test_a_follow_step_past_a_joint_limit_says_it_was_the_follow():
    """The base's lower limit set to 88 deg: the pick ends at base 89.0 deg, and the follow,
    riding 1.8 cm on with the object while the jaws close, would end at 86.9 deg.

    The step's own reason ("needs base = 87.93 deg, outside its limits") read as if the
    pick were out of reach; the skip says it was the follow, then the step's reason.
    """
    data = _reversed_belt(49811)
    data["arm"]["joints"][0]["limits"]["min"] = 88.0
    reason = _the_one_refusal(data, "missed_belt")
    assert reason.startswith(
        "missed on the belt: following it while the jaws close: needs base = "
    ), reason
    assert "outside its limits [88, 160] deg" in reason, reason


def test_a_follow_step_into_a_wall_says_it_was_the_follow():
    """The red bin set on the belt at x = 6.25 cm: the pick at x = 0.8 cm is clear of its
    walls, and the follow's steps, carried on towards +x, come within the clearance (at
    x = 5 cm the pick itself is refused, from 7.5 cm the follow is clear).

    The step's own reason named only the wall, as a pick's does; the skip says it was the
    follow, its kind first, as the follow's own collision refusal reads.
    """
    data = _reversed_belt(49811)
    red = next(c for c in data["task"]["classes"] if c["name"] == "red")
    red["bin_cm"][:2] = [6.25, 47.0]
    reason = _the_one_refusal(data, "collision")
    assert reason.startswith(
        "missed on the belt: collision: following it while the jaws close, gripper_"
    ), reason
    assert "of bin_red_wall_nx at (base " in reason, reason
