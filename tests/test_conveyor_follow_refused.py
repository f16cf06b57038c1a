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
        catches: list[tuple[int, int]] = []  # commands sent before and after each catch
        catch = sorter._catch

        def counted(obj, tid) -> None:  # type: ignore[no-untyped-def]
            before = len(sent)
            catch(obj, tid)
            catches.append((before, len(sent)))

        sorter._catch = counted  # type: ignore[method-assign]
        report = sorter.run()
    assert len(catches) == 1, catches
    before, after = catches[0]
    assert after == before, f"the refused catch sent {after - before} commands"
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
