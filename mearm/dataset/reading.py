"""Reading a dataset's files: each one that cannot be read is a named :class:`DatasetError`.

What ``--resume``, ``mearm dataset show`` and the replay read goes through here, so a
damaged file (cut short, overwritten, of the wrong shape) is one line naming the file and
what is wrong with it, exit 2, and nothing is written; ``mearm dataset check`` reports
the same faults as broken rules.

``meta/mearm_episodes.json`` is mearm's own (LeRobot does not read it): one entry per
episode, ``[trial seed, pick]`` (both ``null`` outside an experiment), and a third, the
scene a replay rebuilds (:class:`RecordedScene`), for an episode of
``mearm sort --random N --seed S`` or ``--scene FILE``, or of an experiment's trial on a
simulated table. A dataset without the file (recorded by other tools) reads as untagged.
``meta/mearm_starts.json``, mearm's too, says where each episode starts and the servo
calibration its sort ran (:class:`EpisodeStart`).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from pydantic import TypeAdapter, ValidationError

from mearm.config import SceneObject
from mearm.config.base import MAX_SEED
from mearm.config.sections import MAX_SCENE_OBJECTS
from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import DatasetError

#: An episode's tag: its trial's seed and its pick's number in the trial (experiments).
Tag = tuple[int | None, int | None]


def damaged(root: Path, rel: str, what: str) -> DatasetError:
    """The error of a dataset file that is there but cannot be read as it should."""
    return DatasetError(
        root / rel,
        f"{what}: the dataset is damaged; `mearm dataset check {root}` lists what is wrong",
    )


#: What an episode's journal (``meta/.commit.json``) is, said of one that is not.
JOURNAL_SHAPE = 'not an object {"replace": {...}, "append": {...}}'


def journal_damage(root: Path) -> str | None:
    """What is wrong with the journal of an episode being written, if anything.

    ``None``: none there, or one a recorder can finish (``--resume``).
    """
    journal = root / L.JOURNAL_PATH
    if not journal.exists():
        return None
    try:
        entries = json.loads(journal.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return f"cannot be read as JSON ({type(exc).__name__})"
    if not (
        isinstance(entries, dict)
        and isinstance(entries.get("replace"), dict)
        and isinstance(entries.get("append", {}), dict)
    ):
        return JOURNAL_SHAPE
    return None


def read_json(root: Path, rel: str) -> Any:
    """A JSON file of the dataset.

    Raises:
        DatasetError: it is missing, unreadable or not valid JSON.
    """
    try:
        text = (root / rel).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise damaged(root, rel, "is missing") from None
    except UnicodeDecodeError:
        raise damaged(root, rel, "not valid JSON (not UTF-8 text)") from None
    except OSError as exc:
        raise damaged(root, rel, f"cannot be read ({exc.strerror})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise damaged(root, rel, f"not valid JSON (line {exc.lineno})") from None


def read_table(
    pq: Any, root: Path, rel: str, columns: list[str] | None = None, *, only: bool = False
) -> Any:
    """A Parquet file of the dataset (pyarrow's ``pq``) that has ``columns``; ``only`` those.

    Raises:
        DatasetError: it is missing, not a readable Parquet file, or lacks a column.
    """
    path = root / rel
    if not path.is_file():
        raise damaged(root, rel, "is missing")
    try:
        names = pq.read_schema(path).names
        missing = [c for c in columns or () if c not in names]
        if missing:
            raise damaged(root, rel, f"has no column {missing[0]}")
        return pq.read_table(path, columns=columns if only else None)
    except (OSError, ValueError) as exc:  # pyarrow's ArrowInvalid is a ValueError
        raise damaged(root, rel, f"not a readable Parquet file ({_reason(exc, path)})") from None


def read_info(root: Path) -> dict[str, Any]:
    """``meta/info.json``: an object with ``fps`` ≥ 1, the totals and the features.

    Raises:
        DatasetError: it is missing (not a dataset), not JSON, or lacks those fields.
    """
    if not (root / L.INFO_PATH).is_file():
        raise DatasetError(root, f"holds no {L.INFO_PATH}: not a LeRobot dataset")
    info = read_json(root, L.INFO_PATH)
    if not isinstance(info, dict):
        raise damaged(root, L.INFO_PATH, "not a JSON object")
    for key in ("fps", "total_episodes", "total_frames", "total_tasks"):
        if not _whole(info.get(key)) or (key == "fps" and info[key] < 1):
            need = "≥ 1" if key == "fps" else "≥ 0"
            raise damaged(
                root, L.INFO_PATH, f"{key} is {info.get(key)!r}, not a whole number {need}"
            )
    features = info.get("features")
    if not isinstance(features, dict) or not all(
        isinstance(f, dict) and "dtype" in f and isinstance(f.get("shape"), list)
        for f in features.values()
    ):
        raise damaged(root, L.INFO_PATH, "its features are not each a dtype and a shape")
    return info


def read_tasks(pq: Any, root: Path) -> list[str]:
    """The tasks of ``meta/tasks.parquet``, by ``task_index``.

    Raises:
        DatasetError: it is missing, unreadable or has no ``task`` column.
    """
    table = read_table(pq, root, L.TASKS_PATH, ["task"])
    return [str(t) for t in table["task"].to_pylist()]


def read_episodes(pq: Any, root: Path, info: dict[str, Any]) -> list[dict[str, Any]]:
    """The rows of ``meta/episodes``, one per episode, in order.

    Raises:
        DatasetError: a file is unreadable, or they hold another number of episodes
            than ``info.json``'s ``total_episodes``.
    """
    needed = ["episode_index", "tasks", "length", "data/chunk_index", "data/file_index"]
    needed += ["dataset_from_index", "dataset_to_index"]
    for key, feature in info["features"].items():
        if feature["dtype"] == "video":
            needed += [f"videos/{key}/{c}" for c in ("chunk_index", "file_index")]
            needed += [f"videos/{key}/{c}" for c in ("from_timestamp", "to_timestamp")]
    rows: list[dict[str, Any]] = []
    for path in sorted((root / "meta" / "episodes").glob("chunk-*/file-*.parquet")):
        rows.extend(read_table(pq, root, str(path.relative_to(root)), needed).to_pylist())
    if len(rows) != info["total_episodes"]:
        raise damaged(
            root,
            "meta/episodes",
            f"holds {len(rows)} episodes, {L.INFO_PATH} says {info['total_episodes']}",
        )
    return rows


#: A recorded table: the objects as a ``--scene`` file holds them.
_TABLE = TypeAdapter(list[SceneObject])


@dataclass(frozen=True)
class RecordedScene:
    """The scene an episode sorted, as a replay rebuilds it (``mearm/Sort-v0``).

    Either drawn again, ``random_scene(config, objects, seed)`` (a sort's ``--random N
    --seed S``), or laid as it was: ``table`` (a ``--scene`` sort's file, an experiment
    trial's table, which ``--random N --seed S`` cannot draw: it deals the classes in
    turn, a trial draws them class by class).

    Attributes:
        seed: ``--seed`` of a ``--random`` sort (the scene's); ``None`` with a ``table``.
        objects: ``--random N`` of the sort; with a ``table``, its length.
        config: ``--config`` as given (``None``: the built-in simulated rig).
        overrides: Its ``--set`` values, in order.
        table: The objects laid, each its class and place; ``None``: drawn from ``seed``.
        noise_seed: The seed the sort's servo and camera noise were drawn from in place
            of the config's own (:func:`~mearm.experiment.trial_config`, an experiment's
            trial's seed: with ``twin.kit.per_trial``, its servo kit); ``None``: the
            config's own (a ``mearm sort``'s).
    """

    seed: int | None
    objects: int
    config: str | None = None
    overrides: tuple[str, ...] = ()
    table: tuple[SceneObject, ...] | None = None
    noise_seed: int | None = None

    @classmethod
    def laid(
        cls,
        table: Sequence[SceneObject],
        config: str | None,
        overrides: Sequence[str],
        noise_seed: int | None = None,
    ) -> RecordedScene:
        """The record of a table laid as it is (a ``--scene`` sort's, a trial's)."""
        return cls(None, len(table), config, tuple(overrides), tuple(table), noise_seed)

    def to_json(self) -> dict[str, Any]:
        """As ``meta/mearm_episodes.json`` holds it.

        A drawn scene: ``{"seed", "objects", "config", "set"}``. A laid one: ``{"table",
        "config", "set"}``, no ``seed`` nor ``objects``: an older mearm refuses it rather
        than draw another table. Either with ``"noise_seed"`` if it has one (a trial's).
        """
        kept: dict[str, Any] = {"config": self.config, "set": list(self.overrides)}
        if self.noise_seed is not None:
            kept["noise_seed"] = self.noise_seed
        if self.table is None:
            return {"seed": self.seed, "objects": self.objects, **kept}
        return {"table": [o.model_dump() for o in self.table], **kept}

    @classmethod
    def from_json(cls, value: Any) -> RecordedScene | None:
        """The scene of an entry's third item; ``None`` if it is not one."""
        if not isinstance(value, dict):
            return None
        config, overrides = value.get("config"), value.get("set", [])
        noise_seed = value.get("noise_seed")
        if not (config is None or isinstance(config, str)):
            return None
        if not isinstance(overrides, list) or not all(isinstance(s, str) for s in overrides):
            return None
        if not (noise_seed is None or (_whole(noise_seed) and noise_seed <= MAX_SEED)):
            return None
        if "table" in value:
            table = _table(value["table"])
            if table is None or "seed" in value or "objects" in value:
                return None
            return cls.laid(table, config, overrides, noise_seed)
        seed, objects = value.get("seed"), value.get("objects")
        if not (isinstance(seed, int) and isinstance(objects, int)):
            return None
        if not (_whole(seed) and _whole(objects)):
            return None
        return cls(seed, objects, config, tuple(overrides), None, noise_seed)


def _table(value: Any) -> list[SceneObject] | None:
    """A recorded table: 1 to MAX_SCENE_OBJECTS objects; ``None`` if it is not one."""
    if not isinstance(value, list) or not 1 <= len(value) <= MAX_SCENE_OBJECTS:
        return None
    try:
        return _TABLE.validate_python(value)
    except ValidationError:
        return None


def read_tags(root: Path, episodes: int) -> tuple[list[Tag], list[RecordedScene | None]]:
    """``meta/mearm_episodes.json``: each episode's tag and recorded scene, in order.

    Without the file every episode is untagged, with no scene: a dataset other tools
    recorded. One mearm recorded keeps it beside ``meta/mearm_starts.json`` (which a
    mearm before 2026-11-30 did not keep): with that there and episodes, it is damaged
    without it (an experiment's ``--resume`` would record its picks again).

    Raises:
        DatasetError: it is missing where mearm keeps it; it is not JSON, not
            ``{"episodes": [...]}`` of entries ``[seed, pick]`` or
            ``[seed, pick, scene]``, or not one entry per episode.
    """
    rel = L.TAGS_PATH
    if not (root / rel).exists():
        if episodes and (root / L.STARTS_PATH).exists():
            raise damaged(
                root,
                rel,
                f"missing, though {L.STARTS_PATH} is there: mearm keeps both, and without "
                "it which picks the episodes hold is lost",
            )
        return [(None, None)] * episodes, [None] * episodes
    data = read_json(root, rel)
    entries = data.get("episodes") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        raise damaged(root, rel, 'not an object {"episodes": [...]}')
    tags: list[Tag] = []
    scenes: list[RecordedScene | None] = []
    for k, entry in enumerate(entries):
        ok = isinstance(entry, list) and len(entry) in (2, 3)
        ok = ok and all(v is None or _whole(v) for v in entry[:2])
        scene = RecordedScene.from_json(entry[2]) if ok and len(entry) == 3 else None
        if not ok or (len(entry) == 3 and scene is None):
            raise damaged(
                root,
                rel,
                f"entry {k} is {_short(entry)}, not [trial seed, pick] (each null or a whole "
                'number ≥ 0), optionally with a scene {"seed", "objects", "config", "set"} '
                'or {"table", "config", "set"}',
            )
        tags.append((entry[0], entry[1]))
        scenes.append(scene)
    if len(entries) != episodes:
        raise damaged(
            root, rel, f"holds {len(entries)} entries for the {episodes} episodes of the dataset"
        )
    return tags, scenes


def tags_json(tags: list[Tag], scenes: list[RecordedScene | None]) -> str:
    """``meta/mearm_episodes.json``'s text (:func:`read_tags` reads it)."""
    entries = [
        [*tag, scene.to_json()] if scene is not None else list(tag)
        for tag, scene in zip(tags, scenes, strict=True)
    ]
    return json.dumps({"episodes": entries})


def _whole(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _reason(exc: BaseException, path: Path) -> str:
    """The message of pyarrow's error, its first sentence, without the path it repeats."""
    text = str(exc).replace(f"'{path}'", "").replace(str(path), "").strip()
    first = text.split(". ")[0].strip().rstrip(".")
    return (first[:120] + "...") if len(first) > 120 else first or type(exc).__name__


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


@dataclass(frozen=True)
class EpisodeStart:
    """Where an episode starts, as a replay rebuilds it, and the servos it ran.

    An episode per pick after a sort's first starts where the one before it left the arm
    and the table, not where the environment's reset does: its replay steps the sort's
    episodes before it first (:mod:`mearm.envs.replay`).

    Attributes:
        known: Whether the recording knows where it starts.
        after: The episode of the same sort it continues (the pick before it); ``None``:
            it starts where the environment's reset leaves the arm (a sort's first).
        gap_frames: The frames of the sort's time between the last frame of ``after``
            and its own first (the sort looking at the table, or going home to look
            again; no frame is recorded then) [frames of 1/fps].
        servos: The servo calibration the sort made at its start
            (``servo.calibrate_at_start``): a servo calibration file in the dataset, its
            path relative to the dataset; ``None``: the config's own.
        why: Why its start is not known, a sentence the replay prints (the recorder
            writes it); ``None`` when known, or not said (a dataset of a mearm that kept
            no reason).
    """

    known: bool = False
    after: int | None = None
    gap_frames: int = 0
    servos: str | None = None
    why: str | None = None

    def to_json(self) -> dict[str, Any]:
        """As ``meta/mearm_starts.json`` holds it: ``{}`` when not known, or its reason.

        ``{"after": null}`` (a reset's start) or ``{"after": K, "gap_frames": G}``; not
        known, ``{"why_not_known": "..."}`` or ``{}``; each with ``"servos":
        "meta/mearm_servos/…"`` where the sort calibrated them.
        """
        out: dict[str, Any] = {}
        if self.known:
            out["after"] = self.after
            if self.after is not None:
                out["gap_frames"] = self.gap_frames
        elif self.why is not None:
            out["why_not_known"] = self.why
        if self.servos is not None:
            out["servos"] = self.servos
        return out

    @classmethod
    def from_json(cls, value: Any, episode: int) -> EpisodeStart | None:
        """Episode ``episode``'s entry; ``None`` if it is not one."""
        keys = {"after", "gap_frames", "servos", "why_not_known"}
        if not isinstance(value, dict) or set(value) - keys:
            return None
        after, gap, servos = value.get("after"), value.get("gap_frames", 0), value.get("servos")
        why = value.get("why_not_known")
        if after is not None and not (_whole(after) and after < episode):
            return None  # an episode continues one before it
        if not _whole(gap) or ("gap_frames" in value and after is None):
            return None
        if servos is not None and not _inside(servos):
            return None
        if "why_not_known" in value and (not isinstance(why, str) or not why or "after" in value):
            return None  # a reason is a sentence, of a start not known
        return cls("after" in value, after, gap, servos, why)


def _inside(rel: Any) -> bool:
    """Whether ``rel`` is a path inside the dataset (relative, no ``..``)."""
    if not isinstance(rel, str) or not rel:
        return False
    path = PurePosixPath(rel)
    return not path.is_absolute() and ".." not in path.parts


#: Why no episode's start is known in a dataset without ``meta/mearm_starts.json``.
NO_STARTS_KEPT = f"recorded by a mearm that kept no {L.STARTS_PATH}"


def read_starts(root: Path, episodes: int) -> list[EpisodeStart]:
    """``meta/mearm_starts.json``: each episode's :class:`EpisodeStart`, in order.

    Without the file (a dataset recorded by an older mearm) no episode's start is known
    (:data:`NO_STARTS_KEPT` says why).

    Raises:
        DatasetError: it is not JSON, not ``{"episodes": [...]}`` of entries, or not one
            entry per episode.
    """
    rel = L.STARTS_PATH
    if not (root / rel).exists():
        return [EpisodeStart(why=NO_STARTS_KEPT)] * episodes
    data = read_json(root, rel)
    entries = data.get("episodes") if isinstance(data, dict) else None
    if not isinstance(entries, list):
        raise damaged(root, rel, 'not an object {"episodes": [...]}')
    starts = []
    for k, entry in enumerate(entries):
        start = EpisodeStart.from_json(entry, k)
        if start is None:
            raise damaged(
                root,
                rel,
                f"entry {k} is {_short(entry)}, not "
                '{"after": null or an earlier episode, "gap_frames": frames ≥ 0, "servos": '
                'a file in the dataset} (each optional) or {"why_not_known": a sentence}',
            )
        starts.append(start)
    if len(entries) != episodes:
        raise damaged(
            root, rel, f"holds {len(entries)} entries for the {episodes} episodes of the dataset"
        )
    return starts


def starts_json(starts: list[EpisodeStart]) -> str:
    """``meta/mearm_starts.json``'s text (:func:`read_starts` reads it)."""
    return json.dumps({"episodes": [s.to_json() for s in starts]})
