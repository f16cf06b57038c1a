"""A stop that lands after the experiment's last trial does not claim a rest to run."""

from __future__ import annotations

from pathlib import Path

from badinput import Outcome, run_in_process

ONE = "- {color: red, x: -10.99, y: 49.70}\n"


def experiment(*args: object) -> Outcome:
    """``mearm experiment ARGS`` in this process."""
    return run_in_process(["experiment", *map(str, args)], within_s=120)


def test_a_ctrl_c_after_every_trial_says_nothing_is_left(tmp_path: Path, monkeypatch) -> None:
    """Ctrl-C after the last trial was logged (the workers' last one finished as it came):
    exit 130, as the user asked it to stop, but "4 of 4 trials complete …: the same command
    runs the rest" was false; it now says nothing is left to run."""
    from mearm.experiment import commandline

    real = commandline.run_trials

    def all_then_ctrl_c(*args, **kwargs):  # every trial, then Ctrl-C
        real(*args, **kwargs)
        raise KeyboardInterrupt

    log, scene = tmp_path / "e.jsonl", tmp_path / "scene.yaml"
    scene.write_text(ONE)
    monkeypatch.setattr(commandline, "run_trials", all_then_ctrl_c)
    out = experiment("--config", "sim", "--scene", scene, "--trials", "2", "--log", log)
    assert out.code == 130, out.stderr
    assert out.line == (
        f"mearm experiment: stopped: interrupted (Ctrl-C) between trials; 2 of 2 trials "
        f"complete in {log}: the stop came after the last, nothing is left to run"
    )
    assert "runs the rest" not in out.stderr
