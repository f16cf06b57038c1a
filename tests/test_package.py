import importlib

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
]


@pytest.mark.parametrize("name", PACKAGES)
def test_all_names_exist(name):
    """Every name in __all__ is importable (mink's __all__ once listed missing names)."""
    module = importlib.import_module(name)
    for attr in module.__all__:
        assert hasattr(module, attr), f"{name}.__all__ lists {attr!r}, which does not exist"


def test_py_typed_shipped():
    from pathlib import Path

    import mearm

    assert (Path(mearm.__file__).parent / "py.typed").is_file()
