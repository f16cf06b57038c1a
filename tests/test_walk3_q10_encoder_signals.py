"""The encoder process outlives a stop signal sent to the whole process group.

Found walking docs/datasets.md: ``kill -TERM -PGID`` of a recorded ``mearm sort`` (a
supervisor's stop; a closed terminal's SIGHUP likewise) killed the encoder process too,
which ignored only Ctrl-C. The sort, stopping as for Ctrl-C, then waited for its finished
episodes' videos from a dead process: it ended ``mearm sort: interrupted`` (exit 143)
without the ``wrote DIR/`` line, the summary or the parked arm's line, and the episodes
still being encoded were lost.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("av")

from mearm.dataset import video_encoder  # noqa: E402

SHM_DIR = Path("/dev/shm")
SHAPE = (48, 64, 3)


@pytest.mark.skipif(not SHM_DIR.is_dir(), reason="no /dev/shm to watch the ring leave")
def test_the_encoder_ignores_the_stop_signals_and_still_writes(tmp_path: Path) -> None:
    encoder = video_encoder.EncoderProcess(SHAPE, 10, "h264")
    try:
        name = encoder._shm.name.lstrip("/")  # noqa: SLF001
        proc = encoder._proc  # noqa: SLF001
        deadline = time.monotonic() + 60  # its start: a hang is the failure
        while (SHM_DIR / name).exists() and time.monotonic() < deadline:
            time.sleep(0.05)  # the ring leaves /dev/shm once serve() has set its signals
        assert not (SHM_DIR / name).exists()
        assert proc.pid is not None
        for stop in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
            os.kill(proc.pid, stop)
        proc.join(timeout=1.0)  # time for a signal's default action to end it
        assert proc.is_alive(), f"the encoder died: exit code {proc.exitcode}"
        encoder.open(0, tmp_path / "e.mp4")
        rng = np.random.default_rng(0)
        for _ in range(3):
            slot, rgb = encoder.slot()
            rgb[:] = rng.integers(0, 255, SHAPE, dtype=np.uint8)
            encoder.frame(0, slot)
        encoder.finish(0)
        done, error, _ = encoder.done(0, wait=True)
        assert (done, error) == (True, None)
        assert (tmp_path / "e.mp4").stat().st_size > 0
    finally:
        encoder.close()
