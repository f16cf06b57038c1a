"""``mearm --help`` lists the subcommands grouped by job; every one is still reachable."""

from __future__ import annotations

import importlib
import re
import sys

import pytest

from mearm.__main__ import GROUPS, SUBCOMMANDS, _usage, main
from mearm.cli import run

TITLES = [
    "start here",
    "sort and see",
    "calibrate",
    "the twin and experiments",
    "data and learning",
    "measure and develop",
]


def test_groups_are_in_the_order_a_user_needs_them() -> None:
    """Start here first, the rarely used measurements last, each group non-empty."""
    titles = list(GROUPS)
    assert [next(t for t in titles if t.startswith(want)) for want in TITLES] == titles
    assert all(GROUPS.values())


def test_every_subcommand_is_in_exactly_one_group() -> None:
    """The flat table is the groups' union, nothing listed twice."""
    names = [name for group in GROUPS.values() for name in group]
    assert len(names) == len(set(names)) == len(SUBCOMMANDS)
    assert {"init-config", "find-port", "flash", "find-camera"} <= set(GROUPS[next(iter(GROUPS))])


def test_the_makers_first_steps_are_not_among_the_benchmarks() -> None:
    """The measurement commands sit in their own group, away from the maker's."""
    measure = GROUPS[next(t for t in GROUPS if t.startswith("measure"))]
    assert {"bench", "ik-stalls", "quantization", "virtual-uno-pulses", "shape-sweep"} <= set(
        measure
    )


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_every_subcommand_names_a_main(name: str) -> None:
    """Each entry's module imports and has ``main``."""
    module, text = SUBCOMMANDS[name]
    assert callable(importlib.import_module(module).main)
    assert text and len(text) <= 72, text


def test_the_help_says_which_subcommands_with_a_config_take_no_set(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """``mearm --help`` says every subcommand that reads a config takes --set: it named
    none of those that do not (calibrate-camera had no --set, and said so only by an
    "unrecognized arguments")."""
    without = []
    for name in SUBCOMMANDS:
        with pytest.raises(SystemExit):
            main([name, "--help"])
        text = capsys.readouterr().out
        if "--config" in text and "--set" not in text:
            without.append(name)
    assert without == ["calibrate-camera", "eval-policy"]
    said = " ".join(_usage().split())
    assert "(but calibrate-camera, which writes its FILE, and eval-policy," in said


def test_help_shows_each_group_and_each_subcommand_once(capsys: pytest.CaptureFixture[str]) -> None:
    """``mearm --help``: a heading per group, one line per subcommand, exit 0."""
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert text == _usage() + "\n"
    for title, commands in GROUPS.items():
        assert f"\n{title}:\n" in text
        for name in commands:
            assert len(re.findall(rf"^  {re.escape(name)}\s", text, re.M)) == 1, name
    assert text.index("init-config") < text.index("  sort ") < text.index("  bench ")


def test_an_unknown_subcommand_exits_2_naming_the_choices(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A typo: exit 2, one line listing the subcommands."""
    with pytest.raises(SystemExit) as exc:
        main(["srot"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown subcommand 'srot'" in err[0] and "init-config" in err[0]


def test_help_with_a_name_is_that_subcommands_help(capsys: pytest.CaptureFixture[str]) -> None:
    """``mearm help sort`` is ``mearm sort --help``; ``mearm help srot`` names the typo."""
    with pytest.raises(SystemExit) as exc:
        main(["help", "fk"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("usage: mearm fk ")
    with pytest.raises(SystemExit) as exc:
        main(["help", "srot"])
    assert exc.value.code == 2
    assert "unknown subcommand 'srot'" in capsys.readouterr().err


@pytest.mark.parametrize("name", list(SUBCOMMANDS))
def test_each_subcommand_names_itself_as_typed(
    name: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``mearm NAME --help`` shows ``usage: mearm NAME``, not the module it runs."""
    monkeypatch.setattr(sys, "argv", sys.argv[:])  # the dispatcher renames the program
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith(f"usage: mearm {name} ")


def test_a_command_suggested_next_is_named_as_this_one_was(monkeypatch: pytest.MonkeyPatch) -> None:
    """After ``mearm experiment``: ``mearm analyze``; after ``python -m mearm.experiment``:
    ``python -m mearm.analyze`` (it printed the module form after either)."""
    from mearm.cli import invoked_as

    monkeypatch.setattr(sys, "argv", ["mearm experiment", "--trials", "2"])
    assert invoked_as("python -m mearm.analyze", "analyze") == "mearm analyze"
    assert invoked_as("python -m mearm.experiment") == "mearm experiment"
    monkeypatch.setattr(sys, "argv", ["/x/mearm/experiment/__main__.py", "--trials", "2"])
    assert invoked_as("python -m mearm.analyze", "analyze") == "python -m mearm.analyze"


@pytest.mark.parametrize(
    ("argv", "module"), [(["sort"], "mearm.sort"), (["detect"], "mearm.detect")]
)
def test_a_bad_option_names_the_command_as_typed(
    argv: list[str],
    module: str,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Through ``mearm`` the error line says ``mearm sort``; run as a module, its -m name."""
    monkeypatch.setattr(sys, "argv", sys.argv[:])
    with pytest.raises(SystemExit) as exc:
        main([*argv, "--bogus"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"mearm {argv[0]}: error: unrecognized arguments: --bogus"]
    monkeypatch.setattr(sys, "argv", [f"/somewhere/{module}.py"])
    with pytest.raises(SystemExit) as exc:
        run(importlib.import_module(module).main, ["--bogus"])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"python -m {module}: error: unrecognized arguments: --bogus"]
