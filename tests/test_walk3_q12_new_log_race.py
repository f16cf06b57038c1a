"""Two experiments started on one new log: the later one appends nothing.

A run that finds no log takes the log's lock only when it opens it, after its workers
start (seconds, for ``--scheduler local``). Another run that wrote the whole log in that
time has ended, so the lock did not stop it; the first used to append its trials again
(trial 0 complete twice: ``mearm analyze`` refuses the log). The other run is a real
experiment, run in this process inside that window (wrapping the check before the trials).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.__main__ import main as mearm_main
from mearm.experiment import commandline
from mearm.runlog import read_runlog

SCENE = "- {color: red, x: -10.99, y: 49.70}\n"


def test_a_log_written_meanwhile_is_left_to_the_run_that_wrote_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Exit 2, one line, nothing appended; the same command then resumes the log."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    log = tmp_path / "trials.jsonl"
    argv = ["experiment", "--scene", str(scene), "--log", str(log)]
    real_check = commandline.check_rig_opens
    others: list[int | None] = []

    def other_run_meanwhile(*args: object, **kwargs: object) -> None:
        if not others:  # the first run's check: the other run starts and ends here
            others.append(None)  # (its own check is then the real one)
            others[0] = commandline.main([*argv[1:], "--trials", "1"])
            capsys.readouterr()  # its lines
        real_check(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(commandline, "check_rig_opens", other_run_meanwhile)
    capsys.readouterr()
    with pytest.raises(SystemExit) as stopped:
        mearm_main([*argv, "--trials", "2"])
    out, err_text = capsys.readouterr()
    err = err_text.strip().splitlines()
    assert others == [0], err
    assert "wrote" not in out, out  # the other run wrote the log, not this one
    assert stopped.value.code == 2, err
    assert len(err) == 1 and "was written by another run while this one started" in err[0], err
    assert [t.number for t in read_runlog(log).trials] == [0]  # the other run's, alone

    monkeypatch.setattr(commandline, "check_rig_opens", real_check)
    with pytest.raises(SystemExit) as resumed:
        mearm_main([*argv, "--trials", "2"])
    assert resumed.value.code == 0, capsys.readouterr().err
    assert [t.number for t in read_runlog(log).trials] == [0, 1]
