"""Episode videos as fragments: appended to a file by bytes, decoded frame for frame.

Each episode is encoded on its own (:class:`EpisodeWriter`); the second's fragment moved
past the first's frames (:meth:`EpisodeVideo.shifted`) and appended must decode as one
video whose frames are both episodes' in order, at consecutive frame times, whatever the
codec. A file written whole (not fragmented) is not appended to.
"""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.dataset.fragments import EpisodeVideo, FragmentError, file_header
from mearm.dataset.lerobot_format import VIDEO_CODECS
from mearm.dataset.sampler import DrawsRGB
from mearm.dataset.video_encoder import EpisodeWriter
from mearm.task import open_rig

FPS = 10
SIZE_HW = (48, 64)


def _frames(n: int, seed: int) -> list[np.ndarray]:
    """Flat colours far apart, so that each decoded frame says which one it was."""
    rng = np.random.default_rng(seed)
    return [np.full((*SIZE_HW, 3), rng.integers(20, 235, 3), np.uint8) for _ in range(n)]


def _episode(path: Path, frames: list[np.ndarray], codec: str) -> EpisodeVideo:
    writer = EpisodeWriter(av, path, FPS, SIZE_HW, codec)
    for frame in frames:
        writer.add(av.VideoFrame.from_ndarray(frame, format="rgb24"))
    writer.close()
    return EpisodeVideo.parse(path.read_bytes())


@pytest.mark.parametrize("codec", list(VIDEO_CODECS))
def test_a_fragment_appended_decodes_after_the_first_episode(codec: str, tmp_path: Path) -> None:
    """5 + 4 frames: 9 frames at k / fps, each the colour it was given, the codec kept."""
    first, second = _frames(5, 1), _frames(4, 2)
    a = _episode(tmp_path / "a.mp4", first, codec)
    b = _episode(tmp_path / "b.mp4", second, codec)
    assert a.header == b.header  # the same encoding: the same header, byte for byte
    joined = tmp_path / "joined.mp4"
    joined.write_bytes(a.header + a.shifted(0, FPS) + b.shifted(len(first), FPS))
    assert file_header(joined) == a.header
    with av.open(str(joined)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name in VIDEO_CODECS[codec].decoders
        decoded = [
            (float(f.pts * f.time_base), f.to_ndarray(format="rgb24"))
            for f in container.decode(stream)
        ]
    assert [t for t, _ in decoded] == pytest.approx([k / FPS for k in range(9)], abs=1e-9)
    for (_, got), want in zip(decoded, first + second, strict=True):
        assert np.abs(got.astype(int) - want).max() <= 6  # lossy, but this frame's colour


def test_a_file_written_whole_is_not_appended_to(tmp_path: Path) -> None:
    """FFmpeg's default MP4 (samples listed in its moov) has no header to append to."""
    path = tmp_path / "whole.mp4"
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=FPS)
        stream.height, stream.width = SIZE_HW
        for frame in _frames(3, 3):
            for packet in stream.encode(av.VideoFrame.from_ndarray(frame, format="rgb24")):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    assert file_header(path) is None
    with pytest.raises(FragmentError, match="not a fragmented MP4"):
        EpisodeVideo.parse(path.read_bytes())


@pytest.mark.heavy
def test_the_twins_frame_drawn_for_a_recording_is_its_peek() -> None:
    """peek_rgb draws into the encoder's buffer what peek shows (RGB), counting no frame."""
    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    with open_rig(config) as rig:
        camera = rig.camera
        assert isinstance(camera, DrawsRGB)
        out = np.zeros((config.camera.height_px, config.camera.width_px, 3), np.uint8)
        camera.peek_rgb(out)
        assert camera.frames_read == 0
        np.testing.assert_array_equal(out, camera.peek()[:, :, ::-1])
