"""Table 9 and success against error, on hand-made logs whose answers are counted by hand."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from mearm.analysis import Rate, fit_weibull, pick_outcomes, success_table, success_vs_error
from mearm.analysis.run_analysis import analyze, to_json
from mearm.config import Config, TaskConfig, default_classes
from mearm.config.classes import HueBand
from mearm.exceptions import AnalysisError
from mearm.runlog import RunLog, read_runlog

HOME = Config().arm.full_values(Config().arm.home())  # every joint by name [deg]

# object, colour, step, attempt, |error| [cm], success
ROUTES = [
    ("red1", "red", "pick", 1, 0.20, True),
    ("red1", "red", "place", 1, 0.50, True),
    ("red2", "red", "pick", 1, 1.50, False),
    ("red2", "red", "pick", 2, 0.30, True),
    ("red2", "red", "place", 1, 0.40, True),
    ("green1", "green", "pick", 1, 1.30, False),
    ("green1", "green", "pick", 2, 1.40, False),
    ("green2", "green", "pick", 1, 1.25, True),
    ("green2", "green", "place", 1, 0.90, True),
    ("blue1", "blue", "pick", 1, 2.00, True),
    ("blue1", "blue", "place", 1, 0.10, False),
    ("blue2", "blue", "pick", 1, 0.70, True),
    ("blue2", "blue", "place", 1, 0.60, True),
]


def write_hand_log(path: Path, routes=ROUTES, config: Config | None = None) -> Path:
    target = np.array([0.0, 45.0, 12.76])
    with RunLog(path, fsync=False) as log:
        log.header(config or Config(), trial=0, seed=None)
        for object_id, color, step, attempt, err, ok in routes:
            log.route(
                object_id=object_id,
                color=color,
                step=step,
                attempt=attempt,
                target_cm=target,
                start_joints=HOME,
                end_joints=HOME,
                iterations=80,
                status="converged",
                initial_error_cm=20.0,
                final_error_cm=0.03,
                ee_cm=target + [0.0, err, 0.0],
                success=ok,
                elapsed_s=0.01,
                motion_s=5.0,
            )
        log.skip(object_id="green1", color="green", target_cm=target, reason="retries exhausted")
        log.summary()
    return path


@pytest.fixture()
def hand_log(tmp_path: Path) -> Path:
    return write_hand_log(tmp_path / "hand.jsonl")


def test_table9_counts_first_attempts_per_colour(hand_log: Path) -> None:
    t = success_table(read_runlog(hand_log).routes)
    assert t.pick == {"red": Rate(1, 2), "green": Rate(1, 2), "blue": Rate(2, 2)}
    assert t.pick_total == Rate(4, 6)
    assert t.place == {"red": Rate(2, 2), "green": Rate(1, 1), "blue": Rate(1, 2)}
    assert t.place_total == Rate(4, 5)
    assert t.pick_total.rate == pytest.approx(4 / 6)
    assert t.place["blue"].failure_rate == pytest.approx(0.5)


def test_table9_rows_follow_the_configs_classes(tmp_path: Path) -> None:
    """Table 9 lists the header config's classes in their order, a class without routes too."""
    yellow = HueBand(lo_deg=45.0, hi_deg=70.0)  # (red's own hues: the same to the camera)
    classes = [*reversed(default_classes()), default_classes()[0].model_copy(
        update={"name": "yellow", "bin_cm": (-20.0, 65.0, 20.0), "hue_bands_deg": [yellow]}
    )]  # fmt: skip
    config = Config(task=TaskConfig(classes=classes))
    log = write_hand_log(tmp_path / "classes.jsonl", config=config)
    t = analyze(read_runlog(log)).table9
    assert list(t.pick) == ["blue", "green", "red", "yellow"] == list(t.place)
    assert t.pick["yellow"] == Rate(0, 0) and t.pick["red"] == Rate(1, 2)
    assert list(success_table(read_runlog(log).routes, ["green"]).pick) == [
        "green", "red", "blue",
    ]  # fmt: skip


def test_rate_of_nothing_is_nan() -> None:
    assert math.isnan(Rate(0, 0).rate) and Rate(0, 0).failures == 0


def test_success_against_error_first_attempts(hand_log: Path) -> None:
    errors, ok = pick_outcomes(read_runlog(hand_log).routes)
    np.testing.assert_allclose(np.sort(errors), [0.2, 0.7, 1.25, 1.3, 1.5, 2.0])
    s = success_vs_error(errors, ok)
    assert s.bound_cm == pytest.approx(1.3)  # the smallest failed pick
    assert s.above == Rate(successes=1, n=3)  # 1.3 ✗, 1.5 ✗, 2.0 ✓
    assert s.above.failure_rate == pytest.approx(2 / 3)
    assert s.picks == Rate(4, 6) and s.max_error_cm == pytest.approx(2.0)
    assert s.p_below is None  # no fit given


def test_success_against_error_all_attempts(hand_log: Path) -> None:
    errors, ok = pick_outcomes(read_runlog(hand_log).routes, attempts="all")
    s = success_vs_error(errors, ok)
    assert s.bound_cm == pytest.approx(1.3)
    assert s.above == Rate(successes=1, n=4)  # + the 1.4 cm retry that failed
    assert s.picks == Rate(5, 8)


def test_probability_below_the_bound_comes_from_the_fit(hand_log: Path) -> None:
    errors, ok = pick_outcomes(read_runlog(hand_log).routes)
    fit = fit_weibull([0.2, 0.5, 0.7, 0.9, 1.25, 1.3, 1.5, 2.0])
    s = success_vs_error(errors, ok, fit)
    assert s.p_below == pytest.approx(1 - math.exp(-((1.3 / fit.scale) ** fit.shape)))


def test_bins_hold_every_pick_once(hand_log: Path) -> None:
    errors, ok = pick_outcomes(read_runlog(hand_log).routes)
    s = success_vs_error(errors, ok, bin_width_cm=0.5)
    assert [(b.lo_cm, b.hi_cm) for b in s.bins] == [
        (0, 0.5),
        (0.5, 1),
        (1, 1.5),
        (1.5, 2),
        (2, 2.5),
    ]
    assert [b.picks for b in s.bins] == [Rate(1, 1), Rate(1, 1), Rate(1, 2), Rate(0, 1), Rate(1, 1)]


def test_no_failed_pick_means_no_bound() -> None:
    s = success_vs_error([0.1, 0.4, 1.9], [True, True, True])
    assert s.bound_cm is None and s.above == Rate(0, 0) and s.p_below is None


@pytest.mark.parametrize(
    ("errors", "flags", "kwargs", "pattern"),
    [
        ([], [], {}, "no picks"),
        ([0.1, 0.2], [True], {}, "2 errors but 1"),
        ([0.1], [True], {"bin_width_cm": 0.0}, "bin width"),
    ],
)
def test_bad_inputs_are_refused(errors, flags, kwargs, pattern) -> None:
    with pytest.raises(AnalysisError, match=pattern):
        success_vs_error(errors, flags, **kwargs)


def test_pick_outcomes_refuses_unknown_attempts(hand_log: Path) -> None:
    with pytest.raises(AnalysisError, match="'first' or 'all'"):
        pick_outcomes(read_runlog(hand_log).routes, attempts="second")  # type: ignore[arg-type]


def test_whole_analysis_of_the_hand_log(hand_log: Path) -> None:
    """analyze() ties it together, and its JSON has the hand-counted figures."""
    a = analyze(read_runlog(hand_log))
    assert (a.trials, a.routes, a.skips, a.faults) == (1, 13, 1, 0)
    assert a.table8.n == 13 and a.weibull is not None
    assert a.success is not None and a.success.bound_cm == pytest.approx(1.3)
    assert set(a.table6) == {"all", "pick", "place"} and a.table6["pick"].n == 8
    data = json.loads(json.dumps(to_json(a), allow_nan=False))
    assert data["table9"]["pick_total"] == {"successes": 4, "n": 6, "rate": pytest.approx(4 / 6)}
    assert data["success"]["above"]["n"] == 3
    assert data["table8"]["xyz"]["max"] == pytest.approx(2.0)
    assert data["paper"]["weibull"] == {"shape": 2.045, "scale": 0.7059}
    assert data["problem"] is None
    # the paper's way, over all 13 routes: 1.3, 1.4, 1.5, 2.0 are at or above the bound
    assert data["around_bound"] == {
        "routes": 13, "above": 4, "failed_picks": 2, "failed_share_above": 0.5,
        "empirical_p_below": pytest.approx(9 / 13),
    }  # fmt: skip


def test_analysis_of_places_only(hand_log: Path) -> None:
    a = analyze(read_runlog(hand_log), step="place")
    assert a.table8.n == 5 and a.table8.xyz.max == pytest.approx(0.9)
    with pytest.raises(AnalysisError, match="no place routes"):
        analyze(
            read_runlog(write_hand_log(hand_log.with_name("p.jsonl"), ROUTES[:1])), step="place"
        )
