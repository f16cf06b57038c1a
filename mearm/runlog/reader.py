"""Reading a run log: :func:`read_runlog` groups its records by trial into :class:`Trial`.

The format is described in :mod:`mearm.runlog`, repeated trial numbers in
:meth:`RunLogContents.latest`.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mearm.runlog.errors import RepeatedTrialError, RunLogError, RunLogFormatError
from mearm.runlog.records import (
    FaultRecord,
    HeaderRecord,
    Record,
    RouteRecord,
    SkipRecord,
    SummaryRecord,
    parse_record,
)

#: A fault's reason when Ctrl-C (or a stop signal taken as one) stopped the trial, as
#: :mod:`mearm.task` words it: ``interrupted (Ctrl-C); arm parked at home``, ``before the
#: sort started: interrupted (SIGTERM)``.
_INTERRUPTED = re.compile(r"(?:^|: )interrupted \(")

#: A fault's reason when the trial's recording could not be written (a full disk) and
#: stopped the trial, as :class:`~mearm.dataset.errors.DatasetWriteError` words it:
#: ``ds/data/chunk-000/file-000.parquet: cannot be written: disk full (…); recording
#: stopped, the dataset keeps the 2 episodes written before; arm parked at home``.
_RECORDING_STOPPED = re.compile(r": cannot be written: .*; recording stopped, ")


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

    @property
    def complete(self) -> bool:
        """Whether the trial has its summary (it ran to the end, or stopped and said so)."""
        return self.summary is not None

    @property
    def interrupted(self) -> bool:
        """Whether Ctrl-C stopped the trial: its summary is there, but the trial was not done."""
        if self.summary is None:
            return False
        left = self.summary.left or {}
        return "interrupted" in left or any(_INTERRUPTED.search(f.reason) for f in self.faults)

    @property
    def recording_stopped(self) -> bool:
        """Whether its recording stopped the trial: a file of the dataset could not be written.

        Not the arm's result, as Ctrl-C is not: the experiment runs the trial again once
        there is room (the picks the dataset holds are not recorded twice). A stopped
        trial that counted as finished was never run again, its picks after the failure
        missing from the dataset for good.
        """
        return self.summary is not None and any(
            _RECORDING_STOPPED.search(f.reason) for f in self.faults
        )

    @property
    def finished(self) -> bool:
        """Whether the trial ran its course: complete, not stopped by Ctrl-C nor its recording.

        Neither :attr:`interrupted` nor :attr:`recording_stopped`. One that stopped on a
        fault of the rig is finished: the fault is its result.
        """
        return self.complete and not self.interrupted and not self.recording_stopped

    @property
    def twin_faults(self) -> tuple[dict[str, Any], ...]:
        """The twin's injected faults that struck in the trial: its summary's ``twin_faults``.

        Those that stopped it and those the sort never noticed (the trial is then
        finished, its summary ``ok``).
        """
        if self.summary is None:
            return ()
        return tuple(self.summary.twin_faults or ())

    @property
    def records(self) -> tuple[Record, ...]:
        """The header and every record under it (grouped by type, not in file order)."""
        summary = () if self.summary is None else (self.summary,)
        return (self.header, *self.routes, *self.skips, *self.faults, *summary)


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

    @property
    def superseded(self) -> tuple[Trial, ...]:
        """Attempts of a numbered trial that another attempt of it replaces.

        The experiment runner runs a trial again, under the same number and seed, when
        its last attempt was cut off before its summary, :attr:`~Trial.interrupted` or
        :attr:`~Trial.recording_stopped` (:mod:`mearm.experiment`). Per trial number,
        the :attr:`~Trial.finished` attempt is kept (when none is, the last complete one;
        when none is complete, the last one) and every other attempt is superseded. Lone
        sort runs (``trial: null``) are never superseded.
        """
        attempts: dict[int, list[Trial]] = {}
        for t in self.trials:
            if t.number is not None:
                attempts.setdefault(t.number, []).append(t)
        out: list[Trial] = []
        for tries in attempts.values():
            if len(tries) < 2:
                continue
            complete = [t for t in tries if t.complete]
            kept = next((t for t in tries if t.finished), (complete or tries)[-1])
            out += [t for t in tries if t is not kept]
        return tuple(sorted(out, key=lambda t: t.line))

    def repeated_trials(self) -> dict[int, tuple[int, ...]]:
        """Trial numbers finished more than once → the header lines of those attempts.

        (Interrupted attempts, and those their recording stopped, do not count: the
        experiment runs such a trial again.)
        """
        lines: dict[int, list[int]] = {}
        for t in self.trials:
            if t.number is not None and t.finished:
                lines.setdefault(t.number, []).append(t.line)
        return {k: tuple(v) for k, v in lines.items() if len(v) > 1}

    def latest(self) -> RunLogContents:
        """These contents without the :attr:`superseded` attempts.

        A trial that is cut off or interrupted and run again reads as the one trial it
        became. A trial number that is *finished* twice cannot be told apart that way
        (two runs written to one file, or a file copied onto its end): it is refused.

        Raises:
            RepeatedTrialError: A trial number is finished more than once.
        """
        repeated = self.repeated_trials()
        if repeated:
            raise RepeatedTrialError(self.path, repeated)
        dropped = self.superseded
        if not dropped:
            return self
        gone = {id(r) for t in dropped for r in t.records}
        return dataclasses.replace(
            self,
            records=tuple(r for r in self.records if id(r) not in gone),
            trials=tuple(t for t in self.trials if all(t is not d for d in dropped)),
        )


def chain_joint_names(config: Mapping[str, Any]) -> tuple[str, ...] | None:
    """The joint names of the arm in a header's config, or ``None`` if it gives none.

    A config that leaves the arm out (the built-in arm) gives ``None``: nothing to check
    joint values against without loading it.
    """
    arm = config.get("arm")
    joints = arm.get("joints") if isinstance(arm, Mapping) else None
    if not isinstance(joints, list) or not joints:
        return None
    names = [j.get("name") if isinstance(j, Mapping) else None for j in joints]
    if not all(isinstance(n, str) for n in names):
        return None
    return tuple(names)  # type: ignore[arg-type]


def _joint_values(record: Record) -> list[tuple[str, dict[str, float]]]:
    if isinstance(record, RouteRecord):
        return [("start_joints", record.start_joints), ("end_joints", record.end_joints)]
    if isinstance(record, FaultRecord) and record.last_joints is not None:
        return [("last_joints", record.last_joints)]
    return []


@dataclass
class _TrialBuilder:
    header: HeaderRecord
    line: int
    routes: list[RouteRecord] = field(default_factory=list)
    skips: list[SkipRecord] = field(default_factory=list)
    faults: list[FaultRecord] = field(default_factory=list)
    summary: SummaryRecord | None = None
    joint_names: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        self.joint_names = chain_joint_names(self.header.config)

    def check(self, record: Record) -> str | None:
        """Why ``record`` cannot come next in this trial, or ``None``."""
        if self.summary is not None:
            return f"{record.type} record after the summary of trial {self.header.trial}"
        trial = record.trial
        if trial != self.header.trial and not (isinstance(record, FaultRecord) and trial is None):
            return (
                f"{record.type} record of trial {trial} under the header of trial "
                f"{self.header.trial}"
            )
        return self._check_joints(record)

    def _check_joints(self, record: Record) -> str | None:
        """Joint values must name every joint of the header's arm, and only those."""
        if self.joint_names is None:
            return None
        for key, values in _joint_values(record):
            missing = [n for n in self.joint_names if n not in values]
            unknown = [n for n in values if n not in self.joint_names]
            if missing or unknown:
                return (
                    f"{record.type} record: field '{key}' names {list(values)}, not the joints "
                    f"of the header's arm {list(self.joint_names)} (missing {missing}, "
                    f"unknown {unknown})"
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


#: Longest line read [bytes]: a header with its whole config is some 10 kB; a longer
#: line is not a record, and is not read into memory to find that out.
MAX_LINE_BYTES = 4 * 1024 * 1024


def _lines(path: Path) -> Iterator[tuple[int, bytes, bool]]:
    """(number, bytes without the newline, whether the newline was there).

    A line longer than :data:`MAX_LINE_BYTES` comes back cut to one byte more than that,
    and is the last.
    """
    with path.open("rb") as f:
        number = 0
        while raw := f.readline(MAX_LINE_BYTES + 2):
            number += 1
            ended = raw.endswith(b"\n")
            yield number, raw.rstrip(b"\r\n") if ended else raw, ended
            if len(raw) > MAX_LINE_BYTES + 1:
                return


def read_runlog(path: str | Path, *, strict: bool = False) -> RunLogContents:
    """Read a run log up to its first bad line.

    Blank lines are ignored. A line is bad when it is torn (no newline at the end of the
    file and not a valid record), not UTF-8 or JSON, of an unknown type or format, has a
    field missing or of the wrong type, comes before any header, carries another trial's
    number, names joints other than those of its header's arm, or follows its trial's
    summary.

    Each line is read in its trial's format (its header's ``format``); format-1 trials
    come back as current records (:mod:`mearm.runlog.format1`).

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
            if len(raw) > MAX_LINE_BYTES:
                why = f"longer than {MAX_LINE_BYTES // 2**20} MiB: not a run-log record"
                problem = RunLogFormatError(p, number, why, excerpt)
                break
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                problem = RunLogFormatError(p, number, f"not UTF-8 ({exc.reason})", excerpt)
                break
            if not text.strip():
                lines_read = number
                continue
            trial_format = trials[-1].header.format if trials else None
            try:
                record = parse_record(text, trial_format=trial_format)
            except ValueError as exc:
                reason = str(exc)
                if not ended:
                    reason = f"torn last line (no newline: the writer stopped mid-line); {reason}"
                problem = RunLogFormatError(p, number, reason, excerpt)
                break
            if isinstance(record, HeaderRecord):
                trials.append(_TrialBuilder(record, number))
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
