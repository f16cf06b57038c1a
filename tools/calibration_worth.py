"""What servo calibration is worth on the twin: final error before and after, kit by kit.

    python tools/calibration_worth.py --kits 20 --trials 1 --jobs 2 --out calib_worth
        [--config configs/sim_mujoco_kits.yaml] [--sensitivity] [--reading-seed BASE]
        [--same-readings]

For each kit (``twin.kit.seed`` 1..N, ``per_trial: false``: one arm per kit) it runs the
maker's procedure against the twin (``mearm calibrate-servos --simulate``, default reading
error) into ``<out>/kit<k>.servos.yaml``, each kit with its own misreadings, as each maker
misreads their own protractor: kit k's ``--reading-seed`` is :func:`reading_seed` of
(``--reading-seed`` BASE, k), ``SeedSequence([BASE, k])``'s first word (not k itself:
``default_rng(k)`` draws the kit's units; ``--same-readings`` gives every kit BASE, the
same misreadings on every arm, as the tool did before 2026-11-30), then ``mearm
experiment`` on the same trials (same ``--seed``, so the same scenes) with the nominal
calibration and with the file, and ``mearm analyze --json`` on each log. The nominal runs set
``servo.calibrate_at_start=never``: a config that calibrates the servos by the camera at
the start of each sort (``sim_mujoco_kits.yaml`` does) would otherwise not sort on the
nominal calibration (a run with the file never does). ``--sensitivity`` adds one run per
joint servo calibrated alone (the file with only that actuator). Prints a ``wrote PATH``
line per file written, then a Markdown table of the mean final end-effector error and the
first-attempt picks (simulated). Bad input (an option, the config, ``--out``) is refused
with one line and exit 2 before anything is made; a ``mearm`` step that fails ends the
run with exit 1 and its last line. Every file goes into ``--out`` (made if missing); a
run already logged there is not repeated (the experiment resumes its log), nor a
calibration file already there: beside each, ``kit<k>.servos.made.json`` records what it
was made with (the config, the kit, its reading seed), and a kit file made with other
settings, or with none recorded, is refused (exit 2, before anything runs: its runs'
logs there are that file's; use a fresh ``--out`` for other reading seeds or another
config). A ``results.json`` already there is kept as ``results.json.bak`` (or ``.bak.N``)
before it is replaced, and the ``wrote`` line says so.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from mearm.cli import (
    ArgumentParser,
    backup_existing,
    check_output_folder,
    config_path_value,
    plain_int,
    run,
    seed_value,
    worker_count,
    write_text_atomic,
)
from mearm.errors import MearmError

ROOT = Path(__file__).resolve().parent.parent
#: What every kit's runs set: the kit's seed (here 1, for the check of the config) and
#: one arm per kit.
KIT_SETS = ("twin.kit.seed=1", "twin.kit.per_trial=false")


class StepFailed(MearmError):
    """One of the ``mearm`` commands the tool runs failed: the run's failure, exit 1."""

    exit_status = 1


def mearm(*args: str, ok: tuple[int, ...] = (0,)) -> subprocess.CompletedProcess[str]:
    """Run ``python -m mearm ...``; on another status, fail with its stderr's last line.

    The ``wrote PATH`` lines it printed are printed here too: every file the tool has
    written for it is named on standard output.

    Raises:
        StepFailed: the command exited with a status not in ``ok``.
    """
    done = subprocess.run(
        [sys.executable, "-m", "mearm", *args], capture_output=True, text=True, check=False
    )
    for line in done.stdout.splitlines():
        if line.startswith("wrote "):
            print(line, flush=True)
    if done.returncode not in ok:
        last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise StepFailed(f"mearm {args[0]} failed (exit {done.returncode}): {last}")
    return done


def reading_seed(base: int, kit: int) -> int:
    """Kit ``kit``'s reading seed: ``SeedSequence([base, kit])``'s first 32-bit word.

    Each kit's maker misreads independently of the others' and of the kit's own units
    (drawn by ``default_rng(kit)``, so not ``kit`` itself); the same (base, kit) gives
    the same misreadings on every run.
    """
    return int(np.random.SeedSequence([base, kit]).generate_state(1)[0])


def made_record(calib: Path) -> Path:
    """Where the settings that made the kit file ``calib`` are recorded, beside it."""
    return calib.with_name(calib.name.removesuffix(".yaml") + ".made.json")


def kit_settings(args: argparse.Namespace, digest: str, kit: int) -> dict:
    """What kit ``kit``'s calibration file is made with: compared before it is reused."""
    return {
        "config": str(args.config),
        "config_sha256": digest,
        "kit": kit,
        "reading_seed": args.reading_seed
        if args.same_readings
        else reading_seed(args.reading_seed, kit),
        "reading_seed_base": args.reading_seed,
        "same_readings": bool(args.same_readings),
    }


def _seeds(made: dict) -> str:
    """``reading seed N (base B)`` or ``reading seed N (the same for every kit)``."""
    how = (
        "the same for every kit"
        if made.get("same_readings")
        else f"base {made.get('reading_seed_base')}"
    )
    return f"reading seed {made.get('reading_seed')} ({how})"


def check_kit_file(calib: Path, want: dict) -> None:
    """Refuse a kit file already in ``--out`` that was not made with ``want``.

    Reused as it is, it would stand for this run's reading seeds (and config) in the
    table, and the logs of its runs beside it are that file's.

    Raises:
        MearmError: the record is missing or unreadable, or differs from ``want``.
    """
    record = made_record(calib)
    fresh = "use a fresh --out (its runs' logs there are that file's)"
    try:
        made = json.loads(record.read_text())
    except FileNotFoundError:
        raise MearmError(
            f"--out {calib.parent}: {calib.name} is there with no record of what made it "
            f"({record.name}): it may not be this run's {_seeds(want)}; {fresh}"
        ) from None
    except (OSError, ValueError) as exc:
        raise MearmError(f"--out {calib.parent}: cannot read {record.name}: {exc}") from None
    if not isinstance(made, dict):
        raise MearmError(f"--out {calib.parent}: {record.name} is not a settings record")
    if made.get("config_sha256") != want["config_sha256"] or made.get("kit") != want["kit"]:
        raise MearmError(
            f"--out {calib.parent}: {calib.name} was made with --config {made.get('config')} "
            f"as it read then, not this run's --config {want['config']}; {fresh}"
        )
    if made.get("reading_seed") != want["reading_seed"]:
        raise MearmError(
            f"--out {calib.parent}: {calib.name} was made with {_seeds(made)}, not this "
            f"run's {_seeds(want)}; {fresh}"
        )


def only(path: Path, name: str, out: Path) -> Path:
    """A copy of a calibration file with only the actuator ``name``."""
    data = yaml.safe_load(path.read_text())
    data["actuators"] = {name: data["actuators"][name]}
    write_text_atomic(out, yaml.safe_dump(data, sort_keys=False))
    print(f"wrote {out}", flush=True)
    return out


def run_arm(config: str, kit: int, calib: Path | None, log: Path, args: argparse.Namespace) -> dict:
    """One arm's trials → ``mearm analyze --json``'s summary."""
    sets = [f"twin.kit.seed={kit}", "twin.kit.per_trial=false"]
    if calib is None:
        # the nominal calibration, not the camera's at the start of the sort
        sets.append("servo.calibrate_at_start=never")
    else:
        sets.append(f"servo.calibration_file={calib.resolve()}")
    opts = [a for s in sets for a in ("--set", s)]
    mearm(
        "experiment",
        "--config",
        config,
        *opts,
        "--trials",
        str(args.trials),
        "--seed",
        str(args.seed),
        "--log",
        str(log),
        "--yes",
        ok=(0, 1),
    )
    # exit 1: not every object sorted; the routes are logged all the same
    return json.loads(mearm("analyze", str(log), "--json").stdout)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the kits; print the table.

    Every input is checked before anything is made: the options, the ``--out`` folder
    (made only then) and the config (read with the kits' settings, simulated by the twin).
    """
    p = ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--config",
        type=config_path_value,
        default=ROOT / "configs" / "sim_mujoco_kits.yaml",
        help="the twin's config with a kit spread (twin.kit), a file or a shipped config's "
        "name (default: configs/sim_mujoco_kits.yaml)",
    )
    p.add_argument(
        "--kits",
        type=plain_int,
        default=20,
        metavar="N",
        help="N kits, twin.kit.seed 1..N (default 20)",
    )
    p.add_argument(
        "--trials", type=plain_int, default=1, help="trials per kit and calibration (default 1)"
    )
    p.add_argument(
        "--seed",
        type=seed_value,
        default=0,
        help="the experiments' seed, the same scenes for every run (default 0)",
    )
    p.add_argument(
        "--jobs",
        type=worker_count,
        default=2,
        help="experiments run at once, one process each (default 2)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=Path("calib_worth"),
        help="folder of every file written, made if missing; what is already there is "
        "reused, not redone, but a kit file made with other settings is refused "
        "(default: calib_worth)",
    )
    p.add_argument(
        "--sensitivity",
        action="store_true",
        help="also one run per joint servo calibrated alone",
    )
    p.add_argument(
        "--reading-seed",
        type=seed_value,
        default=0,
        metavar="BASE",
        help="base of the kits' reading seeds (kit k's: reading_seed(BASE, k); default 0)",
    )
    p.add_argument(
        "--same-readings",
        action="store_true",
        help="every kit's reading seed is BASE itself: the same misreadings on every arm",
    )
    args = p.parse_args(argv)
    if args.kits < 1 or args.trials < 1:
        raise MearmError(f"--kits and --trials must be ≥ 1, got {args.kits} and {args.trials}")
    check_output_folder(args.out, "--out")
    from mearm.config import load_config  # noqa: PLC0415  (not for --help)

    config = load_config(args.config, KIT_SETS)
    if config.simulator != "mujoco":
        raise MearmError(
            f"--config {args.config}: simulator is {config.simulator!r}; the kits are "
            "calibrated and sorted in the twin: give a config with simulator: mujoco "
            "(sim_mujoco_kits, ...)"
        )
    args.config = str(args.config)
    digest = hashlib.sha256(
        json.dumps(config.model_dump(mode="json"), sort_keys=True).encode()
    ).hexdigest()
    for k in range(1, args.kits + 1):  # before anything is made
        calib = args.out / f"kit{k}.servos.yaml"
        if calib.exists() or calib.is_symlink():
            check_kit_file(calib, kit_settings(args, digest, k))
    args.out.mkdir(parents=True, exist_ok=True)
    joints = ("base", "shoulder", "elbow", "gripper")
    jobs = []
    for k in range(1, args.kits + 1):
        calib = args.out / f"kit{k}.servos.yaml"
        if not calib.exists():
            settings = kit_settings(args, digest, k)
            mearm(
                "calibrate-servos",
                "--config",
                args.config,
                "--simulate",
                "--output",
                str(calib),
                "--set",
                f"twin.kit.seed={k}",
                "--set",
                "twin.kit.per_trial=false",
                "--reading-seed",
                str(settings["reading_seed"]),
            )
            record = made_record(calib)
            write_text_atomic(record, json.dumps(settings, indent=1) + "\n")
            print(f"wrote {record}", flush=True)
        jobs.append((k, "before", None))
        jobs.append((k, "after", calib))
        if args.sensitivity:
            for j in joints:
                jobs.append((k, f"only {j}", only(calib, j, args.out / f"kit{k}.{j}.servos.yaml")))

    def one(job: tuple[int, str, Path | None]) -> tuple[int, str, dict]:
        k, label, calib = job
        log = args.out / f"kit{k}.{label.replace(' ', '_')}.jsonl"
        return k, label, run_arm(args.config, k, calib, log, args)

    with ThreadPoolExecutor(args.jobs) as pool:
        results = list(pool.map(one, jobs))
    text = json.dumps(results, indent=1)
    backup_existing(args.out / "results.json", text)  # a .bak, named, unless the same
    write_text_atomic(args.out / "results.json", text)
    print(f"wrote {args.out / 'results.json'}", flush=True)
    labels = list(dict.fromkeys(label for _, label, _ in results))
    readings = (
        f"reading seed {args.reading_seed} for every kit"
        if args.same_readings
        else f"each kit's own reading seed (base {args.reading_seed})"
    )
    print(
        f"{args.kits} kits (seeds 1..{args.kits}), {args.trials} trial(s) each, {readings}, "
        "simulated\n"
    )
    print(
        "| calibration | mean final error [cm] | mean over kits ± std [cm] "
        "| first-attempt picks | routes |"
    )
    print("|---|---|---|---|---|")
    for label in labels:
        rows = [r for _, lab, r in results if lab == label]
        means = [_xyz(r)[0] for r in rows]
        n = sum(_xyz(r)[1] for r in rows)
        pooled = sum(_xyz(r)[0] * _xyz(r)[1] for r in rows) / n
        ok = sum(_picks(r)[0] for r in rows)
        tried = sum(_picks(r)[1] for r in rows)
        picks = f"{100 * ok / tried:.1f} % ({ok}/{tried})" if tried else "—"
        print(
            f"| {label} | {pooled:.3f} | {np.mean(means):.3f} ± {np.std(means):.3f} "
            f"| {picks} | {n} |"
        )
    return 0


def _xyz(summary: dict) -> tuple[float, int]:
    """The mean xyz final error and its route count from ``mearm analyze --json``."""
    e = summary["analysis"]["table8"]["xyz"]
    return float(e["mean"]), int(e["n"])


def _picks(summary: dict) -> tuple[int, int]:
    """First-attempt picks that held and those tried (Table 9's total)."""
    t = summary["analysis"]["table9"]["pick_total"]
    return int(t["successes"]), int(t["n"])


if __name__ == "__main__":
    run(main)
