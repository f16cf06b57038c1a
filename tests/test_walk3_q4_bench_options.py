"""``mearm vision-bench``: an option the chosen bench would not read is refused, and the
rendered bench's figures are labelled simulated.

``--config nope`` without ``--photos`` used to run the rendered bench (the paper's rig,
whatever the config) and exit 0 without reading it; ``--repeat`` with ``--photos`` was
dropped the same way. A user who gives one takes it as obeyed.
"""

from __future__ import annotations

import pytest
from conftest import run_main

from mearm.tools.vision_bench import main


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    return run_main(capsys, main, *argv)


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (
            ["--config", "sim", "--repeat", "1", "--seeds", "1"],
            "--config and --set apply to --photos only",
        ),
        (
            ["--set", "camera.noise_std=0", "--repeat", "1", "--seeds", "1"],
            "--config and --set apply",
        ),
        (["--photos", "nowhere", "--repeat", "3"], "--repeat applies to the rendered scenes"),
        (
            ["--photos", "nowhere", "--learn", "--seeds", "2"],
            "--seeds applies to the rendered scenes",
        ),
    ],
)
def test_an_option_the_bench_would_not_read_is_refused(
    capsys: pytest.CaptureFixture[str], argv: list[str], words: str
) -> None:
    """Exit 2, one line naming the option, nothing on stdout."""
    code, out, err = _run(capsys, argv)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and words in err


def test_rendered_bench_ends_labelled_simulated(capsys: pytest.CaptureFixture[str]) -> None:
    """Its last line says the scenes are rendered, not a camera's frames."""
    code, out, _ = _run(capsys, ["--repeat", "1", "--seeds", "1"])
    assert code == 0
    assert out.splitlines()[-1].startswith("simulated: ")
