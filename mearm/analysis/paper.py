"""The paper's own figures for its real arm (paper §5, §3), to print beside a run's.

100 trials × 12 objects = 1 200 picks + 1 200 places = 2 400 routes.
"""

from __future__ import annotations

from mearm.config.defaults import PAPER_CLASS_NAMES

#: Table 8: final EE-to-target error of the real arm [cm], rows → (mean, std, max, min).
TABLE8_CM: dict[str, tuple[float, float, float, float]] = {
    "x": (-0.0086, 0.41259, 1.40885, -1.596),
    "y": (-0.0047, 0.22245, 0.76329, -0.8509),
    "z": (-0.0022, 0.52336, 2.00255, -1.9053),
    "xy": (0.39882, 0.24635, 1.60043, 0.01067),
    "xyz": (0.62397, 0.32284, 2.15026, 0.02186),
}
TABLE8_ROUTES = 2400

#: Weibull fit of the Euclidean xyz error (location 0).
WEIBULL_SCALE_CM = 0.7059
WEIBULL_SHAPE = 2.0450

#: Table 9: first-attempt pick success [%] per class (the paper's classes, by name) and
#: in total; every place succeeded.
TABLE9_PICK_PERCENT: dict[str, float] = dict(
    zip(PAPER_CLASS_NAMES, (96.00, 94.00, 92.75), strict=True)
)
TABLE9_PICK_TOTAL_PERCENT = 94.25
TABLE9_PLACE_PERCENT = 100.0
TABLE9_PICKS_PER_CLASS = 400
#: First-attempt picks of Table 9, all classes together.
TABLE9_PICKS = len(PAPER_CLASS_NAMES) * TABLE9_PICKS_PER_CLASS

#: Success against error: every pick below this error succeeded [cm] ...
SUCCESS_BOUND_CM = 1.2
#: ... above it this share of picks failed [%], out of this many picks ...
FAILURE_ABOVE_PERCENT = 51.88
PICKS_ABOVE_BOUND = 133
#: ... and "the fitted density" gives P(error < bound) [%]. (It is 1 − 133/2400, the
#: empirical share of routes below 1.2 cm; the fit above gives 94.82 %.)
P_BELOW_BOUND_PERCENT = 94.46
#: Failed first-attempt picks, derived: 1 200 × (100 − 94.25) % = 69 (= 51.88 % of 133).
FAILED_PICKS = 69

#: Table 6 summary (paper §3): 24 routes of the demo, solver on ideal kinematics.
TABLE6_ROUTES = 24
TABLE6_MEAN_ITERATIONS = 82.0
TABLE6_MIN_ITERATIONS = 73
TABLE6_MAX_ITERATIONS = 93
TABLE6_MEAN_INITIAL_ERROR_CM = 24.99
TABLE6_MEAN_FINAL_ERROR_CM = 0.0305
TABLE6_FINAL_ERROR_RANGE_CM = (0.0297, 0.0315)

#: The gains the paper compared (paper §3): kp = 0.01 smoothest, 0.5 overshoots.
GAIN_SWEEP_KP: tuple[float, ...] = (0.01, 0.1, 0.5)
