"""Tracking objects on the belt across rendered frames: one id each, through occlusion."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.config.belt_config import TrackingConfig
from mearm.exceptions import TrackingError
from mearm.sim import SimCamera, World
from mearm.sim.belt import Belt
from mearm.vision import ColorDetector, Seen, Tracker
from mearm.vision.calibration import Calibration
from mearm.vision.tracking import (
    Missing,
    distance_to_path,
    explain,
    nearest_pairs,
    whole_sightings,
)

KINEMATIC = ROOT / "configs" / "sim_conveyor_kinematic.yaml"
#: Frames per second of the test's camera.
FPS = 5.0
#: The arm's shadow in the picture: a dark grey bar across the belt, x in [3, 7] cm.
BAR_X_CM = (3.0, 7.0)
ARM_BGR = (46, 46, 51)  # the twin's link colour


def _occluded(frame: np.ndarray, calibration: Calibration) -> np.ndarray:
    """The frame with the arm's link drawn over the belt (what the camera sees of it)."""
    x0, x1 = BAR_X_CM
    corners = calibration.table_to_pixel([[x0, 40.0], [x1, 40.0], [x1, 54.0], [x0, 54.0]])
    out = frame.copy()
    cv2.fillConvexPoly(out, np.rint(corners).astype(np.int32), ARM_BGR)
    return out


@pytest.fixture(scope="module")
def tracked():
    """Ten seconds of the kinematic conveyor at 5 frames a second, the bar over the belt;
    each frame's tracks and the first object's true position."""
    config = load_config(KINEMATIC)
    world = World.from_config(config)
    camera = SimCamera(config, world)
    calibration = Calibration.from_config(config.calibration)
    detector = ColorDetector.from_config(
        config.vision, config.calibration, config.camera, config.task.classes
    )
    vx, vy = (float(v) for v in Belt(config.belt).velocity_cm_s)
    tracker = Tracker(config.belt.tracking, (vx, vy))  # as the conveyor sorter makes it
    first = world.objects[0]
    frames = []
    for k in range(int(10 * FPS) + 1):
        t = k / FPS
        world.advance(t - world.time_s)
        frame = _occluded(camera.read(), calibration)
        seen = whole_sightings(
            detector.detect(frame),
            calibration,
            config.task.classes,
            config.belt.tracking.min_area_share,
        )
        frames.append((t, tracker.update(t, seen), (first.x_cm, first.y_cm), first.on_table))
    return config, tracker, frames


def test_one_track_follows_the_object_through_the_occlusion(tracked):
    """The object keeps its id from its arrival to the end; under the arm it coasts.
    (The second object arrives at 7.2 s, the first still hidden: it gets id 2.)"""
    _, tracker, frames = tracked
    firsts = [next(s for s in states if s.id == 1) for _, states, _, _ in frames if states]
    assert len(firsts) == 46 and tracker.lost == []  # from 1.0 s to 10.0 s, every frame
    assert {s.id for _, states, _, _ in frames for s in states} == {1, 2}
    coasting = [s.t_s for s in firsts if not s.seen]
    assert coasting, "the bar hid nothing"
    # hidden while its disc (2 cm across) is wholly or partly under the 4 cm bar:
    # x from 8 down to 2 cm; it lands at x = 18 cm at 1 s and rides at 2 cm/s
    assert min(coasting) >= 1 + (18 - 8.0) / 2 - 1e-9
    assert max(coasting) <= 1 + (18 - 2.0) / 2 + 1e-9


def test_the_estimate_holds_while_unseen(tracked):
    """Seen or coasting under the arm, the estimate stays within 0.05 cm of the object."""
    _, _, frames = tracked
    for _, states, truth, _ in frames:
        for s in states:
            if s.id == 1:
                error = math.dist(s.position_cm, truth)
                assert error < 0.05, (s, truth)


def test_the_velocity_is_the_belts(tracked):
    """After a few frames the track's velocity is the belt's, (-2, 0) cm/s."""
    config, _, frames = tracked
    for s in frames[-1][1]:
        assert s.velocity_cm_s == pytest.approx([-config.belt.speed_cm_s, 0.0], abs=0.05)


def test_a_track_unseen_too_long_is_lost():
    """Past coast_s unseen, a track is dropped and a new sighting starts another id."""
    tracker = Tracker(TrackingConfig(coast_s=1.0))
    tracker.update(0.0, [Seen("red", 0.0, 40.0)])
    tracker.update(0.5, [Seen("red", 1.0, 40.0)])
    assert [s.id for s in tracker.update(1.4, [])] == [1]
    assert tracker.update(1.6, []) == [] and tracker.lost == [1]
    assert [s.id for s in tracker.update(1.8, [Seen("red", 3.6, 40.0)])] == [2]


def test_classes_and_the_gate_keep_tracks_apart():
    """A detection of another class, or beyond the gate of a track whose velocity is
    known, does not feed the track; a track seen once has a wide gate."""
    tracker = Tracker(TrackingConfig(gate_cm=1.0))
    tracker.update(0.0, [Seen("red", 0, 40)])
    # its velocity unknown (up to 100 cm/s): 1.5 cm away 0.1 s later is still its object
    assert [s.id for s in tracker.update(0.1, [Seen("red", 1.5, 40.0)])] == [1]
    for k in (2, 3, 4):  # at 15 cm/s
        tracker.update(k / 10, [Seen("red", 1.5 * k, 40.0)])
    # predicted at 7.5 cm: a blue there is not it, nor a red 2 cm on
    states = tracker.update(0.5, [Seen("blue", 7.5, 40.0), Seen("red", 9.5, 40.0)])
    assert sorted((s.id, s.color, s.seen) for s in states) == [
        (1, "red", False),
        (2, "blue", True),
        (3, "red", True),
    ]


def test_an_object_seen_once_rides_the_belt_and_is_not_taken_for_one_far_off():
    """A red seen once, then hidden 2 s (the sorter busy with a pick): on a belt running
    -x at 2 cm/s it is near x = 16 cm, not 21 cm beyond that. A red there is a new object
    with an id of its own (taken at rest, give or take the 100 cm/s of any belt, it took
    the first one's id); the first one seen again where the belt carried it keeps its id,
    and both tracks start at the belt's velocity."""
    belt = Tracker(TrackingConfig(), belt_cm_s=(-2.0, 0.0))
    belt.update(0.0, [Seen("red", 20.0, 40.0)])
    states = belt.update(2.0, [Seen("red", -5.0, 40.0)])
    assert sorted(s.id for s in states) == [1, 2]
    first = next(s for s in states if s.id == 1)
    assert first.position_cm == pytest.approx([16.0, 40.0], abs=1e-6) and not first.seen
    states = belt.update(2.2, [Seen("red", 15.6, 40.0), Seen("red", -5.4, 40.0)])
    assert sorted((s.id, s.seen) for s in states) == [(1, True), (2, True)]
    for s in states:
        assert s.velocity_cm_s == pytest.approx([-2.0, 0.0], abs=0.05)
    anywhere = Tracker(TrackingConfig())  # no belt given
    anywhere.update(0.0, [Seen("red", 20.0, 40.0)])
    assert [s.id for s in anywhere.update(2.0, [Seen("red", -5.0, 40.0)])] == [1]


def test_frames_out_of_order_are_refused():
    """A frame earlier than the last, or at a NaN time, is a TrackingError naming both times."""
    tracker = Tracker(TrackingConfig())
    tracker.update(2.0, [])
    for bad in (1.0, math.nan):
        with pytest.raises(TrackingError, match=r"earlier than the last frame's \(2.0 s\)"):
            tracker.update(bad, [])


# --------------------------------------------------------------------------- still table


def test_nearest_pairs_are_taken_first_each_row_and_column_once():
    """Greedy nearest-first: the closest pair, then the closest of the free ones; a row's
    reach and an ``inf`` keep a pair from being made."""
    d = np.array([[1.0, 0.5, math.inf], [0.4, 0.6, 3.0]])
    assert nearest_pairs(d) == [(1, 0), (0, 1)]
    assert nearest_pairs(d, reach_cm=[0.45, 5.0]) == [(1, 0)]  # row 0: 1.0 and 0.5 too far
    assert nearest_pairs(d, reach_cm=0.45) == [(1, 0)]
    assert nearest_pairs(np.array([[math.inf]])) == []
    assert nearest_pairs(np.zeros((0, 3))) == []


def test_the_distance_to_a_path_is_to_its_nearest_segment():
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    assert distance_to_path(path, (5.0, 2.0)) == pytest.approx(2.0)
    assert distance_to_path(path, (13.0, 14.0)) == pytest.approx(5.0)  # past its end
    assert distance_to_path(path[:1], (3.0, 4.0)) == pytest.approx(5.0)  # one point


def test_a_missing_object_explains_what_appeared_wherever_it_went():
    """An object of the class that is missing is the one that appeared, however far (a
    pushed cylinder tips and rolls): 30 cm off is still it; the class must agree, and a
    second sighting with no missing object left is a new object."""
    missing = [Missing("red", np.array([[0.0, 40.0]]), touched=False)]
    far = [Seen("blue", 1.0, 40.0), Seen("red", 30.0, 40.0), Seen("red", 31.0, 55.0)]
    assert explain(missing, far) == [(0, 1)]
    assert explain(missing, [Seen("blue", 0.5, 40.0)]) == []
    assert explain([], far) == []


def test_objects_off_the_table_and_touched_explain_first_then_the_nearest():
    """Two reds missing from the table: the one the arm went near takes the sighting,
    though the other was nearer it; among equals the nearest pairs go first. One carried
    to its bin (most likely there) explains a sighting only when no red missing from the
    table can, however near its path lies; then, as far as its path."""
    touched = Missing("red", np.array([[0.0, 40.0]]), touched=True)
    hidden = Missing("red", np.array([[9.0, 40.0]]), touched=False)
    assert explain([hidden, touched], [Seen("red", 8.0, 40.0)]) == [(1, 0)]
    two = [Seen("red", 8.0, 40.0), Seen("red", 1.0, 40.0)]
    assert sorted(explain([touched, hidden], two)) == [(0, 1), (1, 0)]
    path = np.array([[0.0, 30.0], [-20.0, 30.0]])
    carried = Missing("red", path, touched=True, carried=True)
    near_its_path = Seen("red", -12.0, 31.0)  # 1 cm from the path, 21 cm from the other
    assert explain([hidden, carried], [near_its_path]) == [(0, 0)]
    assert explain([carried], [near_its_path]) == [(0, 0)]
    farther = Missing("red", path + (0.0, 5.0), touched=False, carried=True)
    assert explain([farther, carried], [near_its_path]) == [(1, 0)]


def test_a_sighting_in_a_frame_dated_as_the_last_keeps_the_estimate():
    """Two frames dated alike (the sorter dates a frame no earlier than the last one):
    the second sighting corrects the estimate as it is. A track just started went to
    (0, 0), at rest, and kept no uncertainty to find its object again."""
    tracker = Tracker(TrackingConfig(), belt_cm_s=(-6.0, 0.0))
    tracker.update(1.0, [Seen("red", 10.0, 46.0)])
    (state,) = tracker.update(1.0, [Seen("red", 10.0, 46.0)])
    assert state.id == 1 and state.seen
    assert state.position_cm == pytest.approx([10.0, 46.0], abs=1e-6)
    assert state.velocity_cm_s == pytest.approx([-6.0, 0.0], abs=1e-6)
    for t_s in (1.5, 1.5):  # a track predicted before: corrected once, then again
        (state,) = tracker.update(t_s, [Seen("red", 7.0, 46.0)])
        assert state.id == 1 and state.position_cm == pytest.approx([7.0, 46.0], abs=0.01)


def test_an_object_up_the_belt_from_where_a_track_was_last_seen_is_another():
    """A belt carries its objects down, never up: a red seen once, unseen 3.4 s since
    (left on a 10 cm/s belt by a failed pick), has a gate of a metre; a red just landed
    up the belt from where it was seen is a new object, not that one."""
    tracker = Tracker(TrackingConfig(), belt_cm_s=(-10.0, 0.0))
    tracker.update(0.0, [Seen("red", 5.0, 47.0)])
    states = tracker.update(3.4, [Seen("red", 17.7, 47.0)])
    assert sorted((s.id, s.seen) for s in states) == [(1, False), (2, True)]
    # down the belt from it, as far as the belt's pull explains, it is still its object
    states = tracker.update(3.5, [Seen("red", 16.7, 47.0), Seen("red", 4.0, 47.0)])
    assert sorted((s.id, s.seen) for s in states) == [(1, True), (2, True)]


def test_an_object_seen_as_it_landed_is_predicted_at_the_belts_speed():
    """A 10 cm/s belt's object first seen as it landed, at rest; the belt brings it to its
    speed in a few milliseconds, and it trails the line through its landing by 0.1 cm.

    Fitted through all its sightings it rode at 9.7 cm/s, and the intercept 0.8 s on aimed
    0.24 cm short: in the twin the jaws closed behind it and pushed it off their pads
    (``sim_conveyor --set belt.speed_cm_s=10 --set belt.arrivals.seed=49303``: blue2,
    first seen at rest at x = 18.00 cm, 9.69 cm/s, "pick failed"; every other object
    10.2 cm/s). The velocity is learned from the second sighting on.
    """
    tracker = Tracker(TrackingConfig(), belt_cm_s=(-10.0, 0.0))
    for t_s, x_cm in ((0.0, 18.0), (0.1, 17.1), (0.2, 16.1), (0.3, 15.1)):
        (state,) = tracker.update(t_s, [Seen("blue", x_cm, 46.2)])
    assert state.id == 1 and state.seen
    assert state.velocity_cm_s == pytest.approx([-10.0, 0.0], abs=0.02)
    assert tracker.tracks[1].position_at(1.1) == pytest.approx([7.1, 46.2], abs=0.02)
