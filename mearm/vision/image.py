"""Reading image files so that no file can hurt: the size is checked before decoding.

:func:`read_image` refuses, with an :class:`~mearm.vision.errors.ImageError` naming the
file, before OpenCV decodes a byte:

- anything but a regular file (a device, FIFO, socket or directory);
- a file over :data:`MAX_IMAGE_BYTES`;
- a format other than PNG, JPEG, BMP, TIFF, WebP or PNM (PPM/PGM/PBM), by its magic bytes;
- a header whose width × height exceeds :data:`MAX_IMAGE_PIXELS` (a 100-byte PNG may
  claim 30000 × 30000 pixels: 2.7 GB to decode), or that gives no size.

The size is read from the header itself (:func:`image_size`): PNG's IHDR, JPEG's SOF
marker, BMP's DIB header, TIFF's first IFD, WebP's VP8/VP8L/VP8X chunk, the PNM text
header.
"""

from __future__ import annotations

import os
import re
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import cv2
import numpy as np

from mearm.errors import InputFileError
from mearm.vision.errors import ImageError
from mearm.yamlio import read_regular_file

#: Most pixels an image file may hold: 50 Mpx, a large phone photo (8660 × 5773). Its
#: BGR frame is 150 MB.
MAX_IMAGE_PIXELS = 50_000_000
#: Longest image side [px] (JPEG's own limit).
MAX_IMAGE_SIDE_PX = 65_535
#: Largest image file [bytes]: a 50 Mpx PNG of noise is ~150 MB.
MAX_IMAGE_BYTES = 256 << 20
#: The formats :func:`read_image` takes.
FORMATS = ("PNG", "JPEG", "BMP", "TIFF", "WebP", "PNM")


#: FFmpeg's log level for OpenCV's video backend: ``AV_LOG_QUIET``. FFmpeg writes its own
#: errors (``[mov,mp4,m4a,3gp,3g2,mj2 @ 0x…] moov atom not found``) to the process's
#: stderr, past OpenCV's log level: a damaged video then said three lines where bad input
#: says one. OpenCV reads ``OPENCV_FFMPEG_LOGLEVEL`` once, as its FFmpeg backend first
#: opens something; one set by the user is kept.
FFMPEG_LOG_LEVEL = "-8"


@contextmanager
def quiet_opencv() -> Iterator[None]:
    """Silence OpenCV's own log lines (e.g. V4L2 warnings) inside the block.

    FFmpeg's own lines too (:data:`FFMPEG_LOG_LEVEL`), for the rest of the process: every
    ``cv2.VideoCapture`` is opened in such a block, so the first one sets it.
    """
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", FFMPEG_LOG_LEVEL)
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_SILENT)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(level)


def opencv_takes_name(path: str | os.PathLike[str]) -> bool:
    """Whether OpenCV can be given the file name ``path``: it is UTF-8 text.

    A Linux file name is any bytes; one that is not UTF-8 (Python holds its bytes as
    surrogates, such as U+DCFF) crashes the process in OpenCV's path-taking calls
    (``cv2.VideoCapture``, ``cv2.haveImageWriter``: SIGSEGV) instead of raising. Such a
    name must be refused, or kept from OpenCV, first.
    """
    try:
        os.fspath(path).encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


class ImageSize(NamedTuple):
    """What an image file's header says."""

    format: str
    width_px: int
    height_px: int


_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
_PNM_HEADER = re.compile(rb"^P([1-6])(?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)")


def _jpeg_size(data: bytes) -> tuple[int, int] | None:
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:  # fill byte
            i += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):  # markers without a length
            i += 2
            continue
        (length,) = struct.unpack(">H", data[i + 2 : i + 4])
        if marker in _JPEG_SOF:
            if i + 9 > len(data):
                return None
            height, width = struct.unpack(">HH", data[i + 5 : i + 9])
            return width, height
        if marker in (0xD9, 0xDA) or length < 2:  # end of image, start of scan
            return None
        i += 2 + length
    return None


def _tiff_size(data: bytes) -> tuple[int, int] | None:
    end = "<" if data[:2] == b"II" else ">"
    (ifd,) = struct.unpack(end + "I", data[4:8])
    if ifd + 2 > len(data):
        return None
    (count,) = struct.unpack(end + "H", data[ifd : ifd + 2])
    size: dict[int, int] = {}
    for k in range(min(count, 4096)):
        entry = data[ifd + 2 + 12 * k : ifd + 14 + 12 * k]
        if len(entry) < 12:
            break
        tag, kind = struct.unpack(end + "HH", entry[:4])
        if tag in (256, 257):  # ImageWidth, ImageLength: SHORT or LONG
            if kind == 3:
                size[tag] = struct.unpack(end + "H", entry[8:10])[0]
            elif kind == 4:
                size[tag] = struct.unpack(end + "I", entry[8:12])[0]
    if 256 in size and 257 in size:
        return size[256], size[257]
    return None


def _webp_size(data: bytes) -> tuple[int, int] | None:
    chunk = data[12:16]
    if chunk == b"VP8 " and len(data) >= 30 and data[23:26] == b"\x9d\x01\x2a":
        w, h = struct.unpack("<HH", data[26:30])
        return w & 0x3FFF, h & 0x3FFF
    if chunk == b"VP8L" and len(data) >= 25 and data[20] == 0x2F:
        (bits,) = struct.unpack("<I", data[21:25])
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    if chunk == b"VP8X" and len(data) >= 30:
        w = int.from_bytes(data[24:27], "little") + 1
        h = int.from_bytes(data[27:30], "little") + 1
        return w, h
    return None


def image_size(data: bytes) -> ImageSize | None:
    """The format and size an image file's header gives, or ``None`` if it gives none.

    Args:
        data: The file's bytes (the first 64 kB are enough for every format but JPEG
            with large metadata, which is scanned marker by marker).

    Returns:
        ``ImageSize(format, width_px, height_px)``; ``None`` for an unknown format or a
        header too short or damaged to give a size.
    """
    size: tuple[int, int] | None = None
    kind = ""
    try:
        if data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR":
            kind, size = "PNG", struct.unpack(">II", data[16:24])
        elif data[:2] == b"\xff\xd8":
            kind, size = "JPEG", _jpeg_size(data)
        elif data[:2] == b"BM" and len(data) >= 26:
            kind = "BMP"
            (dib,) = struct.unpack("<I", data[14:18])
            if dib == 12:
                size = struct.unpack("<HH", data[18:22])
            else:
                w, h = struct.unpack("<ii", data[18:26])
                size = (abs(w), abs(h))
        elif data[:4] in (b"II*\x00", b"MM\x00*"):
            kind, size = "TIFF", _tiff_size(data)
        elif data[:4] == b"RIFF" and data[8:12] == b"WEBP":
            kind, size = "WebP", _webp_size(data)
        elif (m := _PNM_HEADER.match(data[:4096])) is not None:
            kind, size = "PNM", (int(m.group(2)), int(m.group(3)))
    except struct.error:  # a header cut short
        size = None
    if not kind or size is None:
        return None
    return ImageSize(kind, int(size[0]), int(size[1]))


def check_image_bytes(data: bytes, source: str) -> ImageSize:
    """The header's format and size, if :func:`read_image` may decode these bytes.

    Raises:
        ImageError: an unknown format, no size in the header, or too many pixels.
    """
    size = image_size(data)
    if size is None:
        known = data[:8] == b"\x89PNG\r\n\x1a\n" or data[:2] in (b"\xff\xd8", b"BM")
        raise ImageError(
            source,
            "damaged image header (no size in it)"
            if known
            else f"not an image of a known format ({', '.join(FORMATS)})",
        )
    w, h = size.width_px, size.height_px
    if w < 1 or h < 1:
        raise ImageError(source, f"{size.format} header gives an empty {w}x{h} px image")
    if w > MAX_IMAGE_SIDE_PX or h > MAX_IMAGE_SIDE_PX or w * h > MAX_IMAGE_PIXELS:
        raise ImageError(
            source,
            f"{size.format} header says {w}x{h} px, more than the {MAX_IMAGE_PIXELS} pixels "
            f"(and {MAX_IMAGE_SIDE_PX} px a side) an image may have: scale it down",
        )
    return size


#: How much of a file :func:`probe_image` reads first [bytes] (a JPEG's size may follow
#: up to 64 kB of metadata per segment; then the whole file is read).
PROBE_BYTES = 128 << 10


def probe_image(path: str | Path) -> ImageSize:
    """The format and size of an image file from its header, without decoding it.

    Raises:
        ImageError: as :func:`read_image` before decoding (not a regular file, too
            large, an unknown format, too many pixels).
    """
    p = Path(path)
    try:
        data = read_regular_file(p, max_bytes=MAX_IMAGE_BYTES, what="image file", head=PROBE_BYTES)
        if image_size(data) is None and len(data) == PROBE_BYTES:
            data = read_regular_file(p, max_bytes=MAX_IMAGE_BYTES, what="image file")
    except InputFileError as exc:
        raise ImageError(exc.path, exc.reason) from None
    return check_image_bytes(data, str(p))


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as (H, W, 3) uint8 BGR, checked before it is decoded.

    Raises:
        ImageError: not a regular file, too large, an unknown format, a header with too
            many pixels, or a file OpenCV cannot decode; the message names the problem.
    """
    p = Path(path)
    try:
        data = read_regular_file(p, max_bytes=MAX_IMAGE_BYTES, what="image file")
    except InputFileError as exc:
        raise ImageError(exc.path, exc.reason) from None
    check_image_bytes(data, str(p))
    with _codec_lines_kept() as said:
        try:
            with quiet_opencv():
                frame = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
        except cv2.error:
            frame = None
        failed = frame is None or frame.ndim != 3 or frame.shape[2] != 3
        said.keep = not failed  # a failure is said once, below, not in libpng's words too
    if failed or frame is None:
        raise ImageError(str(p), "cannot read it as an image (unsupported format or damaged)")
    return frame


class _Said:
    """Whether the codecs' own lines are passed on (:func:`_codec_lines_kept`)."""

    keep = True


@contextmanager
def _codec_lines_kept() -> Iterator[_Said]:
    """What the image codecs print on stderr in the block; their own errors only if ``keep``.

    libpng writes its own error to the process's stderr (``libpng error: PNG input
    buffer is incomplete``) past OpenCV's log level: a damaged image then said two
    lines, where bad input says one. The block's stderr goes to a temporary file, passed
    on after it: whole after a decode that worked (a codec's warning is kept), without
    the codecs' lines after one that failed.
    """
    import sys  # noqa: PLC0415
    import tempfile  # noqa: PLC0415

    said = _Said()
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, ValueError):  # no stderr to take (closed, or not a file)
        yield said
        return
    with tempfile.TemporaryFile() as caught:
        os.dup2(caught.fileno(), 2)
        try:
            yield said
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            caught.seek(0)
            text = caught.read()
            if not said.keep:  # (another thread's lines meanwhile are kept)
                lines = text.splitlines(keepends=True)
                text = b"".join(ln for ln in lines if not ln.startswith(_CODEC_ERRORS))
            if text:
                os.write(2, text)


#: How libpng and libjpeg begin the lines they write to stderr themselves.
_CODEC_ERRORS = (b"libpng ", b"Corrupt JPEG", b"Premature end of JPEG", b"Invalid SOS")


__all__ = [
    "FORMATS",
    "PROBE_BYTES",
    "MAX_IMAGE_BYTES",
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE_PX",
    "ImageSize",
    "check_image_bytes",
    "image_size",
    "probe_image",
    "opencv_takes_name",
    "quiet_opencv",
    "read_image",
]
