"""The way home: the one checked way the sort and the camera's check park the arm.

Home is gone to along a straight line in joint space (no solve, inside the limits) when
that line is clear of the bins, the table and the objects in the collision model's
world (:meth:`~mearm.kinematics.collision.CollisionModel.first_contact`). Where it is
not, the TCP rises to the safe height first; where the line from there is not clear
either, it goes over at that height to above home (a planned, checked route) and comes
down to it, in joint space or, where that line is not clear, straight down. Where none
of these is clear, nothing more is sent: :class:`~mearm.task.execute.CollisionError`
(``not parked: the way home …; the arm stays where it is``).
"""

from __future__ import annotations

from mearm.task.execute import CollisionError, Executor
from mearm.task.plan import Planner
from mearm.task.route import Route


def go_home(ex: Executor, planner: Planner, *, closed: bool, keep_grip: bool = False) -> None:
    """Take the arm home the checked way (the module docstring).

    The collision model's world (``planner.collision``) must be the table as it is now:
    the caller sets it (the objects, the jaws' opening, what they hold).

    Args:
        ex: What sends the moves, its last confirmed pose the start.
        planner: The planner, with the collision model the moves are checked against.
        closed: Whether the gripper is closed on the way.
        keep_grip: Keep the gripper as it is at home (parking while holding an object:
            it is not dropped); otherwise it opens at home.

    Raises:
        CollisionError: no way home is clear; nothing of it was sent past the last
            clear leg (a rise or the way over), and the arm stays there.
    """
    collision = planner.collision
    assert collision is not None, "the way home is checked: the planner needs its model"
    model = planner.model
    contact = collision.first_contact(ex.joint_path(model.home))
    if contact is not None:
        # up to the safe height first, where the straight way home is clear
        up = planner.way_up(ex.q_now(), ex.ee_now_cm())
        safe = float(up.target.position_cm[2])
        if up.planned:
            ex.stream(up, "travel", closed=closed)
        contact = collision.first_contact(ex.joint_path(model.home))
        if contact is not None:
            # a home that hangs the jaws low between a bin's walls (the paper arm's,
            # over the red bin) is come down to from over it: the straight way there
            # from over another bin sags onto the wall (the twin's belt, seed 997000)
            home = planner.home_target()
            over = Route("", "", "home", 1, planner.above_target(
                home, max(0.0, safe - float(home.position_cm[2]))
            ))  # fmt: skip
            if planner.plan(over, ex.q_now()).planned:
                ex.stream(over, "travel", closed=closed)
                contact = collision.first_contact(ex.joint_path(model.home))
            if contact is not None and over.planned:
                # walls grown tall for many objects (15 reds: 16 cm) rise beside the
                # jaws hung at home: the straight line in joint space down from over
                # home swings them into the wall; the TCP comes straight down instead
                down = Route("", "", "home", 1, home)
                if planner.plan(down, ex.q_now()).planned:
                    ex.stream(down, "travel", closed=closed)
                    contact = collision.first_contact(ex.joint_path(model.home))
        if contact is not None:
            chain = model.chain
            raise CollisionError(
                "not parked: the way home "
                + contact.describe(chain.names, chain.scale)
                + "; the arm stays where it is"
            )
    ex.move_joints(model.home, "travel", closed=closed)
    ex.home_pose(closed=closed and keep_grip)
