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
joint servo calibrated alone (the file with only that actuator). Prints a Markdown table
of the mean final end-effector error and the first-attempt picks (simulated). Every file
goes into ``--out``; a run already logged there is not repeated (the experiment resumes
its log), nor a calibration file already there (whatever reading seed wrote it: use a
fresh ``--out`` for other reading seeds).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import yaml

from mearm.cli import plain_int

ROOT = Path(__file__).resolve().parent.parent


def mearm(*args: str, ok: tuple[int, ...] = (0,)) -> subprocess.CompletedProcess[str]:
    """Run ``python -m mearm ...``; exit on another status with its stderr's last line."""
    done = subprocess.run(
        [sys.executable, "-m", "mearm", *args], capture_output=True, text=True, check=False
    )
    if done.returncode not in ok:
        last = (done.stderr.strip().splitlines() or ["(no output)"])[-1]
        raise SystemExit(f"calibration_worth: mearm {args[0]} failed: {last}")
    return done


def reading_seed(base: int, kit: int) -> int:
    """Kit ``kit``'s reading seed: ``SeedSequence([base, kit])``'s first 32-bit word.

    Each kit's maker misreads independently of the others' and of the kit's own units
    (drawn by ``default_rng(kit)``, so not ``kit`` itself); the same (base, kit) gives
    the same misreadings on every run.
    """
    return int(np.random.SeedSequence([base, kit]).generate_state(1)[0])


def only(path: Path, name: str, out: Path) -> Path:
    """A copy of a calibration file with only the actuator ``name``."""
    data = yaml.safe_load(path.read_text())
    data["actuators"] = {name: data["actuators"][name]}
    out.write_text(yaml.safe_dump(data, sort_keys=False))
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


def main() -> int:
    """Run the kits; print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--config", default=str(ROOT / "configs" / "sim_mujoco_kits.yaml"))
    p.add_argument("--kits", type=plain_int, default=20)
    p.add_argument("--trials", type=plain_int, default=1)
    p.add_argument("--seed", type=plain_int, default=0)
    p.add_argument("--jobs", type=plain_int, default=2)
    p.add_argument("--out", type=Path, default=Path("calib_worth"))
    p.add_argument("--sensitivity", action="store_true")
    p.add_argument(
        "--reading-seed",
        type=plain_int,
        default=0,
        metavar="BASE",
        help="base of the kits' reading seeds (kit k's: reading_seed(BASE, k); default 0)",
    )
    p.add_argument(
        "--same-readings",
        action="store_true",
        help="every kit's reading seed is BASE itself: the same misreadings on every arm",
    )
    args = p.parse_args()
    if args.kits < 1 or args.trials < 1 or args.jobs < 1:
        p.error("--kits, --trials and --jobs are integers ≥ 1")
    if not 0 <= args.reading_seed < 2**32:
        p.error("--reading-seed is an integer in [0, 2³²−1]")
    args.out.mkdir(parents=True, exist_ok=True)
    joints = ("base", "shoulder", "elbow", "gripper")
    jobs = []
    for k in range(1, args.kits + 1):
        calib = args.out / f"kit{k}.servos.yaml"
        if not calib.exists():
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
                str(
                    args.reading_seed if args.same_readings else reading_seed(args.reading_seed, k)
                ),
            )
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
    (args.out / "results.json").write_text(json.dumps(results, indent=1))
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
    sys.exit(main())
