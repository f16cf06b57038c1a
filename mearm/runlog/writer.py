"""Writing a run log: :class:`RunLog`, one durable line per record.

The format is described in :mod:`mearm.runlog`.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import threading
from collections.abc import Iterator, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import ValidationError

from mearm.config import Config
from mearm.fileio import escaped, existing_ancestor
from mearm.runlog.errors import RunLogError
from mearm.runlog.lock import LogLock, lock_file
from mearm.runlog.reader import _TrialBuilder
from mearm.runlog.records import (
    FORMAT_VERSION,
    RECORD_TYPES,
    FaultRecord,
    HeaderRecord,
    Record,
    RouteRecord,
    SkipRecord,
    SummaryRecord,
    _validation_reason,
    library_versions,
    mearm_version,
)


def _plain(value: Any) -> Any:
    """Numpy arrays and scalars, tuples and mappings → JSON-ready Python values.

    Text is what UTF-8 can hold (:func:`mearm.fileio.escaped`): a file name that is not
    UTF-8 (``argv``'s ``--log``) is recorded with those bytes escaped, so the line is JSON.
    """
    if isinstance(value, str):
        return escaped(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {escaped(str(k)): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


#: The longest first line read to tell a run log from another file [bytes] (a header holds
#: the whole config: a few tens of kB).
_FIRST_LINE_MAX = 4 << 20


def _is_header(line: bytes) -> bool:
    """Whether ``line`` is a run log's header record (of any format)."""
    try:
        record = json.loads(line)
    except ValueError:  # not JSON, not UTF-8, or cut at the limit
        return False
    return isinstance(record, dict) and record.get("type") == "header"


def _trial_of(line: bytes) -> int | None:
    """The trial number a header record ``line`` names: ``None`` for a sort run's (or no header)."""
    try:
        trial = json.loads(line).get("trial")
    except (ValueError, AttributeError):
        return None
    return trial if isinstance(trial, int) and not isinstance(trial, bool) else None


class RunLog:
    """Writes a run log, one durable line per record.

    Use it as a context manager; write a header per trial, then its records, then its
    summary::

        with RunLog("trials.jsonl") as log:
            log.header(config, trial=0, seed=1234)
            log.route(object_id="obj1", color=name, step="pick", attempt=1,
                      start_joints={"base": 120.0, ...}, end_joints={...}, ...)
            log.skip(object_id="obj4", color=name, target_cm=t, reason="unreachable: ...")
            log.summary(ok=True)          # counts and means filled in from this trial

    Every method validates its record with the same model and checks the reader uses, so
    whatever is written reads back; numpy arrays and scalars are accepted anywhere. Joint
    values are mappings by joint name and must name every joint of the header's arm
    (``config.arm.joints``). ``trial`` may be left out of the records: it is taken from
    the current header (and a different one is refused).

    Args:
        path: The log file. Created (with its folder) if missing; appended to if it exists.
        exclusive: Refuse an existing file instead of appending to it.
        fsync: ``fsync`` after every record (keep this on for real runs; tests that
            write thousands of records may turn it off).
        lock: The log's lock, already taken by the caller (:class:`~mearm.runlog.lock.
            LogLock`); ``None``: the log takes its own, held while it is open. Either way
            one process writes a log at a time.
        sort_run: The run is one sort's (``mearm sort``, trial ``null``): refuse a file
            that holds an experiment's trials, which ``mearm experiment`` could then no
            longer resume.

    Raises:
        RunLogLockedError: another process is writing the log (it names the process).
        RunLogError: ``exclusive`` and the file exists; the file ends in a torn line
            (:func:`~mearm.runlog.set_aside_torn_end` repairs that); it is not a regular
            file; it cannot be opened; ``sort_run`` and it is an experiment's.
    """

    def __init__(
        self,
        path: str | Path,
        *,
        exclusive: bool = False,
        fsync: bool = True,
        lock: LogLock | None = None,
        sort_run: bool = False,
    ):
        self.path = Path(path)
        self._fsync = fsync
        self._trial: _TrialBuilder | None = None
        self.records_written = 0
        first = b""
        if self.path.exists():
            if exclusive:
                raise RunLogError(self.path, "exists (exclusive=True refuses to append)")
            if not self.path.is_file():
                raise RunLogError(
                    self.path, "is not a regular file (a folder, device or pipe); give a file path"
                )
            first = self._refuse_torn_file()
        folder = existing_ancestor(self.path)
        if not folder.is_dir():  # (mkdir would say the file 'exists', as if it were the log)
            raise RunLogError(self.path, f"cannot write: {folder} is a file, not a folder")
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            # "a" never truncates: what is there stays; "x" refuses a file made meanwhile.
            # unbuffered: a record is written whole or cut back (:meth:`_append`), and
            # closing has nothing left to write (a full disk failed a close with it)
            self._file = self.path.open("xb" if exclusive else "ab", buffering=0)
        except FileExistsError:
            raise RunLogError(self.path, "exists (exclusive=True refuses to append)") from None
        except OSError as exc:
            # strerror: the reason, not the folder mkdir stopped at with its errno
            raise RunLogError(
                self.path, f"cannot open for writing ({exc.strerror or exc})"
            ) from None
        if lock is None:
            try:
                lock_file(self._file, self.path)  # held until the file is closed
            except BaseException:
                self._file.close()
                raise
        trial = _trial_of(first)
        if sort_run and trial is not None:  # (after the lock: a running one is named first)
            self._file.close()
            raise RunLogError(
                self.path,
                f"is an experiment's log (its first record is trial {trial}'s header): a "
                "sort's run appended to it would leave mearm experiment unable to resume "
                "it; give the sort its own --log",
            )

    def _refuse_torn_file(self) -> bytes:
        """Refuse a file to append to that ends mid-line, or that is no run log at all.

        Returns its first line (``b""``: an empty file).
        """
        try:
            with self.path.open("rb") as f:
                f.seek(0, os.SEEK_END)
                if f.tell() == 0:
                    return b""
                f.seek(-1, os.SEEK_END)
                last = f.read(1)
                f.seek(0)
                first = f.readline(_FIRST_LINE_MAX)
        except OSError as exc:
            raise RunLogError(self.path, f"cannot read: {exc}") from None
        if not _is_header(first):
            raise RunLogError(
                self.path,
                "is not a run log (its first line is no header record), so the run is not "
                "appended to it: give a new file or a run log's",
            )
        if last != b"\n":
            raise RunLogError(
                self.path,
                "ends in the middle of a line (a crash while writing?), so it cannot be "
                "appended to; read it with mearm.analyze and write the new run to another "
                "file (mearm experiment sets the torn line aside when it resumes a log)",
            )
        return first

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
            started = datetime.now(UTC)
        if isinstance(started, datetime):
            started = started.isoformat()
        fields = {
            "format": FORMAT_VERSION,
            "mearm_version": mearm_version(),
            "started": started,
            "config": config,
            "versions": library_versions(),
            "trial": trial,
            "seed": seed,
            **extra,
        }
        with _ctrl_c_after():  # the header in the file is the trial the writer is in
            record = self._write("header", fields)
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

    def fault(
        self, reason: str, last_joints: Mapping[str, float] | None = None, **extra: Any
    ) -> FaultRecord:
        """Write a fault: the reason the run stopped and the last joint values.

        Args:
            reason: Why the run stopped.
            last_joints: Every joint of the chain by name [deg or cm], or ``None`` when
                no pose was confirmed.
            **extra: More fields (``trial``, or anything to keep with the fault).
        """
        fields = {"reason": reason, "last_joints": last_joints, **extra}
        return self._write_in_trial("fault", fields)  # type: ignore[return-value]

    def summary(self, **fields: Any) -> SummaryRecord:
        """Close the trial with its summary.

        Fields not given are computed from the records written since the header:
        ``sorted`` (successful places per colour), ``failures`` (confirmed routes
        whose ``success`` is false), ``skipped``, ``routes``, ``mean_iterations``,
        ``mean_final_error_cm`` (the solver's), ``motion_s`` (sum over routes; a sort
        gives its whole run's, the figure it prints) and ``ok`` (no fault was written).
        """
        trial = self._current("summary")
        routes = trial.routes
        computed: dict[str, Any] = {
            "sorted": {
                c: sum(1 for r in routes if r.step == "place" and r.success and r.color == c)
                for c in dict.fromkeys(r.color for r in routes)
            },
            "failures": sum(1 for r in routes if r.confirmed and not r.success),
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
        record = self._validate(kind, fields)
        why = trial.check(record)
        if why is not None:
            raise RunLogError(self.path, why)
        with _ctrl_c_after():  # the file and the trial's state agree, whatever Ctrl-C does
            self._append(record)
            trial.add(record)
        return record

    def _write(self, kind: str, fields: Mapping[str, Any]) -> Record:
        record = self._validate(kind, fields)
        self._append(record)
        return record

    def _validate(self, kind: str, fields: Mapping[str, Any]) -> Record:
        if self.closed:
            raise RunLogError(self.path, f"cannot write a {kind} record: the log is closed")
        try:
            text = json.dumps({"type": kind, **_plain(fields)}, allow_nan=False)
        except (TypeError, ValueError) as exc:
            why = f"{kind} record cannot be written as JSON: {exc}"
            raise RunLogError(self.path, why) from None
        try:
            return RECORD_TYPES[kind].model_validate_json(text)  # type: ignore[return-value]
        except ValidationError as exc:
            raise RunLogError(self.path, _validation_reason(kind, exc)) from None

    def _append(self, record: Record) -> None:
        """Write one record's line whole, or none of it.

        A write the disk refuses part way (full) is cut back to the last whole record,
        so the file stays a run log that can be read and appended to, and is said as a
        :class:`RunLogError` (the sort stops on it as on a fault).
        """
        line = memoryview(record.model_dump_json().encode("utf-8") + b"\n")
        fd = self._file.fileno()
        try:
            end = os.fstat(fd).st_size
        except OSError as exc:
            raise RunLogError(self.path, f"cannot write: {exc}") from None
        try:
            while line:
                line = line[self._file.write(line) or 0 :]
            if self._fsync:
                os.fsync(fd)
        except OSError as exc:
            with contextlib.suppress(OSError):  # (cutting back takes no space)
                os.ftruncate(fd, end)
            raise RunLogError(self.path, f"cannot write: {exc.strerror or exc}") from None
        self.records_written += 1


@contextlib.contextmanager
def _ctrl_c_after() -> Iterator[None]:
    """Hold back Ctrl-C until the block is done (then it takes effect as it would have).

    A record written to the file but not yet to the trial's state would let a fault
    record follow a trial's summary (Ctrl-C between the two). Only the main thread runs
    Python's signal handlers, so only there is there anything to hold back.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: held.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if held:
            signal.raise_signal(signal.SIGINT)
