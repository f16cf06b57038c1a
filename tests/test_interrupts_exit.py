"""Ctrl-C at a command's end: the status it chose, and no "Exception ignored" block.

- A Ctrl-C while the interpreter shut down after ``sys.exit`` (MuJoCo's renderers and
  their EGL contexts are freed there) ended the process by SIGINT, status -2, though
  the work was complete: Python sets the signal's default action back before it frees
  what is left (:func:`mearm.interrupts.clear_python_exit_by_signal`).
- A Ctrl-C inside MuJoCo's ``Renderer.close`` left the EGL context it had destroyed
  still named; the renderer's ``__del__`` destroyed it again at exit and printed an
  "Exception ignored ... EGL_BAD_CONTEXT" block after "interrupted"
  (:func:`mearm.sim.twin.frame_drawer.close_renderer`), in the twin's drawer and in its
  Gymnasium environment alike.

Each child runs a command under :func:`mearm.cli.run` and sends itself a real SIGINT at
the moment in question.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest
from conftest import ROOT

#: A command that chose exit 3, then a Ctrl-C in an exit function (EGL's display is
#: terminated in one) and one while the interpreter frees the module's objects.
CTRL_C_AT_SHUTDOWN = textwrap.dedent(
    """
    import atexit, os, signal
    from mearm.cli import run

    def ctrl_c():
        os.kill(os.getpid(), signal.SIGINT)

    class FreedAtShutdown:
        def __del__(self):
            ctrl_c()

    atexit.register(ctrl_c)
    left_for_shutdown = FreedAtShutdown()
    run(lambda argv: 3)
    """
)

#: Sends a Ctrl-C inside MuJoCo's ``GLContext.free`` once traced
#: (``sys.settrace(ctrl_c_before_it_forgets)``): after ``eglDestroyContext``, before the
#: context is forgotten.
CTRL_C_IN_GL_FREE = textwrap.dedent(
    """
    import inspect, os, signal, sys
    from mujoco import egl
    from mearm.cli import run

    lines, first = inspect.getsourcelines(egl.GLContext.free)
    FORGETS = [first + i for i, line in enumerate(lines) if "self._context = None" in line]
    assert FORGETS, "MuJoCo's GLContext.free no longer reads as this test expects"

    def ctrl_c_before_it_forgets(frame, event, arg):
        if frame.f_code is not egl.GLContext.free.__code__:
            return None
        if event == "line" and frame.f_lineno == FORGETS[0]:
            sys.settrace(None)
            os.kill(os.getpid(), signal.SIGINT)
        return ctrl_c_before_it_forgets
    """
)

#: A command that draws with the twin's frame drawer and is stopped by a Ctrl-C inside its
#: close. It ends 0, "closed", if no Ctrl-C came.
CTRL_C_IN_CLOSE = CTRL_C_IN_GL_FREE + textwrap.dedent(
    """
    import mujoco
    from mearm.sim.twin.frame_drawer import TwinFrameSource

    MODEL = '<mujoco><worldbody><camera name="camera" pos="0 0 1"/></worldbody></mujoco>'

    def main(argv):
        model = mujoco.MjModel.from_xml_string(MODEL)
        drawer = TwinFrameSource(model, (64, 48), "camera", 0, False).open()
        sys.settrace(ctrl_c_before_it_forgets)
        drawer.close()
        sys.settrace(None)
        print("closed")
        return 0

    run(main)
    """
)

#: The twin's Gymnasium environment that rendered its pixels and its video frame (two
#: renderers), closed with a Ctrl-C inside the first renderer's free; then, if the
#: Ctrl-C did not end it, a second close. It prints "closed" if no Ctrl-C came.
CTRL_C_IN_ENV_CLOSE = CTRL_C_IN_GL_FREE + textwrap.dedent(
    """
    from mearm.envs import TwinEnv

    def main(argv):
        env = TwinEnv(task="pick_place", image_size=(16, 16), render_mode="rgb_array")
        env.reset(seed=1)
        env.render()
        sys.settrace(ctrl_c_before_it_forgets)
        try:
            env.close()
        finally:
            sys.settrace(None)
            env.close()  # what the Ctrl-C left: the other renderer, the twin; none twice
        print("closed")
        return 0

    run(main)
    """
)


def _child(code: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120,  # a hang: the failure
    )  # fmt: skip


def test_a_ctrl_c_while_the_interpreter_shuts_down_keeps_the_chosen_status() -> None:
    """Exit 3, as the command chose, nothing on stderr; not death by SIGINT (-2)."""
    out = _child(CTRL_C_AT_SHUTDOWN)
    assert (out.returncode, out.stderr) == (3, ""), out.stderr[-2000:]


@pytest.mark.parametrize(
    "code",
    [
        pytest.param(CTRL_C_IN_CLOSE, id="drawer"),
        pytest.param(CTRL_C_IN_ENV_CLOSE, id="env", marks=pytest.mark.heavy),
    ],
)
def test_a_ctrl_c_inside_a_renderers_close_is_taken_after_it(code: str) -> None:
    """The close completes, then the Ctrl-C stops the command: exit 130 and its one line,
    no "Exception ignored ... EGL_BAD_CONTEXT" at exit. The twin's Gymnasium environment
    freed its renderers by hand, and printed that block (``env``)."""
    out = _child(code)
    lines = out.stderr.splitlines()
    assert (out.returncode, out.stdout, len(lines)) == (130, "", 1), out.stderr[-3000:]
    assert lines[0].endswith(": interrupted"), lines
