"""`mearm eval-policy`: scores, JSON, progress, bad input (exit 2), a policy that raises."""

from __future__ import annotations

import errno
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from badinput import check_bad_input, run_in_process
from conftest import tmpfs

from mearm.envs.evaluate import write_video
from mearm.tools.eval_policy import main

pytestmark = pytest.mark.heavy

ROOT = Path(__file__).resolve().parent.parent

POLICIES = """
import numpy as np

HOME = np.array([120.0, 93.0, -132.0, 60.0, 0.0], dtype=np.float32)

def hold(observation):
    return HOME

def wrong_shape(observation):
    return HOME[:3]

def not_finite(observation):
    return HOME * np.nan

class Raises:
    def __init__(self):
        self.calls = 0
    def reset(self):
        self.calls = 0
    def __call__(self, observation):
        self.calls += 1
        if self.calls > 3:
            raise RuntimeError("the policy broke")
        return HOME

class RaisesOnce:
    def __init__(self):
        self.calls = 0
    def __call__(self, observation):
        self.calls += 1
        if self.calls == 4:
            raise RuntimeError("the policy broke once")
        return HOME
"""


@pytest.fixture
def policies(tmp_path, monkeypatch):
    (tmp_path / "my_policies.py").write_text(textwrap.dedent(POLICIES))
    monkeypatch.syspath_prepend(str(tmp_path))
    return "my_policies"


def _run(*argv: str) -> int:
    return main(["--jobs", "1", "--env-option", "obs_type=state", *argv])


def test_the_expert_succeeds_and_the_json_has_each_episode(tmp_path, capsys):
    """Two expert episodes: 100 % success, seeds, outcomes and returns in the JSON."""
    out = tmp_path / "pp.json"
    assert (
        _run("--policy", "expert", "--episodes", "2", "--first-seed", "7", "--out", str(out)) == 0
    )
    scores = json.loads(out.read_text())
    assert scores["pc_success"] == 100.0 and scores["avg_sum_reward"] == 1.0
    assert [e["seed"] for e in scores["per_episode"]] == [7, 8]
    assert all(e["success"] and e["in_bins"] == 1 for e in scores["per_episode"])
    assert scores["simulated"] is True
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("episode   1/2 seed 7: success")
    assert lines[-2] == f"wrote {out}"
    assert "success 100.0 % of 2 episodes" in lines[-1]  # the totals last


def test_a_policy_that_holds_still_scores_zero_and_require_fails_it(tmp_path, policies):
    """A policy that never moves sorts nothing; --require 0.5 then exits 1."""
    out = tmp_path / "hold.json"
    code = _run("--policy", f"{policies}:hold", "--episodes", "1", "--out", str(out),
                "--env-option", "max_episode_steps=20", "--require", "0.5")  # fmt: skip
    assert code == 1
    scores = json.loads(out.read_text())
    assert scores["pc_success"] == 0.0 and scores["per_episode"][0]["steps"] == 20


def test_a_policy_that_raises_ends_its_episode_as_a_named_failure(tmp_path, policies, capsys):
    """The error is the episode's, named; the next episode runs (reset() was called).

    Every episode ended on the error, so nothing was scored: exit 1 with a line saying so
    (it was exit 0 and "success 0.0 %", as if the policy had tried and failed).
    """
    out = tmp_path / "raises.json"
    assert _run("--policy", f"{policies}:Raises", "--episodes", "2", "--out", str(out)) == 1
    episodes = json.loads(out.read_text())["per_episode"]
    for e in episodes:
        assert not e["success"] and e["steps"] == 3
        assert e["error"] == "the policy raised RuntimeError: the policy broke"
    captured = capsys.readouterr()
    assert "the policy raised RuntimeError" in captured.out
    (line,) = captured.err.strip().splitlines()  # its prefix: the command as typed
    assert line.endswith(
        ": every episode ended on an error, so the policy "
        "was not scored (the first: the policy raised RuntimeError: the policy broke)"
    )


def test_a_run_where_some_episodes_ran_is_scored(tmp_path, policies, capsys):
    """One episode of two raised: the other was scored and --out written, but an episode
    failed, so exit 1 with a line counting them (walk 5: as for a NaN action)."""
    out = tmp_path / "once.json"
    code = _run("--policy", f"{policies}:RaisesOnce", "--episodes", "2", "--out", str(out),
                "--env-option", "max_episode_steps=10")  # fmt: skip
    assert code == 1
    assert [bool(e["error"]) for e in json.loads(out.read_text())["per_episode"]] == [True, False]
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.endswith(
        ": 1 of 2 episodes ended on an error (the first, seed 0: the policy raised "
        "RuntimeError: the policy broke once)"
    )


def test_videos_of_the_first_episodes_are_written(tmp_path):
    """--videos 1 writes the first episode as an H.264 MP4 beside the JSON, every frame
    (lerobot-eval's encoding; SVT-AV1 at its defaults deadlocked under load): the reset's
    and each step's, as lerobot-eval renders them."""
    import av

    out = tmp_path / "v.json"
    assert main(["--jobs", "1", "--episodes", "1", "--videos", "1", "--out", str(out),
                 "--env-option", "image_size=[24, 32]"]) == 0  # fmt: skip
    episode = json.loads(out.read_text())["per_episode"][0]
    video = Path(episode["video"])
    assert video.parent == tmp_path / "videos" and video.stat().st_size > 1000
    with av.open(str(video)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name == "h264"
        assert sum(1 for _ in container.decode(stream)) == episode["steps"] + 1


def test_a_video_on_a_full_disk_raises_its_error_and_leaves_no_part(tmp_path):
    """A video on a full disk: the error is raised, errno and all, and neither the video
    nor its temporary file is left behind (the MP4's index, written last, fails)."""
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 255, (120, 160, 3), dtype=np.uint8) for _ in range(20)]
    with tmpfs(tmp_path / "small", "8k") as small:
        with pytest.raises(OSError) as raised:
            write_video(small / "episode_000_seed_0.mp4", frames, 10)
        assert raised.value.errno == errno.ENOSPC
        assert list(small.iterdir()) == []


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--policy", "no_such_module_xyz:act"], "does not import"),
        (["--policy", "my_policies:missing"], "has no missing"),
        (["--policy", "nonsense"], "give expert, random, module:callable"),
        (["--policy", "my_policies:wrong_shape"], "has shape (3,)"),
        (["--env-option", "colour=red"], "not an option of the environments"),
        (["--env-option", "objects"], "give key=value"),
        (["--env-option", "fps=7"], "fps must divide"),
        (["--episodes", "0"], "--episodes must be at least 1"),
        (["--env", "mearm/Stack-v0"], "--env must be"),
    ],
)
def test_bad_input_exits_2_with_one_line(argv, words, policies):
    """Each bad input: exit 2, one line on stderr that names it (in this process, through
    the command's guard; the test below runs one in a real process)."""
    out = run_in_process(
        ["eval-policy", "--jobs", "1", "--episodes", "1", "--env-option", "obs_type=state",
         *argv], within_s=60,
    )  # fmt: skip
    assert out.code == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0], out.stderr


def test_bad_input_exits_2_with_one_line_from_a_real_process(tmp_path, policies):
    """The process's exit status and stderr, as a shell sees them (a policy of the user's
    module, found on PYTHONPATH, of the wrong shape)."""
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}", "MUJOCO_GL": "egl", "PATH": "/usr/bin:/bin"}
    proc = subprocess.run(
        [sys.executable, "-m", "mearm.tools.eval_policy", "--jobs", "1", "--episodes", "1",
         "--env-option", "obs_type=state", "--policy", "my_policies:wrong_shape"],
        capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "has shape (3,)" in lines[0], proc.stderr


def _baseline(path: Path, n_in: int, n_out: int, env_id: str) -> Path:
    """An untrained baseline of ``n_in`` inputs and ``n_out`` actions, saved as mearm.learn does."""
    import numpy as np

    pytest.importorskip("torch")
    from mearm.learn.baseline import build_mlp, save_baseline

    scaling = np.stack([np.zeros(n_out), np.ones(n_out)])
    net = build_mlp(n_in, n_out, 8)
    meta = {"env_id": env_id, "env_options": {"config": "sim_mujoco"}}
    mean, std = np.zeros(n_in, np.float32), np.ones(n_in, np.float32)  # as train() gives
    save_baseline(path, net, mean, std, scaling, 4, meta)
    return path


class _Opens:
    """Pickled as a call that makes a file: what a ``.pt`` from someone else could hold."""

    def __init__(self, path: Path):
        self.path = path

    def __reduce__(self):
        return (open, (str(self.path), "w"))


def test_a_pt_file_whose_pickle_would_run_code_is_refused_without_running_it(tmp_path):
    """A ``--policy FILE.pt`` is read by torch's weights-only unpickler: tensors, plain
    values and arrays. Read with ``weights_only=False`` this file made ``ran`` first."""
    torch = pytest.importorskip("torch")
    from mearm.envs.errors import PolicyError
    from mearm.learn.baseline import load_baseline

    ran, evil = tmp_path / "ran", tmp_path / "evil.pt"
    torch.save({"format": "mearm-bc-3", "meta": _Opens(ran)}, evil)
    with pytest.raises(PolicyError, match="not a baseline saved by mearm.learn") as caught:
        load_baseline(evil)
    assert "was not run" in str(caught.value) and "weights_only" not in str(caught.value)
    assert "(it holds more than tensors, plain values and arrays," in str(caught.value)
    assert not ran.exists()


def test_a_pt_file_that_is_no_pytorch_file_says_so(tmp_path):
    """Text named .pt was said to hold "more than tensors"; it holds no pickle at all."""
    pytest.importorskip("torch")
    from mearm.envs.errors import PolicyError
    from mearm.learn.baseline import load_baseline

    text = tmp_path / "bad.pt"
    text.write_text("garbage\n")
    with pytest.raises(PolicyError) as caught:
        load_baseline(text)
    assert str(caught.value).endswith(
        "not a baseline saved by mearm.learn (it is not a PyTorch file, and was not run)"
    )


def test_a_baseline_of_other_sizes_is_refused_before_any_episode(tmp_path):
    """Trained on PickPlace's 10 inputs but labelled Sort-v0: each episode raised a shape
    error and the run exited 0 with "success 0.0 %"; now exit 2 naming both sizes."""
    policy = _baseline(tmp_path / "bcsort.pt", 10, 5, "mearm/Sort-v0")
    out = check_bad_input(
        ["eval-policy", "--env", "mearm/Sort-v0", "--policy", policy, "--jobs", "1",
         "--episodes", "1", "--env-option", "obs_type=state"],
        within_s=30, keep=[tmp_path],
    )  # fmt: skip
    assert "takes 10 inputs and gives 5 actions, but mearm/Sort-v0 here gives 54" in out.line
    assert "another arm or number of objects (with config=sim_mujoco)" in out.line


def test_a_baseline_of_the_right_sizes_runs(tmp_path):
    """The same check passes a baseline that fits (Sort-v0 with one object: 10 inputs)."""
    policy = _baseline(tmp_path / "bc1.pt", 10, 5, "mearm/Sort-v0")
    argv = ["--env", "mearm/Sort-v0", "--policy", str(policy), "--episodes", "1",
            "--env-option", "objects=1", "--env-option", "max_episode_steps=5"]  # fmt: skip
    assert _run(*argv) == 0


def test_out_onto_an_input_is_refused(tmp_path, monkeypatch):
    """The scores' JSON replaced the 77 KB network it had just scored; and the config."""
    policy = _baseline(tmp_path / "bcx.pt", 10, 5, "mearm/PickPlace-v0")
    config = tmp_path / "twin.yaml"
    config.write_text("extends: sim_mujoco\n")
    monkeypatch.chdir(tmp_path)
    for out, words in (("./bcx.pt", "--out bcx.pt is the --policy file"),
                       (str(config), f"--out {config} is the --config file")):  # fmt: skip
        result = check_bad_input(
            ["eval-policy", "--policy", policy, "--config", config, "--jobs", "1",
             "--episodes", "1", "--env-option", "obs_type=state", "--out", out],
            within_s=10, keep=[tmp_path],
        )  # fmt: skip
        assert words in result.line


def test_a_policy_that_is_a_folder_says_so(tmp_path):
    """It said "no such file"."""
    pytest.importorskip("torch")
    (tmp_path / "dir.pt").mkdir()
    out = check_bad_input(
        ["eval-policy", "--policy", tmp_path / "dir.pt", "--jobs", "1", "--episodes", "1"],
        within_s=10,
    )
    assert out.line.endswith(
        f"policy {tmp_path / 'dir.pt'}: is a folder, not a baseline file (.pt)"
    )


def test_help_says_where_videos_go(capsys):
    """--videos K: into videos/ beside --out, else ./videos/."""
    with pytest.raises(SystemExit):
        main(["--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "MP4s into videos/ beside --out (without --out: ./videos/)" in text


def test_a_baseline_without_pytorch_asks_for_the_extra(tmp_path, monkeypatch):
    """--policy FILE.pt without torch: one line naming mearm[learn]."""
    from mearm.errors import MearmError

    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` raises ImportError
    with pytest.raises(MearmError, match=r"pip install 'mearm\[learn\]'"):
        _run("--policy", str(tmp_path / "bc.pt"), "--episodes", "1")


def test_without_gymnasium_eval_policy_asks_for_the_extra(monkeypatch):
    """No Gymnasium: one line naming mearm[gym], before anything runs."""
    from mearm.errors import MearmError

    monkeypatch.setitem(sys.modules, "gymnasium", None)
    with pytest.raises(MearmError, match=r"pip install 'mearm\[gym\]'"):
        main(["--episodes", "1"])
