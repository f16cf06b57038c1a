"""Render the meshcat view to a PNG in headless Chromium, driven over the DevTools protocol.

The browser loads the viewer page, whose WebSocket receives the whole scene from the
server (the server replays its scene tree to every browser that connects). A plain
``chromium --screenshot`` may fire before everything is drawn: meshcat adds a textured
object only once its image has been decoded, which virtual time does not wait for. So
the page is driven over the DevTools protocol instead: the picture is taken once the
viewer has received the expected number of messages, holds the expected number of
objects, and has drawn two more frames; every call to the browser has the screenshot's
deadline, so a browser that stops answering is an error naming the step (a
:class:`ViewRunError`, exit 1, as is any failure of the browser once it runs; what the
caller gave, e.g. a size out of range, is a :class:`ViewInputError`, exit 2). WebGL runs on
SwiftShader, the CPU renderer, so no GPU or display is needed. A :class:`HeadlessBrowser`
kept running draws many pages, one tab each, for callers that take many pictures.

Nothing is left behind, whatever ends the screenshot: the browser runs in a process
group of its own, which is ended as a whole (its helper processes too), and its
temporary profile folder, which also holds every temporary file it makes, is removed —
on an error, on Ctrl-C, and on SIGTERM or SIGHUP, which unwind the screenshot
(:func:`_signals_unwind`) before they end the process as they would have.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import errno
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Awaitable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any, TypeVar

import tornado.websocket

from mearm.fileio import existing_ancestor, signal_ends_process, write_atomic
from mearm.view.errors import BrowserNotFoundError, ViewError, ViewInputError, ViewRunError

#: Executable names tried in order; ``$MEARM_CHROMIUM`` (a path or name) comes first.
BROWSER_NAMES: tuple[str, ...] = (
    "chromium",
    "chromium-browser",
    "google-chrome",
    "google-chrome-stable",
)

#: Flags for a quiet, reproducible headless run: no sandbox (containers, root), CPU
#: WebGL, no network traffic of its own; the profile is a fresh temporary folder.
HEADLESS_FLAGS: tuple[str, ...] = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-quic",
    "--enable-unsafe-swiftshader",
    "--use-angle=swiftshader",
    "--hide-scrollbars",
    "--remote-debugging-address=127.0.0.1",
    "--remote-debugging-port=0",
)

#: Signals that end the process by default, which unwind a screenshot first (SIGINT
#: already does: it raises KeyboardInterrupt).
UNWIND_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)
#: How long the browser may take to quit when asked before it is killed [s].
QUIT_TIMEOUT_S = 10.0
#: The browser's window [px]. Each page sets its own size (a device-metrics override,
#: larger or smaller than the window), so the window is never the picture's size: headless
#: Chromium keeps 87 px of a window's height for its (undrawn) toolbars and a window at
#: least 500 px wide, so a window 87 px high or less has no page area, draws no frame,
#: and its screenshot never comes (a 64x64 window hung; Chromium 156).
WINDOW_PX = (1280, 800)
#: Why a PNG is not written that is the storage failing, not the path given (which is
#: bad input, as for every writer of the project): a full disk or quota, a file too
#: large, an I/O error.
STORAGE_FAILURES = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO})

_T = TypeVar("_T")

# [socket state, messages received, objects drawn under /meshcat]. meshcat keeps each
# object in a scene-tree node named "<object>", created only once the object is added
# (for a textured one, after its image has loaded).
_STATE_JS = """(() => {
  const v = window.viewer;
  if (!v || !v.connection || !v.scene_tree) return null;
  let objects = 0;
  const walk = (node) => {
    for (const [name, child] of Object.entries(node.children)) {
      if (name === "<object>") objects += 1;
      walk(child);
    }
  };
  const root = v.scene_tree.children["meshcat"];
  if (root) walk(root);
  return [v.connection.readyState, v.num_messages_received, objects];
})()"""
_TWO_FRAMES_JS = (
    "new Promise(r => requestAnimationFrame(() => requestAnimationFrame(() => r(true))))"
)


@dataclass(frozen=True)
class SceneCounts:
    """What a browser must have received before the picture is taken.

    Attributes:
        messages: Commands the server replays to a new browser.
        objects: Objects among them under ``/meshcat`` (the scene's own root).
    """

    messages: int
    objects: int


def find_browser() -> str:
    """Path of a Chromium-family browser: ``$MEARM_CHROMIUM`` if set, else one on PATH.

    A ``$MEARM_CHROMIUM`` that names no executable is refused, not passed over for
    another browser: whoever set it chose that browser, and pictures from a different
    one would be taken without a word.

    Raises:
        BrowserNotFoundError: ``$MEARM_CHROMIUM`` is set and not found, or it is unset
            and none is on PATH.
    """
    override = os.environ.get("MEARM_CHROMIUM")
    if override:
        path = shutil.which(override)
        if path is None:
            raise BrowserNotFoundError((override,), from_env=True)
        return path
    for name in BROWSER_NAMES:
        path = shutil.which(name)
        if path:
            return path
    raise BrowserNotFoundError(BROWSER_NAMES)


class _DevTools:
    """A minimal DevTools-protocol client over the browser's WebSocket."""

    def __init__(self, conn: tornado.websocket.WebSocketClientConnection, deadline: float):
        self.conn = conn
        self.deadline = deadline
        self.next_id = 0

    async def call(
        self,
        step: str,
        method: str,
        session: str | None = None,
        *,
        refused: type[ViewError] = ViewRunError,
        **params: Any,
    ) -> dict:
        """``method``'s result; a :class:`ViewRunError` naming ``step`` past the deadline.

        A browser that stops drawing never answers a call that waits for a frame. A
        method the browser answers with an error raises ``refused``: a failure of the
        run, unless what it refused is the caller's (an address it cannot load).
        """
        call = self._call(method, session, params, refused)
        return await _by_deadline(call, step, method, self.deadline)

    async def _call(
        self, method: str, session: str | None, params: dict[str, Any], refused: type[ViewError]
    ) -> dict:
        self.next_id += 1
        msg: dict[str, Any] = {"id": self.next_id, "method": method, "params": params}
        if session is not None:
            msg["sessionId"] = session
        await self.conn.write_message(json.dumps(msg))
        while True:
            raw = await self.conn.read_message()
            if raw is None:
                raise ViewRunError(f"the browser closed its DevTools connection during {method}")
            reply = json.loads(raw)
            if reply.get("id") == self.next_id:
                if "error" in reply:
                    raise refused(f"DevTools {method} failed: {reply['error'].get('message')}")
                return reply.get("result", {})


class _Unwind(SystemExit):  # noqa: N818 - not an Exception: nothing may catch it on the way
    """A signal that ends the process arrived: unwind, then end as it would have.

    A :class:`SystemExit`: asyncio's event loop re-raises it from a callback, where any
    other exception (even a bare :class:`BaseException`) is logged and swallowed, and the
    signal with it (a SIGTERM that landed in one of tornado's callbacks was lost, and the
    screenshot ran on to its timeout).
    """

    def __init__(self, signum: int):
        self.signum = signum
        super().__init__(signum)


@contextlib.contextmanager
def _signals_unwind() -> Iterator[None]:
    """Let SIGTERM and SIGHUP unwind the block, then end the process as they would have.

    Inside the block they raise, so every ``finally`` runs; on leaving, the signal is
    taken again with the handler it had (the process ends). Only a signal whose handler
    ends the process is caught, and only from the main thread (only it may install
    handlers); elsewhere the block runs as it is.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def unwind(signum: int, frame: FrameType | None) -> None:
        raise _Unwind(signum)

    previous = {}
    for sig in UNWIND_SIGNALS:
        if signal_ends_process(sig):
            previous[sig] = signal.signal(sig, unwind)
    try:
        yield
    except _Unwind as exc:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        previous = {}
        signal.raise_signal(exc.signum)
        raise  # not reached: the signal ends the process
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _end_group(proc: subprocess.Popen) -> None:
    """End the browser and every process of its group: asked first, then killed."""
    try:
        os.killpg(proc.pid, signal.SIGTERM)
    except ProcessLookupError:
        pass
    try:
        proc.wait(timeout=QUIT_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        pass
    try:  # helpers that outlived the browser, and the browser if it did not quit
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def _devtools_url(profile: Path, proc: subprocess.Popen, deadline: float) -> str:
    """The browser's DevTools WebSocket address, from the file it writes on start."""
    port_file = profile / "DevToolsActivePort"
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise ViewRunError(f"the browser exited ({proc.returncode}) before it was ready")
        try:
            port, path = port_file.read_text().split()[:2]
            return f"ws://127.0.0.1:{port}{path}"
        except (OSError, ValueError):
            time.sleep(0.05)
    raise ViewRunError("the browser did not open its DevTools port in time")


async def _by_deadline(awaitable: Awaitable[_T], step: str, what: str, deadline: float) -> _T:
    """``awaitable``'s result; a :class:`ViewRunError` naming ``step`` once ``deadline`` passes."""
    start = time.monotonic()
    try:
        return await asyncio.wait_for(awaitable, max(0.0, deadline - start))
    except TimeoutError:
        raise ViewRunError(
            f"the browser did not {step} in time: {what} got no answer in "
            f"{time.monotonic() - start:.0f} s (the screenshot's timeout_s ran out)"
        ) from None


async def _capture(
    ws_url: str, url: str, size: tuple[int, int], expect: SceneCounts | None, deadline: float
) -> bytes:
    """PNG bytes of ``url`` in a new tab; every call to the browser ends by ``deadline``."""
    conn = await _by_deadline(
        tornado.websocket.websocket_connect(ws_url, max_message_size=256 * 2**20),
        "accept the DevTools connection",
        "the WebSocket handshake",
        deadline,
    )
    tools = _DevTools(conn, deadline)
    try:
        target = await tools.call("open a tab", "Target.createTarget", url="about:blank")
        attached = await tools.call(
            "attach to its tab", "Target.attachToTarget", targetId=target["targetId"], flatten=True
        )
        sid = attached["sessionId"]
        width, height = size
        await tools.call(
            f"size the page to {width}x{height} px",
            "Emulation.setDeviceMetricsOverride",
            sid,
            width=width,
            height=height,
            deviceScaleFactor=1,
            mobile=False,
        )
        # its one refusal is of the address itself ("Cannot navigate to invalid URL")
        await tools.call(f"load {url}", "Page.navigate", sid, refused=ViewError, url=url)
        want = expect or SceneCounts(messages=1, objects=0)
        state = None
        while True:
            result = await tools.call(
                f"report the state of the view at {url}",
                "Runtime.evaluate",
                sid,
                expression=_STATE_JS,
                returnByValue=True,
            )
            state = result.get("result", {}).get("value")
            if state and state[0] == 1 and state[1] >= want.messages and state[2] >= want.objects:
                break
            if time.monotonic() > deadline:
                raise ViewRunError(
                    f"the view at {url} was not drawn in time: [socket state, messages, "
                    f"objects] = {state}, expected at least {want.messages} messages and "
                    f"{want.objects} objects"
                )
            await asyncio.sleep(0.1)
        if expect is None:  # no counts to wait for: let the messages settle a little
            await asyncio.sleep(0.5)
        await tools.call(
            f"draw two frames of the view at {url}",
            "Runtime.evaluate",
            sid,
            expression=_TWO_FRAMES_JS,
            awaitPromise=True,
        )
        shot = await tools.call(
            f"take the picture of {url}", "Page.captureScreenshot", sid, format="png"
        )
        # a browser that draws more pages keeps no old tab (after a failure it is ended)
        await tools.call("close its tab", "Target.closeTarget", targetId=target["targetId"])
        return base64.b64decode(shot["data"])
    finally:
        conn.close()


class HeadlessBrowser:
    """One headless Chromium that renders pages, each in a tab of its own, until closed.

    :func:`screenshot` starts one for its picture and ends it; a caller that takes many
    pictures may keep one running and pass it as ``session`` (the browser's start and its
    CPU renderer's warm-up are then paid once). Use it as a context manager: on leaving,
    the browser's process group is ended and its temporary profile removed.
    """

    def __init__(self, browser: str | None = None, *, timeout_s: float = 60.0):
        """Start the browser and wait for its DevTools port.

        Its window is :data:`WINDOW_PX` whatever the pictures' sizes: each page sets its own.

        Args:
            browser: The browser executable; default :func:`find_browser`.
            timeout_s: Give up waiting for the port after this long [s].

        Raises:
            BrowserNotFoundError: No browser.
            ViewError: It cannot be run (not an executable).
            ViewRunError: It exited or did not open its port in time.
        """
        exe = browser or find_browser()
        # its own temporary files (org.chromium.Chromium.*, which it leaves in $TMPDIR
        # even when it quits) go into the profile, removed with it
        self._profile = tempfile.TemporaryDirectory(
            prefix="mearm-chromium-", ignore_cleanup_errors=True
        )
        profile = self._profile.name
        cmd = [
            exe,
            *HEADLESS_FLAGS,
            f"--user-data-dir={profile}",
            f"--window-size={WINDOW_PX[0]},{WINDOW_PX[1]}",
            "about:blank",
        ]
        self._proc: subprocess.Popen | None = None
        try:
            try:
                self._proc = subprocess.Popen(
                    cmd,
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    start_new_session=True,  # its own group: ended as a whole, not by Ctrl-C
                    env={**os.environ, "TMPDIR": profile},
                )
            except OSError as exc:
                raise ViewError(f"cannot run {exe}: {exc}") from None
            self._ws_url = _devtools_url(Path(profile), self._proc, time.monotonic() + timeout_s)
        except BaseException:
            self.close()
            raise

    def render(
        self, url: str, size: tuple[int, int], expect: SceneCounts | None, deadline: float
    ) -> bytes:
        """PNG bytes of ``url`` drawn in a new tab of ``size`` px (see :func:`screenshot`).

        Raises:
            ViewError: The browser was closed.
            ViewRunError: It failed, or did not answer by ``deadline``.
        """
        if self._proc is None:
            raise ViewError("the browser was closed")
        try:
            return asyncio.run(_capture(self._ws_url, url, size, expect, deadline))
        except (OSError, tornado.websocket.WebSocketClosedError) as exc:
            raise ViewRunError(f"lost the browser while rendering {url}: {exc}") from None

    def close(self) -> None:
        """End the browser's process group and remove its profile. Safe to call twice."""
        proc, self._proc = self._proc, None
        try:
            if proc is not None:
                _end_group(proc)
        finally:
            self._profile.cleanup()

    def __enter__(self) -> HeadlessBrowser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def screenshot(
    url: str,
    out_png: str | Path,
    *,
    width_px: int = 1280,
    height_px: int = 800,
    expect: SceneCounts | None = None,
    timeout_s: float = 60.0,
    browser: str | None = None,
    session: HeadlessBrowser | None = None,
) -> Path:
    """Render the meshcat page ``url`` in headless Chromium to a ``width_px`` × ``height_px`` PNG.

    Args:
        url: The viewer page, e.g. ``ArmView.url``.
        out_png: Where to write the PNG; missing folders are made as it is written
            (after the render: a failed one makes none).
        width_px: View width [px].
        height_px: View height [px].
        expect: Wait until the page has this much of the scene (see
            ``ArmView.screenshot``, which knows); ``None`` waits for the first message
            and half a second more.
        timeout_s: Give up after this long [s]: the browser's start, the scene's
            arrival and every call to the browser after it end by then.
        browser: The browser executable; default :func:`find_browser`.
        session: A running :class:`HeadlessBrowser` to draw in (a new tab, closed after;
            ``browser`` is then unused); default: start one for this picture, end it after.

    Returns:
        The PNG's path.

    Raises:
        BrowserNotFoundError: No browser, or ``$MEARM_CHROMIUM`` names none (exit 2).
        ViewInputError: A size out of range, or ``out_png`` under a file (exit 2).
        ViewError: The browser cannot be run, ``session`` was closed, ``url`` is not an
            address the browser can load, or ``out_png``'s folder takes no new file (not
            writable, /proc): exit 2.
        ViewRunError: The browser failed, the scene was not drawn or the browser did not
            answer within ``timeout_s`` (the error names the step), or the storage
            failed writing the PNG (:data:`STORAGE_FAILURES`): exit 1. The PNG is
            written in one step: an old file stays whole until the new one replaces it.
    """
    out = Path(out_png).resolve()
    folder = existing_ancestor(out)
    if not folder.is_dir():
        raise ViewInputError("out_png", str(out_png), f"a path not under a file ({folder})")
    for name, value in (("width_px", width_px), ("height_px", height_px)):
        if not 16 <= value <= 8192:
            raise ViewInputError(name, value, "a size in [16, 8192] px")
    size = (width_px, height_px)
    deadline = time.monotonic() + timeout_s
    with _signals_unwind():
        if session is not None:
            png = session.render(url, size, expect, deadline)
        else:
            exe = browser or find_browser()
            start_s = deadline - time.monotonic()
            with HeadlessBrowser(exe, timeout_s=start_s) as own:
                png = own.render(url, size, expect, deadline)
    try:
        write_atomic(out, png)
    except OSError as exc:
        error = ViewRunError if exc.errno in STORAGE_FAILURES else ViewError
        # strerror: the reason, not the temporary file's name the error carries
        raise error(f"cannot write {out}: {exc.strerror or exc}") from None
    return out
