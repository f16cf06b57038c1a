"""Bad-input corpus: image files, for ``detect``, ``calibrate-camera`` and the replay cameras.

Headers that claim huge sizes (a 30000 × 30000 PNG of 100 bytes) in every format read,
damaged and truncated files, files of unknown formats, and special files. Each is
refused before it is decoded: exit 2, one line naming the file and the problem, well
within the time bound. Hypothesis feeds arbitrary bytes behind each format's magic to
the header parser and the reader.
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import ROOT, check_bad_input, check_bad_input_subprocess, run_in_process
from hypothesis import given, settings
from hypothesis import strategies as st

from mearm.exceptions import ImageError
from mearm.vision import image as image_module
from mearm.vision.image import MAX_IMAGE_PIXELS, image_size, read_image

bad_input = pytest.mark.bad_input

LAB = ROOT / "configs" / "lab.yaml"
MARKERS = ["--marker", "0:-17,56", "--marker", "1:16,56", "--marker", "2:16,32",
           "--marker", "3:-17,32"]  # fmt: skip

# --------------------------------------------------------------------------- headers


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png(width: int, height: int, body: bytes | None = None) -> bytes:
    """A PNG whose IHDR says ``width`` × ``height`` (8-bit RGB) with a tiny IDAT."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    idat = zlib.compress(b"\0" * 64) if body is None else body
    sig = b"\x89PNG\r\n\x1a\n"
    return sig + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", idat) + _chunk(b"IEND", b"")


def jpeg(width: int, height: int) -> bytes:
    """SOI, an APP0, a baseline SOF0 saying ``width`` × ``height``, then nothing useful."""
    app0 = b"\xff\xe0" + struct.pack(">H", 16) + b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00"
    sof = b"\xff\xc0" + struct.pack(">HBHHB", 17, 8, height, width, 3)
    sof += b"\x01\x11\x00\x02\x11\x01\x03\x11\x01"
    return b"\xff\xd8" + app0 + sof + b"\xff\xd9"


def bmp(width: int, height: int) -> bytes:
    """A BMP file and info header saying ``width`` × ``height``, 24 bits, no pixels."""
    info = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, 0, 2835, 2835, 0, 0)
    return b"BM" + struct.pack("<IHHI", 14 + len(info), 0, 0, 14 + len(info)) + info


def tiff(width: int, height: int) -> bytes:
    """A little-endian TIFF whose first IFD gives ``width`` × ``height`` (LONG values)."""
    entries = [(256, 4, 1, width), (257, 4, 1, height), (258, 3, 1, 8), (277, 3, 1, 1)]
    ifd = struct.pack("<H", len(entries))
    ifd += b"".join(struct.pack("<HHII", *e) for e in entries) + struct.pack("<I", 0)
    return b"II*\x00" + struct.pack("<I", 8) + ifd


def webp_vp8x(width: int, height: int) -> bytes:
    body = b"VP8X" + struct.pack("<I", 10) + b"\x00\x00\x00\x00"
    body += (width - 1).to_bytes(3, "little") + (height - 1).to_bytes(3, "little")
    return b"RIFF" + struct.pack("<I", 4 + len(body)) + b"WEBP" + body


def webp_vp8l(width: int, height: int) -> bytes:
    bits = (width - 1) | ((height - 1) << 14)
    body = b"VP8L" + struct.pack("<I", 5) + b"\x2f" + struct.pack("<I", bits)
    return b"RIFF" + struct.pack("<I", 4 + len(body)) + b"WEBP" + body


def webp_vp8(width: int, height: int) -> bytes:
    frame = b"\x00\x00\x00" + b"\x9d\x01\x2a" + struct.pack("<HH", width, height)
    body = b"VP8 " + struct.pack("<I", len(frame)) + frame
    return b"RIFF" + struct.pack("<I", 4 + len(body)) + b"WEBP" + body


def pnm(width: int, height: int, data: bytes = b"") -> bytes:
    return f"P6\n# made by a test\n{width} {height}\n255\n".encode() + data


def real(ext: str, shape: tuple[int, ...] = (48, 64, 3)) -> bytes:
    """An empty table's image: a faint tint in colour (a grey one gets detect's warning)."""
    frame = np.full(shape, 90, np.uint8)
    if len(shape) == 3 and shape[2] == 3:
        frame[..., 2] = 96
    ok, buf = cv2.imencode(ext, frame)
    assert ok
    return buf.tobytes()


#: name → (file bytes, words the one line must hold).
BAD_IMAGES: dict[str, tuple[bytes, str]] = {
    "png_30000x30000": (png(30_000, 30_000), "PNG header says 30000x30000 px"),
    "png_wide": (png(70_000, 1), "PNG header says 70000x1 px"),
    "png_4g_wide": (png(2**32 - 1, 1), "PNG header says"),
    "png_zero": (png(0, 0), "empty 0x0 px image"),
    "png_zero_height": (png(640, 0), "empty 640x0 px image"),
    "png_idat_garbage": (png(64, 48, b"definitely not zlib"), "cannot read it as an image"),
    "png_no_idat": (
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", struct.pack(">IIBBBBB", 64, 48, 8, 2, 0, 0, 0))
        + _chunk(b"IEND", b""),
        "cannot read it as an image",
    ),  # fmt: skip
    "png_signature_only": (b"\x89PNG\r\n\x1a\n", "damaged image header"),
    "png_cut_in_ihdr": (png(64, 48)[:20], "damaged image header"),
    "png_cut_in_idat": (real(".png")[:60], "cannot read it as an image"),
    "jpeg_65000x65000": (jpeg(65_000, 65_000), "JPEG header says 65000x65000 px"),
    "jpeg_10000x10000": (jpeg(10_000, 10_000), "JPEG header says 10000x10000 px"),
    "jpeg_zero_height": (jpeg(640, 0), "empty 640x0 px image"),
    "jpeg_no_frame": (b"\xff\xd8\xff\xd9", "damaged image header"),
    "jpeg_soi_only": (b"\xff\xd8", "damaged image header"),
    "jpeg_bad_marker": (b"\xff\xd8\x00\x00\x00\x00", "damaged image header"),
    "jpeg_cut_after_header": (real(".jpg")[:200], "cannot read it as an image"),
    "jpeg_no_scan": (jpeg(64, 48), "cannot read it as an image"),
    "bmp_100000x100000": (bmp(100_000, 100_000), "BMP header says 100000x100000 px"),
    "bmp_top_down_huge": (bmp(20_000, -20_000), "BMP header says 20000x20000 px"),
    "bmp_no_pixels": (bmp(64, 48), "cannot read it as an image"),
    "bmp_cut": (b"BM\x00\x00", "damaged image header"),
    "tiff_100000x100000": (tiff(100_000, 100_000), "TIFF header says 100000x100000 px"),
    "tiff_no_size": (b"II*\x00\x08\x00\x00\x00\x00\x00\x00\x00\x00\x00", "not an image"),
    "tiff_ifd_out_of_file": (b"II*\x00\xff\xff\xff\x7f", "not an image"),
    "tiff_big_endian_huge": (
        b"MM\x00*"
        + struct.pack(">I", 8)
        + struct.pack(">H", 2)
        + struct.pack(">HHII", 256, 4, 1, 60_000)
        + struct.pack(">HHII", 257, 4, 1, 60_000)
        + b"\0" * 4,
        "TIFF header says 60000x60000 px",
    ),  # fmt: skip
    "webp_vp8x_16384": (webp_vp8x(16_384, 16_384), "WebP header says 16384x16384 px"),
    "webp_vp8l_16384": (webp_vp8l(16_384, 16_384), "WebP header says 16384x16384 px"),
    "webp_vp8_16383": (webp_vp8(16_383, 16_383), "WebP header says 16383x16383 px"),
    "webp_no_chunk": (b"RIFF\x04\x00\x00\x00WEBP", "not an image"),
    "pnm_60000x60000": (pnm(60_000, 60_000), "PNM header says 60000x60000 px"),
    "pnm_no_pixels": (pnm(64, 48), "cannot read it as an image"),
    "pnm_huge_number": (b"P6\n" + b"9" * 5000 + b" 1\n255\n", "not an image"),
    "pnm_long_number": (b"P6\n" + b"9" * 3000 + b" 1\n255\n", "PNM header says"),
    "gif": (b"GIF89a\x10\x00\x10\x00\x00\x00\x00;", "not an image of a known format"),
    "svg": (b'<svg xmlns="http://www.w3.org/2000/svg" width="1e9" height="1e9"/>', "not an image"),
    "empty_file": (b"", "not an image of a known format"),
    "one_byte": (b"\x89", "not an image of a known format"),
    "yaml_text": (LAB.read_bytes(), "not an image of a known format"),
    "random_bytes": (
        bytes(np.random.default_rng(0).integers(0, 256, 4096, np.uint8)),
        "not an image",
    ),  # fmt: skip
    "zeros": (b"\0" * 4096, "not an image of a known format"),
}


@pytest.fixture(scope="module")
def images(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The bad images as files (suffix matching the format), and special files."""
    d = tmp_path_factory.mktemp("bad_images")
    paths: dict[str, Path] = {}
    for name, (data, _) in BAD_IMAGES.items():
        suffix = "." + name.split("_")[0] if name.split("_")[0] in (
            "png", "jpeg", "bmp", "tiff", "webp", "pnm", "gif", "svg") else ".png"  # fmt: skip
        paths[name] = d / f"{name}{suffix.replace('.pnm', '.ppm')}"
        paths[name].write_bytes(data)
    os.mkfifo(d / "fifo.png")
    paths["fifo"] = d / "fifo.png"
    (d / "folder.png").mkdir()
    paths["folder"] = d / "folder.png"
    (d / "to_zero.png").symlink_to("/dev/zero")
    paths["link_to_dev_zero"] = d / "to_zero.png"
    paths["dev_zero"] = Path("/dev/zero")
    paths["dev_urandom"] = Path("/dev/urandom")
    paths["missing"] = d / "missing.png"
    good = d / "good.png"
    good.write_bytes(real(".png", (480, 640, 3)))
    paths["good"] = good
    return paths


SPECIAL = {
    "fifo": "not a regular file",
    "folder": "is a directory",
    "link_to_dev_zero": "not a regular file",
    "dev_zero": "not a regular file",
    "dev_urandom": "not a regular file",
    "missing": "image file not found",
}
ALL_IMAGES = {**{k: v[1] for k, v in BAD_IMAGES.items()}, **SPECIAL}


@pytest.fixture(scope="module", autouse=True)
def _imported() -> None:
    for argv in (["detect", "--help"], ["calibrate-camera", "--help"], ["sort", "--help"]):
        run_in_process(argv, within_s=60)


@bad_input
@pytest.mark.parametrize("name", list(ALL_IMAGES))
def test_detect_refuses_a_bad_image(name: str, images: dict[str, Path]) -> None:
    """detect IMAGE: refused before decoding, one line naming the file and the problem."""
    out = check_bad_input(["detect", images[name]], within_s=2, keep=[images["good"].parent])
    assert ALL_IMAGES[name] in out.line and out.stdout == ""


@bad_input
@pytest.mark.parametrize("name", list(ALL_IMAGES))
def test_calibrate_camera_refuses_a_bad_image(
    name: str, images: dict[str, Path], tmp_path: Path
) -> None:
    """calibrate-camera --image: refused, and the config it would rewrite left as it was."""
    config = tmp_path / "lab.yaml"
    config.write_bytes(LAB.read_bytes())
    out = check_bad_input(
        ["calibrate-camera", "--config", config, "--image", images[name], *MARKERS],
        within_s=2,
        keep=[config, images["good"].parent],
    )
    assert ALL_IMAGES[name] in out.line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lab.yaml"]


#: A subset for the commands that read images through the config's camera.
VIA_CAMERA = ("png_30000x30000", "jpeg_65000x65000", "bmp_100000x100000", "tiff_100000x100000",
              "webp_vp8x_16384", "pnm_60000x60000", "png_cut_in_ihdr", "gif", "empty_file",
              "png_idat_garbage")  # fmt: skip


@bad_input
@pytest.mark.parametrize("name", VIA_CAMERA)
def test_detect_camera_file_refuses_a_bad_image(name: str, images: dict[str, Path]) -> None:
    """camera.kind: file with a bad image: the camera refuses it on opening."""
    out = check_bad_input(
        ["detect", "--camera", "--set", "camera.kind=file", "--set",
         f"camera.path={images[name]}"],
        within_s=2,
        keep=[images["good"].parent],
    )  # fmt: skip
    assert "camera (file" in out.line and ALL_IMAGES[name] in out.line


@bad_input
@pytest.mark.parametrize("name", VIA_CAMERA)
def test_detect_camera_folder_refuses_a_bad_image(
    name: str, images: dict[str, Path], tmp_path: Path
) -> None:
    """camera.kind: folder: every frame's header is checked when the folder is opened (a
    damaged body, when its frame is read)."""
    (tmp_path / "1.png").write_bytes(images["good"].read_bytes())
    (tmp_path / "0-bad.png").write_bytes(images[name].read_bytes())
    out = check_bad_input(
        ["detect", "--camera", "--set", "camera.kind=folder", "--set", f"camera.path={tmp_path}"],
        within_s=2,
        keep=[tmp_path],
    )
    assert "camera (folder" in out.line and ALL_IMAGES[name] in out.line


@bad_input
@pytest.mark.parametrize(
    ("kind", "name"),
    [("file", "png_30000x30000"), ("file", "gif"), ("file", "fifo"), ("file", "dev_zero"),
     ("folder", "png_30000x30000"), ("folder", "gif")],
)  # fmt: skip
def test_sort_refuses_a_bad_replay_camera(
    kind: str, name: str, images: dict[str, Path], tmp_path: Path
) -> None:
    """sort with a replay camera whose image cannot be used: bad input, exit 2."""
    path = images[name]
    if kind == "folder":
        (tmp_path / "0.png").write_bytes(path.read_bytes())
        path = tmp_path
    check_bad_input(
        ["sort", "--quiet", "--set", f"camera.kind={kind}", "--set", f"camera.path={path}"],
        within_s=3,
        keep=[images["good"].parent],
    )


@bad_input
def test_two_images_one_bad_prints_nothing(images: dict[str, Path]) -> None:
    """detect good.png huge.png: the bad one stops the run before any output."""
    out = check_bad_input(
        ["detect", "--json", images["good"], images["png_30000x30000"]],
        within_s=3,
        keep=[images["good"].parent],
    )
    assert out.stdout == "" and "30000x30000" in out.line


@bad_input
def test_a_file_over_the_byte_cap_is_refused_unread(
    images: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A file larger than MAX_IMAGE_BYTES is refused by its size, before reading it."""
    monkeypatch.setattr(image_module, "MAX_IMAGE_BYTES", 1000)
    out = check_bad_input(["detect", images["good"]], within_s=2, keep=[images["good"].parent])
    assert "image file too large" in out.line and "at most 1000" in out.line


@bad_input
@pytest.mark.parametrize(
    ("annotate", "words"),
    [
        ("{good}", "is one of the input images"),
        ("{good}/x.png", "is a file, not a folder"),
        ("{fifo}", "exists and is not a regular file"),
        ("{dir}/out.gif2", "unknown image type"),
        ("/proc/mearm-no-such-folder/out.png", "the folder /proc is not writable"),
    ],
)
def test_detect_annotate_never_overwrites_an_input(
    annotate: str, words: str, images: dict[str, Path], tmp_path: Path
) -> None:
    """--annotate onto an input image, a FIFO or nowhere (a folder that cannot be made):
    refused; the input intact."""
    fifo = tmp_path / "out.png"
    os.mkfifo(fifo)
    target = annotate.format(good=images["good"], folder=images["folder"], fifo=fifo, dir=tmp_path)
    out = check_bad_input(
        ["detect", images["good"], "--annotate", target],
        within_s=3,
        keep=[images["good"].parent],
    )
    assert words in out.line


# ------------------------------------------------------------- the promise in a real process


@bad_input
@pytest.mark.parametrize(
    "name", ["png_30000x30000", "jpeg_65000x65000", "tiff_100000x100000", "dev_zero", "fifo"]
)
@pytest.mark.heavy
def test_huge_header_ends_fast_in_a_real_process(name: str, images: dict[str, Path]) -> None:
    """The issue's 30000² PNG header (and its kin): under 2 s, exit 2, one line."""
    out = check_bad_input_subprocess(
        ["detect", images[name]], within_s=2, keep=[images["good"].parent]
    )
    assert ALL_IMAGES[name] in out.line


@bad_input
@pytest.mark.parametrize("name", ["png_cut_in_idat", "png_idat_garbage", "jpeg_cut_after_header"])
@pytest.mark.heavy
def test_a_damaged_image_is_one_line_in_a_real_process(name: str, images: dict[str, Path]) -> None:
    """libpng writes its own error to the process's stderr (``libpng error: …``): it was a
    second line beside mearm's, seen only by a real process's stderr."""
    out = check_bad_input_subprocess(
        ["detect", images[name]], within_s=2, keep=[images["good"].parent]
    )
    assert ALL_IMAGES[name] in out.line and "libpng" not in out.stderr


@bad_input
@pytest.mark.heavy
def test_huge_header_for_calibration_ends_fast_in_a_real_process(
    images: dict[str, Path], tmp_path: Path
) -> None:
    config = tmp_path / "lab.yaml"
    config.write_bytes(LAB.read_bytes())
    out = check_bad_input_subprocess(
        ["calibrate-camera", "--config", config, "--image", images["png_30000x30000"], *MARKERS],
        within_s=2,
        keep=[config],
    )
    assert "30000x30000" in out.line


# --------------------------------------------------------------------------- properties


_MAGIC = [b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR", b"\xff\xd8", b"\xff\xd8\xff\xc0", b"BM",
          b"II*\x00", b"MM\x00*", b"RIFF\x00\x00\x00\x00WEBPVP8 ", b"RIFF\x00\x00\x00\x00WEBPVP8L",
          b"RIFF\x00\x00\x00\x00WEBPVP8X", b"P6\n", b"P5 1 ", b""]  # fmt: skip


@bad_input
@settings(max_examples=400, deadline=None)
@given(st.sampled_from(_MAGIC), st.binary(max_size=200))
def test_any_header_bytes_give_a_size_or_none(magic: bytes, rest: bytes) -> None:
    """image_size never raises, and a size it gives is two non-negative integers."""
    size = image_size(magic + rest)
    if size is not None:
        assert size.width_px >= 0 and size.height_px >= 0


@bad_input
@settings(max_examples=60, deadline=None)
@given(st.sampled_from(_MAGIC), st.binary(max_size=300))
def test_any_file_is_read_or_refused_with_image_error(magic: bytes, rest: bytes) -> None:
    """read_image on arbitrary bytes: a BGR frame within the caps, or an ImageError."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "x.img"
        path.write_bytes(magic + rest)
        try:
            frame = read_image(path)
        except ImageError as exc:
            assert len(str(exc).splitlines()) == 1
        else:
            assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
            assert frame.shape[0] * frame.shape[1] <= MAX_IMAGE_PIXELS


@pytest.mark.parametrize(
    ("ext", "shape"),
    [(".png", (480, 640)), (".png", (480, 640, 4)), (".png", (1, 1, 3)), (".jpg", (480, 640, 3)),
     (".bmp", (480, 640, 3)), (".tif", (480, 640, 3)), (".webp", (480, 640, 3)),
     (".ppm", (480, 640, 3)), (".pgm", (480, 640))],
)  # fmt: skip
def test_every_supported_format_still_reads(ext: str, shape: tuple[int, ...], tmp_path: Path):
    """The header checks accept what OpenCV writes in each supported format."""
    path = tmp_path / f"frame{ext}"
    path.write_bytes(real(ext, shape))
    frame = read_image(path)
    assert frame.shape == (*shape[:2], 3)
    out = run_in_process(["detect", "--json", path], within_s=5)
    assert out.code == 0, out.stderr
