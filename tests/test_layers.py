"""The package's structure: data flows one way, from the commands down to the config.

Every ``import`` of a mearm module counts, wherever it stands (module level, inside a
function, under ``TYPE_CHECKING``): a name taken from a package's ``__init__`` counts as
taken from the module that defines it. No two modules import each other, directly or
round a circle, and no module imports one of a higher layer (:data:`LAYERS`).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

from conftest import ROOT
from package_source import package_modules

PACKAGE = ROOT / "mearm"

#: Low to high: a module may import its own layer and those below, never one above.
LAYERS: tuple[tuple[str, ...], ...] = (
    (
        "mearm.errors", "mearm._lazy", "mearm.fileio", "mearm.interrupts", "mearm.yamlio",
        "mearm.data",
    ),
    ("mearm.config",),
    ("mearm.kinematics", "mearm.runlog", "mearm.cli"),
    ("mearm.ik", "mearm.vision", "mearm.hardware"),
    ("mearm.sim", "mearm.view", "mearm.analysis", "mearm.dataset"),
    ("mearm.backends",),
    ("mearm.task",),
    (
        "mearm.sort", "mearm.detect", "mearm.fk", "mearm.analyze", "mearm.experiment",
        "mearm.maker", "mearm.tools", "mearm.__main__", "mearm.envs", "mearm.learn",
        "mearm.exceptions",  # every error by name, for users: it names all the layers'
    ),
)  # fmt: skip


def _name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_name(p): p for p in PACKAGE.rglob("*.py")}


@functools.cache
def _trees() -> dict[Path, ast.Module]:
    """Each module's syntax, as parsed once per process for every scan of the package."""
    return {module.path: module.tree for module in package_modules()}


def _tree(name: str) -> ast.Module:
    return _trees()[MODULES[name]]


def _module(dotted: str) -> str:
    """The module a dotted name lives in (a module, or the nearest enclosing one)."""
    while dotted not in MODULES:
        if "." not in dotted:
            raise AssertionError(f"{dotted} is no mearm module")
        dotted = dotted.rpartition(".")[0]
    return dotted


@functools.cache
def _reexports(package: str) -> dict[str, str]:
    """Names a package's ``__init__`` takes from its modules: name → module.

    Those it imports, and those it imports lazily (:func:`mearm._lazy.lazy_exports`: a
    dict of names to module names), so that an import through either is an arrow.
    """
    out = {}
    for node in ast.walk(_tree(package)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("mearm"):
            for alias in node.names:
                out[alias.asname or alias.name] = _module(str(node.module))
        elif isinstance(node, (ast.Assign, ast.AnnAssign)) and isinstance(node.value, ast.Dict):
            for key, value in zip(node.value.keys, node.value.values, strict=True):
                if (
                    isinstance(key, ast.Constant)
                    and isinstance(value, ast.Constant)
                    and isinstance(value.value, str)
                    and value.value.startswith("mearm.")
                ):
                    out[str(key.value)] = _module(value.value)
    return out


def test_lazy_exports_are_followed():
    """A name a package exports lazily leads to the module that defines it."""
    assert _reexports("mearm.vision")["detect_markers"] == "mearm.vision.aruco"


def _arrows(name: str) -> set[str]:
    """The mearm modules ``name`` imports, names followed to where they are defined."""
    out = set()
    for node in ast.walk(_tree(name)):
        if isinstance(node, ast.Import):
            out |= {_module(a.name) for a in node.names if a.name.startswith("mearm")}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if not node.module.startswith("mearm"):
                continue
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                if full in MODULES:
                    out.add(full)
                    continue
                target = _module(node.module)
                if target != name and MODULES[target].name == "__init__.py":
                    target = _reexports(target).get(alias.name, target)
                out.add(target)
    out.discard(name)
    return out


@functools.cache
def graph() -> dict[str, set[str]]:
    """Every module's arrows; built when a test asks (not in every worker's collection)."""
    return {name: _arrows(name) for name in MODULES}


def _layer(name: str) -> int:
    if name.rpartition(".")[2] == "__main__":
        return len(LAYERS) - 1  # an entry point is a command
    for k, members in enumerate(LAYERS):
        if any(name == m or name.startswith(m + ".") for m in members):
            return k
    raise AssertionError(f"{name} is in no layer: add it to LAYERS")


def test_every_module_has_a_layer():
    for name in MODULES:
        if name != "mearm":  # the package's own lazy exports reach every layer
            _layer(name)


def test_no_import_circles():
    """Tarjan's strongly connected components of the import graph: each one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph()[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(graph()):
        if v not in index:
            visit(v)
    assert circles == []


def test_no_module_imports_a_higher_layer():
    """config, kinematics, ik, vision and hardware never import the simulators, the
    backends, the task or the commands; nothing imports a command."""
    up = sorted(
        f"{a} -> {b}"
        for a, targets in graph().items()
        if a != "mearm"
        for b in targets
        if b != "mearm" and _layer(b) > _layer(a)
    )
    assert up == []


def test_each_simulator_stands_alone():
    """The kinematic simulator and the twin import nothing of each other (their shared
    errors, conveyor belt and table's collision model aside); the virtual Uno drives the
    kinematic arm and nothing of the twin."""
    kinds = {"mearm.sim.kinematic": (), "mearm.sim.twin": (),
             "mearm.sim.virtual_uno": ("mearm.sim.kinematic",)}  # fmt: skip
    crossing = sorted(
        f"{a} -> {b}"
        for kind, allowed in kinds.items()
        for a, targets in graph().items()
        if a == kind or a.startswith(kind + ".")
        for b in targets
        if b.startswith("mearm.sim.")
        and b not in ("mearm.sim.errors", "mearm.sim.belt", "mearm.sim.table_collision")
        and not (b == kind or b.startswith(kind + "."))
        and not any(b == k or b.startswith(k + ".") for k in allowed)
    )
    assert crossing == []


def test_a_backend_kind_of_ones_own_sorts_without_touching_the_package(monkeypatch):
    """A toy servo bus registered here is what the rig opens; the sort runs on it."""
    from mearm import backends  # noqa: PLC0415
    from mearm.backends import bus_kinds, open_bus, register_bus  # noqa: PLC0415
    from mearm.config import Config, SceneObject  # noqa: PLC0415
    from mearm.sim.kinematic.servo_bus import SimArm  # noqa: PLC0415
    from mearm.task import Sorter, open_rig  # noqa: PLC0415

    class ToyBus(SimArm):
        """The kinematic arm, counting what it is sent."""

        moves = 0

        def _send_move(self, command, pulses_us):  # noqa: ANN001, ANN202
            ToyBus.moves += 1
            super()._send_move(command, pulses_us)

    monkeypatch.setattr(backends, "_BUSES", dict(backends._BUSES))  # gone after the test
    register_bus("toy", lambda config, world, port: ToyBus(config, world))
    assert "toy" in bus_kinds()
    config = Config()
    config = config.model_copy(update={"servo": config.servo.model_copy(update={"backend": "toy"})})
    scene = [SceneObject(color="red", x=0.0, y=45.0), SceneObject(color="blue", x=-8.0, y=40.0)]
    with open_rig(config, scene) as rig:
        assert isinstance(rig.bus, ToyBus)
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None).run()
    assert report.sorted_per_class() == {"red": 1, "blue": 1} and ToyBus.moves > 20
    with open_rig(config, scene) as rig:
        assert isinstance(open_bus(config, rig.world), ToyBus)


def test_a_simulator_of_ones_own_is_what_the_rig_opens(monkeypatch):
    """A toy simulator registered here opens the rig's parts; the sort runs on them."""
    import contextlib  # noqa: PLC0415

    from mearm import backends  # noqa: PLC0415
    from mearm.backends import RigParts, register_simulator, simulator_kinds  # noqa: PLC0415
    from mearm.config import Config, SceneObject  # noqa: PLC0415
    from mearm.sim.kinematic.servo_bus import SimArm  # noqa: PLC0415
    from mearm.sim.kinematic.table_camera import SimCamera  # noqa: PLC0415
    from mearm.task import Sorter, open_rig  # noqa: PLC0415

    closed = []

    @contextlib.contextmanager
    def toy(config, scene):  # noqa: ANN001, ANN202
        world = backends.table_world(config, scene)
        bus = SimArm(config, world)
        yield RigParts(
            world, SimCamera(config, world), bus, lambda: {"red": len(world.in_bin("red"))}
        )
        closed.append(bus)

    monkeypatch.setattr(backends, "_SIMULATORS", dict(backends._SIMULATORS))  # gone after
    register_simulator("toy", toy)
    assert "toy" in simulator_kinds()
    config = Config().model_copy(update={"simulator": "toy"})
    with open_rig(config, [SceneObject(color="red", x=0.0, y=45.0)]) as rig:
        assert rig.simulated and rig.world is not None
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None).run()
    assert report.sorted_per_class() == {"red": 1} and closed == [rig.bus]
