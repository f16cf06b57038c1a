"""What a new user's config runs into: booleans for numbers, an approach above the box,
messages that name files the user has, config-docs that keeps the user's files, and the
odd ``--config`` and ``extends`` values."""

from __future__ import annotations

import copy
import functools
import os
from pathlib import Path
from typing import Any

import pytest
from badinput import Outcome, run_in_process
from conftest import ROOT, run_cli
from pydantic import ValidationError
from test_wheel import Installed, _run
from test_wheel import installed as installed  # the fixture: the wheel, built once per run

from mearm.config import Config, load_config
from mearm.config.base import describe_error
from mearm.config.schema_doc import render
from mearm.exceptions import ConfigError


def _mearm(*args: str, cwd: Path = ROOT) -> Outcome:
    """``mearm ARGS`` in this process, from ``cwd`` (the checks are of what it says and
    writes, not of a process's start)."""
    return run_in_process(args, within_s=10, cwd=cwd)


def _error(path: str | Path | None, overrides: list[str]) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(path, overrides)
    text = str(info.value)
    assert "\n" not in text
    return text


# ------------------------------------------------------------------ booleans for numbers


@pytest.mark.parametrize(
    ("override", "said"),
    [
        ("controller.kp=true", "controller.kp: expected a number, got true"),
        ("controller.kp=yes", "controller.kp: expected a number, got 'yes'"),
        ("arm.joints.shoulder.home=true", "arm.joints.shoulder.home: expected a number, got true"),
        ("task.pick_retries=false", "task.pick_retries: expected a number, got false"),
        ("task.approach_height_cm=on", "task.approach_height_cm: expected a number, got 'on'"),
        ("task.classes.red.bin_cm=[1, true, 3]", "task.classes.red.bin_cm.1: expected a number"),
        (
            "arm.joints.base.servo.direction=true",
            "arm.joints.base.servo.direction: expected a number, got true",
        ),
        (
            "servo.error_model.offset_deg={base: false}",
            "servo.error_model.offset_deg.base: expected a number, got false",
        ),
    ],
)
def test_a_boolean_is_no_number(override: str, said: str) -> None:
    """Pydantic's lax mode read ``true`` as 1: every kind of number field refuses it."""
    assert said in _error(None, [override])


def test_a_boolean_in_a_file_is_named(tmp_path: Path) -> None:
    path = tmp_path / "kp.yaml"
    path.write_text("extends: sim\ncontroller: {kp: yes}\n")
    assert f"{path}: controller.kp: expected a number, got true" == _error(path, [])


def _number_paths(data: Any, path: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    if isinstance(data, dict):
        return [p for k, v in data.items() for p in _number_paths(v, (*path, k))]
    if isinstance(data, list | tuple):
        return [p for i, v in enumerate(data) for p in _number_paths(v, (*path, i))]
    return [path] if type(data) in (int, float) else []


@pytest.mark.parametrize("name", ["sim", "sim_conveyor", "sim_mujoco_lamp", "sim_5dof"])
def test_every_number_of_a_shipped_config_refuses_a_boolean(name: str) -> None:
    """Each number the config holds, set to ``true``: refused there, by name."""
    data = load_config(name).model_dump(mode="json")
    paths = _number_paths(data)
    assert len(paths) > 150
    for path in paths:
        bad = copy.deepcopy(data)
        node = bad
        for part in path[:-1]:
            node = node[part]
        node[path[-1]] = True
        with pytest.raises(ValidationError) as info:
            Config.model_validate(bad)
        assert any(
            e["type"] == "number_not_bool" and tuple(e["loc"]) == path for e in info.value.errors()
        ), path


def test_numbers_stay_as_lax_as_before() -> None:
    """Only booleans are refused: an int for a float, and YAML 1.1's ``1e3`` (a string to
    PyYAML), still load."""
    config = load_config(None, ["task.carry_accel_deg_s2=1e3", "controller.kp=1"])
    assert config.task.carry_accel_deg_s2 == 1000.0 and config.controller.kp == 1.0
    assert load_config(None, ["task.pick_retries=3.0"]).task.pick_retries == 3


def test_the_sort_refuses_a_boolean_kp() -> None:
    r = _mearm("sort", "--quiet", "--set", "controller.kp=true")
    assert r.code == 2, r.stdout
    assert (
        r.stderr.strip() == "mearm sort: error: --set: controller.kp: expected a number, got true"
    )


# ------------------------------------------------------------------ the approach in the box


def test_an_approach_above_the_box_is_refused_at_load() -> None:
    """The sim's picks are at z = 12.76 cm and its box ends at 60 cm: at most 47.24 cm."""
    text = _error(None, ["task.approach_height_cm=50"])
    assert text.startswith("overrides: task.approach_height_cm: 50 cm above the picks of red, ")
    assert "puts the TCP at z = 62.76 cm, above arm.target_box.z_cm [10, 60]" in text
    assert "at most 47.24 cm" in text
    assert load_config(None, ["task.approach_height_cm=47.24"]).task.approach_height_cm == 47.24
    assert "at most 47.24 cm" in _error(None, ["task.approach_height_cm=47.25"])


def test_only_the_classes_picked_highest_are_named() -> None:
    text = _error(None, ["task.approach_height_cm=45", "task.classes.blue.grip_height_cm=4.5"])
    assert "the picks of blue (at z = 15.76 cm)" in text and "red" not in text


def test_the_sort_refuses_an_approach_above_the_box_before_it_moves() -> None:
    r = _mearm("sort", "--quiet", "--set", "task.approach_height_cm=50")
    assert r.code == 2 and r.stdout == ""
    line = r.stderr.strip()
    assert "\n" not in line and "task.approach_height_cm: 50 cm above the picks" in line


# ------------------------------------------------------------------ files the user has


def _named_file(line: str) -> str:
    before, sep, _ = line.partition(" shows every key")
    assert sep, line
    return before.rsplit("(", 1)[1].rsplit("; ", 1)[-1]


@pytest.mark.parametrize(
    ("key", "shown"), [("controller.kpp=1", "sim.yaml"), ("arm.fooo=1", "mearm_paper.yaml")]
)
def test_an_unknown_key_names_a_file_there_is(tmp_path: Path, key: str, shown: str) -> None:
    """Run outside the checkout, the file named is where the package has it."""
    r = _mearm("fk", "--joints", "90,90,-90", "--set", key, cwd=tmp_path)
    assert r.code == 2
    named = _named_file(r.stderr)
    assert named.endswith(shown) and (tmp_path / named).is_file(), named


def test_an_unknown_key_names_the_checkout_file_as_typed_there(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.chdir(ROOT)
    assert "(configs/sim.yaml shows every key)" in _error(None, ["controller.kpp=1"])
    assert "(configs/arms/mearm_v1.yaml shows every key)" in _error("sim_mearm_v1", ["arm.fooo=1"])
    monkeypatch.chdir(tmp_path)
    err = {"type": "extra_forbidden", "loc": ("arm", "x"), "msg": "", "input": 1}
    named = _named_file(describe_error(err))  # type: ignore[arg-type]
    assert Path(named).is_absolute() and Path(named).is_file()


@pytest.mark.parametrize(
    ("key", "meant", "section", "anchor"),
    [
        ("twin.lamp.shadow=false", "shadows", "twin.lamp", "twinlamp"),
        ("twin.camera.tilt=3", "tilt_deg", "twin.camera", "twincamera"),
        ("twin.kit.sed=1", "seed", "twin.kit", "twinkit"),
        (
            "task.classes.red.learned_colour.max_distanse=3",
            "max_distance",
            "task.classes[].learned_colour",
            "taskclasseslearned_colour",
        ),
    ],
)
def test_an_unknown_key_in_a_section_the_shipped_file_leaves_null_is_helped(
    monkeypatch: pytest.MonkeyPatch, key: str, meant: str, section: str, anchor: str
) -> None:
    """``twin.lamp`` is null in configs/sim.yaml: an unknown key in it got no "did you
    mean" (the keys were read from the built-in config) and was pointed at sim.yaml, which
    does not list them. The keys come from the models; the docs' section shows them."""
    monkeypatch.chdir(ROOT)
    text = _error(None, [key])
    shown = f"(docs/configuration.md#{anchor} shows every key)"
    assert f"unknown key; did you mean {meant}? {shown}" in text, text
    assert f"- [{section}](#{anchor})" in (ROOT / "docs" / "configuration.md").read_text()


def test_shown_path_is_relative_only_under_the_current_folder(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from mearm.data import doc_page, shown_path

    monkeypatch.chdir(ROOT)
    assert shown_path(ROOT / "configs" / "sim.yaml") == "configs/sim.yaml"
    assert doc_page("maker-path.md") == "docs/maker-path.md"
    monkeypatch.chdir(tmp_path)
    assert shown_path(ROOT / "configs" / "sim.yaml") == str(ROOT / "configs" / "sim.yaml")


# ------------------------------------------------------------------ config-docs

NOTES = "MY OWN NOTES\n"


@functools.cache
def _page() -> str:
    """The configuration page config-docs writes, rendered once (0.25 s a render)."""
    return render()


@pytest.mark.heavy
def test_config_docs_writes_the_checkouts_page_not_the_current_folders(tmp_path: Path) -> None:
    """From any folder the default is the checkout's page; ./docs is never touched."""
    page = ROOT / "docs" / "configuration.md"
    if page.read_text(encoding="utf-8") != _page():
        pytest.skip("docs/configuration.md is stale (test_docs fails): not rewritten here")
    (tmp_path / "docs").mkdir()
    mine = tmp_path / "docs" / "configuration.md"
    mine.write_text(NOTES)
    r = _mearm("config-docs", cwd=tmp_path)
    assert r.code == 0, r.stderr
    assert r.stdout.strip() == f"wrote {page}"
    assert mine.read_text() == NOTES
    assert page.read_text(encoding="utf-8") == _page()
    r = _mearm("config-docs", "--help", cwd=tmp_path)
    assert str(page) in " ".join(r.stdout.split())


@pytest.mark.heavy
def test_config_docs_replaces_only_a_page_it_wrote(tmp_path: Path) -> None:
    """The refusal as a shell sees it (a process of its own: exit 2, one line); the runs
    after it in this process."""
    mine = tmp_path / "notes.md"
    mine.write_text(NOTES)
    r = run_cli("-m", "mearm", "config-docs", "--output", str(mine), cwd=tmp_path)
    assert r.returncode == 2 and r.stdout == ""
    line = r.stderr.strip()
    assert "\n" not in line and f"--output {mine}: exists and is not a configuration" in line
    assert "--force" in line and mine.read_text() == NOTES
    done = _mearm("config-docs", "--output", str(mine), "--force", cwd=tmp_path)
    assert done.code == 0 and mine.read_text(encoding="utf-8") == _page()
    bak = tmp_path / "notes.md.bak"  # the user's file, kept and named first
    assert done.stdout.splitlines() == [f"wrote {bak} (the old {mine})", f"wrote {mine}"]
    assert bak.read_text() == NOTES
    done = _mearm("config-docs", "--output", str(mine), cwd=tmp_path)  # the same page
    assert done.code == 0 and done.stdout.splitlines() == [f"wrote {mine}"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.md", "notes.md.bak"]


@pytest.mark.heavy
@pytest.mark.parametrize(
    "edit",
    [
        pytest.param(lambda page: page + "MY OWN NOTE\n", id="a line appended"),
        pytest.param(
            lambda page: page.replace("Every key a config", "Some keys a config"),
            id="an older page",
        ),
    ],
)
def test_config_docs_replaces_a_reference_that_differs_only_with_force(
    tmp_path: Path, edit: Any
) -> None:
    """A page config-docs wrote, then edited (or written from other models): its header
    is the generated one, but what differs may be the user's, so it is kept as the rest."""
    mine = tmp_path / "configuration.md"
    edited = edit(_page())
    mine.write_text(edited, encoding="utf-8")
    r = _mearm("config-docs", "--output", str(mine), cwd=tmp_path)
    assert r.code == 2 and r.stdout == "", r
    line = r.stderr.strip()
    assert "\n" not in line and "differs from the one written now" in line, line
    assert f"--force replaces it, keeping it as {mine}.bak" in line
    assert mine.read_text(encoding="utf-8") == edited
    done = _mearm("config-docs", "--output", str(mine), "--force", cwd=tmp_path)
    assert done.code == 0 and mine.read_text(encoding="utf-8") == _page()
    assert done.stdout.splitlines()[0] == f"wrote {mine}.bak (the old {mine})"
    assert (tmp_path / "configuration.md.bak").read_text(encoding="utf-8") == edited


# ------------------------------------------------------------------ odd --config and extends


def test_an_empty_config_name_says_so() -> None:
    assert _error("", []).startswith("path: the value is empty: give a config file's path")


def test_a_config_name_is_shown_quoted(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.chdir(tmp_path)
    text = _error(" sim", [])
    assert text.startswith("' sim': config file not found")
    assert "no packaged config is named ' sim' (did you mean 'sim'?)" in text


def test_extends_a_link_loop_says_so(tmp_path: Path) -> None:
    """As ``--config loop1`` does: the system's reason, not "no packaged config"."""
    (tmp_path / "loop1").symlink_to("loop1")
    path = tmp_path / "ext.yaml"
    path.write_text("extends: loop1\n")
    text = _error(path, [])
    assert text.startswith(f"{path}: extends: cannot open 'loop1' (looked for ")
    assert text.endswith(os.strerror(40)), text  # ELOOP
    assert os.strerror(40) in _error(tmp_path / "loop1", [])


# ------------------------------------------------------------------ from the wheel


@pytest.mark.slow
@pytest.mark.skipif(
    os.environ.get("MEARM_SKIP_WHEEL") == "1" and os.environ.get("CI") != "true",
    reason="MEARM_SKIP_WHEEL=1: the wheel is not built (CI always builds it)",
)
def test_from_the_wheel(installed: Installed) -> None:
    """Installed, with no checkout: an unknown key names the file the wheel ships, and
    config-docs wants --output (and writes nothing to the current folder)."""
    r = _run([installed.mearm, "fk", "--joints", "90,90,-90", "--set", "arm.fooo=1"],
             installed.work)  # fmt: skip
    assert r.returncode == 2
    named = Path(_named_file(r.stderr))
    assert named.is_absolute() and named.is_file() and not named.is_relative_to(ROOT)
    r = _run([installed.mearm, "config-docs"], installed.work)
    assert r.returncode == 2 and r.stdout == ""
    line = r.stderr.strip()
    assert "\n" not in line and "give --output FILE" in line
    assert not (installed.work / "docs").exists()
