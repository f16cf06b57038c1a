"""Is a frame fit to act on? A black frame and a frozen stream are camera faults.

A sort acts on what the camera shows: a black frame shows an empty table, and a stream
that froze shows the table as it was. Either would have the sort conclude wrongly (the
table is clear; the object just picked is still there) and move on it, so each is a
:class:`~mearm.vision.errors.CameraError` naming what is wrong:

- **black**: fewer than :data:`LIT_FRACTION` of the pixels reach :data:`BLACK_LEVEL` —
  a covered lens, a dead sensor, the light off;
- **frozen**: a source that tells when each frame was taken
  (:attr:`~mearm.vision.camera.Camera.frame_time_s`) gives a frame no newer than the one
  before it, though its clock has moved on since (two reads at one instant of a
  simulated clock are the same frame, not a frozen stream).

Every frame the sort acts on goes through the one check of its camera: the table's looks
and the looks at the claw alike (:meth:`FrameCheck.read`). A frozen stream gives again the
last frame read, whoever read it: a look at the table after the claw's last look checked
against the table's look before would take the claw's frame (the object still on the
table, the jaws about to close) for a new one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import cv2
import numpy as np

from mearm.vision.errors import CameraError

if TYPE_CHECKING:
    from mearm.vision.camera import Camera

#: Grey level a lit pixel reaches [0–255]: a table under room light is far brighter; a
#: covered lens or a dark room reads a few levels of sensor noise.
BLACK_LEVEL = 16
#: Fraction of the pixels that must reach :data:`BLACK_LEVEL` for the frame to be lit [-]
#: (a few hot pixels of a dark sensor do not make a picture).
LIT_FRACTION = 0.01


class FrameCheck:
    """Checks each frame of one camera before the sort acts on it.

    Args:
        source: The camera, for messages (``Camera.source``).
    """

    def __init__(self, source: str):
        self.source = source
        self._last_time_s: float | None = None

    def read(self, camera: Camera) -> np.ndarray:
        """Read a frame of ``camera`` and :meth:`check` it: the frame, fit to act on.

        A frame ``camera`` gave past this check before (its
        :attr:`~mearm.vision.camera.Camera.frame_time_s` as the read begins: another
        part's read) counts as the one before (:meth:`after`).

        Raises:
            CameraError: the read failed, the frame is black, or the stream froze.
        """
        self.after(camera.frame_time_s)
        frame = camera.read()
        self.check(frame, camera.frame_time_s, camera.clock_s)
        return frame

    def after(self, time_s: float | None) -> None:
        """The frames checked from now on follow one taken at ``time_s`` [s], read elsewhere.

        A frame read past this check (the servos' calibration at the start of a sort, with
        a check of its own) is what a stream that froze since gives again: the next
        frame checked must be newer, as after one checked here. ``None``: none known.
        """
        if time_s is not None and (self._last_time_s is None or time_s > self._last_time_s):
            self._last_time_s = time_s

    def check(
        self, frame: np.ndarray, time_s: float | None = None, now_s: float | None = None
    ) -> None:
        """Refuse a black frame, or one no newer than the last though time went on.

        Args:
            frame: The frame, (H, W, 3) uint8 BGR.
            time_s: When it was taken, on the source's clock [s]; ``None``: unknown.
            now_s: The source's clock as it was read [s]; ``None``: unknown (time is
                taken to have moved on since the last frame).

        Raises:
            CameraError: the frame is black, or not newer than the one checked before
                while the clock moved on.
        """
        if time_s is not None:
            last, self._last_time_s = self._last_time_s, time_s
            moved_on = now_s is None or last is None or now_s > last
            if last is not None and time_s <= last and moved_on:
                raise CameraError(
                    self.source,
                    f"the stream froze: this frame was taken at {time_s:.3f} s, no later "
                    f"than the one before ({last:.3f} s); check the camera's cable and driver",
                )
        if _lit_in_part(frame):
            return
        grey = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        lit = np.count_nonzero(grey >= BLACK_LEVEL) / grey.size
        if lit < LIT_FRACTION:
            raise CameraError(
                self.source,
                f"the frame is black ({lit:.2%} of its pixels reach grey level "
                f"{BLACK_LEVEL}, under {LIT_FRACTION:.0%}): is the lens covered, the light "
                "off or the camera failing?",
            )


#: Rows of a frame read first by the black-frame check: their lit pixels alone are mostly
#: the whole frame's share (16 rows of 480 hold 3.3 % of its pixels, LIT_FRACTION 1 %).
FIRST_ROWS = 16


def _lit_in_part(frame: np.ndarray) -> bool:
    """Whether the first :data:`FIRST_ROWS` rows alone make the frame lit.

    Their lit pixels, over the whole frame's, are no more than the frame's share: when
    they reach :data:`LIT_FRACTION` so does the frame (each pixel's grey level is its
    own), and the rest need not be read. Otherwise the whole frame is measured.
    """
    part = frame[:FIRST_ROWS]
    if part.size == frame.size:  # a frame this small is measured whole
        return False
    grey = cv2.cvtColor(part, cv2.COLOR_BGR2GRAY)
    size = frame.shape[0] * frame.shape[1]
    return bool(np.count_nonzero(grey >= BLACK_LEVEL) / size >= LIT_FRACTION)
