"""Render the meshcat view to a PNG in headless Chromium.

The browser loads the viewer page, connects its WebSocket to the server and receives the
whole scene tree (the server replays it to every new browser), so a screenshot shows the
scene as it is when the browser connects. ``--virtual-time-budget`` lets the page run
(three.js, the WebSocket messages, texture decoding) before the picture is taken.
WebGL runs on SwiftShader, the CPU renderer, so no GPU or display is needed.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from mearm.exceptions import BrowserNotFoundError, ViewError, ViewInputError

#: Executable names tried in order; ``$MEARM_CHROMIUM`` (a path or name) comes first.
BROWSER_NAMES: tuple[str, ...] = (
    "chromium",
    "chromium-browser",
    "google-chrome",
    "google-chrome-stable",
)

#: Flags for a quiet, reproducible headless run: no sandbox (containers, root), CPU
#: WebGL, no network traffic of its own, a throwaway profile.
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
)


def find_browser() -> str:
    """Path of a Chromium-family browser.

    Raises:
        BrowserNotFoundError: None on PATH and ``$MEARM_CHROMIUM`` unset or not found.
    """
    override = os.environ.get("MEARM_CHROMIUM")
    names = ((override,) if override else ()) + BROWSER_NAMES
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    raise BrowserNotFoundError(names)


def screenshot(
    url: str,
    out_png: str | Path,
    *,
    width_px: int = 1280,
    height_px: int = 800,
    budget_ms: int = 4000,
    timeout_s: float = 60.0,
    browser: str | None = None,
) -> Path:
    """Render ``url`` in headless Chromium and save a ``width_px`` × ``height_px`` PNG.

    Args:
        url: The page, e.g. ``ArmView.url``.
        out_png: Where to write the PNG; its folder must exist.
        width_px: Window width [px].
        height_px: Window height [px].
        budget_ms: Virtual time the page runs before the picture is taken [ms].
        timeout_s: Give up on the browser after this long [s].
        browser: The browser executable; default :func:`find_browser`.

    Returns:
        The PNG's path.

    Raises:
        BrowserNotFoundError: No browser.
        ViewInputError: A size or budget out of range, or the folder of ``out_png``
            does not exist.
        ViewError: The browser failed, timed out or wrote no picture.
    """
    out = Path(out_png).resolve()
    if not out.parent.is_dir():
        raise ViewInputError("out_png", str(out_png), "a path in an existing folder")
    for name, value in (("width_px", width_px), ("height_px", height_px)):
        if not 16 <= value <= 8192:
            raise ViewInputError(name, value, "a size in [16, 8192] px")
    if budget_ms < 0:
        raise ViewInputError("budget_ms", budget_ms, "a virtual time budget >= 0 ms")
    exe = browser or find_browser()
    out.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory(prefix="mearm-chromium-") as profile:
        cmd = [
            exe,
            *HEADLESS_FLAGS,
            f"--user-data-dir={profile}",
            f"--window-size={width_px},{height_px}",
            f"--virtual-time-budget={budget_ms}",
            f"--screenshot={out}",
            url,
        ]
        try:
            proc = subprocess.run(
                cmd, capture_output=True, text=True, timeout=timeout_s, check=False
            )
        except subprocess.TimeoutExpired:
            raise ViewError(
                f"{exe} did not finish rendering {url} within {timeout_s:g} s"
            ) from None
        except OSError as exc:
            raise ViewError(f"cannot run {exe}: {exc}") from None
    if proc.returncode != 0 or not out.is_file() or out.stat().st_size == 0:
        tail = " | ".join(line for line in proc.stderr.strip().splitlines()[-3:])
        raise ViewError(
            f"{exe} exited {proc.returncode} without a screenshot of {url}: {tail or 'no output'}"
        )
    return out
