"""Resuming an experiment's log: check it holds this run's trials, find where to go on.

Trial k in the log must carry the seed, config and layout this run gives trial k; the
run continues after the last finished trial (a trial cut off before its summary, or
stopped by Ctrl-C or by its recording, is run again), and a torn last line is set aside first.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mearm.config import Config, SceneObject
from mearm.experiment.trials import TrialPlan, plan_trial
from mearm.runlog import (
    HeaderRecord,
    TornEnd,
    end_line,
    find_torn_end,
    read_runlog,
    set_aside_torn_end,
)
from mearm.runlog.errors import RunLogError
from mearm.task import scene_layout


@dataclass(frozen=True)
class Resume:
    """Where an experiment continues its log.

    Attributes:
        done: Trials 0 .. ``done``−1 are finished in the log; the run starts at ``done``.
        cut_off: Attempts of trial ``done`` in the log that stopped before their summary
            (it is run again).
        interrupted: Attempts of trial ``done`` in the log that Ctrl-C stopped (it is run
            again, too: :attr:`~mearm.runlog.Trial.interrupted`).
        recording_stopped: Attempts of trial ``done`` in the log that its recording
            stopped, a file of the dataset not written (run again, too:
            :attr:`~mearm.runlog.Trial.recording_stopped`).
        torn: The log's unfinished last line, or ``None``.
        torn_is_record: Whether that line is a whole record missing only its newline.
    """

    done: int = 0
    cut_off: int = 0
    interrupted: int = 0
    recording_stopped: int = 0
    torn: TornEnd | None = None
    torn_is_record: bool = False


def ready_to_append(path: Path, resume: Resume) -> Path | None:
    """Make a resumed log appendable: set its torn last line aside, or end its last line.

    Returns:
        The side file the torn line went to, or ``None``.

    Raises:
        RunLogError: The log cannot be changed (it is then as it was).
    """
    if resume.torn is None:
        return None
    if resume.torn_is_record:
        end_line(path)
        return None
    return set_aside_torn_end(path, resume.torn)


def resume_point(
    path: Path, config: Config, seed: int, scene: list[SceneObject] | None = None
) -> Resume:
    """Check that ``path`` holds this experiment's trials; say where to continue.

    Reads only; :func:`ready_to_append` then deals with a torn last line.

    Args:
        path: The ``--log``; a missing or empty file starts at trial 0.
        config: The experiment's config.
        seed: Its base seed.
        scene: Its ``--scene``, if any.

    Raises:
        RunLogError: The log cannot be read, is damaged before its last line, holds a
            lone sort run, trials out of order, or trials of another run (another config,
            seed or layout); the message names the first such trial and what differs.
    """
    if not path.exists() or (path.is_file() and path.stat().st_size == 0):
        return Resume()
    contents = read_runlog(path)
    torn = find_torn_end(path)
    problem = contents.problem
    if problem is not None and (torn is None or problem.line != torn.line):
        raise RunLogError(
            path,
            f"line {problem.line}: {problem.reason}; a damaged log is not resumed (mearm "
            "analyze reads it up to that line): write the new trials to another --log",
        )
    done = cut_off = interrupted = recording_stopped = 0
    plans: dict[int, TrialPlan] = {}
    for t in contents.trials:
        if t.number is None:
            raise RunLogError(
                path,
                f"line {t.line}: a sort run (trial null), not a trial of an experiment; "
                "give the experiment its own --log",
            )
        if (interrupted or recording_stopped) and not cut_off and t.number == done + 1:
            # written before such trials were run again: that run went on to the next
            # trial, and the stopped one stands (analysed as it is)
            done, interrupted, recording_stopped = done + 1, 0, 0
        if t.number != done:
            raise RunLogError(
                path,
                f"line {t.line}: trial {t.number} where trial {done} comes next: not the "
                "trials of one experiment in order; write to another --log",
            )
        if t.number not in plans:  # attempts of one trial share its plan
            plans[t.number] = plan_trial(config, seed, t.number, scene)
        why = _differs(t.header, plans[t.number], seed)
        if why is not None:
            raise RunLogError(
                path,
                f"trial {t.number} (line {t.line}) was written by another run: {why}; resume "
                "with its --config, --set, --seed and --scene, or write to another --log",
            )
        if t.finished:
            done, cut_off, interrupted, recording_stopped = done + 1, 0, 0, 0
        elif t.interrupted:
            interrupted += 1
        elif t.recording_stopped:
            recording_stopped += 1
        else:
            cut_off += 1
    return Resume(
        done, cut_off, interrupted, recording_stopped, torn,
        torn_is_record=torn is not None and problem is None,
    )  # fmt: skip


def _differs(header: HeaderRecord, plan: TrialPlan, seed: int) -> str | None:
    """How a logged trial's header differs from the trial this run would write, if it does."""
    if header.seed != plan.seed:
        return f"it was seeded {header.seed}; --seed {seed} seeds it {plan.seed}"
    difference = _first_difference(header.config, _json(plan.config.model_dump(mode="json")))
    if difference is not None:
        key, logged, now = difference
        return f"its config differs at {key or 'the top'} (log: {logged}; now: {now})"
    logged_scene = (header.model_extra or {}).get("scene")
    if logged_scene != _json(scene_layout(plan.config, plan.layout)):
        return "its table layout differs (was --scene given to one run and not the other?)"
    return None


def _json(value: Any) -> Any:
    """``value`` as it reads back from a log line (tuples → lists, keys → strings)."""
    return json.loads(json.dumps(value))


def _first_difference(logged: Any, now: Any, key: str = "") -> tuple[str, str, str] | None:
    """The dotted key where two JSON values first differ, and both values (shortened)."""
    if isinstance(logged, Mapping) and isinstance(now, Mapping):
        for name in sorted(set(logged) | set(now), key=str):
            sub = f"{key}.{name}" if key else str(name)
            if name not in logged or name not in now:
                return sub, _short(logged.get(name, "(none)")), _short(now.get(name, "(none)"))
            found = _first_difference(logged[name], now[name], sub)
            if found is not None:
                return found
        return None
    if isinstance(logged, list) and isinstance(now, list) and len(logged) == len(now):
        for i, (a, b) in enumerate(zip(logged, now, strict=True)):
            found = _first_difference(a, b, f"{key}[{i}]")
            if found is not None:
                return found
        return None
    same_type = type(logged) is type(now) or (_number(logged) and _number(now))
    if same_type and logged == now:
        return None
    return key, _short(logged), _short(now)


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


# -- the prompt
