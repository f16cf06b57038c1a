"""Counting that cannot grow: an object the arm pushes is the same object wherever it ends.

On the kinematic rig (configs/sim.yaml) the first grip also moves another object, as the
twin's jaws push, drag or tip a neighbour: a few centimetres, across the table, or to the
image border. The sort follows it there and counts it once; only an object that no missing
one of its class can be is a new one (nothing caps the count: a real rig has no scene).
"""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
from conftest import ROOT

from mearm.config import SceneObject, load_config
from mearm.sim.kinematic.world import World, WorldObject
from mearm.task import Sorter, open_rig
from mearm.task.report import SortReport
from mearm.task.rig import Rig
from mearm.task.table_tracking import REST_LOOK_S, REST_LOOKS

pytestmark = pytest.mark.heavy

TWO_REDS = [SceneObject(color="red", x=-6.0, y=45.0), SceneObject(color="red", x=6.0, y=40.0)]


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "configs" / "sim.yaml")


def _sort_pushing(
    config, scene: list[SceneObject], push: Callable[[World, str], None], rig: Rig | None = None
) -> tuple[World, SortReport]:
    """Sort ``scene`` (on ``rig``, else one opened here); the first grip also calls
    ``push(world, gripped id)``."""
    if rig is None:
        with open_rig(config, scene) as opened:
            return _sort_pushing(config, scene, push, opened)
    bus, world = rig.bus, rig.world
    assert world is not None
    grip = bus._close_gripper
    pushed: list[str] = []

    def grip_and_push():
        result = grip()
        if not pushed:
            pushed.append(result.object_id)
            push(world, result.object_id)
        return result

    bus._close_gripper = grip_and_push
    return world, Sorter(config, rig.camera, bus, model=rig.model, echo=None).run()


def _other(world: World, gripped: str) -> WorldObject:
    return next(o for o in world.table_objects() if o.id != gripped)


def _slips_aside(dx_cm: float, dy_cm: float) -> Callable[[World, str], None]:
    """A push for :func:`_sort_pushing`: the gripped object leaves the jaws, moved by (dx, dy)."""

    def push(world: World, gripped: str) -> None:
        obj = world.held_object()
        assert obj is not None and obj.id == gripped
        obj.held = False
        obj.x_cm += dx_cm
        obj.y_cm += dy_cm

    return push


def _unconfirmed(rig: Rig) -> None:
    """Make ``rig`` confirm no release, as a real rig: a place cannot tell it held nothing."""
    bus = rig.bus
    release = bus._open_gripper

    def unconfirmed() -> None:
        release()
        bus.last_release = None

    bus._open_gripper = unconfirmed


@pytest.mark.parametrize("shift_cm", [(4.0, 3.0), (9.0, 0.0), (12.0, 6.0)])
def test_an_object_the_arm_pushes_is_the_same_object_wherever_it_ends(config, shift_cm):
    """The neighbour moved 5, 9 or 13.4 cm while the other red is picked (farther than any
    detection's jitter, and than an object dropped on the way lands from its path): still
    one of the two reds seen, picked from where it lies."""

    def push(world: World, gripped: str) -> None:
        other = _other(world, gripped)
        other.x_cm += shift_cm[0]
        other.y_cm += shift_cm[1]

    world, report = _sort_pushing(config, TWO_REDS, push)
    assert report.outcome.line() == "sorted 2 of 2 objects"
    assert len(world.in_bin("red")) == 2
    assert {r.object_id for r in report.routes} == {"red1", "red2"}


def test_an_object_pushed_to_the_image_border_is_counted_once(config):
    """Pushed half out of the picture (x = 19.5 cm, the right edge): the region cut by the
    border is that object, seen in part; it is left as cut, once, and nothing is left as
    no longer in the work area."""

    def push(world: World, gripped: str) -> None:
        other = _other(world, gripped)
        other.x_cm, other.y_cm = 19.5, 40.0

    _, report = _sort_pushing(config, TWO_REDS, push)
    assert report.outcome.line() == "sorted 1 of 2 objects (1 cut by the image border)"
    (skip,) = report.skipped
    assert skip.kind == "cut" and skip.reason.startswith("cut by the image border")


def test_an_object_of_another_class_does_not_explain_one_that_appeared(config):
    """A red pushed away while a blue is knocked off the table: the red is the red it was,
    the blue is left as no longer in the work area, and the count is the scene's."""
    scene = [*TWO_REDS, SceneObject(color="blue", x=0.0, y=52.0)]

    def push(world: World, gripped: str) -> None:
        red = next(o for o in world.table_objects() if o.color == "red" and o.id != gripped)
        blue = next(o for o in world.table_objects() if o.color == "blue")
        red.x_cm, red.y_cm = -14.0, 54.0
        if blue.id != gripped:
            blue.x_cm, blue.y_cm = 300.0, 300.0

    _, report = _sort_pushing(config, scene, push)
    out = report.outcome
    assert out.n_objects == 3 and out.seen == {"red": 2, "green": 0, "blue": 1}
    assert out.sorted["red"] == 2


def test_an_object_no_missing_one_can_be_is_a_new_one(config):
    """Nothing caps the count at the scene's: a green put on the table during the sort,
    when no green is missing, is a new object, and is sorted too."""

    def put(world: World, gripped: str) -> None:
        world.objects.append(WorldObject("green9", "green", 10.0, 50.0))

    world, report = _sort_pushing(config, TWO_REDS, put)
    assert report.outcome.line() == "sorted 3 of 3 objects"
    assert [o.id for o in world.in_bin("green")] == ["green9"]


def test_touching_objects_pushed_apart_are_two_objects(config):
    """Two reds overlapping (one region, which the detector cannot split) are pushed apart
    while a third is picked, on a rig that confirms no release (as a real one): the one
    come apart from the region is a new object, not the red just sorted dropped on the
    way; all three are sorted."""
    scene = [
        SceneObject(color="red", x=-8.0, y=45.0),
        SceneObject(color="red", x=0.0, y=45.0),
        SceneObject(color="red", x=1.2, y=45.0),
    ]

    def part(world: World, gripped: str) -> None:
        other = max(world.table_objects(), key=lambda o: o.x_cm)
        assert gripped == "red1" and other.id == "red3"
        other.x_cm = 3.5

    with open_rig(config, scene) as rig:
        _unconfirmed(rig)
        world, report = _sort_pushing(config, scene, part, rig=rig)
    assert report.outcome.line() == "sorted 3 of 3 objects"


def test_a_pick_that_pushes_its_object_aside_fails_and_goes_for_it_there(config):
    """The first grip closes on nothing: the jaws push their object 3.4 cm aside (as the
    twin's closing jaws tip a prism). On a rig that confirms no release, the look from over
    the bin sees it there, near where it lay, while the other red is where it was: the pick
    failed, and is tried again where it lies. Before, it counted, and so did the place."""
    with open_rig(config, TWO_REDS) as rig:
        _unconfirmed(rig)
        world, report = _sort_pushing(config, TWO_REDS, _slips_aside(3.0, 1.5), rig=rig)
    assert report.outcome.line() == "sorted 2 of 2 objects"
    assert len(world.in_bin("red")) == 2
    first = [r for r in report.routes if r.step in ("pick", "place")][:3]
    assert [(r.step, r.success) for r in first] == [
        ("pick", False),
        ("pick", True),
        ("place", True),
    ]
    assert len({r.object_id for r in first}) == 1
    why = re.fullmatch(
        r"the camera sees it (\d+\.\d) cm from where it lay: the closing jaws pushed it aside",
        first[0].why_failed or "",
    )
    assert why is not None, first[0].why_failed
    assert float(why.group(1)) == pytest.approx(3.35, abs=0.1)  # hypot(3, 1.5), as seen
    assert report.failed_picks == 1


def test_a_pick_that_pushes_its_object_half_out_of_the_picture_fails(config):
    """The closing jaws push their red 3 cm, to the image border's right edge (x = 19.7
    cm): seen in part, it is still no longer in the jaws. On a rig that confirms no
    release the pick fails, and the red is left as cut by the image border, never placed.
    Before, the pick counted, and so would a real rig's place."""
    scene = [SceneObject(color="red", x=16.7, y=40.0), SceneObject(color="blue", x=-6.0, y=45.0)]
    with open_rig(config, scene) as rig:
        _unconfirmed(rig)
        _, report = _sort_pushing(config, scene, _slips_aside(3.0, 0.0), rig=rig)
    assert report.outcome.line() == "sorted 1 of 2 objects (1 cut by the image border)"
    reds = [(r.step, r.success) for r in report.routes if r.object_id == "red1"]
    assert reds == [("pick", False)]
    assert "the closing jaws pushed it aside" in (report.routes[0].why_failed or "")
    (skip,) = report.skipped
    assert (skip.object_id, skip.kind) == ("red1", "cut")


def test_a_neighbour_the_jaws_push_is_not_taken_for_the_object_they_hold(config):
    """Two reds 3.4 cm apart; the jaws take one and push the other 2 cm. The look from over
    the bin sees a red near where the picked one lay, but the neighbour is missing from its
    place too: which is which is not known, so the pick stands (the next look follows the
    neighbour), and nothing held is put back."""
    scene = [SceneObject(color="red", x=-1.7, y=45.0), SceneObject(color="red", x=1.7, y=45.0)]

    def push(world: World, gripped: str) -> None:
        assert world.held_object() is not None
        _other(world, gripped).y_cm += 2.0

    with open_rig(config, scene) as rig:
        _unconfirmed(rig)
        world, report = _sort_pushing(config, scene, push, rig=rig)
    assert report.outcome.line() == "sorted 2 of 2 objects"
    picks = [r for r in report.routes if r.step == "pick"]
    assert [r.success for r in picks] == [True, True]


def test_the_held_object_seen_past_its_bin_is_not_taken_for_one_pushed(config):
    """A low camera places the held object, in the air over its bin, on the table past the
    bin's walls, and it may be near where it lay. Here an image of it (a red that is there
    while the jaws hold the first red, and gone once they open) lies 3 cm from the spot:
    the jaws let go over the bin, the look sees it gone, and the pick and place count."""
    scene = [SceneObject(color="red", x=-6.0, y=45.0), SceneObject(color="green", x=6.0, y=40.0)]
    with open_rig(config, scene) as rig:
        _unconfirmed(rig)
        bus, world = rig.bus, rig.world
        assert world is not None
        release = bus._open_gripper

        def grip_shows_an_image(world: World, gripped: str) -> None:
            held = world.held_object()
            assert held is not None and held.color == "red"
            world.objects.append(WorldObject("image", "red", held.x_cm + 3.0, held.y_cm))

        def release_clears_it() -> None:
            world.objects[:] = [o for o in world.objects if o.id != "image"]
            release()

        bus._open_gripper = release_clears_it
        world, report = _sort_pushing(config, scene, grip_shows_an_image, rig=rig)
    assert report.outcome.line() == "sorted 2 of 2 objects"
    assert report.failed_picks == 0
    assert [(r.step, r.success) for r in report.routes[:2]] == [("pick", True), ("place", True)]


def _rolling(rig: Rig, speed_cm_s: float, for_s: float) -> list[float]:
    """From the first grip on, the other red rolls along x, towards the middle, at
    ``speed_cm_s`` while the rig's time passes in holds, for ``for_s`` of them (a disc
    dropped on its side rolls on after it lands). Returns the holds' lengths from the
    first grip on [s]."""
    bus, world = rig.bus, rig.world
    assert world is not None
    hold, grip = bus._hold, bus._close_gripper
    holds: list[float] = []
    rolling: list[WorldObject] = []
    way: list[float] = []

    def grip_and_start() -> object:
        result = grip()
        if not rolling:
            rolling.append(_other(world, result.object_id))
            way.append(-1.0 if rolling[0].x_cm > 0 else 1.0)  # (it stays in view)
        return result

    def hold_and_roll(seconds: float) -> None:
        hold(seconds)
        if rolling:
            left = for_s - sum(holds)
            holds.append(seconds)
            if not rolling[0].held and left > 0:
                rolling[0].x_cm += way[0] * speed_cm_s * min(seconds, left)

    bus._close_gripper = grip_and_start
    bus._hold = hold_and_roll
    return holds


def test_an_object_found_moved_is_picked_once_it_has_stopped(config):
    """The other red rolls 7.2 cm over 1.8 s of the rig's time from the first grip on.
    The look from over the bin finds it moved: it is looked at again, half a second of
    table time later each, until it stays put; then picked where it stopped, once. Before,
    the pick went where the first look saw it, mid-roll, and missed."""
    with open_rig(config, TWO_REDS) as rig:
        holds = _rolling(rig, speed_cm_s=4.0, for_s=1.8)
        world = rig.world
        assert world is not None
        start = {o.id: o.x_cm for o in world.table_objects()}
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None).run()
    assert report.outcome.line() == "sorted 2 of 2 objects"
    assert report.failed_picks == 0
    picks = [r for r in report.routes if r.step == "pick"]
    rolled = next(o for o in start if o != picks[0].object_id)
    way = -1.0 if start[rolled] > 0 else 1.0
    assert picks[1].target.position_cm[0] == pytest.approx(start[rolled] + way * 7.2, abs=0.3)
    rests = sum(1 for s in holds if s == REST_LOOK_S)
    assert 2 <= rests <= REST_LOOKS
    assert report.motion is not None  # the waits are the run's time too
    assert report.motion.rest_s == pytest.approx(rests * REST_LOOK_S)
    assert f"; {rests * REST_LOOK_S:.1f} s waiting for a moved object to lie still)" in (
        report.motion.line()
    )


def test_an_object_still_rolling_after_the_last_look_again_is_picked_where_seen(config):
    """A red that rolls on for 3.5 s of table time at 3.2 cm/s (1.6 cm a half second: each
    look finds it moved) is looked at again at most ``REST_LOOKS`` times in a row; then the
    sort goes on, and sorts both."""
    with open_rig(config, TWO_REDS) as rig:
        holds = _rolling(rig, speed_cm_s=3.2, for_s=3.5)
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None).run()
    runs, run = [], 0
    for s in holds:
        run = run + 1 if s == REST_LOOK_S else 0
        runs.append(run)
    assert max(runs) == REST_LOOKS, holds
    assert report.outcome.line() == "sorted 2 of 2 objects"
