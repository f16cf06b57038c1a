"""Reading a run log: :func:`read_runlog` groups its records by trial into :class:`Trial`.

The format is described in :mod:`mearm.runlog`.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from mearm.exceptions import RunLogError, RunLogFormatError
from mearm.runlog.records import (
    FaultRecord,
    HeaderRecord,
    Record,
    RouteRecord,
    SkipRecord,
    SummaryRecord,
    parse_record,
)


@dataclass(frozen=True)
class Trial:
    """One trial of a log: its header and the records under it, in order.

    Attributes:
        header: The trial's header.
        line: The header's line number (from 1).
        routes: Its route records.
        skips: Its skip records.
        faults: Its fault records.
        summary: Its summary, or ``None`` when the run stopped before writing one.
    """

    header: HeaderRecord
    line: int
    routes: tuple[RouteRecord, ...] = ()
    skips: tuple[SkipRecord, ...] = ()
    faults: tuple[FaultRecord, ...] = ()
    summary: SummaryRecord | None = None

    @property
    def number(self) -> int | None:
        """The trial number of the header (``None`` for a lone sort run)."""
        return self.header.trial


@dataclass(frozen=True)
class RunLogContents:
    """What :func:`read_runlog` found.

    Attributes:
        path: The file read.
        records: Every valid record before the first bad line, in file order.
        trials: The same records grouped by header.
        problem: The first bad line and why, or ``None`` when the whole file is valid.
        lines_read: Lines read, including blank ones but not the bad one.
    """

    path: Path
    records: tuple[Record, ...]
    trials: tuple[Trial, ...]
    problem: RunLogFormatError | None = None
    lines_read: int = 0

    @property
    def complete(self) -> bool:
        """Whether every line was valid."""
        return self.problem is None

    @property
    def routes(self) -> list[RouteRecord]:
        """Every route record, in file order."""
        return [r for t in self.trials for r in t.routes]

    @property
    def skips(self) -> list[SkipRecord]:
        """Every skip record, in file order."""
        return [r for t in self.trials for r in t.skips]

    @property
    def faults(self) -> list[FaultRecord]:
        """Every fault record, in file order."""
        return [r for t in self.trials for r in t.faults]


@dataclass
class _TrialBuilder:
    header: HeaderRecord
    line: int
    routes: list[RouteRecord] = field(default_factory=list)
    skips: list[SkipRecord] = field(default_factory=list)
    faults: list[FaultRecord] = field(default_factory=list)
    summary: SummaryRecord | None = None

    def check(self, record: Record) -> str | None:
        """Why ``record`` cannot come next in this trial, or ``None``."""
        if self.summary is not None:
            return f"{record.type} record after the summary of trial {self.header.trial}"
        trial = record.trial
        if isinstance(record, FaultRecord) and trial is None:
            return None
        if trial != self.header.trial:
            return (
                f"{record.type} record of trial {trial} under the header of trial "
                f"{self.header.trial}"
            )
        return None

    def add(self, record: Record) -> None:
        if isinstance(record, RouteRecord):
            self.routes.append(record)
        elif isinstance(record, SkipRecord):
            self.skips.append(record)
        elif isinstance(record, FaultRecord):
            self.faults.append(record)
        elif isinstance(record, SummaryRecord):
            self.summary = record

    def freeze(self) -> Trial:
        return Trial(
            header=self.header,
            line=self.line,
            routes=tuple(self.routes),
            skips=tuple(self.skips),
            faults=tuple(self.faults),
            summary=self.summary,
        )


def _lines(path: Path) -> Iterator[tuple[int, bytes, bool]]:
    """(number, bytes without the newline, whether the newline was there)."""
    with path.open("rb") as f:
        for number, raw in enumerate(f, start=1):
            ended = raw.endswith(b"\n")
            yield number, raw.rstrip(b"\r\n") if ended else raw, ended


def read_runlog(path: str | Path, *, strict: bool = False) -> RunLogContents:
    """Read a run log up to its first bad line.

    Blank lines are ignored. A line is bad when it is torn (no newline at the end of the
    file and not a valid record), not UTF-8 or JSON, of an unknown type or format, has a
    field missing or of the wrong type, comes before any header, carries another trial's
    number, or follows its trial's summary.

    Args:
        path: The log file.
        strict: Raise the problem instead of returning it.

    Returns:
        The valid records before the bad line, grouped by trial, and the problem.

    Raises:
        RunLogError: The file cannot be opened.
        RunLogFormatError: Only with ``strict=True``: a bad line.
    """
    p = Path(path)
    if not p.is_file():
        raise RunLogError(p, "no such run log" if not p.exists() else "not a file")
    records: list[Record] = []
    trials: list[_TrialBuilder] = []
    problem: RunLogFormatError | None = None
    lines_read = 0
    try:
        for number, raw, ended in _lines(p):
            excerpt = raw[:80].decode("utf-8", errors="replace")
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                problem = RunLogFormatError(p, number, f"not UTF-8 ({exc.reason})", excerpt)
                break
            if not text.strip():
                lines_read = number
                continue
            try:
                record = parse_record(text)
            except ValueError as exc:
                reason = str(exc)
                if not ended:
                    reason = f"torn last line (no newline: the writer stopped mid-line); {reason}"
                problem = RunLogFormatError(p, number, reason, excerpt)
                break
            if isinstance(record, HeaderRecord):
                trials.append(_TrialBuilder(record, number))
            elif not trials:
                why = f"{record.type} record before any header"
                problem = RunLogFormatError(p, number, why, excerpt)
                break
            else:
                out_of_order = trials[-1].check(record)
                if out_of_order is not None:
                    problem = RunLogFormatError(p, number, out_of_order, excerpt)
                    break
                trials[-1].add(record)
            records.append(record)
            lines_read = number
    except OSError as exc:
        raise RunLogError(p, f"cannot read: {exc}") from None
    if problem is not None and strict:
        raise problem
    return RunLogContents(
        path=p,
        records=tuple(records),
        trials=tuple(t.freeze() for t in trials),
        problem=problem,
        lines_read=lines_read,
    )
