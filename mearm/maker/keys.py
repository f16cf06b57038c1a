"""Single keystrokes from the terminal, for the interactive maker commands.

:class:`KeyReader` puts the terminal in cbreak mode (each key arrives at once, nothing
is echoed; Ctrl-C still raises :class:`KeyboardInterrupt`) and restores it on exit, even
after an exception. :meth:`KeyReader.read` returns a key's name: the character itself
(``"a"``, ``"+"``, ``"Q"``), or ``up``, ``down``, ``left``, ``right``, ``enter``,
``space``, ``tab``, ``backspace``, ``esc`` for the special keys (the arrow keys'
``ESC [ A`` … sequences, in both the normal and the application cursor mode).

Plain ``termios``/``tty``: no library is needed for one key at a time.
"""

from __future__ import annotations

import os
import select
import sys
import termios
import tty
from types import TracebackType
from typing import TextIO

from mearm.errors import MearmError

#: Escape sequences of the special keys → their names.
SEQUENCES = {
    b"\x1b[A": "up",
    b"\x1b[B": "down",
    b"\x1b[C": "right",
    b"\x1b[D": "left",
    b"\x1bOA": "up",
    b"\x1bOB": "down",
    b"\x1bOC": "right",
    b"\x1bOD": "left",
}
#: Single control bytes → their names.
CONTROLS = {
    b"\r": "enter",
    b"\n": "enter",
    b" ": "space",
    b"\t": "tab",
    b"\x7f": "backspace",
    b"\x08": "backspace",
}
#: How long the rest of an escape sequence may take to arrive [s].
_ESCAPE_WAIT_S = 0.05


class NoTerminalError(MearmError):
    """The command is interactive and its standard input or output is not a terminal."""


def require_terminal(what: str, stdin: TextIO | None = None, stdout: TextIO | None = None) -> None:
    """Refuse to start an interactive session without a terminal.

    Args:
        what: What needs it, for the message (``"calibrate-servos"``).
        stdin: Standard input (default ``sys.stdin``).
        stdout: Standard output (default ``sys.stdout``).

    Raises:
        NoTerminalError: standard input or output is not a terminal (or is closed).
    """
    for name, stream in (("input", stdin or sys.stdin), ("output", stdout or sys.stdout)):
        try:
            ok = stream is not None and stream.isatty()
        except ValueError:  # closed
            ok = False
        if not ok:
            raise NoTerminalError(
                f"{what} is interactive and needs a terminal: its standard {name} is not "
                "one; run it in a terminal window (or over ssh -t)"
            )


class KeyReader:
    """Keys from a terminal in cbreak mode; a context manager that restores the terminal.

    Args:
        fd: The terminal's file descriptor (default: standard input).
    """

    def __init__(self, fd: int | None = None):
        self.fd = sys.stdin.fileno() if fd is None else fd
        self._saved: list[int | list[bytes | int]] | None = None
        self._pending = b""

    def __enter__(self) -> KeyReader:
        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd, termios.TCSANOW)
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._saved is not None:
            termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)
            self._saved = None

    def _read_byte(self, timeout_s: float | None) -> bytes:
        if self._pending:
            byte, self._pending = self._pending[:1], self._pending[1:]
            return byte
        if timeout_s is not None:
            ready, _, _ = select.select([self.fd], [], [], timeout_s)
            if not ready:
                return b""
        data = os.read(self.fd, 64)
        if not data:
            raise EOFError("the terminal closed")
        self._pending = data[1:]
        return data[:1]

    def read(self) -> str:
        """Block until a key is pressed; return its name (see the module docstring).

        Raises:
            EOFError: the terminal closed.
            KeyboardInterrupt: Ctrl-C.
        """
        byte = self._read_byte(None)
        if byte == b"\x1b":
            seq = byte
            for _ in range(2):
                nxt = self._read_byte(_ESCAPE_WAIT_S)
                if not nxt:
                    break
                seq += nxt
            if seq in SEQUENCES:
                return SEQUENCES[seq]
            self._pending = seq[1:] + self._pending
            return "esc"
        if byte in CONTROLS:
            return CONTROLS[byte]
        if byte == b"\x03":  # ISIG off (not in cbreak mode, but a raw terminal may send it)
            raise KeyboardInterrupt
        if byte == b"\x04":
            raise EOFError("end of input (Ctrl-D)")
        return byte.decode("utf-8", "replace")

    def confirm(self, question: str, out: TextIO | None = None) -> bool:
        """Ask a y/N question; only ``y`` or ``Y`` answers yes."""
        stream = out or sys.stdout
        stream.write(f"{question} [y/N] ")
        stream.flush()
        key = self.read()
        yes = key in ("y", "Y")
        stream.write(("yes" if yes else "no") + "\n")
        stream.flush()
        return yes
