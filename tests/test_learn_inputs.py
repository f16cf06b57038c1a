"""`python -m mearm.learn.bc`'s inputs and output: a --demos file of another run, a bad
--demos file, and an --out that cannot be written (exit 2, one line, nothing lost)."""

from __future__ import annotations

import contextlib
import importlib.util
import resource
import signal
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

if importlib.util.find_spec("torch") is None:
    pytest.skip("could not import 'torch': No module named 'torch'", allow_module_level=True)

from mearm.cli import run  # noqa: E402
from mearm.config.files import resolve_config_path  # noqa: E402
from mearm.learn.bc import main as bc_main  # noqa: E402

pytestmark = pytest.mark.heavy


#: The run that collected the module's demos file (one PickPlace episode, seed 0).
RUN = ["--episodes", "1", "--first-seed", "0", "--jobs", "1", "--steps", "2", "--batch", "8"]


def _bc(capsys, *argv: object) -> tuple[int, str]:
    """Exit status and stderr of the command, through its CLI guard, in this process."""
    with pytest.raises(SystemExit) as exc:
        run(bc_main, [str(a) for a in argv])
    return int(exc.value.code or 0), capsys.readouterr().err


@pytest.fixture(scope="module")
def demos(tmp_path_factory) -> Path:
    """A demos file collected by the command (RUN), and the baseline trained on it."""
    folder = tmp_path_factory.mktemp("demos")
    assert bc_main([*RUN, "--demos", str(folder / "d.npz"), "--out", str(folder / "a.pt")]) == 0
    return folder / "d.npz"


def test_the_same_run_reuses_its_demos_also_with_the_config_as_a_path(demos, tmp_path, capsys):
    """Reused unchanged; ``sim_mujoco`` and its file are one config."""
    before = demos.read_bytes()
    config = resolve_config_path("sim_mujoco")
    code, err = _bc(capsys, *RUN, "--config", config, "--demos", demos, "--out", tmp_path / "b.pt")
    assert code == 0, err
    assert demos.read_bytes() == before and (tmp_path / "b.pt").stat().st_size > 1000


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--env", "mearm/Sort-v0"], "collected with --env mearm/PickPlace-v0, not mearm/Sort-v0"),
        (["--episodes", "3"], "collected with --episodes 1, not 3"),
        (["--first-seed", "5"], "collected with --first-seed 0, not 5"),
        (["--config", "sim_mujoco_perspective"], "collected with --config "),
    ],
)
def test_demos_of_another_run_are_refused(demos, tmp_path, capsys, args, words):
    """Each was reused silently: a model labelled Sort-v0 trained on PickPlace's demos."""
    before = demos.read_bytes()
    argv = [*RUN, *args, "--demos", demos, "--out", tmp_path / "b.pt"]
    code, err = _bc(capsys, *argv)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert words in err and f"or delete {demos} to collect anew" in err
    assert demos.read_bytes() == before and not (tmp_path / "b.pt").exists()


def _old_file(demos: Path, path: Path) -> None:
    """The demos as an older mearm wrote them: the arrays, no metadata."""
    with np.load(demos) as data:
        np.savez(path, **{k: data[k] for k in data.files if k != "meta"})


def _no_arrays(demos: Path, path: Path) -> None:
    np.savez(path, a=np.zeros(3))


def _truncated(demos: Path, path: Path) -> None:
    path.write_bytes(demos.read_bytes()[:1000])


def _text(demos: Path, path: Path) -> None:
    path.write_text("episodes: 3\n")


def _empty(demos: Path, path: Path) -> None:
    path.write_bytes(b"")


def _one_array(demos: Path, path: Path) -> None:
    with path.open("wb") as f:
        np.save(f, np.zeros(3))


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (_old_file, "does not say what its episodes were collected for"),
        (_no_arrays, "not a demonstrations file of mearm.learn: it has no agent_pos, "),
        (_truncated, "a damaged or truncated .npz (BadZipFile"),
        (_text, "not a demonstrations file (.npz, a zip archive)"),
        (_empty, "the file is empty"),
        (_one_array, "one array (.npy), not a demonstrations file"),
    ],
)
def test_a_bad_demos_file_is_refused_in_one_line(demos, tmp_path, capsys, make, words):
    """Each was a traceback (ValueError, KeyError, BadZipFile), exit 1; now exit 2 naming
    the file, and the file is left as it was."""
    bad = tmp_path / "bad.npz"
    make(demos, bad)
    before = bad.read_bytes()
    code, err = _bc(capsys, *RUN, "--demos", bad, "--out", tmp_path / "b.pt")
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"--demos {bad}: {words}" in err
    assert bad.read_bytes() == before and not (tmp_path / "b.pt").exists()


def test_out_onto_the_demos_file_is_refused(demos, tmp_path, capsys):
    """A .pt path given to both would be collected into, then replaced by the baseline."""
    both = tmp_path / "x.pt"
    code, err = _bc(capsys, *RUN, "--demos", both, "--out", both)
    assert code == 2 and "is the --demos file" in err and not both.exists()


def test_a_baseline_that_exists_is_kept_without_force(demos, tmp_path, capsys):
    """A second run (learning.md's own --steps 3000 retry) replaced bc.pt, a baseline
    trained for minutes, without a word: now exit 2, one line, the file as it was."""
    out = tmp_path / "bc.pt"
    out.write_bytes(b"the earlier baseline")
    code, err = _bc(capsys, *RUN, "--demos", demos, "--out", out)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"--out {out}: exists; pass --force to replace it" in err
    assert out.read_bytes() == b"the earlier baseline"


@contextlib.contextmanager
def _file_size_limit(limit: int) -> Iterator[None]:
    """Writes past ``limit`` bytes of a file fail (EFBIG), as on a full disk, in this process
    while the block runs: the soft limit only, put back after (the hard one stays)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, handler)


def test_an_out_that_cannot_be_written_keeps_the_old_file_and_leaves_no_part(
    demos, tmp_path, capsys, monkeypatch
):
    """The baseline's write fails (a file-size limit, as a full disk does): one line, exit 2,
    the earlier baseline intact and no temporary or empty .pt left (it was torch.save to
    the path itself: "unexpected error: RuntimeError" and a half file). Run in this
    process, from ``tmp_path``: nothing else may be left there either."""
    out = tmp_path / "bc.pt"
    out.write_bytes(b"the earlier baseline")
    monkeypatch.chdir(tmp_path)
    with _file_size_limit(20_000):
        code, err = _bc(capsys, *RUN, "--demos", demos, "--out", out, "--force")
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and f"cannot write --out {out}: " in lines[0], err
    assert out.read_bytes() == b"the earlier baseline"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bc.pt"]


@pytest.mark.parametrize("flag", ["--episodes", "--steps", "--batch"])
@pytest.mark.parametrize("value", ["0", "-3"])
def test_a_count_under_one_is_named_with_what_it_got(tmp_path, capsys, flag, value):
    """It said "--episodes, --steps and --batch must be at least 1", not which one."""
    argv = list(RUN)
    argv[argv.index(flag) + 1] = value
    code, err = _bc(capsys, *argv, "--out", tmp_path / "b.pt")
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert lines[0].endswith(f": error: {flag} must be at least 1, got {value}"), err
    assert not list(tmp_path.iterdir())
