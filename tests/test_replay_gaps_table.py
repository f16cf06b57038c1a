"""A sort of the config's own table (no --scene, no --random) keeps that table.

``mearm sort --config C --record DIR`` on C's own ``task.scene`` recorded no scene: the
replay refused the episode ("keeps no scene": no --seed draws that table), and had it
laid the config's table, a config changed since would have laid another. The episode now
keeps the table as it was laid, as a ``--scene`` sort's.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from badinput import Outcome, run_in_process
from conftest import run_main

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from mearm.config import SceneObject  # noqa: E402
from mearm.dataset.reading import read_tags  # noqa: E402
from mearm.envs.replay import main as replay_main  # noqa: E402
from mearm.envs.replay import replay  # noqa: E402

pytestmark = pytest.mark.heavy

#: A config of its own table: the twin's sim_mujoco with two objects.
CONFIG = """extends: sim_mujoco
task:
  scene:
    - {color: red, x: -10.99, y: 49.70}
    - {color: blue, x: 5.0, y: 45.0, yaw_deg: 30}
"""
#: The same config once its table has changed.
CHANGED = CONFIG.replace("x: 5.0, y: 45.0, yaw_deg: 30", "x: 8.0, y: 40.0")
#: The table laid.
LAID = (
    SceneObject(color="red", x=-10.99, y=49.70),
    SceneObject(color="blue", x=5.0, y=45.0, yaw_deg=30.0),
)


def _mearm(*args: object, cwd: Path) -> Outcome:
    """``mearm ARGS`` in this process, in ``cwd``."""
    return run_in_process(args, within_s=30, cwd=cwd)


@pytest.fixture(scope="module")
def own_table(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """``mearm sort --config two.yaml --record`` per scene at the servo rate, then the
    config's table changed: the dataset and the config."""
    here = tmp_path_factory.mktemp("own")
    config, ds = here / "two.yaml", here / "ds"
    config.write_text(CONFIG)
    out = _mearm(
        "sort", "--config", config, "--record", ds, "--record-per", "scene",
        "--record-fps", "50", "--record-codec", "h264", "--quiet", cwd=here,
    )  # fmt: skip
    assert out.code == 0 and "sorted 2 of 2 objects" in out.stdout, out.stderr
    config.write_text(CHANGED)
    return ds, config


def test_the_episode_keeps_the_table_it_sorted(own_table):
    """The table as laid (the yaw too), with the config by its absolute path; no seed."""
    ds, config = own_table
    (kept,) = read_tags(ds, 1)[1]
    assert kept is not None and kept.table == LAID
    assert kept.config == str(config) and kept.overrides == () and kept.seed is None


def test_the_replay_lays_the_recorded_table_not_the_config_changed_since(
    own_table, capsys, monkeypatch
):
    """The replay command from another folder, no --seed or --objects: exit 0, both
    objects in their bins, on the recorded table. Before: exit 2, "keeps no scene"."""
    ds, _ = own_table
    monkeypatch.chdir(ds)
    code, out, err = run_main(capsys, replay_main, ds)
    assert code == 0, out + err
    assert "2 of 2 objects in their bins" in out
    out = replay(ds, 0)
    assert out.table == LAID and out.success


def test_a_trial_or_a_random_sort_keeps_its_own_scene(tmp_path):
    """The config's table is kept only where no scene is given: a --random sort of a
    config with a table keeps its seed, not the table."""
    config = tmp_path / "two.yaml"
    config.write_text(CONFIG)
    ds = tmp_path / "ds"
    out = _mearm(
        "sort", "--config", config, "--random", "1", "--seed", "3", "--record", ds,
        "--record-per", "scene", "--record-fps", "10", "--record-codec", "h264", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    (entry,) = json.loads((ds / "meta" / "mearm_episodes.json").read_text())["episodes"]
    assert entry[2]["seed"] == 3 and entry[2]["objects"] == 1 and "table" not in entry[2]
