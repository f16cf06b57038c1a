"""The jaws close on a fast belt's object as the arm follows it: the twin catches it."""

from __future__ import annotations

from conftest import ROOT

from mearm.config import config_from_dict, load_config
from mearm.task.conveyor import ConveyorSorter
from mearm.task.rig import open_rig

TWIN = ROOT / "configs" / "sim_conveyor.yaml"


def _twin_belt(speed_cm_s: float, count: int, seed: int):
    data = load_config(TWIN).model_dump(mode="json")
    data["belt"]["speed_cm_s"] = speed_cm_s
    data["belt"]["arrivals"]["count"] = count
    data["belt"]["arrivals"]["seed"] = seed
    return config_from_dict(data)


def test_the_twin_catches_a_10_cm_s_belts_objects():
    """The twin's jaws take 0.36 s to close, in which a 10 cm/s object rides 3.6 cm.

    Closed where the object stood, they met it 1.2 cm downstream of their middle, off
    their 1.48 cm wide pads, knocked it aside and closed on nothing: "sorted 0 of 2
    objects (2 pick failed)" (every catch failed from 6 cm/s on). The arm now
    follows it while they close.
    """
    config = _twin_belt(10.0, 2, 49303)
    with open_rig(config) as rig:
        sorter = ConveyorSorter(
            config, rig.camera, rig.bus, model=rig.model, echo=None, in_bins=rig.in_bins
        )
        report = sorter.run()
    assert report.complete and report.outcome.n_sorted == 2, report.outcome.line()
