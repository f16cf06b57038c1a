"""``mearm analyze --out DIR`` refuses a folder it cannot write before reading the log.

The folder was made only once the log was read and analysed: a log's warnings (a torn
last line, attempts left out) were printed first, so the refusal was not stderr's only
line, and the analysis (or a long gain sweep) ran for nothing.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.__main__ import main
from mearm.analysis.synthetic import write_synthetic_log

#: A folder no file can be made in, even by root: ``/proc`` refuses every new file.
UNWRITABLE = Path("/proc/mearm-analyze-out")


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc")
def test_unwritable_out_is_the_only_line_and_nothing_is_analysed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "trials.jsonl"
    write_synthetic_log(log, n_routes=24, seed=27001)
    with log.open("a") as f:
        f.write('{"type": "route", "torn')  # a torn last line: analyse warns of it
    with pytest.raises(SystemExit) as exc:
        main(["analyze", str(log), "--out", str(UNWRITABLE)])
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1, err
    assert f"--out {UNWRITABLE}: cannot write" in err
