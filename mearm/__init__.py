"""mearm: a vision-guided colour-sorting robot arm, for any hobby arm described as data.

The data flows one way: config → kinematics → (vision, ik) → hardware → sim → task.
See README.md. The top-level names are imported on first use, so ``import mearm`` (and
every command) loads only what it needs; ``mearm.analysis`` (SciPy, matplotlib) is
imported on its own.
"""

from __future__ import annotations

import os
import sys

# Run as a program (python -m mearm.sort, or the installed mearm script), a module imports
# what it needs before its main runs under the guard every command shares (mearm.cli.run):
# a Ctrl-C there is one line and exit 130 too, not Python's traceback. Only then: a
# program that imports mearm keeps Python's own handling
# (mearm.interrupts.guard_program_start). First, so that it holds from mearm's first
# line. ("-m" is Python's mark while it imports the packages of a -m module.)
if sys.argv[:1] == ["-m"] or os.path.basename(sys.argv[0] if sys.argv else "") == "mearm":
    from mearm.interrupts import guard_program_start

    guard_program_start()

import logging  # noqa: E402

# MuJoCo picks its OpenGL backend when it is first imported: without a display, render
# offscreen with Mesa's EGL (the physical twin's camera) unless the user chose one.
if sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")
# An arm's matrices are 3×3 to 6×n: OpenBLAS's thread pool only spins on them (measured:
# 0.2 s of CPU in a 0.9 s simulated sort, 0.07 s of it starting the pool at NumPy's
# import). One thread, unless the user chose; no effect if NumPy was imported first.
#: Whether the one thread is mearm's choice (the variable was unset): the programs this
#: process starts inherit it, which ``mearm bench`` undoes to time a peer as a shell runs it.
_OPENBLAS_THREAD_SET_HERE = "OPENBLAS_NUM_THREADS" not in os.environ
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from mearm._lazy import lazy_exports  # noqa: E402
from mearm.exceptions import __all__ as _error_names  # noqa: E402

__version__ = "0.2.0"

# A library logs and lets the application choose where it goes: without a handler of its
# own, Python's last-resort handler would print warnings (a retry, a fault) to stderr
# beside the one line each command prints for an error.
logging.getLogger(__name__).addHandler(logging.NullHandler())

#: Public name → the module that defines it; imported on first access.
_LAZY: dict[str, str] = {
    "Config": "mearm.config",
    "config_from_dict": "mearm.config",
    "load_config": "mearm.config",
    "ArmCommand": "mearm.hardware",
    "ArmState": "mearm.hardware",
    "ServoBus": "mearm.hardware",
    "open_bus": "mearm.backends",
    "IKResult": "mearm.ik",
    "IKTarget": "mearm.ik",
    "PdPij": "mearm.ik",
    "make_solver": "mearm.ik",
    "solve_ik": "mearm.ik",
    "ArmModel": "mearm.kinematics",
    "Chain": "mearm.kinematics",
    "dh_fk": "mearm.kinematics",
    "generate_urdf": "mearm.kinematics",
    "RunLog": "mearm.runlog",
    "RunLogContents": "mearm.runlog",
    "read_runlog": "mearm.runlog",
    "Sorter": "mearm.task",
    "SortReport": "mearm.task",
    "open_rig": "mearm.task",
    "random_scene": "mearm.task",
    "Calibration": "mearm.vision",
    "ColorDetector": "mearm.vision",
    "Detection": "mearm.vision",
    "open_camera": "mearm.backends",
    "SimArm": "mearm.sim",
    "SimCamera": "mearm.sim",
    "World": "mearm.sim",
    "WorldObject": "mearm.sim",
    # every error by name, each imported with its family (mearm.exceptions)
    **dict.fromkeys(_error_names, "mearm.exceptions"),
}

__all__ = sorted([*_LAZY, "__version__"])


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
