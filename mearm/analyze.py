"""The paper's error statistics, fits and plots for a run log (mearm analyze).

Examples::

    python -m mearm.analyze trials.jsonl                  # tables beside the paper's
    python -m mearm.analyze trials.jsonl --out report/    # + PNG plots and report.md
    python -m mearm.analyze trials.jsonl --json           # everything as JSON
    python -m mearm.analyze --gains --out gains/          # kp and kd sweeps of one route

A damaged log (a crash mid-line, a missing field) is analysed up to the bad line, which
is reported on stderr (``--strict`` makes it an error instead, and so it is when no route
comes before it).

**Repeated trial numbers.** A trial that ``mearm experiment`` ran again after it was cut
off (killed before its summary) appears twice: its complete attempt is analysed and the
cut-off one left out, with a note on stderr. A trial number that is *complete* twice —
two runs written to one log — is refused (exit 2, naming the numbers): pooling them would
count every such trial twice (:meth:`mearm.runlog.RunLogContents.latest`).

``--out`` refuses, before any work, to replace a file it would write there (``report.md``,
a plot) unless ``--force`` is given. Every option is checked, and the gain sweeps run,
before anything is written; the files are written into a hidden folder in ``--out``
and put in place of an earlier run's together at the end
(:func:`mearm.fileio.replace_earlier_run`): a failure or Ctrl-C leaves the earlier
report and its plots as they were, never half of each run (a file linked into ``--out``
from elsewhere is written through its link, after the others). The gain options
(``--config``, ``--set``, ``--kp``, ``--kd``, ``--mode``, ``--start``, ``--target``) are
read only with ``--gains``, and refused (exit 2) without it.
"""

from __future__ import annotations

import argparse
import json
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    check_output_folder,
    config_from_args,
    float_list,
    invoked_as,
    refuse_own_inputs,
    refuse_to_replace,
    run,
    say_on_stderr,
    write_text_atomic,
)
from mearm.config import Config
from mearm.errors import MearmError
from mearm.fileio import (
    existing_ancestor,
    remove_staging_leftovers,
    replace_earlier_run,
    staging_folder,
    write_atomic,
)
from mearm.interrupts import signals_deferred, stop_signals_as_ctrl_c
from mearm.runlog import HeaderRecord, RouteRecord, RunLogContents, read_runlog

DEFAULT_KP = "0.01,0.1,0.5"
DEFAULT_KD = "0,0.01,0.1,0.5"
#: The options only the gain sweeps read (``--gains``), by their attribute names.
GAIN_OPTIONS = ("config", "set", "kp", "kd", "mode", "start", "target")
#: The hidden folder in --out a run writes into first (:func:`mearm.fileio.staging_folder`).
_COMMAND = "analyze"
#: The gain sweeps' default route: home to the paper's first object, M1 (paper §4).
DEFAULT_TARGET_XY_CM = (-10.99, 49.70)


def _parser() -> ArgumentParser:
    parser = ArgumentParser(
        prog=invoked_as("python -m mearm.analyze"), description=__doc__.splitlines()[0]
    )
    parser.add_argument("log", nargs="?", type=Path, help="run log (JSON lines) to analyse")
    parser.add_argument("--out", type=Path, help="write PNG plots and report.md into this folder")
    parser.add_argument(
        "--force", action="store_true", help="replace report.md and plots already in --out"
    )
    parser.add_argument("--json", action="store_true", help="print everything as JSON")
    parser.add_argument(
        "--step",
        choices=("all", "pick", "place"),
        default="all",
        help="routes for Table 8 and the Weibull fit (default: all, as the paper's 2 400)",
    )
    parser.add_argument(
        "--first-attempt", action="store_true", help="Table 8 and the fit over first attempts only"
    )
    parser.add_argument(
        "--attempts",
        choices=("first", "all"),
        default="first",
        help="picks for success against error (default: first attempts, as Table 9)",
    )
    parser.add_argument("--strict", action="store_true", help="a damaged log is an error")
    gains = parser.add_argument_group("gain sweeps (--gains)")
    gains.add_argument("--gains", action="store_true", help="sweep kp and kd on one route")
    add_config_argument(gains)
    gains.add_argument(
        "--kp",
        type=float_list(None, "--kp"),
        help=f"kp values, kd from the config (default {DEFAULT_KP})",
    )
    gains.add_argument(
        "--kd",
        type=float_list(None, "--kd"),
        help=f"kd values, kp from the config (default {DEFAULT_KD})",
    )
    gains.add_argument(
        "--mode",
        choices=("paper", "coupled"),
        help="PD-PIJ mode for the sweeps (default: the config's controller.mode)",
    )
    gains.add_argument(
        "--start",
        type=float_list(None, "--start"),
        help="start pose: the actuated joints in chain order [deg, or cm for a prismatic "
        "joint], e.g. 120,93,-132 for the paper's base, shoulder, elbow (default: home)",
    )
    gains.add_argument(
        "--target",
        type=float_list(3, "--target"),
        help="target x,y,z [cm] (default: the config's first scene object at its pick "
        "height; the built-in config's is the paper's M1)",
    )
    return parser


def _require_extras(*, plots: bool) -> None:
    """Refuse (exit 2) in one line unless SciPy (and Matplotlib, for ``plots``) import.

    Raised from the ImportError, not printed here: :func:`mearm.cli.run` knows an
    ImportError a Ctrl-C turned into one (a C extension that was initialising,
    :func:`mearm.interrupts.hidden_in`) by the error's context, and ends it as the
    interruption it is, exit 130, not as a package that is not installed.

    Raises:
        MearmError: SciPy or Matplotlib is not installed.
    """
    try:
        import scipy  # noqa: F401

        if plots:
            import matplotlib  # noqa: F401
    except ImportError as exc:
        raise MearmError(
            f"{exc.name or 'SciPy or Matplotlib'} is not installed (analyze needs SciPy, "
            "and Matplotlib for --out): pip install 'mearm[analysis]'"
        ) from None


def _read_log(path: Path, *, strict: bool) -> RunLogContents:
    """The log's latest attempt of each trial; notes on stderr what was left out."""
    contents = read_runlog(path, strict=strict)
    superseded = contents.superseded
    contents = contents.latest()
    if contents.problem is not None and not contents.routes:
        raise contents.problem  # nothing before the bad line to analyse: it is the error
    for kind, attempts in (
        ("cut-off", [t for t in superseded if not (t.interrupted or t.recording_stopped)]),
        ("interrupted", [t for t in superseded if t.interrupted]),
        ("recording-stopped", [t for t in superseded if t.recording_stopped]),
    ):
        if attempts:
            numbers = sorted({t.number for t in attempts if t.number is not None})
            say_on_stderr(
                f"note: left out {len(attempts)} {kind} attempt(s) of trial(s) "
                f"{', '.join(map(str, numbers))} (header line(s) "
                f"{', '.join(str(t.line) for t in attempts)}), which were run again",
                "python -m mearm.analyze",
            )
    if contents.problem is not None:
        p = contents.problem
        say_on_stderr(
            f"warning: {p}; analysed the {len(contents.records)} records before it",
            "python -m mearm.analyze",
        )
    return contents


def _write_report(
    out: Path,
    images: dict[str, Path],
    *,
    analysis: Any,
    contents: RunLogContents | None,
    path_routes: list[Any],
    gains_kp: list[Any],
    gains_kd: list[Any],
) -> Path:
    """Write ``report.md`` into ``out``, linking the plots; return its path."""
    from mearm.analysis.document import report_markdown

    report = out / OUTPUT_NAMES[0]
    rig = _rig(contents) if contents is not None else None
    write_text_atomic(
        report,
        report_markdown(
            out,
            images,
            analysis=analysis,
            rig=rig,
            path_routes=path_routes,
            gains_kp=gains_kp,
            gains_kd=gains_kd,
        ),
    )
    return report


def _check_start(parser: ArgumentParser, config: Config, start: list[float] | None) -> None:
    """Exit 2 (``parser.error``) unless --start gives one number per actuated joint."""
    actuated = config.arm.actuated_joints()
    if start is not None and len(start) != len(actuated):
        parser.error(
            f"--start needs {len(actuated)} numbers, one per actuated joint "
            f"({', '.join(j.name for j in actuated)}), got {len(start)}"
        )


#: The files ``--out`` receives from a run log (the report links them).
LOG_OUTPUT_NAMES = ("histogram.png", "success_vs_error.png", "ee_path_3d.png", "joint_angles.png")
#: The files ``--out`` receives from ``--gains``.
GAIN_OUTPUT_NAMES = ("gains_kp.png", "gains_kd.png")
#: The files ``--out`` receives (:func:`_write_report`, the plots).
OUTPUT_NAMES = ("report.md", *LOG_OUTPUT_NAMES, *GAIN_OUTPUT_NAMES)


def _may_write(args: argparse.Namespace) -> list[Path]:
    """The files this run may write into ``--out`` (whether a plot is drawn shows later)."""
    names = [OUTPUT_NAMES[0]]
    names += LOG_OUTPUT_NAMES if args.log is not None else ()
    names += GAIN_OUTPUT_NAMES if args.gains else ()
    return [args.out / name for name in names]


def _check_out_files(args: argparse.Namespace) -> None:
    """Refuse (exit 2) a file --out would replace without --force, or one this run reads."""
    from mearm.config.files import resolve_config_path

    outputs = _may_write(args)
    config = resolve_config_path(args.config) if args.gains and args.config else None
    refuse_own_inputs(
        [("--out", path) for path in outputs], [("run log", args.log), ("--config", config)]
    )
    for path in outputs:
        refuse_to_replace(path, "--out", args.force)


def _is_output(log: Path, out: Path) -> bool:
    """Whether writing into ``out`` would replace ``log`` (one of :data:`OUTPUT_NAMES`)."""
    try:
        return log.name in OUTPUT_NAMES and log.resolve().parent == out.resolve()
    except OSError:  # a loop of links: the readers say so
        return False


def main(argv: Sequence[str] | None = None) -> int:
    """Analyse a run log and / or sweep the gains; print tables or JSON, write plots."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.log is None and not args.gains:
        parser.error("give a run log to analyse, --gains, or both")
    if args.out is not None and args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {args.out} is not a folder")
    if args.out is not None and not args.out.exists():
        above = existing_ancestor(args.out)
        if not above.is_dir():
            parser.error(f"--out {args.out}: {above} is a file, not a folder")
    if args.out is not None and args.log is not None and _is_output(args.log, args.out):
        parser.error(
            f"{args.log} is the run log to analyse, and --out {args.out} would write "
            f"{args.log.name} over it: give another --out folder"
        )
    unread = [f"--{name}" for name in GAIN_OPTIONS if getattr(args, name) not in (None, [])]
    if unread and not args.gains:
        parser.error(
            f"{', '.join(unread)}: read only with --gains (the gain sweeps); add --gains, or "
            f"leave {'it' if len(unread) == 1 else 'them'} out"
        )
    args.kp = args.kp if args.kp is not None else float_list(None, "--kp")(DEFAULT_KP)
    args.kd = args.kd if args.kd is not None else float_list(None, "--kd")(DEFAULT_KD)
    if args.out is not None:
        _check_out_files(args)
        # a folder no file can be made in is refused now, not after the analysis: its
        # warnings (a torn last line) came first, and a gain sweep ran for nothing
        check_output_folder(args.out, "--out")
    _require_extras(plots=args.out is not None)

    from mearm.analysis.run_analysis import analyze, jsonable, to_json
    from mearm.analysis.tables import analysis_tables, gain_table, render_text

    result: dict[str, Any] = {}
    text: list[str] = []
    analysis = None
    contents: RunLogContents | None = None
    if args.log is not None:
        contents = _read_log(args.log, strict=args.strict)
        analysis = analyze(
            contents, step=args.step, first_attempt=args.first_attempt, attempts=args.attempts
        )
        result["analysis"] = to_json(analysis)
        rig = _rig(contents)
        result["analysis"]["produced_by"] = rig
        text += [f"{args.log}: {rig}"] if rig else []
        text += [render_text(t) for t in analysis_tables(analysis)]
    gains_kp: list[Any] = []
    gains_kd: list[Any] = []
    if args.gains:  # (before anything is written: a refused option writes nothing)
        config = config_from_args(args)
        _check_start(parser, config, args.start)
        gains_kp, gains_kd = _gain_sweeps(config, args)
        result["gains"] = {
            "kp": jsonable(_gain_rows(gains_kp)),
            "kd": jsonable(_gain_rows(gains_kd)),
        }
        text += [
            render_text(gain_table(gains_kp, "Proportional gain kp")),
            render_text(gain_table(gains_kd, "Derivative gain kd")),
        ]
    if args.out is not None:
        report, images = _write_out(args, contents, analysis, gains_kp, gains_kd)
        result["report"] = str(report)
        result["plots"] = {k: str(v) for k, v in images.items()}
        text.append(f"wrote {report} and {len(images)} plots into {args.out}/")
    if args.json:
        print(json.dumps(result, indent=1, allow_nan=False))
    else:
        print("\n\n".join(text))
    return 0


def _write_out(
    args: argparse.Namespace,
    contents: RunLogContents | None,
    analysis: Any,
    gains_kp: list[Any],
    gains_kd: list[Any],
) -> tuple[Path, dict[str, Path]]:
    """Write the plots and ``report.md`` into ``--out``, in place of an earlier run's, whole.

    Written into a hidden folder there first, then renamed into place together
    (:func:`~mearm.fileio.replace_earlier_run`; a Ctrl-C, SIGTERM or SIGHUP, or a failure,
    removes the folder and leaves the earlier run's files as they were). Returns the
    report's path and the plots' paths in ``--out``.
    """
    out: Path = args.out
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MearmError(f"cannot make --out {out}: {exc.strerror or exc}") from None
    with stop_signals_as_ctrl_c():  # a SIGTERM or SIGHUP, too, removes the hidden folder
        remove_staging_leftovers(out, _COMMAND)
        staging = staging_folder(out, _COMMAND)
        try:
            try:
                staging.mkdir()
            except OSError as exc:
                raise MearmError(f"cannot write into --out {out}: {exc.strerror or exc}") from None
            images: dict[str, Path] = {}
            path_routes: list[Any] = []
            if contents is not None:
                images.update(_log_plots(contents, analysis, args, staging))
                path_routes = _path_routes(contents)
                if path_routes:
                    images.update(_path_plots(path_routes, staging, _rig(contents)))
            if gains_kp:
                images.update(_gain_plots(gains_kp, gains_kd, staging))
            report = _write_report(
                staging,
                images,
                analysis=analysis,
                contents=contents,
                path_routes=path_routes,
                gains_kp=gains_kp,
                gains_kd=gains_kd,
            )
            names = [report.name, *(p.name for p in images.values())]
            # a file kept elsewhere and linked into --out is written through its link
            linked = {n: (staging / n).read_bytes() for n in names if (out / n).is_symlink()}
            renamed = [n for n in names if n not in linked]
            try:  # (only the files this run writes: --force replaces those, no others)
                replace_earlier_run(staging, out, renamed, lambda p: p.name in renamed)
                for name, data in linked.items():
                    write_atomic(out / name, data)
            except OSError as exc:
                name = Path(exc.filename2 or exc.filename or "?").name
                raise MearmError(
                    f"cannot replace {name} in --out {out}: {exc.strerror or exc}; the "
                    "earlier run's report and plots are kept as they were"
                ) from None
        except BaseException:
            with signals_deferred():  # a second Ctrl-C does not leave the folder behind
                shutil.rmtree(staging, ignore_errors=True)
            raise
    return out / report.name, {k: out / p.name for k, p in images.items()}


def _rig(contents: RunLogContents) -> str | None:
    """What produced the log (simulated, synthetic, hardware): said beside every figure."""
    if not contents.trials:
        return None
    if (contents.trials[0].header.model_extra or {}).get("synthetic"):
        return "synthetic data from mearm.analysis.synthetic: neither a simulation nor hardware"
    config = contents.trials[0].header.config
    servo = config.get("servo", {})
    backend = servo.get("backend")
    if backend == "sim":
        quant = servo.get("error_model", {}).get("quantization")
        return f"the simulated arm (servo backend 'sim', quantization '{quant}'): not hardware"
    camera = config.get("camera", {}).get("kind")
    if backend == "virtual_uno" or camera == "sim":  # the firmware in simavr, a drawn table
        return f"simulated (servo backend {backend!r}, camera {camera!r}): not hardware"
    return f"servo backend {backend!r}" if backend else None


def _log_plots(
    contents: RunLogContents, analysis: Any, args: argparse.Namespace, out: Path
) -> dict[str, Path]:
    from mearm.analysis import plots
    from mearm.analysis.stats import route_errors_cm, select_routes
    from mearm.analysis.success import pick_outcomes

    chosen = select_routes(contents.routes, step=args.step, first_attempt=args.first_attempt)
    norms = np.linalg.norm(route_errors_cm(chosen), axis=1)
    source = _rig(contents)
    images = {
        "histogram": plots.error_histogram(
            norms, analysis.weibull, out / "histogram.png", source=source
        )
    }
    if analysis.success is not None:
        errors, success = pick_outcomes(contents.routes, attempts=args.attempts)
        images["success"] = plots.success_against_error(
            errors, success, analysis.success, out / "success_vs_error.png", source=source
        )
    return images


def _joint_distance(a: dict[str, float], b: dict[str, float]) -> float:
    """Largest difference of the joints two poses both name [deg or cm]."""
    return max((abs(a[name] - b[name]) for name in a.keys() & b.keys()), default=0.0)


def _first_pick_and_place(contents: RunLogContents) -> tuple[Config, list[RouteRecord]] | None:
    """The first gripped pick and its place, preferring a pair whose paths do not overlap.

    A place that ends where its pick started (a bin at home) would draw one path on top
    of the other; the poses are compared joint by joint, by name.
    """
    first: tuple[HeaderRecord, list[RouteRecord]] | None = None
    for trial in contents.trials:
        for pick in (r for r in trial.routes if r.step == "pick" and r.success):
            place = next(
                (r for r in trial.routes if r.step == "place" and r.object_id == pick.object_id),
                None,
            )
            if place is None:
                continue
            if _joint_distance(pick.start_joints, place.end_joints) > 5.0:
                return trial.header.load_config(), [pick, place]
            first = first or (trial.header, [pick, place])
    return (first[0].load_config(), first[1]) if first else None


def _path_routes(contents: RunLogContents) -> list[Any]:
    from mearm.analysis.paths import resolve_logged_route
    from mearm.kinematics import ArmModel

    try:
        found = _first_pick_and_place(contents)
        if found is None:
            return []
        config, routes = found
        model = ArmModel(config.arm)
        return [resolve_logged_route(r, config, model=model) for r in routes]
    except MearmError as exc:  # the tables and the other plots are still worth having
        say_on_stderr(f"warning: path plots skipped: {exc}", "python -m mearm.analyze")
        return []


def _path_plots(routes: list[Any], out: Path, source: str | None) -> dict[str, Path]:
    from mearm.analysis import plots

    title = "EE path of a pick and the place after it"
    return {
        "path3d": plots.ee_paths_3d(routes, out / "ee_path_3d.png", title=title, source=source),
        "joints": plots.joint_angles(routes, out / "joint_angles.png", source=source),
    }


def _gain_sweeps(config: Config, args: argparse.Namespace) -> tuple[list[Any], list[Any]]:
    from mearm.analysis.paths import gain_sweep
    from mearm.kinematics import ArmModel

    if args.mode is not None:
        controller = config.controller.model_copy(update={"mode": args.mode})
        config = config.model_copy(update={"controller": controller})
    model = ArmModel(config.arm)
    chain = model.chain
    if args.start is not None:
        q0 = chain.from_named(dict(zip(chain.actuated, args.start, strict=True)))
    else:
        q0 = model.home
    model.check_limits(q0)
    if args.target is not None:
        target = np.array(args.target)
    else:
        scene = config.task.scene
        xy_cm = (scene[0].x, scene[0].y) if scene else DEFAULT_TARGET_XY_CM
        cls = config.task.class_named(scene[0].color) if scene else config.task.classes[0]
        target = np.array([*xy_cm, cls.grip_z_cm + config.arm.tool.tcp_above_grip_cm])
    kp0, kd0 = config.controller.kp, config.controller.kd
    by_kp = gain_sweep(config, q0, target, [(kp, kd0) for kp in args.kp], vary="kp", model=model)
    by_kd = gain_sweep(config, q0, target, [(kp0, kd) for kd in args.kd], vary="kd", model=model)
    return by_kp, by_kd


def _gain_rows(routes: list[Any]) -> list[dict[str, Any]]:
    return [
        {
            "mode": r.mode,
            "kp": r.kp,
            "kd": r.kd,
            "iterations": r.iterations,
            "status": r.status,
            "final_error_cm": r.final_error_cm,
            "path_deviation_cm": r.path_deviation_cm,
            "target_cm": r.target_cm,
            "start_joints": r.start_joints,
        }
        for r in routes
    ]


def _gain_plots(by_kp: list[Any], by_kd: list[Any], out: Path) -> dict[str, Path]:
    from mearm.analysis import plots

    kd, kp, mode = by_kp[0].kd, by_kd[0].kp, by_kp[0].mode
    return {
        "gains_kp": plots.gain_sweep(
            by_kp, out / "gains_kp.png", title=f"PD-PIJ ({mode} mode) with several kp (kd = {kd:g})"
        ),
        "gains_kd": plots.gain_sweep(
            by_kd, out / "gains_kd.png", title=f"PD-PIJ ({mode} mode) with several kd (kp = {kp:g})"
        ),
    }


if __name__ == "__main__":
    run(main)
