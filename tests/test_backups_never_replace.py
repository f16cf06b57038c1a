"""A backup never replaces another: a second run (and a third) loses nothing.

Two walks (2026-12-06) lost a user's own file to a second run: ``sort --save-mjcf
mine.xml`` kept the user's ``mine.xml`` as ``mine.xml.bak``, and the next run kept its
own first MJCF there, over it; ``calibrate-camera`` twice on a hand-written config kept
the first fit as ``.bak`` over the config as written. Backups now go beside an earlier
one (``.bak.1``, ``.bak.2``, …); the same bytes are not kept twice.
"""

from __future__ import annotations

from pathlib import Path

from badinput import run_in_process

from mearm.fileio import keep_backup


def test_each_backup_goes_beside_the_last(tmp_path: Path) -> None:
    path = tmp_path / "f.yaml"
    assert keep_backup(path) is None  # nothing there
    path.write_text("mine\n")
    assert keep_backup(path, "mine\n") is None  # rewriting the same bytes loses nothing
    assert keep_backup(path, "new\n") == tmp_path / "f.yaml.bak"
    assert keep_backup(path, "new\n") is None  # kept already
    path.write_text("second\n")
    assert keep_backup(path) == tmp_path / "f.yaml.bak.1"
    path.write_text("third\n")
    assert keep_backup(path) == tmp_path / "f.yaml.bak.2"
    texts = [(tmp_path / n).read_text() for n in ("f.yaml.bak", "f.yaml.bak.1", "f.yaml.bak.2")]
    assert texts == ["mine\n", "second\n", "third\n"]


def test_a_users_file_outlives_two_save_mjcf_runs(tmp_path: Path) -> None:
    mine = tmp_path / "mine.xml"
    mine.write_text("precious\n")
    for seed in ("1", "2"):
        argv = ["sort", "--config", "sim_mujoco", "--random", "1", "--seed", seed, "--quiet",
                "--save-mjcf", mine]  # fmt: skip
        done = run_in_process(argv, within_s=120)
        assert done.code == 0, done.stderr
    assert (tmp_path / "mine.xml.bak").read_text() == "precious\n"
    first = (tmp_path / "mine.xml.bak.1").read_text()
    assert first.startswith("<mujoco") and first != mine.read_text()
    assert f"wrote {mine}.bak.1 (the old {mine})" in done.stdout


def test_sorts_refusal_of_a_file_that_is_no_calibration_names_its_own_flag(tmp_path: Path) -> None:
    """It named calibrate-servos' --force and --output, which sort does not have."""
    from badinput import check_bad_input

    cal = tmp_path / "cal.yaml"
    cal.write_text("# my precious calibration\n")
    argv = ["sort", "--config", "sim_mujoco_kits", "--quiet", "--save-calibration", cal]
    out = check_bad_input(argv, keep=[tmp_path], within_s=60)
    assert out.line.startswith(f"mearm sort: error: {cal} is not replaced: "), out.line
    assert out.line.endswith("write elsewhere with another --save-calibration, or remove it")
    assert "--force" not in out.line and "--output" not in out.line
