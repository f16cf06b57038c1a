"""An episode's video as one fragment of a fragmented MP4, appended to the shared file.

Each episode is encoded on its own into a fragmented MP4 (FFmpeg's ``movflags``
:data:`MOVFLAGS`): a header (``ftyp`` and a ``moov`` with no samples) and one fragment,
a ``moof`` (the samples' sizes, times and key-frame flags) and its ``mdat`` (the coded
frames), offsets relative to the ``moof`` (``default_base_moof``). Every episode of the
same size and encoder settings has the same header, byte for byte, so an episode joins
a dataset's video file by appending its fragment: its decode time (``tfdt``) moved past
the frames already there and its sequence number (``mfhd``) after theirs. No frame is
read or written again (LeRobot's ``concatenate_video_files`` re-muxes the whole file for
every episode). PyAV, FFmpeg and torchcodec read such a file as any MP4.

ISO/IEC 14496-12 boxes: a 32-bit big-endian size (1: a 64-bit size follows; 0: to the
end), a 4-character type, then the payload; ``tfdt`` is a full box (version, flags) with
a 32-bit (version 0) or 64-bit (version 1) time in the track's timescale.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

#: What boxes are read from.
Buffer = bytes | bytearray | memoryview

#: FFmpeg's MP4 muxer flags for an episode: fragments only where the writer closes one
#: (one per episode), a header without samples, offsets relative to each fragment.
MOVFLAGS = "frag_custom+empty_moov+default_base_moof"

#: The boxes a fragment is made of (the optional ``mfra`` index at the end is dropped).
FRAGMENT_BOXES = (b"moof", b"mdat")


class FragmentError(ValueError):
    """A file that is not a fragmented MP4 of the expected shape."""


@dataclass(frozen=True)
class Box:
    """One box: its type, where it starts, its size and its header's size [bytes]."""

    kind: bytes
    start: int
    size: int
    header: int

    @property
    def end(self) -> int:
        """Where the box ends [bytes]."""
        return self.start + self.size

    @property
    def body(self) -> int:
        """Where its payload starts [bytes]."""
        return self.start + self.header


def boxes(data: Buffer, start: int = 0, end: int | None = None) -> Iterator[Box]:
    """The boxes in ``data[start:end]``, in order.

    Raises:
        FragmentError: a box runs past ``end`` or is shorter than its header.
    """
    end = len(data) if end is None else end
    at = start
    while at < end:
        if end - at < 8:
            raise FragmentError(f"{end - at} stray bytes at offset {at}")
        size, kind = struct.unpack_from(">I4s", data, at)
        header = 8
        if size == 1:
            (size,) = struct.unpack_from(">Q", data, at + 8)
            header = 16
        elif size == 0:
            size = end - at
        if size < header or at + size > end:
            raise FragmentError(f"box {kind!r} at offset {at} is {size} bytes, past the end")
        yield Box(kind, at, size, header)
        at += size


def _child(data: Buffer, parent: Box, kind: bytes) -> Box:
    for box in boxes(data, parent.body, parent.end):
        if box.kind == kind:
            return box
    raise FragmentError(f"no {kind.decode()} box in {parent.kind.decode()}")


@dataclass(frozen=True)
class EpisodeVideo:
    """An episode's fragmented MP4, split into its header and its fragments.

    Attributes:
        header: ``ftyp`` and ``moov``: the same for every episode of the same encoding.
        fragments: The ``moof``/``mdat`` pairs, decode times from 0.
        timescale: The track's ticks per second (``mdhd``).
    """

    header: bytes
    fragments: bytes
    timescale: int

    @classmethod
    def parse(cls, data: bytes) -> EpisodeVideo:
        """Split an episode's file (:data:`MOVFLAGS`).

        Raises:
            FragmentError: it is not a fragmented MP4 with a header and fragments.
        """
        top = list(boxes(data))
        kinds = [b.kind for b in top]
        if kinds[:2] != [b"ftyp", b"moov"] or b"moof" not in kinds:
            raise FragmentError(f"not a fragmented MP4 (boxes {[k.decode() for k in kinds]})")
        moov = top[1]
        frags = b"".join(data[b.start : b.end] for b in top[2:] if b.kind in FRAGMENT_BOXES)
        return cls(data[: moov.end], frags, timescale(data, moov))

    def shifted(self, frames_before: int, fps: int) -> bytes:
        """The fragments, as they follow ``frames_before`` frames at ``fps`` in a file.

        Each ``tfdt`` decode time moves by ``frames_before / fps`` seconds and each
        ``mfhd`` sequence number by ``frames_before`` (they stay increasing through the
        file, as the format asks).

        Raises:
            FragmentError: the timescale is not a whole number of ticks a frame.
        """
        ticks, rest = divmod(self.timescale, fps)
        if rest:
            raise FragmentError(f"timescale {self.timescale} is not a multiple of {fps} fps")
        out = bytearray(self.fragments)
        for moof in boxes(out):
            if moof.kind != b"moof":
                continue
            mfhd = _child(out, moof, b"mfhd")
            (number,) = struct.unpack_from(">I", out, mfhd.body + 4)
            struct.pack_into(">I", out, mfhd.body + 4, number + frames_before)
            for traf in boxes(out, moof.body, moof.end):
                if traf.kind != b"traf":
                    continue
                tfdt = _child(out, traf, b"tfdt")
                version = out[tfdt.body]
                fmt = ">Q" if version == 1 else ">I"
                (t,) = struct.unpack_from(fmt, out, tfdt.body + 4)
                struct.pack_into(fmt, out, tfdt.body + 4, t + frames_before * ticks)
        return bytes(out)


def timescale(data: Buffer, moov: Box) -> int:
    """The first track's timescale [ticks/s] (``moov/trak/mdia/mdhd``)."""
    mdhd = _child(data, _child(data, _child(data, moov, b"trak"), b"mdia"), b"mdhd")
    version = data[mdhd.body]
    # version, flags, then creation and modification times of 4 or 8 bytes each
    at = mdhd.body + 4 + (16 if version == 1 else 8)
    (scale,) = struct.unpack_from(">I", data, at)
    return int(scale)


def file_header(path: Path) -> bytes | None:
    """The header (``ftyp`` + ``moov``) of a fragmented MP4 file, ``None`` if it is not one.

    A file written whole (its ``moov`` holds the samples, as FFmpeg writes by default) is
    not one: episodes cannot be appended to it.
    """
    try:
        with path.open("rb") as f:
            data = f.read(1 << 16)
    except OSError:
        return None
    try:
        first = []
        for box in boxes(data, 0, len(data)):
            first.append(box)
            if len(first) == 2:
                break
    except FragmentError:  # the moov runs past what was read: a whole file's sample tables
        return None
    if [b.kind for b in first] != [b"ftyp", b"moov"]:
        return None
    moov = first[1]
    try:
        _child(data, moov, b"mvex")  # only a fragmented file says its samples come later
    except FragmentError:
        return None
    return bytes(data[: moov.end])


def tear(path: Path) -> str | None:
    """What is wrong with a video file's top-level boxes, ``None`` if they fill it exactly.

    Each box's header is read (a seek and 16 bytes), not its payload: a file cut short
    (its last box runs past the end) is found without reading its frames. A missing file
    is one.
    """
    try:
        with path.open("rb") as f:
            end = f.seek(0, 2)
            at = 0
            while at < end:
                f.seek(at)
                head = f.read(16)
                if len(head) < 8:
                    return f"cut short: {end - at} stray bytes at offset {at}"
                size, kind = struct.unpack_from(">I4s", head)
                header = 8
                if size == 1 and len(head) == 16:
                    (size,) = struct.unpack_from(">Q", head, 8)
                    header = 16
                elif size == 0:
                    size = end - at
                if size < header or at + size > end:
                    name = kind.decode("latin-1")
                    return f"cut short: box {name!r} at offset {at} runs past the end"
                at += size
    except FileNotFoundError:
        return "is missing"
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    return None
