"""Check or show a LeRobot dataset recorded with --record (mearm dataset).

    mearm dataset check DIR        # every rule of the format (docs/datasets.md)
    mearm dataset show DIR [--sheet PNG]

"check" prints each broken rule and exits 1 if any is broken (0: the dataset passes);
"show" prints the episodes, tasks and statistics of the state and the action, and saves
a contact sheet of frames with their states (default DIR-sheet.png beside DIR).
Exit 2 on bad input: DIR missing, a file, or holding no dataset.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import EXIT_FAILURE, EXIT_OK, ArgumentParser, check_output_file, run


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
    show.add_argument("--sheet", type=Path, metavar="PNG", help="default: DIR-sheet.png")
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
    from mearm.dataset.format_check import check_dataset

    check_dataset(args.dir, videos=False)  # bad input (not a dataset) is exit 2 here
    sheet = args.sheet or args.dir.with_name(args.dir.name + "-sheet.png")
    check_output_file(sheet, "--sheet")  # before the report, not after it
    for line in describe(args.dir):
        print(line)
    n = contact_sheet(args.dir, sheet)
    print(f"contact sheet: {sheet} ({n} frames)")
    return EXIT_OK


if __name__ == "__main__":
    run(main)
