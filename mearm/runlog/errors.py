"""Errors of the run log: a file that cannot be opened, written in order, or read."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from mearm.errors import MearmError


class RunLogError(MearmError):
    """A run log cannot be opened, appended to or written in the order asked.

    Attributes:
        path: The log file.
    """

    def __init__(self, path: object, message: str):
        self.path = str(path)
        super().__init__(f"{self.path}: {message}")


class RepeatedTrialError(RunLogError):
    """A trial number is complete more than once in one log: two runs pooled in one file.

    Attributes:
        path: The log file.
        lines: Per repeated trial number, the header lines of its complete attempts.
    """

    def __init__(self, path: object, lines: Mapping[int, Sequence[int]]):
        self.lines = {k: tuple(v) for k, v in lines.items()}
        numbers = sorted(self.lines)
        shown = ", ".join(map(str, numbers[:10])) + (" …" if len(numbers) > 10 else "")
        first = numbers[0]
        where = " and ".join(map(str, self.lines[first]))
        super().__init__(
            path,
            f"trial{'s' if len(numbers) > 1 else ''} {shown} "
            f"{'are' if len(numbers) > 1 else 'is'} complete more than once (trial {first} "
            f"at lines {where}): the file holds two runs of the same trials; analyse "
            "each run's log on its own",
        )


class RunLogFormatError(RunLogError):
    """One line of a run log is not a valid record (torn, not JSON, a field missing or wrong).

    :func:`mearm.runlog.read_runlog` returns this (it does not raise it unless asked to)
    together with every record before the bad line.

    Attributes:
        path: The log file.
        line: The bad line's number, counting from 1.
        reason: What is wrong with it.
        text: The start of the bad line (at most 80 characters).
    """

    def __init__(self, path: object, line: int, reason: str, text: str = ""):
        self.line = int(line)
        self.reason = reason
        self.text = text
        super().__init__(path, f"line {self.line}: {reason}")


class RunLogLockedError(RunLogError):
    """Another process is writing the run log.

    Attributes:
        path: The log file.
        pid: The holder's process id, or ``None`` when it cannot be found.
        command: The holder's command line, or ``""``.
    """

    def __init__(self, path: object, pid: int | None, command: str):
        self.pid = pid
        self.command = command
        if pid is None:
            who = "another process"
        else:
            who = f"process {pid}" + (f" ({command})" if command else "")
        super().__init__(
            path,
            f"is being written by {who}: one run writes a log at a time; wait for it to "
            "end, or give this run another --log",
        )
