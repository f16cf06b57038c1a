"""The run log: one JSON object per line (JSON Lines), one line per event.

The sort (``python -m mearm.sort --log run.jsonl``) and the experiment runner
(``python -m mearm.experiment --log trials.jsonl``) write it through :class:`RunLog`;
``python -m mearm.analyze`` reads it through :func:`read_runlog`.

Layout (format 2). Every line is an object with a ``"type"``:

- ``header`` starts a *trial*: ``format``, ``mearm_version``, ``started`` (ISO 8601),
  ``config`` (``Config.model_dump(mode="json")``), ``versions`` (library versions),
  ``trial`` (int, or null for a lone sort run) and ``seed`` (int or null).
- ``route`` one PD-PIJ route (a pick or a place), see :class:`RouteRecord`; its
  ``color`` is a class name of ``config.task.classes``, its ``start_joints`` and
  ``end_joints`` map every joint of ``config.arm.joints`` by name to its value (deg for a
  revolute joint, cm for a prismatic one).
- ``skip`` an object that was not sorted, and why.
- ``fault`` a camera / servo failure or Ctrl-C, with the last joint values by name
  (``last_joints``, or null).
- ``summary`` closes the trial; ``sorted`` counts placed objects per class name; in the
  physical twin, ``twin_faults`` lists the injected faults (``twin.faults``) that struck,
  including one the sort never noticed (its ``ok`` is then true: the run ran its course).

**Formats.** A header's ``format`` is the format of its trial's lines. This mearm
writes format 2 and reads formats 1 and 2: a format-1 trial (joint values as lists
``start_joints_deg`` …, the ``robot:`` config layout) is converted line by line into the
format-2 records (:mod:`mearm.runlog.format1`): joints named ``joint1``..``joint4`` and the
header's config migrated by :func:`mearm.config.migrate.migrate_v1_config`, so
:meth:`HeaderRecord.load_config` works on old logs too. Appending to a format-1 file
starts a format-2 trial with its own header.

**One header per trial.** A file holds a sequence of trials; each is a header, its
records and (unless the run crashed) one summary. Every record after a header carries
that header's ``trial`` number, so each trial is self-contained: its header alone says
how it was configured and seeded. A sort run is one trial with ``trial: null``; the
experiment runner writes trials 0..N-1, one header each, into one file.

**Appending.** Opening an existing log appends to it (it is never truncated or
rewritten): what is there stays, and the new run starts with its own header.
``RunLog(path, exclusive=True)`` refuses an existing file instead. A file whose last line
is torn (a crash mid-write) is refused either way, since a record written after it would
be read as part of the broken line; :func:`set_aside_torn_end` moves such a line into a
side file first (:mod:`mearm.runlog.repair`). A path that is not a regular file (a
folder, a device) is refused.

**One writer.** A :class:`RunLog` holds an advisory ``flock`` on its file while it is
open (:mod:`mearm.runlog.lock`); a second writer, in this process or another, gets a
:class:`~mearm.runlog.errors.RunLogLockedError` naming the holder's pid and command. A
command that reads a log before appending to it takes a :class:`LogLock` first and hands
it to the :class:`RunLog`.

**Repeated trial numbers.** The experiment runner runs a trial again under the same
number when its last attempt was cut off before its summary, stopped by Ctrl-C
(:attr:`Trial.interrupted`) or by its recording (:attr:`Trial.recording_stopped`).
Reading keeps every attempt; :meth:`RunLogContents.latest` keeps the finished one (or,
if none is, the last complete one, else the last) and refuses a number that is finished
twice (:class:`RepeatedTrialError`): that is two runs in one file, which ``mearm
analyze`` will not pool.

**Durability.** Each record is written as one ``write`` of one line, then flushed and
``fsync``-ed, so a crash loses at most the record being written.

**Reading.** :func:`read_runlog` returns every valid record up to the first bad line
(torn, not JSON, not UTF-8, longer than :data:`MAX_LINE_BYTES`, unknown type or format,
a field missing or of the wrong type, a number out of range — lengths beyond
±:data:`~mearm.runlog.records.MAX_RECORD_CM`, joint values beyond
±:data:`~mearm.runlog.records.MAX_RECORD_JOINT`, times beyond
:data:`~mearm.runlog.records.MAX_RECORD_S` —, joint names other than the header's arm's,
records out of order) and a :class:`~mearm.runlog.errors.RunLogFormatError` naming that
line and why.
"""

from mearm.runlog.errors import RunLogLockedError
from mearm.runlog.format1 import upgrade_v1_record
from mearm.runlog.lock import LogLock
from mearm.runlog.reader import (
    MAX_LINE_BYTES,
    RepeatedTrialError,
    RunLogContents,
    Trial,
    read_runlog,
)
from mearm.runlog.records import (
    ERROR_CONSISTENCY_CM,
    FORMAT_VERSION,
    READABLE_FORMATS,
    RECORD_TYPES,
    VERSIONED_PACKAGES,
    FaultRecord,
    HeaderRecord,
    JointValues,
    Record,
    RouteRecord,
    SkipRecord,
    SummaryRecord,
    Vec3,
    library_versions,
    mearm_version,
    parse_record,
)
from mearm.runlog.repair import TornEnd, end_line, find_torn_end, set_aside_torn_end
from mearm.runlog.writer import RunLog

__all__ = [
    "ERROR_CONSISTENCY_CM",
    "FORMAT_VERSION",
    "MAX_LINE_BYTES",
    "READABLE_FORMATS",
    "RECORD_TYPES",
    "VERSIONED_PACKAGES",
    "FaultRecord",
    "HeaderRecord",
    "JointValues",
    "LogLock",
    "Record",
    "RepeatedTrialError",
    "RouteRecord",
    "RunLog",
    "RunLogContents",
    "RunLogLockedError",
    "SkipRecord",
    "SummaryRecord",
    "TornEnd",
    "Trial",
    "Vec3",
    "end_line",
    "find_torn_end",
    "library_versions",
    "mearm_version",
    "parse_record",
    "read_runlog",
    "set_aside_torn_end",
    "upgrade_v1_record",
]
