"""What the camera's servo calibration is tuned to: the doubt, the moves, the fit."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mearm.config import Config

# --- the doubt: how far a servo may be from where it is sent [µs of pulse] ---------------
#: The gears' play: half a unit's backlash (up to 2° of shaft) and its dead band (up to
#: 10 µs), 1° each at 10 µs per degree (the twin's kits, servo_kit's sourced ranges).
PLAY_US = 20.0
#: A unit's zero before any fit: up to 2° of shaft at the neutral pulse.
ZERO_PRIOR_US = 20.0
#: A unit's µs per degree before the scales are fitted: −19…+15 % of the datasheet's.
SCALE_PRIOR = 0.2
#: A fitted zero [µs], and the least error of a fitted scale beyond the pulses it was
#: fitted over [-].
FIT_ZERO_US = 5.0
FIT_SCALE = 0.05

# --- the moves ---------------------------------------------------------------------------
#: The tool's lowest point stays this far above the table, within the doubt [cm].
TABLE_MARGIN_CM = 1.0
#: Each joint stays this far inside its limits, within the doubt [deg or cm].
JOINT_MARGIN = 1.0
#: The collision clearance is ``task.clearance_cm`` plus the doubt's reach of the tool,
#: rounded up to this step [cm] (a planner per step, kept).
CLEARANCE_STEP_CM = 0.5
#: The points' TCP heights above the objects' pick height, highest first [cm].
HEIGHTS_ABOVE_PICK_CM = (9.0, 6.0, 3.0)
#: The grid of points about the view's centre: its pitch, and how far it reaches across
#: and along the table [cm].
GRID_STEP_CM = 4.0
GRID_HALF_CM = (16.0, 12.0)
#: Every look's final move: each joint turning from this far below (or above) [deg or
#: cm]: more than a unit's backlash and dead band together (2° and 1° of shaft at most),
#: so each arrives with its gears' play taken up the same way.
APPROACH_FROM = {"deg": 4.0, "cm": 0.4}
#: Where a joint the points' targets leave free is set besides where the solver leaves
#: it, each a share of its range [-]: the 5-DOF arm's wrist roll turns the marker about
#: the tool's axis, not the TCP, and its scale is fitted only if the points turn it.
FREE_SHARES = (0.25, 0.75)
#: A path's doubt is checked at poses this many degrees (cm) of its largest joint turn apart.
PATH_CHECK_STEP = 1.0
#: How long the arm is held still before a frame is read [s].
SETTLE_S = 0.3
#: A predicted marker keeps this far inside the frame, besides the doubt's reach [px].
VIEW_MARGIN_PX = 25.0

# --- the sightings and the fit -----------------------------------------------------------
#: Points visited at most (after the look at home).
POINTS = 16
#: Looks (home and the first points) after which a marker never seen ends the run.
FIRST_FEW = 4
#: The scales are fitted from this many sightings on, spread over this much of each
#: servo's pulse [µs] (10° at 10 µs per degree; how well they are known follows from the
#: spread, ServoDoubt).
MIN_SCALE_SIGHTINGS = 6
MIN_SPREAD_US = 100.0
#: A fit whose RMS corner residual is above this does not converge [px]: the marker is
#: then not where the arm puts it.
MAX_RMS_PX = 3.0
#: A fit of the zeros alone leaves the scales' errors over the pulses sighted; above
#: this it is not used for the moves [px].
MAX_ZEROS_RMS_PX = 20.0
#: A sighting whose corners fit a square's image worse than this is not used [px].
MAX_SQUARE_RMS_PX = 1.5
#: The arm's motion (moves, waits and holds) stops taking points past this [s], so that
#: parking keeps the whole within 3 minutes.
MOTION_BUDGET_S = 150.0


def floor_cm(config: Config) -> float:
    """How high the tool's lowest point stays above a table with objects, within the doubt [cm].

    :data:`TABLE_MARGIN_CM` above the tallest class's objects: the moves then pass over
    every object, whether the camera saw it from home or not (a sort's calibration at its
    start, and ``calibrate-servos --camera`` on a table with objects).
    """
    return max(c.height_cm for c in config.task.classes) + TABLE_MARGIN_CM
