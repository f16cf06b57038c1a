"""A run log the disk stops taking mid-sort is a fault: the arm parks, the file stays whole.

``mearm sort --config sim --log small/run.jsonl`` on a full disk (a 16 KiB tmpfs) ended
"unexpected error: OSError: [Errno 28] No space left on device" (the log's close failed
again after its write had), the arm left holding an object at its pick, not parked, and
the log cut in the middle of a record (it could not be appended to or resumed). Now the
sort stops, says why, parks, exits 1; the log ends with its last whole record.
"""

from __future__ import annotations

from pathlib import Path

from conftest import mearm_here, one_stderr_line, tmpfs

from mearm.runlog import read_runlog


def test_a_full_disk_stops_the_sort_parked_and_keeps_the_log_whole(tmp_path: Path) -> None:
    with tmpfs(tmp_path / "small", "16k") as small:
        log = small / "run.jsonl"
        done = mearm_here("sort", "--config", "sim", "--log", log, "--quiet", cwd=tmp_path)
        line = one_stderr_line(done, 1)
        assert line == (
            f"mearm sort: stopped: run log {log}: cannot write: No space left on device; "
            "arm parked at home"
        ), line
        text = log.read_bytes()
        assert text.endswith(b"\n"), text[-80:]
        trials = read_runlog(log).trials
        assert len(trials) == 1 and trials[0].routes  # every whole record is read back
        assert "stopped by a fault" in done.stdout
