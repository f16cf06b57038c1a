"""Check or show a LeRobot dataset recorded with --record (mearm dataset).

    mearm dataset check DIR        # every rule of the format (docs/datasets.md)
    mearm dataset show DIR [--sheet PNG] [--force]

"check" prints each broken rule and exits 1 if any is broken (0: the dataset passes);
"show" prints the episodes, tasks and statistics of the state and the action, and saves
a contact sheet of frames with their states (default DIR-sheet.png beside DIR; a sheet
that exists is replaced only with --force, and never one inside DIR).
Exit 2 on bad input: DIR missing, a file, or holding no dataset; for "show", a dataset
"check" fails (its videos not decoded: a torn episode, totals that disagree); a sheet
refused.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    check_output_file,
    refuse_to_replace,
    run,
)
from mearm.errors import MearmError


def main(argv: Sequence[str] | None = None) -> int:
    """Run ``check`` or ``show``; see the module docstring."""
    parser = ArgumentParser(prog="mearm dataset", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    check = sub.add_parser("check", help="check DIR against the LeRobotDataset v3.0 format")
    check.add_argument("dir", type=Path, metavar="DIR")
    check.add_argument(
        "--no-videos", action="store_true", help="skip decoding the videos (rule 'videos')"
    )
    show = sub.add_parser("show", help="print episodes, tasks, statistics; save a contact sheet")
    show.add_argument("dir", type=Path, metavar="DIR")
    show.add_argument(
        "--sheet", type=Path, metavar="PNG", help="default: DIR-sheet.png, beside DIR"
    )
    show.add_argument("--force", action="store_true", help="replace the sheet if it exists")
    for p in (check, show):
        p.error = parser.error  # type: ignore[method-assign]  # one line, exit 2
    args = parser.parse_args(argv)

    if args.command == "check":
        from mearm.dataset.format_check import RULES, check_dataset

        problems = check_dataset(args.dir, videos=not args.no_videos)
        for line in problems:
            print(line)
        if problems:
            more = f" (and {len(problems) - 1} more above)" if len(problems) > 1 else ""
            print(f"mearm dataset check: {args.dir}: {problems[0]}{more}", file=sys.stderr)
            return EXIT_FAILURE
        rules = len(RULES) - (1 if args.no_videos else 0)
        print(f"{args.dir}: passes the LeRobotDataset v3.0 checks ({rules} rules)")
        return EXIT_OK

    from mearm.dataset.contact_sheet import contact_sheet, describe
    from mearm.dataset.format_check import check_dataset, refuse_damaged

    problems = check_dataset(args.dir, videos=False)  # bad input (not a dataset) is exit 2 here
    sheet = args.sheet or default_sheet(args.dir)
    # before the report, not after it
    check_output_file(sheet, "--sheet")
    refuse_inside(sheet, args.dir)
    if sheet.suffix.lower() != ".png":  # PNG bytes under .jpg: a viewer's guess, not a JPEG
        raise MearmError(f"--sheet {sheet}: the contact sheet is a PNG: give a name ending .png")
    refuse_to_replace(sheet, "--sheet", args.force)
    report = list(describe(args.dir))  # a damaged file is named here, with what is wrong
    # a rule broken with every file readable (a torn episode, totals that disagree) is
    # refused too: the report would count it wrong, the sheet draw it wrong or crash
    refuse_damaged(args.dir, problems)
    # the sheet decodes frames: a video damaged inside (its boxes whole) is refused there,
    # before the report is printed, not after it
    n = contact_sheet(args.dir, sheet)
    for line in report:
        print(line)
    print(f"wrote {sheet} (the contact sheet, {n} frames)")
    return EXIT_OK


def default_sheet(root: Path) -> Path:
    """``DIR-sheet.png`` beside DIR, named after the folder ``.`` or ``..`` stands for."""
    if root.name in ("", ".."):
        root = root.resolve()
    return root.parent / f"{root.name or 'dataset'}-sheet.png"


def refuse_inside(sheet: Path, root: Path) -> None:
    """Refuse a sheet inside the dataset, even with --force: it would replace its files.

    Both paths resolved: ``DIR/./meta/info.json``, a link into DIR, a name of DIR's own
    folder by another way are all caught.

    Raises:
        MearmError: ``sheet`` resolves to a path under ``root``.
    """
    try:
        target, folder = sheet.resolve(), root.resolve()
    except (OSError, RuntimeError) as exc:  # a loop of links (RuntimeError before 3.13)
        raise MearmError(f"--sheet {sheet}: cannot be resolved ({exc})") from None
    if folder in target.parents:
        raise MearmError(
            f"--sheet {sheet}: is inside the dataset {root}, whose files it would replace: "
            f"give a path outside it (default: {default_sheet(root)})"
        )


if __name__ == "__main__":
    run(main)
