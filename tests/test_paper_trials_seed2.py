"""Three of the paper arm's 100 trials on seed 2 stopped on a fault; each is a whole sort now.

``mearm experiment --config sim_paper_arm --trials 100 --seed 2`` sorted 1183 of 1200
(simulated): trials 10 and 42 missed a grip by 1.2–1.7 cm (the servos' noise), and the
next move's noise swung the closed, empty jaws sideways into a neighbour ("the arm ran
into something: gripper_jaw_right_pad touches green2"): the kinematic simulator's jaws
now push such an object, as the twin's do and a real arm's would. Trial 68's pick of
blue2 was planned within a hair (0.005 cm) of the clearance, its check looking at poses
that kept the hair and every timing's chords at poses that did not ("not sent: followed
command by command, even at 0.0625 of the servos' speeds, … within 1.50 cm of blue2"):
the chords are now held to the clearance itself.
"""

from __future__ import annotations

import numpy as np
import pytest

from mearm.config import load_config
from mearm.experiment.trials import plan_trial
from mearm.kinematics import ArmModel
from mearm.kinematics.collision import TOUCH_M
from mearm.sim.table_collision import collision_model
from mearm.task import run_sort


@pytest.mark.parametrize("trial", [10, 42, 68])
def test_the_trial_sorts_its_whole_table(trial: int) -> None:
    plan = plan_trial(load_config("sim_paper_arm"), 2, trial, None)
    report = run_sort(plan.config, scene=plan.layout, log=None, trial=trial, seed=plan.seed)
    assert report.fault is None, report.fault
    assert report.outcome.line(simulated=True) == "sorted 12 of 12 objects (simulated)"


def test_the_allowance_holds_a_path_to_the_clearance_not_a_hair_more() -> None:
    """A path whose last pose keeps the clearance and less than TOUCH_M more: refused
    without the allowance, passed with it; one that ends inside the clearance is refused
    either way."""
    config = load_config("sim")
    model = ArmModel(config.arm)
    col = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    home = model.home

    def gap(t: float, far: np.ndarray) -> float:
        return col.gap(home + t * (far - home))[0]

    # the shoulder and the elbow turned until the tool goes into something
    for way in (1.0, -1.0):
        far = home + way * np.array([0.0, 0.6, 0.6, 0.0])
        if gap(1.0, far) < 0:
            break
    assert gap(0.0, far) > TOUCH_M and gap(1.0, far) < 0
    # the first of 2000 steps whose gap is under TOUCH_M, then bisected back into the band
    ts = np.linspace(0.0, 1.0, 2001)
    k = next(i for i, t in enumerate(ts) if gap(t, far) < TOUCH_M)
    lo, hi = ts[k - 1], ts[k]
    while gap(hi, far) < 0:
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if gap(mid, far) >= TOUCH_M else (lo, mid)
    q = home + hi * (far - home)
    assert col.first_contact(np.array([home, q])) is not None
    assert col.first_contact(np.array([home, q]), allowance_m=TOUCH_M) is None
    assert col.first_contact(np.array([home, far]), allowance_m=TOUCH_M) is not None
