"""A dropped AV1 episode says nothing on stderr.

Found walking docs/datasets.md: Ctrl-C (or SIGTERM) of a recorded ``mearm sort`` printed
``Svt[error]: deinit called without sending EOS!`` from the encoder process above the
sort's own stderr line: the episode being recorded was dropped, its SVT-AV1 encoder
closed without its end of stream.
"""

from __future__ import annotations

import gc
from pathlib import Path

import numpy as np
import pytest

av = pytest.importorskip("av")

from mearm.dataset.encoder_server import EpisodeWriter, rgb_frame  # noqa: E402


@pytest.mark.parametrize("codec", ["av1", "h264"])
def test_a_dropped_episode_is_dropped_quietly(
    codec: str, tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(0)
    writer = EpisodeWriter(av, tmp_path / "e.mp4", 10, (64, 96), codec)
    for _ in range(3):
        writer.add(rgb_frame(av, rng.integers(0, 255, (64, 96, 3), dtype=np.uint8)))
    writer.discard()
    del writer  # its codec context freed: where SVT-AV1 said it
    gc.collect()
    assert not (tmp_path / "e.mp4").exists()
    assert capfd.readouterr().err == ""
