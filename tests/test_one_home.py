"""One fact, one home: a unit, a rule or a naming scheme is defined once and used elsewhere.

Units are defined once (:data:`HOMES`). A yaw becomes a quaternion in one function
(``kinematics/mjspec.py: yaw_quat``); the table's body and geom names (``bin_<class>``,
``obj_<id>``) are made and read back in one module (``kinematics/bodies.py``); and every
answer to "is it in its bin" uses the bin's rule, ``ColorClass.in_bin``.
"""

from __future__ import annotations

import ast
import functools

import pytest
from package_source import package_modules, syntax

#: Facts that must have exactly one definition, and its module.
HOMES = {"M_PER_CM": "mearm/kinematics/chain.py", "RAD_PER_DEG": "mearm/kinematics/chain.py"}


@functools.cache
def _top_level_names() -> dict[str, list[str]]:
    """Name → every module of the package that assigns it at its top level."""
    where: dict[str, list[str]] = {}
    for module in package_modules():
        for node in module.tree.body:
            targets = node.targets if isinstance(node, ast.Assign) else []
            if isinstance(node, ast.AnnAssign):
                targets = [node.target]
            for t in targets:
                if isinstance(t, ast.Name):
                    where.setdefault(t.id, []).append(module.where)
    return where


@pytest.mark.parametrize("name", sorted(HOMES))
def test_a_unit_is_defined_once(name: str) -> None:
    assert _top_level_names().get(name) == [HOMES[name]]


def test_the_scan_sees_definitions() -> None:
    """It finds an assignment where one is and none where none is (so the test can fail)."""
    names = _top_level_names()
    assert "mearm/kinematics/chain.py" in names["M_PER_CM"]
    assert "NOT_A_NAME_ANYWHERE_IN_MEARM" not in names


# --------------------------------------------------------------------------- yaw → quaternion

#: The one module that turns a yaw into a quaternion.
YAW_HOME = "mearm/kinematics/mjspec.py"


def _half_angle_call(node: ast.expr, fn: str) -> str | None:
    """``ast.dump`` of the angle when ``node`` is ``<x>.fn(angle / 2)`` (or ``fn(angle / 2)``)."""
    if not (isinstance(node, ast.Call) and len(node.args) == 1):
        return None
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
    arg = node.args[0]
    halved = (
        isinstance(arg, ast.BinOp)
        and isinstance(arg.op, ast.Div)
        and isinstance(arg.right, ast.Constant)
        and arg.right.value == 2
    )
    return ast.dump(arg.left) if name == fn and halved else None  # type: ignore[union-attr]


def _yaw_quaternions(source: str | ast.Module) -> int:
    """How many ``[cos(a / 2), 0, 0, sin(a / 2)]`` (a turn about z) a source writes out."""
    n = 0
    for node in ast.walk(syntax(source)):
        if not isinstance(node, ast.List | ast.Tuple):
            continue
        for k in range(len(node.elts) - 3):  # also inside a longer list (a pose's 7)
            w = _half_angle_call(node.elts[k], "cos")
            n += w is not None and w == _half_angle_call(node.elts[k + 3], "sin")
    return n


def _modules() -> list[tuple[str, ast.Module]]:
    """(path, syntax) of every module of the package, parsed once per process."""
    return [(m.where, m.tree) for m in package_modules()]


def test_a_yaw_becomes_a_quaternion_in_one_place() -> None:
    """Only ``yaw_quat`` writes the quaternion of a turn about the vertical."""
    where = {path: n for path, tree in _modules() if (n := _yaw_quaternions(tree))}
    assert where == {YAW_HOME: 1}


@pytest.mark.parametrize(
    ("source", "found"),
    [
        ("q = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]", 1),
        ("q = (cos(t / 2), 0, 0, sin(t / 2))", 1),
        ("d.qpos[0:7] = [*centre, math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]", 1),
        ("q = [math.cos(a / 2), 0, 0, math.sin(b / 2)]", 0),
        ("p = [a / 2 * math.cos(t0), a / 2 * math.sin(t0), dd]", 0),
    ],
)
def test_the_yaw_scan_finds_a_written_out_quaternion(source: str, found: int) -> None:
    """It finds a turn about z written out, and not two different angles (so it can fail)."""
    assert _yaw_quaternions(source) == found


# --------------------------------------------------------------------------- class ↔ geom name

#: The one module that makes and reads the table's body and geom names.
NAMES_HOME = "mearm/kinematics/bodies.py"
PREFIXES = ("bin_", "obj_")


def _name_literals(source: str | ast.Module) -> list[int]:
    """Lines that spell a table name's prefix: ``"obj_"``, ``f"bin_{c}"``, ``"bin_red_…"``."""
    lines = []
    for node in ast.walk(syntax(source)):
        if isinstance(node, ast.JoinedStr) and node.values:
            first = node.values[0]
            text = first.value if isinstance(first, ast.Constant) else ""
            if isinstance(text, str) and text.startswith(PREFIXES):
                lines.append(node.lineno)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            if node.value in PREFIXES or node.value.startswith(("bin_" + "{", "obj_" + "{")):
                lines.append(node.lineno)
    return lines


def test_table_names_are_made_and_read_in_one_module() -> None:
    """``bin_name``/``class_of`` and ``object_name``/``object_of`` are the only spelling."""
    where = {
        path: lines
        for path, tree in _modules()
        if path != NAMES_HOME and (lines := _name_literals(tree))
    }
    assert where == {}


@pytest.mark.parametrize(
    ("source", "found"),
    [
        ('name = f"obj_{oid}"', True),
        ('body = model.body(f"bin_{name}_wall_px")', True),
        ('if name.startswith("obj_"): pass', True),
        ('key = "bin_cm"', False),
        ('kind = "bin_unreachable"', False),
    ],
)
def test_the_name_scan_finds_a_spelled_name(source: str, found: bool) -> None:
    """A made or parsed table name is found, a field name is not (so the test can fail)."""
    assert bool(_name_literals(source)) == found


def test_a_bin_name_reads_back_to_its_class() -> None:
    """``class_of`` undoes ``bin_name`` for the bin, its floor and its walls; others are None."""
    from mearm.kinematics.bodies import bin_name, class_of, object_name, object_of

    for cls in ("red", "dark_blue"):
        for part in (None, "floor", "wall_px", "wall_ny"):
            assert class_of(bin_name(cls, part)) == cls
    assert class_of("obj_red1") is None and class_of("table") is None
    assert object_of(object_name("red1")) == "red1" and object_of("bin_red") is None


# --------------------------------------------------------------------------- bin membership

#: The rule of membership, and the one module that may define it.
MEMBERSHIP_HOME = "mearm/config/classes.py"


def _membership_functions(source: str | ast.Module) -> list[tuple[str, bool]]:
    """Each function named like a membership test (``*in_bin*``), and whether it asks one.

    Asking: calling ``.in_bin`` or a method that does (``.objects_in_bin``, a counter's).
    """
    out = []
    for node in ast.walk(syntax(source)):
        if isinstance(node, ast.FunctionDef) and "in_bin" in node.name:
            uses = any(
                isinstance(n, ast.Call)
                and isinstance(n.func, ast.Attribute)
                and "in_bin" in n.func.attr
                for n in ast.walk(node)
            )
            out.append((node.name, uses))
    return out


def test_every_bin_membership_uses_the_class_rule() -> None:
    """The simulators' answers (``World.in_bin``, ``TwinArm.objects_in_bin``) ask the class."""
    found = {path: f for path, tree in _modules() if (f := _membership_functions(tree))}
    assert ("in_bin", False) in found.pop(MEMBERSHIP_HOME)  # the rule itself
    assert {"mearm/sim/kinematic/world.py", "mearm/sim/twin/twin_bus.py"} <= set(found)
    own = {path: [name for name, uses in f if not uses] for path, f in found.items()}
    assert {path: names for path, names in own.items() if names} == {}


def test_the_membership_scan_tells_a_rule_from_its_use() -> None:
    """A function with its own geometry is found; one that asks the class is not."""
    own = "def in_bin(self, x, y):\n    return abs(x - self.x) < self.half\n"
    uses = "def objects_in_bin(self):\n    return [o for o in self.o if c.in_bin(o.x, o.y)]\n"
    assert _membership_functions(own) == [("in_bin", False)]
    assert _membership_functions(uses) == [("objects_in_bin", True)]
