"""The docs match the code and point nowhere outside the repository; help is plain words."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from built_once import computed_once

from mearm.__main__ import SUBCOMMANDS
from mearm.config.schema_doc import render
from mearm.exceptions import ConfigError

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted([ROOT / "README.md", *(ROOT / "docs").glob("*.md")])

#: ``[text](target)`` and ``![alt](target)``; the target up to a space or ``)``.
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
#: Raw reStructuredText a terminal shows as-is: ``literal``, :class:`x`, :func:`x`, …
RST = re.compile(r"``|:(?:class|func|meth|mod|data|attr|obj|ref|math):`")
#: References a user cannot follow: the project's internal spec, numbered sections.
UNFOLLOWABLE = re.compile(r"\bSPEC\b|§")


def _anchors(markdown: str) -> set[str]:
    """GitHub's anchors of every heading in a Markdown file, and explicit ``id=``s."""
    out = set(re.findall(r"<a\s+(?:id|name)=\"([^\"]+)\"", markdown))
    in_code = False
    for line in markdown.splitlines():
        if line.startswith("```"):
            in_code = not in_code
        elif not in_code and (m := re.match(r"^#{1,6}\s+(.*?)\s*#*$", line)):
            text = re.sub(r"[`*_]{2,}|`", "", m.group(1)).strip().lower()
            out.add(re.sub(r"[^\w\- ]", "", text).replace(" ", "-"))
    return out


def _links(path: Path) -> list[str]:
    text = re.sub(r"```.*?```", "", path.read_text(encoding="utf-8"), flags=re.DOTALL)
    return LINK.findall(text)


@pytest.mark.heavy
def test_configuration_reference_is_current() -> None:
    """docs/configuration.md is what the config models generate today."""
    written = (ROOT / "docs" / "configuration.md").read_text(encoding="utf-8")
    assert written == render(), (
        "docs/configuration.md is stale: run mearm config-docs --output docs/configuration.md"
        " --force"
    )


def test_reference_covers_every_key() -> None:
    """Every field of every config model reached from Config appears in the reference."""
    from mearm.config.schema_doc import walk

    text = render()
    keys = [d.path for _, _, docs in walk() for d in docs]
    assert len(keys) > 100
    for key in keys:
        assert f"**`{key}`**" in text, key


def test_the_type_column_names_the_words_a_key_takes() -> None:
    """``vision.work_area_px: whole_frame`` loads, so the reference's type column says
    so (it said "list of 2 × number or null", and only the description named it)."""
    from mearm.config import VisionConfig

    assert VisionConfig(work_area_px="whole_frame").work_area_px is not None
    key = "- **`vision.work_area_px`** — "
    line = next(x for x in render().splitlines() if x.startswith(key))
    assert line.startswith(key + "list of 2 × number, `whole_frame` or null;")


def _reference_line(key: str) -> str:
    start = f"- **`{key}`** — "
    return next(x for x in render().splitlines() if x.startswith(start))


def test_the_reference_says_what_the_validators_enforce() -> None:
    """The reference contradicted the validators: vision.median_kernel said only
    "≥ 1; ≤ 31" (an even one is refused), learned_colour.ab_cov said "each > 0 …; each ≥
    -10000 …" (its middle item may be negative), and a fault's kind had a default though
    every fault must name it."""
    from mearm.config import load_config

    assert "; ≥ 1; ≤ 31; odd." in _reference_line("vision.median_kernel")
    with pytest.raises(ConfigError, match="vision.median_kernel: must be odd"):
        load_config(None, ["vision.median_kernel=4"])
    cov = _reference_line("task.classes[].learned_colour.ab_cov")
    assert "items 1 and 3 > 0, ≤ 10000, finite; item 2 ≥ -10000, ≤ 10000, finite." in cov
    colour = "{ab_mean: [0, 0], ab_cov: [4, -1, 4], lightness: [10, 90]}"
    assert load_config(None, [f"task.classes.red.learned_colour={colour}"])
    kinds = [x for x in render().splitlines() if x.startswith("- **`twin.faults[].kind`**")]
    assert len(kinds) == 5 and all("; default *required*." in x for x in kinds)
    allowed = "one of: limp_servo, knock_object, camera_black, camera_frozen, camera_bump"
    for fault, said in [
        ("{at_s: 1}", f"twin.faults.0.kind: required but missing ({allowed})"),
        ("{kind: zap, at_s: 1}", f"twin.faults.0.kind: expected {allowed} (got 'zap')"),
    ]:
        with pytest.raises(ConfigError) as info:
            load_config(None, [f"twin.faults=[{fault}]"])
        assert str(info.value) == f"overrides: {said}"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc: Path) -> None:
    """Every relative link names a file in the repository (and an anchor it has)."""
    bad = []
    for target in _links(doc):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        dest = (doc.parent / file_part).resolve() if file_part else doc
        if not dest.is_relative_to(ROOT) or not dest.exists():
            bad.append(f"{target}: no such file in the repository")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest.read_text()):
            bad.append(f"{target}: {dest.name} has no heading #{anchor}")
    assert not bad, f"{doc.name}: " + "; ".join(bad)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_nothing_points_outside_the_repository(doc: Path) -> None:
    """No doc cites the internal spec or the shared folder the user does not have."""
    text = doc.read_text(encoding="utf-8")
    assert not re.search(r"\bSPEC\b", text), f"{doc.name} mentions SPEC"
    assert "../shared" not in text, f"{doc.name} points into ../shared"


def test_every_doc_page_is_reachable_from_the_readme() -> None:
    """Each page of docs/ is linked from README.md or from a page it links to."""
    reached, todo = set(), [ROOT / "README.md"]
    while todo:
        page = todo.pop()
        for target in _links(page):
            dest = (page.parent / target.partition("#")[0]).resolve()
            if dest.suffix == ".md" and dest.is_file() and dest not in reached:
                reached.add(dest)
                todo.append(dest)
    missing = [p.name for p in DOCS if p.name != "README.md" and p.resolve() not in reached]
    assert not missing, f"not linked from the README: {missing}"


#: Run in one fresh process: every subcommand's ``--help`` (and ``mearm --help``), as JSON.
HELP_OF_EVERY_SUBCOMMAND = """
import contextlib, io, json, sys
from mearm.__main__ import SUBCOMMANDS, _load, _usage
out = {"mearm": _usage()}
for name, (target, _) in SUBCOMMANDS.items():
    sys.argv = [f"mearm {name}"]
    text = io.StringIO()
    try:
        with contextlib.redirect_stdout(text):
            _load(target)(["--help"])
    except SystemExit:
        pass
    out[name] = text.getvalue()
print(json.dumps(out))
"""


def _help_of_every_subcommand() -> dict[str, str]:
    r = subprocess.run(
        [sys.executable, "-c", HELP_OF_EVERY_SUBCOMMAND],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert r.returncode == 0, r.stderr
    texts: dict[str, str] = json.loads(r.stdout)
    return texts


@pytest.fixture(scope="module")
def help_texts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """``mearm --help`` and every ``mearm SUBCOMMAND --help``, from one process (once per
    test run: the workers share it)."""
    return computed_once(tmp_path_factory, "help-texts", _help_of_every_subcommand)


@pytest.mark.parametrize("name", ["mearm", *SUBCOMMANDS])
@pytest.mark.heavy
def test_help_is_plain_words(help_texts: dict[str, str], name: str) -> None:
    """--help shows no raw reStructuredText and no SPEC or § references."""
    text = help_texts[name]
    assert text.startswith("usage: "), text[:80]
    bad = [line for line in text.splitlines() if RST.search(line) or UNFOLLOWABLE.search(line)]
    assert not bad, f"mearm {name} --help: {bad}"
