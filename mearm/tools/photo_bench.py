"""Detection on labelled real photos: recall and precision per image and class.

A folder of photos with a ``manifest.yaml`` (per image: ``file``, ``source_repo``,
``shapes`` with the objects' size as ``~N px``, ``objects`` per class with their
``centres`` [px], optional ``partial`` regions, a list of ``{region: 'x A-B, y C-D'}``
[px] whose detections are not counted, an optional ``camera`` naming the camera that
took it) is scored as a user's camera would see it: each photo scaled so its objects
are as wide as the config's calibration sees one at its camera's centre
(:func:`object_px_of`: 32 px, 2 cm, under the paper's calibration; another calibration
scores the photos as a nearer or farther camera sees them), the detector of a config and
the 8-bit ``inRange`` recipe run on it, and each detection matched to the nearest
unmatched labelled object of its class within half an object. A detection that matches
none (another colour's object, a distractor, a wrong class) is a false positive; a
labelled object no detection matches is missed. A manifest with no photo, or an entry
without a size of at least 1 px (and at most its photo's shorter side), with a class the
config lacks, a centre that is not a pixel of its photo or a ``partial`` that is not a
list of regions, is refused (:class:`~mearm.errors.InputFileError` naming the entry).

With ``learn``, each source's colours are taught from its first photo that shows every
class the source labels (a source with none is refused), as a user teaches them: one
click per class, on the first labelled object of that class (moved to its most
coloured pixel within half an object when the centre is grey: a blown-out top),
and the photos are scored with the config that makes. A click the teacher refuses (a
label on grey, on the table, or two classes labelled on one colour) is the manifest's
fault: :class:`~mearm.errors.InputFileError` naming the entry and the label. Without
``learn`` nothing is taught, so such labels are only scored.

One click is one choice among many: another user clicks another cube, or teaches from
another photo. :func:`run_click_study` teaches each source every way a user could with
one photo and one click per class — from each photo that shows all the source's classes,
once per combination of clicked objects (the first :data:`CLICKS_PER_CLASS` of each
class) — scores the source's photos each time, and gives the spread: how much the
figures owe to the click.

A source is a ``source_repo`` and, where its photos name one, a ``camera`` (rows read
``source owner/repo (camera)``): colours are taught on the camera that sorts, and one
camera's taught colours do not carry to another camera's photos (docs/vision.md).
"""

from __future__ import annotations

import itertools
import re
import statistics
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from mearm.config import Config
from mearm.errors import InputFileError
from mearm.vision.calibration import Calibration, camera_geometry, object_width_px
from mearm.vision.detector import ColorDetector, Detection
from mearm.vision.errors import ImageError, SampleError
from mearm.vision.image import read_image
from mearm.vision.inrange import detect_inrange
from mearm.vision.learned import CHROMA_MIN, chroma, lab_of
from mearm.vision.teaching import Sample, teach
from mearm.yamlio import load_yaml_file

#: The click study clicks each of the first this-many labelled objects of a class.
CLICKS_PER_CLASS = 4
#: The click study draws at most this many combinations of the sources' teachings
#: (all of them when there are fewer; else a sample, seeded).
COMBINATIONS_MAX = 100_000


@dataclass(frozen=True)
class Photo:
    """One labelled photo, scaled: frame, labelled centres, ignored boxes, object width.

    ``object_px`` is the width its objects were scaled to [px]; ``scale`` the factor the
    photo was scaled by, and ``entry`` its manifest entry (``images[i] (file)``), so that
    a label a teaching refuses is named as the manifest gives it.
    """

    name: str
    source: str
    frame: np.ndarray = field(repr=False)
    centres: dict[str, np.ndarray] = field(repr=False)
    ignore: list[tuple[float, float, float, float]] = field(repr=False)
    object_px: float
    scale: float = 1.0
    entry: str = ""


@dataclass
class Score:
    """Counts of one detector on one photo, per class: found, missed, false."""

    found: dict[str, int] = field(default_factory=dict)
    missed: dict[str, int] = field(default_factory=dict)
    false: dict[str, int] = field(default_factory=dict)

    def add(self, other: Score) -> None:
        """Add ``other``'s counts to these."""
        for mine, theirs in (
            (self.found, other.found),
            (self.missed, other.missed),
            (self.false, other.false),
        ):
            for k, v in theirs.items():
                mine[k] = mine.get(k, 0) + v

    def totals(self) -> tuple[int, int, int]:
        """(found, missed, false) over every class."""
        return sum(self.found.values()), sum(self.missed.values()), sum(self.false.values())


def _size_px(entry: dict, where: str, manifest: Path) -> float:
    """The objects' width [px] from an entry's ``shapes`` (``~N px`` or ``~A-B px``)."""
    match = re.search(r"~\s*(\d+)(?:\s*-\s*(\d+))?\s*px", str(entry.get("shapes", "")))
    if match is None:
        raise InputFileError(str(manifest), f"{where}: its 'shapes' gives no object size (~N px)")
    lo, hi = match.group(1), match.group(2) or match.group(1)
    size = (float(lo) + float(hi)) / 2.0
    if size < 1.0:
        raise InputFileError(
            str(manifest), f"{where}: its 'shapes' gives objects {size:g} px wide (~N px, N >= 1)"
        )
    return size


#: The source of a manifest entry that names none (``source_repo``): a user's own photos.
NO_SOURCE = "(no source_repo)"


def _source(entry: dict, where: str, manifest: Path) -> str:
    """An entry's source: its ``source_repo``, with its ``camera`` when it names one.

    An entry without ``source_repo`` (a user's own photos) is of the source named
    ``NO_SOURCE``, not of a blank one.
    """
    repo, camera = entry.get("source_repo"), entry.get("camera")
    if repo is None:
        repo = NO_SOURCE
    elif not isinstance(repo, str) or not repo.strip():
        raise InputFileError(
            str(manifest),
            f"{where}: its 'source_repo' is {repo!r}: give where the photo came from (text), "
            "or leave it out",
        )
    repo = repo.strip()
    if camera is None:
        return repo
    if not isinstance(camera, str) or not camera.strip():
        raise InputFileError(
            str(manifest), f"{where}: its 'camera' is {camera!r}: give the camera's name (text)"
        )
    return f"{repo} ({camera.strip()})"


def _centres(
    entry: dict, where: str, manifest: Path, shape: Sequence[int], classes: Sequence[str] | None
) -> dict[str, np.ndarray]:
    """An entry's labelled centres per class [px], each checked to be a pixel of the photo.

    Raises:
        InputFileError: ``objects`` is not a mapping of class to ``centres``, a class is
            not one of ``classes``, or a centre is not a pair of numbers inside the photo.
    """
    h, w = int(shape[0]), int(shape[1])
    objects = entry.get("objects") or {}
    if not isinstance(objects, dict):
        raise InputFileError(str(manifest), f"{where}: 'objects' must map each class to centres")
    out = {}
    for name, obj in objects.items():
        if classes is not None and str(name) not in classes:
            raise InputFileError(
                str(manifest),
                f"{where}: class '{name}' is not one of the config's ({', '.join(classes)}): "
                "give a --config with it, or list those objects under 'other'",
            )
        given = obj.get("centres") if isinstance(obj, dict) else obj
        pts = [] if given is None else given
        ok = isinstance(obj, dict | None) and isinstance(pts, list)
        if not ok or not all(
            isinstance(c, list)
            and len(c) == 2
            and all(isinstance(x, int | float) and not isinstance(x, bool) for x in c)
            for c in pts
        ):
            raise InputFileError(
                str(manifest),
                f"{where}: objects.{name} must be {{centres: [[u, v], ...]}} in pixels, "
                f"got {obj!r:.60}",
            )
        count = obj.get("count") if isinstance(obj, dict) else None
        if count is not None and count != len(pts):  # a centre left out scores no miss
            raise InputFileError(
                str(manifest),
                f"{where}: objects.{name} has count {count!r} but {len(pts)} centre"
                f"{'' if len(pts) == 1 else 's'}: "
                "give every object's centre (count may be left out)",
            )
        arr = np.asarray(pts, dtype=float).reshape(-1, 2)
        if not np.isfinite(arr).all():
            raise InputFileError(
                str(manifest), f"{where}: objects.{name} has a centre that is not a number"
            )
        bad = (arr[:, 0] < 0) | (arr[:, 0] >= w) | (arr[:, 1] < 0) | (arr[:, 1] >= h)
        if bad.any():
            u, v = arr[int(np.argmax(bad))]
            raise InputFileError(
                str(manifest),
                f"{where}: objects.{name} centre [{u:g}, {v:g}] is outside the photo ({w}x{h} px): "
                f"0 <= u < {w}, 0 <= v < {h}, at the photo's own size",
            )
        out[str(name)] = arr
    return out


#: A ``partial`` region as the manifest gives it, in the photo's own pixels.
REGION = re.compile(r"\s*x\s*(\d+)\s*-\s*(\d+)\s*,\s*y\s*(\d+)\s*-\s*(\d+)\s*")
#: How a manifest entry gives its ``partial`` regions, for the messages.
PARTIAL_FORM = "a list of {region: 'x A-B, y C-D'} (pixels of the photo, A <= B, C <= D)"


def _boxes(
    entry: dict, where: str, manifest: Path, scale: float
) -> list[tuple[float, float, float, float]]:
    """An entry's ``partial`` regions (detections there are not counted), scaled [px].

    Raises:
        InputFileError: ``partial`` is not :data:`PARTIAL_FORM` (a region not read, or
            read as another, would leave its detections counted: the scores wrong).
    """
    given = entry.get("partial")
    if given is None:
        return []
    if not isinstance(given, list):
        raise InputFileError(
            str(manifest), f"{where}: 'partial' is {given!r:.60}: expected {PARTIAL_FORM}"
        )
    out = []
    for i, p in enumerate(given):
        region = p.get("region") if isinstance(p, dict) else None
        m = REGION.fullmatch(region) if isinstance(region, str) else None
        if m is None:  # (a region not read would count its detections as false positives)
            got = f"region {region!r:.60}" if isinstance(p, dict) else f"{p!r:.60}"
            raise InputFileError(
                str(manifest), f"{where}: partial[{i}] is {got}: expected {PARTIAL_FORM}"
            )
        x0, x1, y0, y1 = (float(g) for g in m.groups())
        if x0 > x1 or y0 > y1:
            raise InputFileError(
                str(manifest),
                f"{where}: partial[{i}] region {region!r} is empty: expected {PARTIAL_FORM}",
            )
        out.append((x0 * scale, x1 * scale, y0 * scale, y1 * scale))
    return out


def object_px_of(config: Config) -> float:
    """One object's width [px] at the centre of ``config``'s camera, through its calibration."""
    diameter = max(c.diameter_cm for c in config.task.classes)
    return object_width_px(config.calibration, config.camera, diameter)


def load_photos(
    folder: Path, object_px: float, classes: Sequence[str] | None = None
) -> list[Photo]:
    """The labelled photos of ``folder`` (its ``manifest.yaml``), scaled.

    Each is scaled so that its objects are ``object_px`` across [px]. ``classes``: the
    class names the labels may use (any, if ``None``).

    Raises:
        InputFileError: the manifest lists no photo, or an entry is malformed (no
            ``file``, no object size or one wider than the photo, a class not in
            ``classes``, a centre that is not a pixel of its photo, a ``partial`` that is
            not a list of regions); the message names the entry.
    """
    path = folder / "manifest.yaml"
    manifest = load_yaml_file(path, what="manifest")
    if not isinstance(manifest, dict) or not isinstance(manifest.get("images"), list):
        raise InputFileError(str(path), "expected a mapping with 'images'")
    if not manifest["images"]:
        raise InputFileError(str(path), "'images' is empty: list at least one labelled photo")
    photos = []
    for i, entry in enumerate(manifest["images"]):
        if not isinstance(entry, dict) or not isinstance(entry.get("file"), str):
            raise InputFileError(str(path), f"images[{i}]: expected a mapping with 'file'")
        where = f"images[{i}] ({entry['file']})"
        size = _size_px(entry, where, path)
        source = _source(entry, where, path)
        try:
            frame = read_image(folder / str(entry["file"]))
        except ImageError as exc:  # (which entry: the manifest's line, not only the photo)
            raise InputFileError(str(path), f"{where}: {exc.source}: {exc.reason}") from None
        labels = _centres(entry, where, path, frame.shape, classes)
        h, w = frame.shape[:2]
        if size > min(h, w):  # (scaled to nothing: no object that wide fits the photo)
            raise InputFileError(
                str(path),
                f"{where}: its 'shapes' gives objects {size:g} px wide, wider than the photo "
                f"({w}x{h} px): give the objects' width in the photo's pixels (~N px, "
                f"1 <= N <= {min(h, w)})",
            )
        scale = object_px / size
        boxes = _boxes(entry, where, path, scale)
        frame = cv2.resize(frame, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        photos.append(
            Photo(
                str(entry["file"]),
                source,
                frame,
                {name: c * scale for name, c in labels.items()},
                boxes,
                object_px,
                scale,
                where,
            )
        )
    return photos


def score(photo: Photo, found: Sequence[Detection]) -> Score:
    """Match detections to the photo's labels (class, within half an object)."""
    out = Score()
    left = {k: list(range(len(v))) for k, v in photo.centres.items()}
    for k in photo.centres:
        out.found[k] = out.missed[k] = out.false[k] = 0
    for d in found:
        u, v = d.centroid_px
        if any(x0 <= u <= x1 and y0 <= v <= y1 for x0, x1, y0, y1 in photo.ignore):
            continue
        labels = photo.centres.get(d.color, np.zeros((0, 2)))
        free = left.get(d.color, [])
        dist = [float(np.hypot(*(labels[i] - (u, v)))) for i in free]
        if dist and min(dist) <= photo.object_px / 2:
            free.pop(int(np.argmin(dist)))
            out.found[d.color] = out.found.get(d.color, 0) + 1
        else:
            out.false[d.color] = out.false.get(d.color, 0) + 1
    for k, free in left.items():
        out.missed[k] += len(free)
    return out


def _click(photo: Photo, name: str, index: int = 0) -> Sample:
    """One click on the ``index``-th labelled object of class ``name``.

    At its centre, or at its most coloured pixel within half an object when the centre is
    grey (a blown-out top): where a user would click.
    """
    u, v = photo.centres[name][index]
    r = int(photo.object_px / 2)
    h, w = photo.frame.shape[:2]
    y0, y1, x0, x1 = (
        max(int(v) - r, 0),
        min(int(v) + r + 1, h),
        max(int(u) - r, 0),
        min(int(u) + r + 1, w),
    )
    c = cv2.blur(chroma(lab_of(photo.frame[y0:y1, x0:x1])).astype(np.float32), (5, 5))
    if c[int(v) - y0, int(u) - x0] >= 2 * CHROMA_MIN:
        return Sample(name, float(u), float(v))
    j, i = np.unravel_index(int(np.argmax(c)), c.shape)
    return Sample(name, float(x0 + i), float(y0 + j))


def learned_config(config: Config, photo: Photo, clicks: Mapping[str, int] | None = None) -> Config:
    """``config`` with the colours taught by one click per class on ``photo``.

    ``clicks``: per class, which of its labelled objects is clicked (the first if absent).
    """
    names = [n for n, c in photo.centres.items() if len(c) and n in config.task.class_names]
    picked = clicks or {}
    samples = [_click(photo, n, picked.get(n, 0)) for n in names]
    taught = teach([photo.frame], samples, object_px=photo.object_px)
    classes = [
        c.model_copy(update={"learned_colour": taught.colours[c.name]})
        if c.name in taught.colours
        else c
        for c in config.task.classes
    ]
    vision = config.vision.model_copy(
        update={"reference_bgr": taught.reference_bgr, "work_area_px": taught.work_area_px}
    )
    return config.model_copy(
        update={"vision": vision, "task": config.task.model_copy(update={"classes": classes})}
    )


def refused_labels(
    manifest: Path, photo: Photo, exc: SampleError, clicks: Mapping[str, int] | None = None
) -> InputFileError:
    """A teaching's refusal as the manifest's fault, naming the labels clicked.

    The teacher names its samples in the scaled photo's pixels (``red=35,401``), which
    are nowhere in the manifest: the error names the entry and each refused class's
    clicked centre as labelled (the photo's own pixels), then the teacher's reason.
    """
    picked = clicks or {}
    named = []
    for name in dict.fromkeys(re.findall(r"([^\s=]+)=", exc.sample)):
        if name in photo.centres and len(photo.centres[name]):
            u, v = photo.centres[name][picked.get(name, 0)] / photo.scale
            named.append(f"objects.{name} centre [{u:g}, {v:g}]")
    labels = " and ".join(named) or exc.sample
    return InputFileError(
        str(manifest),
        f"{photo.entry}: a click on {labels} cannot teach its class: {exc.reason} "
        "(check that label)",
    )


def _detectors(config: Config) -> dict[str, Callable[[np.ndarray], Sequence[Detection]]]:
    cal = camera_geometry(config.calibration, config.camera)
    detector = ColorDetector(config.vision, cal, config.task.classes)
    plain = cal if isinstance(cal, Calibration) else None
    return {
        "mearm": detector.detect,
        "inRange": lambda f: detect_inrange(f, config.task.classes, config.vision, plain),
    }


def run_photo_bench(folder: Path, config: Config, *, learn: bool = False) -> list[dict]:
    """Recall and precision of the detector and the ``inRange`` recipe on labelled photos.

    Rows per photo, per source (``source <repo>``: scored as held out when the
    detector was developed on the others), per class (``scope``) and over all, for
    each detector (``who``):
    found, missed, false, recall, precision. With ``learn`` the detector's config is
    taught per source from its first photo that shows every class the source labels
    (:func:`teaching_photos`, :func:`learned_config`); the recipe keeps the config's hue
    bands (it has no learned colours).

    Raises:
        InputFileError: a bad manifest (:func:`load_photos`), a source with no photo to
            teach it from, or a click the teacher refuses (with ``learn``).
    """
    photos = load_photos(folder, object_px_of(config), config.task.class_names)
    groups: dict[str, list[Photo]] = {}
    for p in photos:
        groups.setdefault(p.source, []).append(p)
    manifest = folder / "manifest.yaml"
    plain = _detectors(config)
    taught = {}
    for src, group in groups.items() if learn else ():  # the shipped bands teach nothing
        first = teaching_photos(manifest, group, config)[0]
        try:
            taught[src] = _detectors(learned_config(config, first))["mearm"]
        except SampleError as exc:
            raise refused_labels(manifest, first, exc) from None
    totals: dict[str, Score] = {"mearm": Score(), "inRange": Score()}
    sources = {(src, who): Score() for src in groups for who in totals}
    rows = []
    for p in photos:
        runs = {"mearm": taught[p.source] if learn else plain["mearm"], "inRange": plain["inRange"]}
        for who, detect in runs.items():
            s = score(p, detect(p.frame))
            totals[who].add(s)
            sources[p.source, who].add(s)
            rows.append(_row(p.name, who, s))
    for (src, who), s in sources.items():
        rows.append(_row(f"source {src}", who, s))
    for who, s in totals.items():
        for name in s.found:
            one = Score({name: s.found[name]}, {name: s.missed[name]}, {name: s.false[name]})
            rows.append(_row(f"all photos, {name}", who, one))
        rows.append(_row("all photos", who, s))
    return rows


def _row(scope: str, who: str, s: Score) -> dict:
    found, missed, false = s.totals()
    return {
        "scope": scope,
        "who": who,
        "found": found,
        "missed": missed,
        "false": false,
        "recall": found / (found + missed) if found + missed else None,
        "precision": found / (found + false) if found + false else None,
    }


def _shown(photo: Photo, config: Config) -> set[str]:
    """The classes of ``config`` with at least one labelled object in ``photo``."""
    return {n for n, c in photo.centres.items() if len(c) and n in config.task.class_names}


def teaching_photos(manifest: Path, photos: Sequence[Photo], config: Config) -> list[Photo]:
    """The photos of one source a user can teach it from: those showing every class it labels.

    A photo without one of them would leave that class untaught, scored with the
    config's hue bands under the name of taught colours.

    Raises:
        InputFileError: no photo of the source shows all its classes (names the source).
    """
    labelled = set().union(*(_shown(p, config) for p in photos))
    fit = [p for p in photos if _shown(p, config) == labelled]
    if not fit:
        raise InputFileError(
            str(manifest),
            f"source {photos[0].source}: no photo shows every class it labels "
            f"({', '.join(sorted(labelled))}), so no one photo can teach it: "
            "add one that does, or label those objects on one",
        )
    return fit


def teachings(photos: Sequence[Photo], config: Config) -> Iterator[tuple[Photo, dict[str, int]]]:
    """Every way to teach one source with one photo and one click per class.

    Each photo of ``photos`` (one source's) that shows every class the source labels
    (of ``config``'s), with each combination of clicked objects: the first
    :data:`CLICKS_PER_CLASS` of each class; a photo that shows fewer teaches none.
    """
    labelled = set().union(*(_shown(p, config) for p in photos))
    for p in photos:
        names = sorted(_shown(p, config))
        if set(names) != labelled:
            continue
        counts = [range(min(len(p.centres[n]), CLICKS_PER_CLASS)) for n in names]
        for picked in itertools.product(*counts):
            yield p, dict(zip(names, picked, strict=True))


def run_click_study(folder: Path, config: Config) -> list[dict]:
    """The spread of recall and precision over every way a user could teach each source.

    Per source, its photos scored once per teaching (:func:`teachings`); over all sources,
    the totals of every combination of one teaching per source (a seeded sample of
    :data:`COMBINATIONS_MAX` when there are more). A teaching whose click the teacher
    refuses (a label off its object's colour: grey or black there) is left out and
    counted; a source whose every teaching is refused stops the study
    (:class:`~mearm.errors.InputFileError` naming the first refused label). Rows:
    ``scope`` (``source <repo>`` or ``all sources``), ``teachings`` (over all sources: the
    combinations), ``refused``, and the ``recall`` and ``precision`` quantiles
    (``min``, ``q10``, ``median``, ``max``) as fractions.
    """
    photos = load_photos(folder, object_px_of(config), config.task.class_names)
    sources: dict[str, list[Photo]] = {}
    for p in photos:
        sources.setdefault(p.source, []).append(p)
    per_source: dict[str, list[tuple[int, int, int]]] = {}
    refused: dict[str, int] = {}
    for src, group in sources.items():
        teaching_photos(folder / "manifest.yaml", group, config)  # none: refused, not left out
        totals = []
        first_refusal: InputFileError | None = None
        for photo, picked in teachings(group, config):
            try:
                taught = learned_config(config, photo, picked)
            except SampleError as exc:  # a label off its object's colour: a user clicks again
                refused[src] = refused.get(src, 0) + 1
                if first_refusal is None:
                    first_refusal = refused_labels(folder / "manifest.yaml", photo, exc, picked)
                continue
            detect = _detectors(taught)["mearm"]
            s = Score()
            for q in group:
                s.add(score(q, detect(q.frame)))
            totals.append(s.totals())
        if first_refusal is not None and not totals:  # no row for it would say why
            raise InputFileError(
                first_refusal.path,
                f"source {src}: each of its {refused[src]} teachings was refused; the first: "
                f"{first_refusal.reason}",
            )
        if totals:
            per_source[src] = totals
    rows = [_spread(f"source {src}", t, refused.get(src, 0)) for src, t in per_source.items()]
    if per_source:
        combined = _combined(list(per_source.values()))
        rows.append(_spread("all sources", combined, sum(refused.values())))
    return rows


def _combined(per_source: list[list[tuple[int, int, int]]]) -> list[tuple[int, int, int]]:
    """Found, missed, false summed over one teaching per source, for each combination."""
    n = 1
    for t in per_source:
        n *= len(t)
    if n <= COMBINATIONS_MAX:
        combos: Iterator[tuple[tuple[int, int, int], ...]] = itertools.product(*per_source)
    else:
        rng = np.random.default_rng(0)
        picks = [rng.integers(0, len(t), COMBINATIONS_MAX) for t in per_source]
        combos = (
            tuple(t[int(k[i])] for t, k in zip(per_source, picks, strict=True))
            for i in range(COMBINATIONS_MAX)
        )
    return [
        (sum(c[0] for c in combo), sum(c[1] for c in combo), sum(c[2] for c in combo))
        for combo in combos
    ]


def _spread(scope: str, totals: Sequence[tuple[int, int, int]], refused: int) -> dict:
    recall = sorted(f / (f + m) if f + m else 1.0 for f, m, _ in totals)
    precision = sorted(f / (f + x) if f + x else 1.0 for f, _, x in totals)
    return {
        "scope": scope,
        "teachings": len(totals),
        "refused": refused,
        "recall": _quantiles(recall),
        "precision": _quantiles(precision),
    }


def _quantiles(values: Sequence[float]) -> dict[str, float]:
    """min, q10 (the lower of the two neighbours), median and max of sorted ``values``."""
    return {
        "min": values[0],
        "q10": values[int(0.1 * (len(values) - 1))],
        "median": statistics.median(values),
        "max": values[-1],
    }
