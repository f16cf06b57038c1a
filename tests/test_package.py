import importlib
import sys
from pathlib import Path

import pytest

PACKAGES = [
    "mearm",
    "mearm.kinematics",
    "mearm.ik",
    "mearm.vision",
    "mearm.hardware",
    "mearm.task",
    "mearm.analysis",
    "mearm.runlog",
    "mearm.view",
    "mearm.data",
    "mearm.tools",
]


@pytest.mark.parametrize("name", PACKAGES)
def test_all_names_exist(name):
    """Every name in __all__ is importable (mink's __all__ once listed missing names)."""
    module = importlib.import_module(name)
    for attr in module.__all__:
        assert hasattr(module, attr), f"{name}.__all__ lists {attr!r}, which does not exist"


def test_py_typed_shipped():
    import mearm

    assert (Path(mearm.__file__).parent / "py.typed").is_file()


# ------------------------------------------------------------- the wheel's contents


ROOT = Path(__file__).resolve().parent.parent
#: tools/ scripts that stay scripts of the checkout: they regenerate the docs' pictures.
DEVELOPER_SCRIPTS = {"screenshots.py", "calibration_pictures.py", "calibration_worth.py"}


def _pyproject() -> dict:
    import tomllib

    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def _lowest_python(specifier: str) -> tuple[int, int]:
    """The lowest Python 3.x a ``Requires-Python`` allows."""
    from packaging.specifiers import SpecifierSet

    spec = SpecifierSet(specifier)
    return next((3, minor) for minor in range(0, 40) if spec.contains(f"3.{minor}.99"))


def test_requires_python_is_what_the_dependencies_need():
    """``requires-python`` is the highest lower bound of the dependencies' own (installed
    versions' metadata), and this interpreter meets it."""
    from importlib.metadata import distribution

    from packaging.requirements import Requirement

    project = _pyproject()["project"]
    ours = _lowest_python(project["requires-python"])
    needed = {}
    for text in project["dependencies"] + project["optional-dependencies"]["analysis"]:
        name = Requirement(text).name
        requires = distribution(name).metadata.get("Requires-Python")
        needed[name] = _lowest_python(requires) if requires else (3, 0)
    assert ours == max(needed.values()), (ours, needed)
    assert sys.version_info[:2] >= ours


def test_every_subcommand_is_a_module_of_the_package():
    """Each subcommand names an importable module with a ``main``: nothing loads a file."""
    from mearm.__main__ import SUBCOMMANDS

    for name, (target, help_text) in SUBCOMMANDS.items():
        assert not target.endswith(".py"), name
        assert callable(importlib.import_module(target).main), name
        assert help_text and "\n" not in help_text


def test_tools_scripts_run_the_package_commands():
    """Every ``tools/X.py`` but the developer scripts only calls ``mearm.tools.X.main``."""
    for script in sorted((ROOT / "tools").glob("*.py")):
        if script.name in DEVELOPER_SCRIPTS:
            continue
        text = script.read_text()
        assert f"from mearm.tools.{script.stem} import main" in text, script.name
        assert len(text.splitlines()) < 15, f"{script.name} is not a thin script"


def test_data_links_point_at_the_top_level_folders():
    """In the checkout, mearm/data's links are the fixed top-level folders themselves."""
    from mearm import data

    assert data.source_checkout() == ROOT
    assert data.CONFIGS_DIR.resolve() == ROOT / "configs"
    assert data.URDF_DIR.resolve() == ROOT / "robot_description"
    assert data.FIRMWARE_DIR.resolve() == ROOT / "tools" / "arduino"
    assert (data.FIRMWARE_DIR / "mearm_servo" / "mearm_servo.ino").is_file()
    assert data.DOCS_DIR.resolve() == ROOT / "docs"


def test_config_by_name_is_the_packaged_file(tmp_path, monkeypatch):
    """``sim`` and ``sim.yaml`` name the shipped configs/sim.yaml from any folder; its
    calibration files resolve next to it."""
    from mearm.config import load_config
    from mearm.config.files import resolve_config_path

    monkeypatch.chdir(tmp_path)
    shipped = ROOT / "configs" / "sim.yaml"
    assert resolve_config_path("sim").resolve() == shipped
    assert resolve_config_path("sim.yaml").resolve() == shipped
    assert load_config("sim") == load_config(shipped)
    config = load_config("sim_mujoco_perspective")
    intrinsics = config.calibration.intrinsics_file
    assert intrinsics is not None
    assert Path(intrinsics).resolve() == ROOT / "configs" / "calibration" / "twin_intrinsics.yaml"


def test_a_file_wins_over_a_packaged_name(tmp_path, monkeypatch):
    from mearm.config import load_config

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sim").write_text("task:\n  scene: []\n")
    assert load_config("sim").task.scene == []
    assert load_config("sim.yaml").task.scene != []


def test_a_folder_named_as_a_shipped_config_does_not_hide_it(tmp_path, monkeypatch):
    """A folder is never a config: ``sim`` beside a folder ``sim/`` is still the shipped
    one; a folder with no shipped config of its name is refused as a folder."""
    from mearm.config import load_config
    from mearm.exceptions import ConfigError

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sim").mkdir()
    (tmp_path / "runs").mkdir()
    assert load_config("sim") == load_config(ROOT / "configs" / "sim.yaml")
    with pytest.raises(ConfigError, match="is a directory, not a config file"):
        load_config("runs")


@pytest.mark.parametrize("typed", ["sim/", "./sim", "./sim.yaml"])
def test_a_config_typed_as_a_path_is_never_the_shipped_one(tmp_path, monkeypatch, typed):
    """``--config sim/`` or ``./sim`` name a file or folder here, as typed: ``Path`` would
    drop the ``./`` and the ``/`` and load the shipped ``sim`` instead."""
    from mearm.cli import ArgumentParser, add_config_argument, config_from_args
    from mearm.exceptions import ConfigError

    monkeypatch.chdir(tmp_path)
    parser = ArgumentParser(prog="mearm sort")
    add_config_argument(parser)
    args = parser.parse_args(["--config", typed])
    with pytest.raises(ConfigError, match="config file not found"):
        config_from_args(args)
    (tmp_path / "sim").mkdir()
    with pytest.raises(ConfigError, match="is a directory|config file not found"):
        config_from_args(args)


@pytest.mark.parametrize("given", ["simm", "sim.yml", ".sim", "../sim"])
def test_an_unknown_config_name_lists_the_packaged_ones(tmp_path, monkeypatch, given):
    from mearm.config import load_config
    from mearm.exceptions import ConfigError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as info:
        load_config(given)
    message = str(info.value)
    assert "config file not found" in message
    if "/" not in given:
        assert f"no packaged config is named {given!r}" in message
        assert "lab, sim, sim_4colours" in message


@pytest.mark.parametrize(
    ("given", "meant"),
    [
        ("sim_mujuco", "'sim_mujoco'"),
        ("lab.yml", "'lab'"),
        ("sim_4colors.yaml", "'sim_4colours'"),
        ("nothing_like_it", None),
    ],
)
def test_a_mistyped_config_name_is_met_with_the_names_it_is_close_to(
    tmp_path, monkeypatch, given, meant
):
    """A typo's error says which packaged names were likely meant, before the whole list."""
    from mearm.config import load_config
    from mearm.exceptions import ConfigError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as info:
        load_config(given)
    message = str(info.value)
    if meant is None:
        assert "did you mean" not in message
    else:
        assert f"(did you mean {meant}" in message
        assert message.index("did you mean") < message.index("lab, sim, sim_4colours")


def test_unknown_config_name_on_the_command_line(tmp_path):
    """``mearm fk --config nope``: exit 2, one line naming the choices."""
    import subprocess

    r = subprocess.run(
        [sys.executable, "-m", "mearm", "fk", "--config", "nope", "--joints", "90,90,-90"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "(mearm --help lists them): lab, sim" in r.stderr


def test_analyze_out_without_the_extra_names_it(tmp_path, monkeypatch, capsys):
    """Without matplotlib, ``mearm analyze LOG --out DIR`` is one line naming the extra,
    exit 2, and nothing is written."""
    from mearm.__main__ import main

    monkeypatch.setattr(sys, "argv", sys.argv[:])  # the dispatcher renames the program
    log = tmp_path / "run.jsonl"
    scene = "task.scene=[{color: red, x: 0.0, y: 45.0}]"
    with pytest.raises(SystemExit) as info:
        main(["sort", "--config", "sim", "--set", scene, "--log", str(log)])
    assert info.value.code == 0
    capsys.readouterr()
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(SystemExit) as info:
        main(["analyze", str(log), "--out", str(tmp_path / "plots")])
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert err.count("\n") == 1 and "pip install 'mearm[analysis]'" in err
    assert not (tmp_path / "plots").exists()


def test_a_config_name_too_long_for_a_file_is_bad_input(tmp_path, monkeypatch):
    """A name longer than any file's (ENAMETOOLONG from the look for it): a ConfigError
    (exit 2, one line), not an unexpected OSError."""
    from mearm.config import load_config
    from mearm.exceptions import ConfigError

    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError):
        load_config("x" * 5000)


@pytest.mark.parametrize("typed", ["", "  "])
def test_an_empty_config_value_is_named_empty(typed):
    """``--config ''`` read as the current folder: ``.: is a directory``."""
    from mearm.cli import ArgumentParser, add_config_argument

    parser = ArgumentParser(prog="mearm sort")
    add_config_argument(parser)
    with pytest.raises(SystemExit) as info:
        parser.parse_args(["--config", typed])
    assert info.value.code == 2
