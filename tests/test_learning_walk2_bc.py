"""docs/learning.md walked as a new user: the baseline's command names each file it writes."""

from __future__ import annotations

import pytest

from mearm.learn.bc import main as bc_main

#: One PickPlace expert episode, two minibatches: a run in seconds.
RUN = ["--episodes", "1", "--first-seed", "0", "--jobs", "1", "--steps", "2", "--batch", "8"]


def _wrote(out: str) -> list[str]:
    return [line.removeprefix("wrote ") for line in out.splitlines() if line.startswith("wrote ")]


def test_each_file_written_is_named_on_a_wrote_line(tmp_path, capsys):
    """The demonstrations and the baseline: neither had a ``wrote`` line (the baseline's
    name ended the "trained" line; the demonstrations were not named)."""
    pytest.importorskip("torch")  # here, not at the module's top: collecting it in every
    # worker imported PyTorch three times (about 1.9 s of CPU each, docs/development.md)
    demos, out = tmp_path / "d.npz", tmp_path / "bc.pt"
    assert bc_main([*RUN, "--demos", str(demos), "--out", str(out)]) == 0
    assert _wrote(capsys.readouterr().out) == [str(demos), str(out)]
    assert demos.is_file() and out.is_file()

    again = tmp_path / "bc2.pt"  # the demonstrations reused: only the baseline is written
    assert bc_main([*RUN, "--demos", str(demos), "--out", str(again)]) == 0
    assert _wrote(capsys.readouterr().out) == [str(again)]
