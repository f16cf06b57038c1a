"""A belt sort stopped by a signal says what stopped it, in its reason and in its count.

Found walking docs/sorting.md: ``timeout 3 mearm sort --config sim_conveyor_kinematic``
(SIGTERM) printed ``stopped: interrupted (Ctrl-C)``, and when an object had just landed on
the belt the last line read ``sorted 5 of 6 objects (simulated; 1 never seen by the
camera)``: the stop was in neither.
"""

from __future__ import annotations

import signal

import pytest
from conftest import ROOT

from mearm import interrupts
from mearm.config import config_from_dict, load_config
from mearm.sim.belt import belt_arrivals
from mearm.task.conveyor import ConveyorSorter
from mearm.task.rig import open_rig
from mearm.task.sorter import SortAborted

KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"


class StoppedCamera:
    """The rig's camera, until the bus's clock passes ``at_s``: then ``stop`` is raised."""

    def __init__(self, camera, bus, at_s: float, stop: KeyboardInterrupt):
        self.camera, self.bus, self.at_s, self.stop = camera, bus, at_s, stop

    def read(self):
        if self.bus.time_s >= self.at_s:
            raise self.stop
        return self.camera.read()

    def __getattr__(self, name):
        return getattr(self.camera, name)


def _stopped_run(stop: KeyboardInterrupt):
    """Stop the belt's sort at the first look after its first object lands."""
    data = load_config(KINEMATIC).model_dump(mode="json")
    data["belt"]["arrivals"] = {**data["belt"]["arrivals"], "count": 2, "first_s": 0.5}
    config = config_from_dict(data)
    landed_s = belt_arrivals(config)[0].t_s
    with open_rig(config) as rig:
        camera = StoppedCamera(rig.camera, rig.bus, landed_s, stop)
        sorter = ConveyorSorter(
            config, camera, rig.bus, model=rig.model, echo=None, in_bins=rig.in_bins
        )
        with pytest.raises(SortAborted) as caught:
            sorter.run()
    return sorter.report, caught.value


def test_a_sigterm_is_named_as_such():
    report, stop = _stopped_run(interrupts.Terminated(signal.SIGTERM))
    assert str(stop).startswith("interrupted (SIGTERM); arm parked at home"), str(stop)
    assert report.fault is not None and "SIGTERM" in report.fault


def test_an_object_landed_but_not_yet_seen_is_left_to_the_stop():
    """One of the M objects, left ``interrupted``, not ``never seen by the camera``."""
    report, stop = _stopped_run(KeyboardInterrupt())
    assert str(stop).startswith("interrupted (Ctrl-C)")
    outcome = stop.outcome
    assert outcome.n_objects == 1 and outcome.n_sorted == 0
    assert outcome.left == {"interrupted": 1}
    assert report.line() == "sorted 0 of 1 objects (simulated; 1 interrupted)"
