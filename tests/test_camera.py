"""Camera sources: sim (renders the world), file, folder, device; every failure named."""

from __future__ import annotations

import os
import time
from pathlib import Path

import cv2
import numpy as np
import pytest

from mearm.backends import open_camera
from mearm.config import Config, config_from_dict
from mearm.exceptions import CameraError, ConfigError
from mearm.sim import SimCamera, World
from mearm.sim.kinematic.renderer import Disc, Paper, Shadow, TableRenderer, class_discs
from mearm.vision import (
    Calibration,
    ColorDetector,
    DeviceCamera,
    FileCamera,
    FolderCamera,
)


def cfg(**camera) -> Config:
    return config_from_dict({"camera": camera})


def frame_of(value: int, size=(640, 480)) -> np.ndarray:
    return np.full((size[1], size[0], 3), value, np.uint8)


def test_sim_camera_shows_the_current_table() -> None:
    """Picked objects vanish from the next frame; bins are never drawn."""
    config = Config()
    world = World.from_config(config)
    detector = ColorDetector.from_config(
        config.vision, config.calibration, config.camera, config.task.classes
    )
    with SimCamera(config, world) as cam:
        assert len(detector.detect(cam.read())) == 12
        world.objects[0].held = True
        found = detector.detect(cam.read())
        assert len(found) == 11 and [d.color for d in found].count("red") == 3
        world.objects[0].held, world.objects[0].bin = False, "red"
        world.objects[4].bin = "green"
        assert len(detector.detect(cam.read())) == 10
        for o in world.objects:
            o.bin = o.color
        assert detector.detect(cam.read()) == []
        assert cam.frames_read == 4


def test_sim_frames_are_seeded() -> None:
    """Each read has fresh noise; the same seed gives the same sequence."""
    config = Config()
    a, b = (SimCamera(config, World.from_config(config)) for _ in range(2))
    first, second = a.read(), a.read()
    assert first.shape == (480, 640, 3) and first.dtype == np.uint8
    assert not np.array_equal(first, second)
    assert np.array_equal(first, b.read()) and np.array_equal(second, b.read())
    other = SimCamera(cfg(seed=1), World.from_config(config))
    assert not np.array_equal(first, other.read())


def test_a_changed_table_is_drawn_as_a_fresh_renderer_draws_it() -> None:
    """Frame for frame, bit for bit, a renderer that has drawn the scenes before draws a
    table with objects taken, nudged and reordered (and distractors) as a new one does:
    only the box of what changed is drawn again, in the order a whole frame is drawn."""
    config = Config()
    calibration = Calibration.from_config(config.calibration)
    extras = (Shadow(0.0, 40.0, 3.0), Disc((10, 200, 30), 3.0, 45.0, 2.5), Paper(-5, 45, 10, 8))
    rng = np.random.default_rng(4101)
    for kept in ((), extras):
        renderer = TableRenderer.from_config(config.camera, calibration, kept)
        table = [
            (c.name, *rng.uniform((-15.0, 30.0, 0.0), (15.0, 55.0, 90.0)))
            for c in config.task.classes
            for _ in range(4)
        ]
        for i in range(16):
            discs = class_discs(config.task.classes, table)
            fresh = TableRenderer.from_config(config.camera, calibration, kept)
            assert np.array_equal(renderer.render(discs, i), fresh.render(discs, i)), i
            if table:
                table.pop(int(rng.integers(len(table))))
            if table and i % 3 == 1:
                name, x, y, yaw = table[0]
                table[0] = (name, x + 0.4, y, yaw)
            if i == 9:
                table.reverse()


def test_open_camera_builds_the_sim_world_from_the_scene() -> None:
    """kind sim without a world: the config's scene is on the table."""
    config = Config()
    with open_camera(config) as cam:
        assert isinstance(cam, SimCamera)
        assert len(cam.world.table_objects()) == 12


def test_open_camera_shows_the_world_given() -> None:
    """kind sim with a world: that world is on the table."""
    config = Config()
    world = World.from_config(config)
    world.objects[0].bin = "red"
    with open_camera(config, world) as cam:
        assert cam.world is world
        assert (
            len(
                ColorDetector.from_config(
                    config.vision, config.calibration, config.camera, config.task.classes
                ).detect(cam.read())
            )
            == 11
        )


def test_sim_object_of_an_unknown_class_is_an_error() -> None:
    """An object whose class is not in task.classes cannot be drawn: CameraError naming it."""
    config = Config()
    world = World.from_config(config)
    world.objects[3].color = "purple"
    with pytest.raises(CameraError, match=r"red4 is of class 'purple'.*\(red, green, blue\)"):
        SimCamera(config, world).read()


def test_read_after_close_is_an_error() -> None:
    cam = open_camera(Config())
    cam.close()
    with pytest.raises(CameraError, match="read after close"):
        cam.read()


def test_folder_replays_images_in_name_order(tmp_path: Path) -> None:
    """Frames come in file-name order; other files are ignored; the end is an error."""
    for name, value in [("b.png", 20), ("a.png", 10), ("c.jpg", 30)]:
        cv2.imwrite(str(tmp_path / name), frame_of(value))
    (tmp_path / "notes.txt").write_text("not a frame")
    with open_camera(cfg(kind="folder", path=str(tmp_path))) as cam:
        assert isinstance(cam, FolderCamera)
        assert [int(np.median(cam.read())) for _ in range(3)] == [10, 20, 30]
        with pytest.raises(CameraError, match="no more frames after 3"):
            cam.read()


def test_folder_loops_when_asked(tmp_path: Path) -> None:
    for name, value in [("0.png", 1), ("1.png", 2)]:
        cv2.imwrite(str(tmp_path / name), frame_of(value))
    with open_camera(cfg(kind="folder", path=str(tmp_path), loop=True)) as cam:
        assert [int(cam.read()[0, 0, 0]) for _ in range(5)] == [1, 2, 1, 2, 1]


def test_folder_errors(tmp_path: Path) -> None:
    """Missing folder, no images, a file that is no image (on opening), a frame of the
    wrong size (on reading)."""
    with pytest.raises(CameraError, match="no such folder"):
        open_camera(cfg(kind="folder", path=str(tmp_path / "nope")))
    with pytest.raises(CameraError, match="holds no images"):
        open_camera(cfg(kind="folder", path=str(tmp_path)))
    (tmp_path / "0.png").write_bytes(b"not a png")
    cv2.imwrite(str(tmp_path / "1.png"), frame_of(5, (320, 240)))
    with pytest.raises(CameraError, match="0.png: not an image of a known format") as info:
        open_camera(cfg(kind="folder", path=str(tmp_path)))  # every header checked on opening
    assert info.value.source == f"folder {tmp_path}"
    (tmp_path / "0.png").unlink()
    cam = open_camera(cfg(kind="folder", path=str(tmp_path)))
    with pytest.raises(CameraError, match="frame is 320x240 px but the config says 640x480"):
        cam.read()


def test_file_camera_still_image(tmp_path: Path) -> None:
    """An image file: every read returns it (a copy)."""
    path = tmp_path / "still.png"
    cv2.imwrite(str(path), frame_of(77))
    with open_camera(cfg(kind="file", path=str(path))) as cam:
        assert isinstance(cam, FileCamera)
        a = cam.read()
        a[...] = 0
        assert int(cam.read()[0, 0, 0]) == 77


def _write_video(path: Path, values: list[int]) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (640, 480))
    assert writer.isOpened()
    for v in values:
        writer.write(frame_of(v))
    writer.release()


def test_file_camera_video_in_order_then_end_or_loop(tmp_path: Path) -> None:
    """A video: frames in order; at the end an error, or the start again with loop."""
    path = tmp_path / "clip.avi"
    _write_video(path, [40, 120, 200])
    with open_camera(cfg(kind="file", path=str(path))) as cam:
        got = [int(np.median(cam.read())) for _ in range(3)]
        assert all(abs(g - w) <= 3 for g, w in zip(got, [40, 120, 200], strict=True))
        with pytest.raises(CameraError, match="end of video"):
            cam.read()
    with open_camera(cfg(kind="file", path=str(path), loop=True)) as cam:
        got = [int(np.median(cam.read())) for _ in range(4)]
        assert abs(got[3] - 40) <= 3


def test_file_camera_errors(tmp_path: Path) -> None:
    with pytest.raises(CameraError, match="no such file"):
        open_camera(cfg(kind="file", path=str(tmp_path / "missing.png")))
    junk = tmp_path / "junk.bin"
    # fixed bytes: of 4,000 random ones, 3 began with "/", which an OpenCV image reader
    # claims, and CI's run once met one (then the error is the image reader's)
    junk.write_bytes(b"mearm: neither a picture nor a video\n" * 56)
    assert not cv2.haveImageReader(str(junk))
    with pytest.raises(CameraError, match="neither an image nor a video"):
        open_camera(cfg(kind="file", path=str(junk)))
    bad_png = tmp_path / "bad.png"
    bad_png.write_bytes(b"\x89PNG\r\n\x1a\n garbage")
    with pytest.raises(CameraError, match="damaged image header"):
        open_camera(cfg(kind="file", path=str(bad_png)))


def test_replay_kinds_need_a_path() -> None:
    with pytest.raises(ConfigError, match="needs camera.path"):
        cfg(kind="folder")


def test_missing_device_is_a_quick_clear_error() -> None:
    """A camera index with no device: CameraError naming it, without waiting the timeout."""
    start = time.monotonic()
    with pytest.raises(CameraError, match=r"device 63.*cannot open or read it") as info:
        open_camera(cfg(kind="device", device_index=63, open_timeout_s=60.0))
    assert time.monotonic() - start < 30.0
    assert info.value.source == "device 63"


@pytest.mark.heavy
def test_device_that_hangs_times_out(tmp_path: Path) -> None:
    """A device path whose open blocks (a FIFO nobody writes) fails after the timeout."""
    fifo = tmp_path / "video-fifo"
    os.mkfifo(fifo)
    start = time.monotonic()
    with pytest.raises(CameraError, match=r"did not open within 0.5 s"):
        DeviceCamera(cfg(kind="device", path=str(fifo), open_timeout_s=0.5).camera)
    assert 0.4 < time.monotonic() - start < 30.0  # waited the timeout; the bound: no hang
    try:  # let the abandoned opener finish
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    except OSError:
        pass
