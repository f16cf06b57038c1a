"""The run log: one JSON object per line (JSON Lines), one line per event.

The sort (``python -m mearm.sort --log run.jsonl``) and the experiment runner
(``python -m mearm.experiment --log trials.jsonl``) write it through :class:`RunLog`;
``python -m mearm.analyze`` reads it through :func:`read_runlog`.

Layout (format 1). Every line is an object with a ``"type"``:

- ``header`` starts a *trial*: ``format``, ``mearm_version``, ``started`` (ISO 8601),
  ``config`` (``Config.model_dump(mode="json")``), ``versions`` (library versions),
  ``trial`` (int, or null for a lone sort run) and ``seed`` (int or null).
- ``route`` one PD-PIJ route (a pick or a place), see :class:`RouteRecord`.
- ``skip`` an object that was not sorted, and why.
- ``fault`` a camera / servo failure or Ctrl-C, with the last joint angles.
- ``summary`` closes the trial.

**One header per trial.** A file holds a sequence of trials; each is a header, its
records and (unless the run crashed) one summary. Every record after a header carries
that header's ``trial`` number, so each trial is self-contained: its header alone says
how it was configured and seeded. A sort run is one trial with ``trial: null``; the
experiment runner writes trials 0..N-1, one header each, into one file.

**Appending.** Opening an existing log appends to it: what is there stays, and the new
run starts with its own header. ``RunLog(path, exclusive=True)`` refuses an existing file
instead. A file whose last line is torn (a crash mid-write) is refused either way, since
a record written after it would be read as part of the broken line.

**Durability.** Each record is written as one ``write`` of one line, then flushed and
``fsync``-ed, so a crash loses at most the record being written.

**Reading.** :func:`read_runlog` returns every valid record up to the first bad line
(torn, not JSON, unknown type, a field missing or of the wrong type, records out of
order) and a :class:`~mearm.exceptions.RunLogFormatError` naming that line and why.
"""

from __future__ import annotations

import functools
import json
import math
import os
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from mearm.config import Color, Config
from mearm.exceptions import RunLogError, RunLogFormatError

FORMAT_VERSION = 1

#: Distributions whose versions go into every header (key → PyPI name).
VERSIONED_PACKAGES: dict[str, str] = {
    "numpy": "numpy",
    "pinocchio": "pin",
    "mink": "mink",
    "mujoco": "mujoco",
    "opencv": "opencv-python-headless",
    "pydantic": "pydantic",
    "pyserial": "pyserial",
    "scipy": "scipy",
    "matplotlib": "matplotlib",
}

_Finite = Annotated[float, Field(allow_inf_nan=False)]
_NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Vec3 = tuple[_Finite, _Finite, _Finite]
Joints4 = tuple[_Finite, _Finite, _Finite, _Finite]

#: Largest allowed |error_cm − (ee_cm − target_cm)| on any axis [cm].
ERROR_CONSISTENCY_CM = 1e-6


class _Record(BaseModel):
    # strict: a string is not an int, 1 is not true, 1.0 is not an iteration count.
    # extra="allow": a later writer may add fields; readers keep them.
    model_config = ConfigDict(extra="allow", frozen=True, strict=True)


class HeaderRecord(_Record):
    """Starts a trial: how it was configured, with what software, and its seed."""

    type: Literal["header"] = "header"
    format: int
    mearm_version: str
    started: str
    """Wall-clock start, ISO 8601 with the UTC offset."""
    config: dict[str, Any]
    """``Config.model_dump(mode="json")``; :meth:`load_config` turns it back."""
    versions: dict[str, str | None]
    trial: int | None
    seed: int | None

    @field_validator("started")
    @classmethod
    def _iso(cls, value: str) -> str:
        try:
            datetime.fromisoformat(value)
        except ValueError:
            raise ValueError(f"not an ISO 8601 time: {value!r}") from None
        return value

    def load_config(self) -> Config:
        """The trial's configuration as a :class:`~mearm.config.Config`.

        Raises:
            ConfigError: The stored config does not validate with this version of mearm.
        """
        from mearm.config import config_from_dict

        return config_from_dict(self.config, source="run-log header")


class RouteRecord(_Record):
    """One route of the arm to a pick or place point (SPEC §1 steps 4–5).

    ``final_error_cm`` is the solver's, on ideal kinematics; ``ee_cm`` is where the arm
    really ended (for the simulated arm, the FK of its quantised / noisy joints) and
    ``error_cm = ee_cm − target_cm`` the error the paper's Table 8 measures.
    """

    type: Literal["route"] = "route"
    trial: int | None
    object_id: str = Field(min_length=1)
    color: Color
    step: Literal["pick", "place"]
    attempt: int = Field(ge=1)
    """1 for the first attempt at this object's pick (or place)."""
    target_cm: Vec3
    start_joints_deg: Joints4
    end_joints_deg: Joints4
    """Commanded joint angles at the end of the route [deg]."""
    iterations: int = Field(ge=0)
    status: str
    initial_error_cm: _NonNegative
    final_error_cm: _NonNegative
    ee_cm: Vec3
    error_cm: Vec3
    success: bool
    """Pick: the object was gripped. Place: it landed in its bin."""
    elapsed_s: _NonNegative
    motion_s: _NonNegative

    @model_validator(mode="after")
    def _error_is_ee_minus_target(self) -> RouteRecord:
        expected = np.subtract(self.ee_cm, self.target_cm)
        worst = float(np.max(np.abs(np.subtract(self.error_cm, expected))))
        if worst > ERROR_CONSISTENCY_CM:
            raise ValueError(
                f"error_cm {list(self.error_cm)} is not ee_cm − target_cm "
                f"{[round(v, 9) for v in expected.tolist()]} (off by {worst:.3g} cm)"
            )
        return self

    @property
    def error_norm_cm(self) -> float:
        """Euclidean xyz error |ee − target| [cm]."""
        return math.hypot(*self.error_cm)


class SkipRecord(_Record):
    """An object that was not sorted: unreachable, outside the box, retries exhausted."""

    type: Literal["skip"] = "skip"
    trial: int | None
    object_id: str = Field(min_length=1)
    color: Color
    target_cm: Vec3 | None
    reason: str


class FaultRecord(_Record):
    """A camera or servo failure, or Ctrl-C: the run stopped here."""

    type: Literal["fault"] = "fault"
    trial: int | None = None
    reason: str
    last_joints_deg: Joints4 | None


class SummaryRecord(_Record):
    """Closes a trial: what it sorted and how its routes went."""

    type: Literal["summary"] = "summary"
    trial: int | None
    sorted: dict[str, Annotated[int, Field(ge=0)]]
    """Objects placed in their bin, per colour."""
    failures: int = Field(ge=0)
    skipped: int = Field(ge=0)
    routes: int = Field(ge=0)
    mean_iterations: _NonNegative | None
    mean_final_error_cm: _NonNegative | None
    motion_s: _NonNegative
    ok: bool


Record = HeaderRecord | RouteRecord | SkipRecord | FaultRecord | SummaryRecord

RECORD_TYPES: dict[str, type[_Record]] = {
    "header": HeaderRecord,
    "route": RouteRecord,
    "skip": SkipRecord,
    "fault": FaultRecord,
    "summary": SummaryRecord,
}


def library_versions() -> dict[str, str | None]:
    """Python's and the main libraries' versions (``None`` for one not installed)."""
    return dict(_library_versions())


@functools.cache
def _library_versions() -> dict[str, str | None]:
    # Reading package metadata costs ~7 ms a package; a run's versions do not change.
    import platform

    versions: dict[str, str | None] = {"python": platform.python_version()}
    for key, dist in VERSIONED_PACKAGES.items():
        try:
            versions[key] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[key] = None
    return versions


def mearm_version() -> str:
    """The installed mearm version (``"unknown"`` when run from an uninstalled tree)."""
    try:
        return metadata.version("mearm")
    except metadata.PackageNotFoundError:
        return "unknown"


def _plain(value: Any) -> Any:
    """Numpy arrays and scalars, tuples and mappings → JSON-ready Python values."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def _describe(err: Mapping[str, Any]) -> str:
    loc = ".".join(str(p) for p in err["loc"])
    if err["type"] == "missing":
        return f"field '{loc}' is missing"
    msg = str(err["msg"])
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if not loc:
        return msg
    return f"field '{loc}': {msg} (got {err.get('input')!r})"


def _validation_reason(kind: str, exc: ValidationError) -> str:
    problems = [_describe(e) for e in exc.errors()]
    more = f" (+{len(problems) - 1} more)" if len(problems) > 1 else ""
    return f"{kind} record: {problems[0]}{more}"


def parse_record(text: str) -> Record:
    """One line of a run log → its record.

    Raises:
        ValueError: The line is not a valid record; the message says why.
    """
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not valid JSON ({exc.msg} at column {exc.colno})") from None
    if not isinstance(obj, dict):
        raise ValueError(f"a record must be a JSON object, got {type(obj).__name__}")
    kind = obj.get("type")
    if kind not in RECORD_TYPES:
        raise ValueError(f"unknown record type {kind!r}; known: {sorted(RECORD_TYPES)}")
    if kind == "header" and obj.get("format") != FORMAT_VERSION:
        raise ValueError(
            f"header format {obj.get('format')!r} is not supported "
            f"(this mearm reads format {FORMAT_VERSION})"
        )
    try:
        return RECORD_TYPES[kind].model_validate_json(text)  # type: ignore[return-value]
    except ValidationError as exc:
        raise ValueError(_validation_reason(kind, exc)) from None


# --------------------------------------------------------------------------- reading


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


# --------------------------------------------------------------------------- writing


class RunLog:
    """Writes a run log, one durable line per record.

    Use it as a context manager; write a header per trial, then its records, then its
    summary::

        with RunLog("trials.jsonl") as log:
            log.header(config, trial=0, seed=1234)
            log.route(object_id="red1", color="red", step="pick", attempt=1, ...)
            log.skip(object_id="blue4", color="blue", target_cm=t, reason="unreachable: ...")
            log.summary(ok=True)          # counts and means filled in from this trial

    Every method validates its record with the same model the reader uses, so whatever
    is written reads back; numpy arrays and scalars are accepted anywhere. ``trial`` may
    be left out of the records: it is taken from the current header (and a different
    one is refused).

    Args:
        path: The log file. Created (with its folder) if missing; appended to if it exists.
        exclusive: Refuse an existing file instead of appending to it.
        fsync: ``fsync`` after every record (keep this on for real runs; tests that
            write thousands of records may turn it off).

    Raises:
        RunLogError: ``exclusive`` and the file exists; the file ends in a torn line;
            it cannot be opened.
    """

    def __init__(self, path: str | Path, *, exclusive: bool = False, fsync: bool = True):
        self.path = Path(path)
        self._fsync = fsync
        self._trial: _TrialBuilder | None = None
        self.records_written = 0
        if self.path.exists():
            if exclusive:
                raise RunLogError(self.path, "exists (exclusive=True refuses to append)")
            self._refuse_torn_file()
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = self.path.open("ab")
        except OSError as exc:
            raise RunLogError(self.path, f"cannot open for writing: {exc}") from None

    def _refuse_torn_file(self) -> None:
        try:
            with self.path.open("rb") as f:
                f.seek(0, os.SEEK_END)
                if f.tell() == 0:
                    return
                f.seek(-1, os.SEEK_END)
                last = f.read(1)
        except OSError as exc:
            raise RunLogError(self.path, f"cannot read: {exc}") from None
        if last != b"\n":
            raise RunLogError(
                self.path,
                "ends in the middle of a line (a crash while writing?), so it cannot be "
                "appended to; read it with mearm.analyze and write the new run to another file",
            )

    # -- context manager

    def __enter__(self) -> RunLog:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._file.closed

    def close(self) -> None:
        """Close the file (records are already on disk)."""
        self._file.close()

    # -- records

    def header(
        self,
        config: Config | Mapping[str, Any],
        *,
        trial: int | None = None,
        seed: int | None = None,
        started: datetime | str | None = None,
        **extra: Any,
    ) -> HeaderRecord:
        """Start a trial.

        Args:
            config: The run's configuration (a :class:`Config` or its JSON dump).
            trial: Trial number (``None`` for a lone sort run).
            seed: The seed the trial's layout / noise was drawn from, if any.
            started: Start time (default: now, UTC).
            **extra: More fields to store in the header (e.g. ``argv``, ``scene``).
        """
        if isinstance(config, Config):
            config = config.model_dump(mode="json")
        if started is None:
            started = datetime.now(timezone.utc)
        if isinstance(started, datetime):
            started = started.isoformat()
        record = self._write(
            "header",
            {
                "format": FORMAT_VERSION,
                "mearm_version": mearm_version(),
                "started": started,
                "config": config,
                "versions": library_versions(),
                "trial": trial,
                "seed": seed,
                **extra,
            },
        )
        assert isinstance(record, HeaderRecord)
        self._trial = _TrialBuilder(record, self.records_written)
        return record

    def route(self, **fields: Any) -> RouteRecord:
        """Write one route (fields of :class:`RouteRecord`).

        ``error_cm`` may be left out: it is computed as ``ee_cm − target_cm``.
        """
        if "error_cm" not in fields and "ee_cm" in fields and "target_cm" in fields:
            fields["error_cm"] = np.subtract(
                np.asarray(fields["ee_cm"], dtype=float),
                np.asarray(fields["target_cm"], dtype=float),
            )
        return self._write_in_trial("route", fields)  # type: ignore[return-value]

    def skip(self, **fields: Any) -> SkipRecord:
        """Write an object that was not sorted (fields of :class:`SkipRecord`)."""
        return self._write_in_trial("skip", fields)  # type: ignore[return-value]

    def fault(self, reason: str, last_joints_deg: Any = None, **extra: Any) -> FaultRecord:
        """Write a fault: the reason the run stopped and the last joint angles [deg]."""
        fields = {"reason": reason, "last_joints_deg": last_joints_deg, **extra}
        return self._write_in_trial("fault", fields)  # type: ignore[return-value]

    def summary(self, **fields: Any) -> SummaryRecord:
        """Close the trial with its summary.

        Fields not given are computed from the records written since the header:
        ``sorted`` (successful places per colour), ``failures`` (routes whose
        ``success`` is false), ``skipped``, ``routes``, ``mean_iterations``,
        ``mean_final_error_cm`` (the solver's), ``motion_s`` (sum over routes) and
        ``ok`` (no fault was written).
        """
        trial = self._current("summary")
        routes = trial.routes
        computed: dict[str, Any] = {
            "sorted": {
                c: sum(1 for r in routes if r.step == "place" and r.success and r.color == c)
                for c in dict.fromkeys(r.color for r in routes)
            },
            "failures": sum(1 for r in routes if not r.success),
            "skipped": len(trial.skips),
            "routes": len(routes),
            "mean_iterations": float(np.mean([r.iterations for r in routes])) if routes else None,
            "mean_final_error_cm": (
                float(np.mean([r.final_error_cm for r in routes])) if routes else None
            ),
            "motion_s": float(sum(r.motion_s for r in routes)),
            "ok": not trial.faults,
        }
        return self._write_in_trial("summary", {**computed, **fields})  # type: ignore[return-value]

    # -- plumbing

    def _current(self, kind: str) -> _TrialBuilder:
        if self.closed:
            raise RunLogError(self.path, f"cannot write a {kind} record: the log is closed")
        if self._trial is None:
            raise RunLogError(self.path, f"cannot write a {kind} record before a header")
        return self._trial

    def _write_in_trial(self, kind: str, fields: dict[str, Any]) -> Record:
        trial = self._current(kind)
        fields = dict(fields)
        number = fields.setdefault("trial", trial.header.trial)
        if trial.summary is not None:
            raise RunLogError(
                self.path,
                f"trial {trial.header.trial} already has its summary; write a header "
                f"for the next trial before any {kind} record",
            )
        if number != trial.header.trial:
            raise RunLogError(
                self.path,
                f"{kind} record of trial {number} under the header of trial {trial.header.trial}",
            )
        record = self._write(kind, fields)
        trial.add(record)
        return record

    def _write(self, kind: str, fields: Mapping[str, Any]) -> Record:
        if self.closed:
            raise RunLogError(self.path, f"cannot write a {kind} record: the log is closed")
        try:
            text = json.dumps({"type": kind, **_plain(fields)}, allow_nan=False)
        except (TypeError, ValueError) as exc:
            why = f"{kind} record cannot be written as JSON: {exc}"
            raise RunLogError(self.path, why) from None
        try:
            record = RECORD_TYPES[kind].model_validate_json(text)
        except ValidationError as exc:
            raise RunLogError(self.path, _validation_reason(kind, exc)) from None
        line = record.model_dump_json().encode("utf-8") + b"\n"
        try:
            self._file.write(line)
            self._file.flush()
            if self._fsync:
                os.fsync(self._file.fileno())
        except OSError as exc:
            raise RunLogError(self.path, f"cannot write: {exc}") from None
        self.records_written += 1
        return record  # type: ignore[return-value]
