"""The docs show what is there: every linked picture exists, every command shown parses.

Commands are taken from the code blocks of README.md and docs/*.md: each line that starts
with ``mearm`` or ``python -m mearm…`` (continuation lines joined, comments cut) is parsed
by its subcommand's own parser, in this process, and stopped right after parsing: nothing
runs, so the check is fast. A placeholder a reader must replace is written in capitals
(``MY_CONFIG.yaml``) and is a plain value to the parser.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import re
import shlex
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import pytest

from mearm.__main__ import SUBCOMMANDS

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted([ROOT / "README.md", ROOT / "CONTRIBUTING.md", *(ROOT / "docs").glob("*.md")])
#: ``![alt](target)``.
PICTURE = re.compile(r"!\[[^\]]*\]\(\s*<?([^)\s>]+)>?")
#: The languages of the fenced code blocks whose lines are commands (none: commands too).
SHELL = ("bash", "sh", "shell", "console", "")
#: Pictures as large as this are too large to keep in the repository [bytes].
MAX_PICTURE_BYTES = 400_000


@dataclass(frozen=True)
class Command:
    """A command shown in a doc's code block.

    Attributes:
        doc: The page, relative to the repository.
        line: Its line in the block's text (continuations joined).
        module: The module whose ``main`` parses it.
        argv: Its arguments after the subcommand.
    """

    doc: str
    line: str
    module: str
    argv: tuple[str, ...]


def _shell_blocks(text: str) -> Iterator[str]:
    """The bodies of the fenced code blocks in a shell language (or none)."""
    fence: str | None = None
    body: list[str] = []
    for line in text.splitlines():
        if fence is None and line.startswith("```"):
            fence, body = line[3:].strip(), []
        elif fence is not None and line.startswith("```"):
            if fence in SHELL:
                yield "\n".join(body)
            fence = None
        elif fence is not None:
            body.append(line)


def _shell_lines(text: str) -> Iterator[str]:
    for block in _shell_blocks(text):
        joined = re.sub(r"\\\n\s*", " ", block)
        for raw in joined.splitlines():
            line = raw.strip().removeprefix("$ ").strip()
            if line:
                yield line


#: ``[--force]``, ``[--mode paper|coupled]``: an optional part of a usage line.
OPTIONAL = re.compile(r"\[([^\[\]]*)\]")


def usage_forms(line: str) -> list[str]:
    """A usage line as commands: without its ``[optional]`` parts, and with each (the
    first of its ``a|b`` choices); a line without any, as it is. ``$(…)`` is left out."""
    line = re.sub(r"\$\([^)]*\)", "", line)
    if not re.match(r"^(\S*/)?mearm |^python -m mearm", line) or not OPTIONAL.search(line):
        return [line]
    bare = OPTIONAL.sub("", line)
    full = OPTIONAL.sub(lambda m: re.sub(r"\S+", lambda w: w[0].split("|")[0], m[1]), line)
    return [bare, full]


def _command(doc: str, line: str) -> Command | None:
    """The command a line runs, or ``None`` for a line that runs no mearm command."""
    try:
        words = shlex.split(line, comments=True)
    except ValueError:
        return None
    words = [w for w in words if w not in ("...", "…")]
    if words[:1] and Path(words[0]).name == "mearm" and len(words) > 1:
        name = words[1]
        if name in ("--help", "-h", "--version") or name.endswith(":"):
            return None  # the top-level help, or a line of output (``mearm sort: error: …``)
        module = SUBCOMMANDS[name][0] if name in SUBCOMMANDS else f"<unknown subcommand {name}>"
        return Command(doc, line, module, tuple(words[2:]))
    if words[:2] == ["python", "-m"] and len(words) > 2 and words[2].startswith("mearm"):
        module = words[2]
        if importlib.util.find_spec(module) is not None and module.endswith(
            ("mearm.ik", "mearm.dataset")
        ):
            module += ".__main__"
        return Command(doc, line, module, tuple(words[3:]))
    return None


def doc_commands(paths: Sequence[Path] = DOCS) -> list[Command]:
    """Every mearm command in the code blocks of ``paths``."""
    out = []
    for path in paths:
        rel = str(path.relative_to(ROOT))
        for line in _shell_lines(path.read_text(encoding="utf-8")):
            for form in usage_forms(line):
                command = _command(rel, form)
                if command is not None:
                    out.append(command)
    return out


class _Parsed(Exception):
    """Raised right after a command's arguments parsed: nothing else runs."""


def parse_only(module: str, argv: Sequence[str]) -> str | None:
    """Parse ``argv`` with ``module``'s own parser; ``None`` if it parses, else the error."""
    try:
        main = importlib.import_module(module).main
    except (ImportError, AttributeError) as exc:
        return f"no command module {module}: {exc}"
    original = argparse.ArgumentParser.parse_args

    def parse_then_stop(self: argparse.ArgumentParser, *args: object, **kwargs: object) -> None:
        original(self, *args, **kwargs)  # type: ignore[call-overload]
        raise _Parsed

    err = io.StringIO()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(argparse.ArgumentParser, "parse_args", parse_then_stop)
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                main(list(argv))
        except _Parsed:
            return None
        except SystemExit as exc:
            return err.getvalue().strip() or f"exit {exc.code}"
    return "the command ran without parsing its arguments through argparse"


COMMANDS = doc_commands()


def test_the_docs_show_commands() -> None:
    """The collector finds the commands (a broken pattern would pass every doc)."""
    modules = {c.module for c in COMMANDS}
    assert len(COMMANDS) > 40
    assert {"mearm.sort", "mearm.maker.init_config", "mearm.tools.calibrate_camera"} <= modules


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: f"{c.doc}: {c.line[:60]}")
def test_every_command_in_the_docs_parses(command: Command) -> None:
    """Each command a doc shows is accepted by its parser as written."""
    problem = parse_only(command.module, command.argv)
    assert problem is None, f"{command.doc}: `{command.line}`: {problem}"


def test_usage_lines_are_read_both_ways() -> None:
    """``[--opt a|b]`` is checked left out and given (its first choice)."""
    assert usage_forms("mearm ik --start 1 [--mode paper|coupled] $(cat x)") == [
        "mearm ik --start 1  ",
        "mearm ik --start 1 --mode paper ",
    ]


def test_a_bad_command_is_caught() -> None:
    """The check fails on a misspelt option and an unknown subcommand (it can fail)."""
    assert parse_only("mearm.sort", ["--config", "sim", "--qiuet"]) is not None
    bad = _command("x.md", "mearm sortt --config sim")
    assert bad is not None and parse_only(bad.module, bad.argv) is not None
    assert parse_only("mearm.sort", ["--config", "sim", "--quiet"]) is None


def linked_pictures(path: Path) -> list[str]:
    """The pictures a Markdown file links (code blocks left out)."""
    text = re.sub(r"```.*?```", "", path.read_text(encoding="utf-8"), flags=re.S)
    return [t for t in PICTURE.findall(text) if not re.match(r"^[a-z][a-z0-9+.-]*:", t)]


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_linked_picture_exists(doc: Path) -> None:
    """Each picture a page links is a PNG in the repository, small enough to keep."""
    for target in linked_pictures(doc):
        path = (doc.parent / target).resolve()
        assert path.is_file(), f"{doc.name}: {target} does not exist"
        head = path.read_bytes()[:8]
        assert head == b"\x89PNG\r\n\x1a\n", f"{doc.name}: {target} is not a PNG"
        assert path.stat().st_size <= MAX_PICTURE_BYTES, f"{target}: over {MAX_PICTURE_BYTES} B"


def test_a_missing_picture_is_caught(tmp_path: Path) -> None:
    """A page linking a picture that is not there is found (the check can fail)."""
    page = tmp_path / "page.md"
    page.write_text("![gone](images/gone.png)\n```bash\n![not a link](x.png)\n```\n")
    assert linked_pictures(page) == ["images/gone.png"]
    assert not (tmp_path / "images/gone.png").exists()


VISUAL_PAGES = {
    "README.md": "twin_sorting.png",
    "docs/maker-path.md": "frames_mearm_v1.png",
    "docs/your-arm.md": "frames_mearm_paper.png",
    "docs/twin.md": "twin_sorting.png",
    "docs/sorting.md": "twin_conveyor.png",
    "docs/calibration.md": "calibration_sheet.png",
    "docs/view.md": "view_sim.png",
    "docs/learning.md": "env_pick_place.png",
    "docs/datasets.md": "dataset_sheet.png",
}


@pytest.mark.parametrize(("page", "picture"), VISUAL_PAGES.items())
def test_visual_pages_show_their_picture(page: str, picture: str) -> None:
    """Each page about something visual links its picture, drawn by a command in the repo."""
    targets = [Path(t).name for t in linked_pictures(ROOT / page)]
    assert picture in targets
    makers = (ROOT / "tools" / "screenshots.py").read_text() + (
        ROOT / "tools" / "calibration_pictures.py"
    ).read_text()
    stem = Path(picture).stem
    assert picture in makers or stem.startswith(("view_", "calibration_")), picture
