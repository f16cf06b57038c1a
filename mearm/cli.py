"""Shared plumbing for the command-line tools.

Every CLI exits 2 on bad input with a single line on stderr (never a traceback), and
130 on Ctrl-C. Anything unexpected is exit 1 with one line that says where the traceback
was written (``--debug`` prints it instead).
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import logging
import os
import re
import sys
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, Protocol, TextIO, TypeVar, cast

from mearm import interrupts
from mearm.errors import ConfigError, MearmError
from mearm.fileio import existing_ancestor  # noqa: F401  (re-exported: the commands import it here)

if TYPE_CHECKING:  # only the pools' callers import concurrent.futures (7 ms)
    from concurrent.futures import Executor, Future

    from mearm.config import Config

_T = TypeVar("_T")
_N = TypeVar("_N", int, float)

EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
#: Standard output's reader went away (``mearm detect | head -1``): what a program killed
#: by SIGPIPE exits with in a shell, 128 + 13.
EXIT_OUTPUT_CLOSED = 141


class ArgumentParser(argparse.ArgumentParser):
    """An ``argparse`` parser whose errors are one line on stderr and exit 2.

    It also accepts option values that start with a minus sign, such as
    ``--target -10.99,49.70,12.76`` (plain argparse takes that for an option).
    """

    def __init__(self, *args: Any, **kwargs: Any):
        if not args:  # the command as typed (python -m mearm.envs.replay), not replay.py
            kwargs.setdefault("prog", _program_name())
        super().__init__(*args, **kwargs)
        self.add_argument(
            "--debug",
            action="store_true",
            help="print the library's log (retried frames, warnings) as it comes, and "
            "on an unexpected error the traceback (default: one line)",
        )

    def error(self, message: str) -> NoReturn:  # noqa: D102
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {one_line(message)}\n")

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action:
        """As argparse's, but a path (``type=Path``) may not be empty.

        ``Path("")`` is ``.``: ``--log=`` or ``--scene ""`` was refused as the folder
        ``.`` (or read as the current folder), naming a path nobody typed.
        """
        if kwargs.get("type") is Path:
            kwargs["type"] = non_empty_path
        return super().add_argument(*args, **kwargs)

    def parse_known_args(  # type: ignore[override]  # noqa: D102
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        argv = list(sys.argv[1:] if args is None else args)
        return super().parse_known_args(self._attach_negative_values(argv), namespace)

    def _attach_negative_values(self, argv: list[str]) -> list[str]:
        """``--opt -1.5,2`` → ``--opt=-1.5,2`` for options that take a value."""
        out: list[str] = []
        i = 0
        while i < len(argv):
            action = self._option_string_actions.get(argv[i])
            nxt = argv[i + 1] if i + 1 < len(argv) else ""
            if action is not None and action.nargs != 0 and re.match(r"^-[\d.]", nxt):
                out.append(f"{argv[i]}={nxt}")
                i += 2
            else:
                out.append(argv[i])
                i += 1
        return out


def non_empty_path(text: str) -> Path:
    """An argument's path; the empty text is refused (``Path("")`` would be ``.``)."""
    if not text:
        raise argparse.ArgumentTypeError("the value is empty: give a path")
    return Path(text)


#: What a number typed on the command line may be made of, for the errors that refuse one.
PLAIN_DECIMAL = "ASCII digits 0-9, sign, point, exponent; no '_'"
PLAIN_INTEGER = "ASCII digits 0-9 and sign; no '_'"


def check_plain_number(text: str, must_be: str) -> None:
    """Refuse number text that Python reads but nobody types as a number.

    ``float`` and ``int`` also read ``1_20`` and other scripts' digits (Arabic-Indic
    ``١٢٠``, fullwidth ``１２０``) as 120: an option typed so is refused, not read as a
    number nobody wrote. Every numeric argparse type here checks its text with this
    first, so every command reads numbers alike.

    Args:
        text: The option's value as typed.
        must_be: What it must be and what is allowed, the error's start, e.g.
            ``f"--joints must be plain decimal numbers ({PLAIN_DECIMAL}), comma-separated"``.

    Raises:
        argparse.ArgumentTypeError: ``text`` holds a non-ASCII character or an ``_``.
    """
    if not text.isascii() or "_" in text:
        raise argparse.ArgumentTypeError(f"{must_be}, got {text[:60]!r}")


def plain_int(text: str) -> int:
    """An argparse type for an integer option (a count, an index, a port, a resolution).

    ``type=int`` would read ``1_20`` and other scripts' digits as 120
    (:func:`check_plain_number`) and say only ``invalid int value`` of the rest. The
    option's range is its own check, after parsing.
    """
    return _read_plain(text, int, f"must be a plain integer ({PLAIN_INTEGER})")


def plain_float(text: str) -> float:
    """An argparse type for a number option (a size, a share, a noise level).

    As :func:`plain_int`, for ``type=float``. ``nan`` and ``inf`` are read as ``float``
    reads them: each option's range check refuses them in its own words.
    """
    return _read_plain(text, float, f"must be a plain decimal number ({PLAIN_DECIMAL})")


def _read_plain(text: str, kind: Callable[[str], _N], must_be: str) -> _N:
    """``kind(text)`` of a plain number; ``must_be`` starts the error of anything else."""
    check_plain_number(text, must_be)
    try:
        return kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{must_be}, got {text[:40]!r}") from None


def float_list(n: int | None = None, name: str = "values") -> Callable[[str], list[float]]:
    """An argparse type for comma-separated numbers, e.g. ``120,93,-132``."""

    def parse(text: str) -> list[float]:
        check_plain_number(
            text, f"{name} must be plain decimal numbers ({PLAIN_DECIMAL}), comma-separated"
        )
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"{name} must be comma-separated numbers, got {text!r}"
            ) from None
        if n is not None and len(values) != n:
            raise argparse.ArgumentTypeError(
                f"{name} needs {n} numbers, got {len(values)}: {text!r}"
            )
        if not all(v == v and abs(v) != float("inf") for v in values):
            raise argparse.ArgumentTypeError(f"{name} must be finite numbers, got {text!r}")
        return values

    return parse


def positive_number(lo: float, hi: float, unit: str = "") -> Callable[[str], float]:
    """An argparse type: a positive finite number in [lo, hi] (e.g. a step, a rate).

    A sweep in steps of 1e-300 would never end, nor one at 1e9 frames per second.
    """
    suffix = f" {unit}" if unit else ""

    def parse(text: str) -> float:
        check_plain_number(text, f"must be a plain decimal number ({PLAIN_DECIMAL})")
        try:
            value = float(text)
        except ValueError:
            value = float("nan")
        if not value > 0 or value == float("inf"):
            raise argparse.ArgumentTypeError(
                f"must be a positive number{suffix}, got {text[:40]!r}"
            )
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(
                f"must be in [{lo:g}, {hi:g}]{suffix}, got {text[:40]!r}"
            )
        return value

    return parse


def seed_value(text: str) -> int:
    """An argparse type for a random seed: an integer in [0, 2³²−1] (what NumPy takes)."""
    from mearm.config.base import MAX_SEED

    check_plain_number(text, f"a seed is a plain integer ({PLAIN_INTEGER})")
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a seed is an integer, got {text[:40]!r}") from None
    if not 0 <= value <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"the seed must be in [0, {MAX_SEED}], got {text[:40]}")
    return value


def worker_count(text: str) -> int:
    """An argparse type for ``--jobs``: a number of worker processes, an integer ≥ 1."""
    check_plain_number(text, f"a number of workers is a plain integer ({PLAIN_INTEGER})")
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a number of workers is an integer ≥ 1, got {text[:40]!r}"
        ) from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"a number of workers must be ≥ 1, got {value}")
    return value


class ArgumentContainer(Protocol):
    """What takes arguments: an ``argparse`` parser or an argument group of one."""

    def add_argument(self, *args: Any, **kwargs: Any) -> argparse.Action: ...  # noqa: D102


def config_path_value(text: str) -> Path:
    """``--config``'s value as a path that keeps what the user typed a path.

    ``Path`` drops a leading ``./`` and a trailing ``/``, which would turn ``./sim`` or
    ``sim/`` (a file or folder here) into the bare name of a shipped config
    (:func:`mearm.config.files.resolve_config_path`). Such a value is kept a path, made
    absolute, so the reader says what is wrong with the file it names.
    """
    if not text.strip():
        raise argparse.ArgumentTypeError(
            "the value is empty: give a config file's path or the name of a shipped config "
            "(mearm --help lists them)"
        )
    path = Path(text)
    if any(sep in text for sep in "/\\") and len(path.parts) == 1 and not path.is_absolute():
        return Path.cwd() / path
    return path


def add_config_argument(parser: ArgumentContainer, default: str | None = None) -> None:
    """Add ``--config PATH`` and ``--set dotted.key=value`` to a parser or group.

    Args:
        parser: The parser or group.
        default: The shipped config a command uses without ``--config`` (``None``: the
            built-in simulated rig, as ``sim``).
    """
    shown = "the built-in simulated rig, as sim" if default is None else default
    parser.add_argument(
        "--config",
        type=config_path_value,
        default=None if default is None else Path(default),
        help="YAML config file, or the name of one shipped with mearm (sim, lab, virtual_uno, "
        f"...: mearm --help lists them; default: {shown})",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override one config value before validation, e.g. "
        "--set arm.joints.shoulder.limits.max=140 (repeatable)",
    )


def config_from_args(args: argparse.Namespace) -> Config:
    """Load the config named by ``--config`` with every ``--set`` applied.

    Its errors name the flags (``--set: KEY: …``), not the Python call's arguments.
    """
    from mearm.config import load_config  # noqa: PLC0415  (not for --help or --version)

    overrides = getattr(args, "set", None) or ()
    return load_config(args.config, overrides, path_as="--config", overrides_as="--set")


def check_closed_form(config: Config) -> None:
    """Refuse, naming the config as its other errors do, an ``arm.closed_form`` it cannot use.

    The name is valid data, so the config loads (:mod:`mearm.config` cannot build the
    closed form: :mod:`mearm.kinematics` imports it); every solver of the arm builds it
    (:func:`~mearm.kinematics.closed_form_for`) and stops on an unknown name or an arm
    without the structure the formula needs. Called first by what solves or describes a
    config (``mearm ik``, ``mearm urdf``, a sort's config check), so the line says where
    the arm came from.

    Raises:
        ConfigError: the closed form's problem, with the config's source, led by the
            arm's unit hints (:func:`~mearm.config.loader.unit_hints`: an alpha in
            radians is the likely cause of a structure the formula does not know).
    """
    from mearm.config.files import config_source  # noqa: PLC0415  (not for --help)
    from mearm.config.loader import unit_hints  # noqa: PLC0415
    from mearm.kinematics import closed_form_for  # noqa: PLC0415
    from mearm.kinematics.errors import ModelError  # noqa: PLC0415

    try:
        closed_form_for(config.arm)
    except ModelError as exc:
        hints = unit_hints(config.model_dump(mode="json"))
        raise ConfigError(config_source(config), [*hints, str(exc)]) from None


def backup_written(path: Path, backup: Path) -> str:
    """The line naming the backup of ``path`` once kept: ``wrote BACKUP (the old PATH)``.

    Every file a command writes is named on stdout, a backup of the file it replaces
    (:func:`mearm.fileio.keep_backup`: ``PATH.bak``, or ``PATH.bak.N`` beside an earlier
    one) before the file that replaced it.
    """
    return f"wrote {backup} (the old {path})"


def backup_existing(path: Path, new_text: str | None = None) -> None:
    """Keep an existing regular file's contents as a backup before it is replaced.

    With ``new_text``, only when that changes the file: rewriting the same bytes loses
    nothing. The backup never replaces an earlier one (:func:`mearm.fileio.keep_backup`)
    and is named on stdout once written (:func:`backup_written`), as every file a command
    writes is.

    Raises:
        OSError: the backup could not be written (the file is as it was).
    """
    from mearm.fileio import keep_backup

    backup = keep_backup(path, new_text)
    if backup is not None:
        print(backup_written(path, backup), flush=True)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` in one step (:func:`mearm.fileio.write_atomic`).

    The folder is made if missing; a symbolic link is written through; on any failure
    or signal the old file stays as it was and no temporary file is left.

    Raises:
        MearmError: the directory cannot be made or the file written.
    """
    from mearm.fileio import write_atomic

    try:
        write_atomic(path, text)
    except OSError as exc:
        # strerror: the reason, not the temporary file's name the error carries
        raise MearmError(f"cannot write {path}: {exc.strerror or exc}") from None


def check_output_file(path: Path, flag: str) -> None:
    """Refuse, before any work, an output file that could not be written.

    A folder, a device or pipe, a path under a regular file, a folder that is not
    writable: each is one :class:`MearmError` naming ``flag`` and the path, so a command
    refuses it before it measures or sorts (not with a traceback after). Nothing is
    created here.

    Raises:
        MearmError: the path cannot be written as a file.
    """
    if path.is_dir():
        raise MearmError(
            f"{flag} {path}: exists and is not a regular file (a folder); give a file path"
        )
    if path.exists() and not path.is_file():
        raise MearmError(f"{flag} {path}: exists and is not a regular file (a device or pipe)")
    _check_writable_folder(path, flag)


def counted(n: int, what: str) -> str:
    """``1 trial``, ``2 trials``: ``n`` and ``what``, plural unless ``n`` is 1."""
    return f"{n} {what}{'' if n == 1 else 's'}"


#: Suffixes of pictures the commands read (frames, boards, marker sheets): a YAML file
#: written under one is taken for a picture by the next command that reads a folder.
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".gif")


def check_yaml_output(path: Path, flag: str) -> None:
    """:func:`check_output_file` for a YAML output, then :func:`refuse_picture_name`."""
    check_output_file(path, flag)
    refuse_picture_name(path, flag)


def refuse_picture_name(path: Path, flag: str) -> None:
    """Refuse a YAML output named as a picture (after a command's more specific checks).

    ``calibrate-intrinsics --images boards --out boards/intrinsics.png`` wrote YAML there,
    exit 0, and the next run over that folder stopped on it ("not an image").

    Raises:
        MearmError: ``path`` ends in a picture's suffix (:data:`IMAGE_SUFFIXES`).
    """
    if path.suffix.lower() in IMAGE_SUFFIXES:
        raise MearmError(
            f"{flag} {path}: names a picture ({path.suffix}); this is a YAML file: give a "
            "name ending .yaml"
        )


def refuse_to_replace(path: Path | None, flag: str, force: bool) -> None:  # noqa: FBT001
    """Refuse, before any work, an output that exists unless ``--force`` was given.

    A second run, or a name shared with the user's own file, must not replace what is
    there silently; the project's writers all say so in the same words.

    Raises:
        MearmError: ``path`` exists and ``force`` is false.
    """
    if path is not None and not force and (path.exists() or path.is_symlink()):
        raise MearmError(f"{flag} {path}: exists; pass --force to replace it")


def refuse_own_inputs(
    outputs: Sequence[tuple[str, Path | None]], inputs: Sequence[tuple[str, Path | None]]
) -> None:
    """Refuse an output that is one of the run's inputs (by any name), even with --force.

    A file this run reads is not the place for what it writes (an image would become
    YAML, the intrinsics a pose). Files are compared by identity
    (:func:`mearm.fileio.file_identity`), so ``./a`` and a link are caught too.

    Raises:
        MearmError: an output names the same file as an input.
    """
    from mearm.fileio import file_identity  # noqa: PLC0415  (the commands that write)

    seen = [(flag, path, file_identity(path)) for flag, path in inputs if path is not None]
    for out_flag, out in outputs:
        if out is None:
            continue
        here = file_identity(out)
        for in_flag, path, ident in seen:
            if here is not None and here == ident:
                raise MearmError(
                    f"{out_flag} {out}: is the {in_flag} file {path}, one of this run's "
                    "inputs: write elsewhere"
                )


def check_output_folder(path: Path, flag: str) -> None:
    """As :func:`check_output_file`, for an output folder (missing folders are made).

    Raises:
        MearmError: the path exists and is not a folder, lies under a regular file, or
            its nearest existing folder is not writable.
    """
    if path.exists() and not path.is_dir():
        raise MearmError(f"{flag} {path}: exists and is not a folder")
    if not path.exists():
        _check_writable_folder(path, flag)
    elif not os.access(path, os.W_OK | os.X_OK):
        raise MearmError(f"{flag} {path}: the folder is not writable")


def _check_writable_folder(path: Path, flag: str) -> None:
    """Refuse ``path`` unless a file can be made in its nearest existing folder.

    The folder's permissions first, then a file made there and removed at once: the
    permissions pass for root everywhere, and a read-only mount or ``/proc`` refuses only
    the write (found here, not after the run that was to be saved).
    """
    folder = existing_ancestor(path)
    if not folder.is_dir():
        raise MearmError(f"{flag} {path}: cannot write: {folder} is a file, not a folder")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise MearmError(f"{flag} {path}: cannot write: the folder {folder} is not writable")
    import tempfile  # noqa: PLC0415  (only a command that writes a file)

    try:
        with tempfile.TemporaryFile(dir=folder, prefix=".mearm-probe-"):
            pass
    except OSError as exc:
        raise MearmError(
            f"{flag} {path}: cannot write: the folder {folder} is not writable: a new file "
            f"there failed ({exc.strerror or exc})"
        ) from None


def extra_missing(module: str, extra: str) -> ModuleNotFoundError:
    """``module`` (an extra's) is not installed: the error to raise, or exit 2 for a command.

    Called where a package would import ``module`` at its top: before :func:`run` can say
    so, the import's traceback was all a ``python -m mearm.…`` user saw. When the program
    running is one of mearm's modules (``python -m mearm.envs.replay``: ``sys.argv[0]`` is
    ``-m`` while it is located; ``python -m mearm.learn.bc``: its ``__main__``), one line on
    stderr and exit 2; in a script of one's own, the returned error names the extra.

    Raises:
        SystemExit: 2, once ``COMMAND: error: … pip install 'mearm[EXTRA]'`` is on stderr.
    """
    why = f"needs {module}, which is not installed: pip install 'mearm[{extra}]'"
    main = getattr(sys.modules.get("__main__"), "__spec__", None)
    argv = getattr(sys, "orig_argv", [])
    if sys.argv[:1] == ["-m"] or (main is not None and main.name.startswith("mearm.")):
        named = argv[argv.index("-m") + 1] if "-m" in argv[:-1] else "mearm"
        print(f"python -m {named}: error: {named} {why}", file=sys.stderr)
        raise SystemExit(EXIT_BAD_INPUT)
    return ModuleNotFoundError(f"mearm {why}", name=module.lower())


def invoked_as(module_command: str, subcommand: str | None = None) -> str:
    """A command's name as the user typed it, for its usage and error lines.

    ``mearm sort`` when run as a subcommand of the ``mearm`` command (which names itself
    so in ``sys.argv[0]``), else ``module_command`` (``python -m mearm.sort``). With
    ``subcommand``, another command to suggest, named the same way (``mearm analyze``
    after ``mearm experiment``, ``python -m mearm.analyze`` after ``python -m
    mearm.experiment``).
    """
    if sys.argv and sys.argv[0].startswith("mearm "):
        return sys.argv[0] if subcommand is None else f"mearm {subcommand}"
    return module_command


def _program_name() -> str:
    """The running command's name (:func:`invoked_as`).

    ``python -m mearm.ik`` for a module run with -m, ``mearm`` for ``python -m mearm``
    (its file is ``__main__.py``), else the script's name.
    """
    spec = getattr(sys.modules.get("__main__"), "__spec__", None)
    if spec is not None and spec.name == "mearm.__main__":
        return invoked_as("mearm")
    if spec is not None and spec.name:
        return invoked_as("python -m " + spec.name.removesuffix(".__main__"))
    return invoked_as(Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "mearm")


def say_on_stderr(line: str, module_command: str | None = None) -> None:
    """Print ``line`` (a warning, a note) on stderr, named as the running command's own.

    ``mearm detect: warning: …``, as its errors are named (:func:`run`): a line a
    command says beside its output, in a pipeline or a log, says which command said it.
    ``module_command``: the command's name run as a module (:func:`invoked_as`); without
    it, the running command's (:func:`_program_name`: for code more than one runs).
    """
    prog = _program_name() if module_command is None else invoked_as(module_command)
    print(f"{prog}: {line}", file=sys.stderr, flush=True)


def crash_log_path() -> Path:
    """Where unexpected errors' tracebacks are appended.

    ``$MEARM_STATE_DIR/crash.log``, else ``$XDG_STATE_HOME/mearm/crash.log``, else
    ``~/.local/state/mearm/crash.log``.
    """
    base = os.environ.get("MEARM_STATE_DIR")
    if base:
        return Path(base) / "crash.log"
    xdg = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(xdg) / "mearm" / "crash.log"


def _record_crash(prog: str, argv: Sequence[str]) -> str:
    """Append the current exception's traceback to the crash log; say where it went."""
    path = crash_log_path()
    stamp = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    entry = f"--- {stamp} {prog} {' '.join(argv)}\n{traceback.format_exc()}\n"
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # an argument may be a file name that is not UTF-8 (its bytes as surrogates)
        with path.open("a", encoding="utf-8", errors="backslashreplace") as fh:
            fh.write(entry)
    except OSError:
        return "traceback not saved: the crash log is not writable; --debug prints it"
    return f"traceback in {path}; --debug prints it"


#: An error line up to this long is said whole (:func:`_one_line`) [characters]: a dozen
#: rows of a terminal; a longer one quotes something huge.
LINE_MAX = 1000
#: Shortening a line, no run of characters without a space is cut below this [characters].
WORD_MIN = 40


def _middle_cut(text: str, size: int, head: int) -> str:
    """``text`` cut to ``size`` characters: its first ``head``, "…", and its end."""
    if len(text) <= size:
        return text
    return text[:head] + "…" + text[len(text) - (size - head - 1) :]


def _longest_word(text: str, room: int) -> int:
    """How long the runs without a space in ``text`` may stay for it to fit in ``room``.

    Each run longer is cut to that length; it is at least :data:`WORD_MIN`.
    """
    long = [len(w) for w in text.split(" ") if len(w) > WORD_MIN]
    rest = len(text) - sum(long)  # the shorter runs and the spaces

    def length(cap: int) -> int:
        return rest + sum(min(n, cap) for n in long)

    low, high = WORD_MIN, max(long, default=WORD_MIN)
    while low < high:  # the largest cap whose line fits (length grows with the cap)
        mid = (low + high + 1) // 2
        low, high = (mid, high) if length(mid) <= room else (low, mid - 1)
    return low


def _one_line(exc: BaseException) -> str:
    """An error's message as one line on stderr (:func:`one_line`)."""
    return one_line(str(exc))


def one_line(message: str) -> str:
    """An error message as one line on stderr, at most :data:`LINE_MAX` characters.

    A mearm message names what failed first and says what to do last (``… (mearm
    find-port lists the ports)``), so a line too long is never cut at its end. What
    makes a line that long is text it quotes (a path typed, the system's own message
    quoting it again, a value), not its prose: first the longest runs without a space
    are cut in their middle, evenly and no more than the line needs, each keeping its
    two ends (a path its first folders and its file's name) around "…"; a line still too
    long (a huge text of short words) keeps its first third and its end around "…".
    """
    text = " ".join(message.split())
    if len(text) <= LINE_MAX:
        return text
    cap = _longest_word(text, LINE_MAX)
    text = " ".join(_middle_cut(w, cap, cap // 2) for w in text.split(" "))
    return _middle_cut(text, LINE_MAX, LINE_MAX // 3)


def output_closed() -> bool:
    """Whether standard output's reader has gone: a pipe whose other end is closed."""
    import select  # noqa: PLC0415  (a broken pipe only)

    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):
        return False
    poll = select.poll()
    poll.register(fd, select.POLLOUT)
    return any(events & (select.POLLERR | select.POLLHUP) for _, events in poll.poll(0))


def _silence_output() -> None:
    """Send the rest of standard output nowhere (its reader has gone)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def echo_line(line: str, *, flush: bool = False) -> None:
    """Print one line of a long run's report (a sort's); the run outlives its reader.

    When standard output's reader goes (``mearm sort | head -3``), the rest of the lines go
    nowhere and the run goes on: the arm finishes its job as it would on a terminal (the
    run log keeps every route), and Ctrl-C still stops it. Standard output that cannot
    be written (a full disk, ``> /dev/full``) is no reason to leave the arm mid-job
    either: the rest goes nowhere, and :func:`run` says so as the run ends (exit 1).
    """
    global _OUTPUT_LOST
    try:
        print(line, flush=flush)  # flush: a line said before the run (its reader may be gone)
    except BrokenPipeError:
        if not output_closed():
            raise
        _silence_output()
    except _OutputUnwritable as exc:
        _OUTPUT_LOST = _OUTPUT_LOST or str(exc)
        _silence_output()


#: Why standard output could not be written while a long run went on (:func:`echo_line`).
_OUTPUT_LOST = ""


class _OutputUnwritable(Exception):
    """Standard output refused what was printed (a full disk, ``> /dev/full``, an I/O error)."""


class _CheckedOutput:
    """Standard output under :func:`run`, whose write errors are known as its own.

    An ``OSError`` from a ``print`` names no file, so the run could not tell a full disk
    under standard output from one under a file the command writes; and argparse drops
    write errors, so ``--help > /dev/full`` exited 0 having shown nothing. Here a write or
    flush that fails raises :class:`_OutputUnwritable` instead. A closed pipe
    (``BrokenPipeError``) passes as it is: :func:`echo_line` and :func:`run` end quietly on
    it. Everything else is the stream's own.
    """

    def __init__(self, stream: TextIO):
        self._stream = stream

    def write(self, text: str) -> int:  # noqa: D102
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _OutputUnwritable(exc.strerror or str(exc)) from exc

    def flush(self) -> None:  # noqa: D102
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise
        except OSError as exc:
            raise _OutputUnwritable(exc.strerror or str(exc)) from exc

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def _flush_or_drop_output() -> None:
    """Flush standard output as a run ends; what cannot be written goes nowhere.

    The interpreter flushes standard output again at exit, and output it cannot write
    then would add a traceback ("Exception ignored") and turn the exit status into 120.
    The run's own line on stderr has already said what went wrong.
    """
    if sys.stdout is None:
        return
    try:
        sys.stdout.flush()
    except (OSError, ValueError):  # ValueError: closed
        with contextlib.suppress(OSError, ValueError):  # no file descriptor to point away
            _silence_output()


def _debug_mode(args: Sequence[str], prog: str) -> bool:
    """Whether ``--debug`` (or ``MEARM_DEBUG=1``) is on; if so, the log is shown."""
    debug = "--debug" in args or os.environ.get("MEARM_DEBUG", "") not in ("", "0")
    if debug:  # the library's log (a retried frame, a dropped line, a twin's fault)
        _show_log(prog)
    else:  # GLFW's complaints without a display: the twin's camera says what to set
        warnings.filterwarnings("ignore", module=r"glfw(\.|$)")
        _say_injected_faults()
    return debug


def _say_injected_faults() -> None:
    """Say the twin's injected faults (``twin.faults``) on stderr, struck or never struck.

    A fault injected to test the sort's handling that never struck (timed after the run's
    end) tested nothing; its warning was a log record only ``--debug`` showed.
    """
    logger = logging.getLogger("mearm.sim.twin.twin_faults")
    if any(isinstance(h, _FaultLog) for h in logger.handlers):  # once a process
        return
    handler = _FaultLog()
    handler.setLevel(logging.WARNING)
    logger.addHandler(handler)
    logger.setLevel(min(logger.getEffectiveLevel(), logging.WARNING))


class _FaultLog(logging.Handler):
    """The handler that says the twin's injected faults (:func:`_say_injected_faults`).

    On standard error as it is when a record comes (a command run in-process, as the
    tests run them, has its own), not as it was when the handler was added.
    """

    def emit(self, record: logging.LogRecord) -> None:  # noqa: D102
        try:  # (named as the command running now is: in-process runs share the handler)
            print(f"{_program_name()}: warning: {self.format(record)}", file=sys.stderr, flush=True)
        except Exception:  # noqa: BLE001  (logging's own rule: a handler never raises)
            self.handleError(record)


def _show_log(prog: str) -> None:
    """Print the package's log records, warnings and up, on stderr as they come.

    Without ``--debug`` a command prints its own lines only: a retry that succeeded is no
    error, and a bad input stays one line.
    """
    logger = logging.getLogger("mearm")
    if any(isinstance(h, _DebugLog) for h in logger.handlers):  # once a process
        return
    handler = _DebugLog(sys.stderr)
    handler.setFormatter(logging.Formatter(f"{prog}: log: %(levelname)s %(name)s: %(message)s"))
    logger.addHandler(handler)
    logger.setLevel(min(logger.getEffectiveLevel(), logging.WARNING))


class _DebugLog(logging.StreamHandler):
    """The handler ``--debug`` adds (:func:`_show_log`)."""


def _unexpected(exc: Exception, prog: str, args: Sequence[str], *, debug: bool) -> int:
    """Say an exception no command caught, and the exit status (:func:`run`)."""
    if isinstance(exc, BrokenPipeError) and output_closed():
        _silence_output()
        return EXIT_OUTPUT_CLOSED
    bad = _bad_environment(exc)
    if bad is not None:
        print(f"{prog}: error: {bad}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if debug:
        traceback.print_exc()
        print(f"{prog}: unexpected error: {type(exc).__name__}", file=sys.stderr)
    else:
        where = _record_crash(prog, args)
        print(
            f"{prog}: unexpected error: {type(exc).__name__}: {_one_line(exc)} ({where})",
            file=sys.stderr,
        )
    return EXIT_FAILURE


def _bad_environment(exc: BaseException) -> str | None:
    """The line for an error a library raises on a bad environment variable, or ``None``.

    MuJoCo refuses an unknown ``MUJOCO_GL`` as it is first imported, with a plain
    ``RuntimeError`` that names the value but not what it takes: bad input, not a crash.
    """
    text = str(exc)
    if isinstance(exc, RuntimeError) and text.startswith(
        "invalid value for environment variable MUJOCO_GL"
    ):
        value = os.environ.get("MUJOCO_GL", "")
        return (
            f"MUJOCO_GL={value!r} is not a value MuJoCo takes: egl or osmesa render without "
            "a display, glfw (or glx) with one; unset it, or set MUJOCO_GL=egl"
        )
    return None


def run(main: Callable[[Sequence[str] | None], int], argv: Sequence[str] | None = None) -> NoReturn:
    """Run a CLI ``main`` under the one guard every command shares.

    :class:`MearmError` (bad input) → exit 2 (its ``exit_status``: 1 for a failure
    of the run itself, such as a full disk); Ctrl-C → 130 (SIGTERM and SIGHUP are taken
    as Ctrl-C in every command, so a supervisor's stop parks an arm, removes a temporary
    file and ends a browser as Ctrl-C does: 143, 129; :mod:`mearm.interrupts`), also when
    a library turned it into an error of its own (:func:`mearm.interrupts.hidden_in`);
    any other exception → exit 1
    with one line naming the error and where its traceback was written (``--debug`` or
    ``MEARM_DEBUG=1``: the traceback itself). Standard output's reader gone (a closed
    pipe) → exit 141, quietly, as a shell's tools do. Standard output that cannot be
    written (a full disk, ``> /dev/full``, closed: ``>&-``) → exit 1 with one line saying
    so, whether the write fails in the command, at its end (what was buffered) or after
    ``--help``.
    """
    prog = _program_name()
    args = list(sys.argv[1:] if argv is None else argv)
    debug = _debug_mode(args, prog)
    interrupts.install()  # a Ctrl-C inside a finalizer is not lost
    uncount = interrupts.count_ctrl_c()  # and one a library swallows is raised again
    signals_before = interrupts.stop_signals_noted()
    stdout = sys.stdout  # None: started with standard output closed (>&-)
    if stdout is not None:
        sys.stdout = cast("TextIO", _CheckedOutput(stdout))
    else:  # what it prints goes nowhere; the job is done (a sort's), then exit 1 says so
        global _OUTPUT_LOST
        _OUTPUT_LOST = "it is closed"
    code: int | str | None
    try:
        try:
            with interrupts.stop_signals_as_ctrl_c():  # SIGTERM, SIGHUP: in every command
                interrupts.raise_swallowed_ctrl_c()  # one C code swallowed in an import
                code = main(argv)
                if code in (0, None):  # and one swallowed after the command's last check:
                    interrupts.raise_swallowed_ctrl_c()  # its job done, the exit says it came
        except SystemExit as stop:  # argparse's --help: what it printed must arrive too
            code = stop.code  # the same exit, once standard output is flushed
        except Exception as exc:
            stopped = interrupts.stop_signals_noted() > signals_before  # one came meanwhile
            stopped = stopped or interrupts.ctrl_c_unanswered()  # C code swallowed one
            if not (stopped or interrupts.hidden_in(exc)):
                raise
            raise KeyboardInterrupt from exc  # a Ctrl-C a library turned into an error
        if sys.stdout is not None:
            sys.stdout.flush()  # what was printed reaches the reader, or its pipe is closed
        if _OUTPUT_LOST and code in (0, None):  # the job was done; its report was not
            raise _OutputUnwritable(_OUTPUT_LOST)
    except MearmError as exc:
        print(f"{prog}: error: {_one_line(exc)}", file=sys.stderr)
        code = exc.exit_status  # EXIT_BAD_INPUT, or 1 for a failure of the run itself
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        code = interrupts.exit_status()  # 130; 143 after a SIGTERM taken as Ctrl-C
    except _OutputUnwritable as exc:
        print(f"{prog}: error: cannot write standard output: {exc}", file=sys.stderr)
        code = EXIT_FAILURE
    except Exception as exc:
        code = _unexpected(exc, prog, args, debug=debug)
    finally:
        sys.stdout = stdout
        interrupts.answered()  # this run's Ctrl-Cs are done with, whatever became of them
        uncount()
    _flush_or_drop_output()
    interrupts.clear_python_exit_by_signal()  # this status, also after a Ctrl-C in an import
    sys.exit(code)


def ordered_results(
    pool: Executor, fn: Callable[..., _T], calls: Iterable[tuple[Any, ...]]
) -> Iterator[_T]:
    """Each call's result in the order of ``calls``, run by ``pool``'s workers.

    Leaving the iterator early (Ctrl-C, an error) cancels the calls not yet started, and
    the pool is shut down either way.
    """
    futures: list[Future[_T]] = []
    try:
        futures = [pool.submit(fn, *args) for args in calls]
        for fut in futures:
            yield fut.result()
    finally:  # whole: a second Ctrl-C here left workers no one told to end
        with interrupts.signals_deferred():
            for fut in futures:
                fut.cancel()
            pool.shutdown(wait=True, cancel_futures=True)
