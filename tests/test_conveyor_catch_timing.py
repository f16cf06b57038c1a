"""A catch is timed as its commands are sent: a route slowed near a wall comes late."""

from __future__ import annotations

from belt_sort import sort_measuring_grips
from conftest import ROOT

from mearm.config import config_from_dict, load_config

KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"

#: A belt speed at which a grip 0.18 s late closes 1.8 cm behind its object, beyond the
#: kinematic grip's 1.2 cm tolerance [cm/s].
FAST_CM_S = 10.0


def _beside_tall_red_walls(seed: int = 0):
    """Two objects at 10 cm/s, the red bin's walls 9 cm tall (raised to hold them).

    The first pick from home passes the red walls so near that its commands' chords are
    sent at half the servos' speeds (``Executor.followed``), as on the shipped belt of 20
    objects, whose 9 reds grow those walls to 10 cm.
    """
    data = load_config(KINEMATIC).model_dump(mode="json")
    data["belt"]["speed_cm_s"] = FAST_CM_S
    data["belt"]["arrivals"]["count"] = 2
    data["belt"]["arrivals"]["seed"] = seed
    red = next(c for c in data["task"]["classes"] if c["name"] == "red")
    red["bin_cm"] = [red["bin_cm"][0], red["bin_cm"][1], 26.0]
    red["bin_height_cm"] = 9.0
    return config_from_dict(data)


def test_a_fast_belt_is_caught_where_a_slowed_route_brings_the_jaws():
    """Each grip closes on its object, within 0.05 cm of where the aim put it.

    The intercept timed its routes at the servos' full speed while the stream sent the
    first at half of it: the jaws came 0.18 s late, 1.6 cm behind the object, and every
    catch failed ("sorted 0 of 2 objects (simulated; 2 pick failed)").
    """
    report, errors = sort_measuring_grips(_beside_tall_red_walls())
    assert len(errors) == 2 and max(errors) < 0.05, errors
    assert report.complete and report.outcome.n_sorted == 2, report.outcome.line()


def test_an_intercept_that_does_not_converge_waits_for_its_object():
    """Aimed nearer, the first pick is slowed and late; aimed farther, it is not and is
    early: the rounds never converge. The early one is taken, its jaws waiting open for
    the object (a period, 0.02 s), and each grip closes within 0.05 cm of it.

    The last round was taken, aimed at where the object had been a round before: the
    jaws closed 0.2 cm behind it here, and 1.8 cm on the shipped belt of 20
    objects at 10 cm/s (its 4th catch, ``--set belt.arrivals.seed=49101``), a miss.
    """
    report, errors = sort_measuring_grips(_beside_tall_red_walls(seed=49118))
    assert len(errors) == 2 and max(errors) < 0.05, errors
    assert report.complete and report.outcome.n_sorted == 2, report.outcome.line()
