"""``--annotate``: each detection's label is drawn once, on a filled box, readable."""

from __future__ import annotations

import numpy as np

from mearm import detect
from mearm.config import Config
from mearm.sim import TableRenderer, class_discs
from mearm.vision import Calibration, ColorDetector

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]


def _annotated(objects):
    frame = TableRenderer(CAL).render(class_discs(CONFIG.task.classes, objects))
    detector = ColorDetector(CONFIG.vision, CAL, CONFIG.task.classes)
    found = detector.detect(frame)
    records = detect.to_records(found, frame.shape)
    return frame, detect.annotate(frame, detector, records, found), records, found


def _boxes(records, found, shape):
    taken: list[tuple[int, int, int, int]] = []
    for rec, det in zip(records, found, strict=True):
        taken.append(detect.label_box(detect.label_text(rec), det.bbox_px, shape, taken))
    return taken


def test_each_label_is_drawn_once_on_its_box() -> None:
    """Every label's box holds exactly one drawing of its text: pixel for pixel the same
    as the text drawn once on a plain box of the class colour (a second drawing, e.g. an
    outline under the text, changes the anti-aliased pixels); boxes never overlap."""
    frame, drawn, records, found = _annotated(LAYOUT)
    assert len(found) == 12
    boxes = _boxes(records, found, frame.shape)
    bgr = {c.name: tuple(reversed(c.draw_rgb)) for c in CONFIG.task.classes}
    for rec, (x, y, w, h) in zip(records, boxes, strict=True):
        assert 0 <= x and x + w <= frame.shape[1] and 0 <= y and y + h <= frame.shape[0]
        once = np.zeros((h, w, 3), np.uint8)
        detect.draw_label(once, detect.label_text(rec), (0, 0, w, h), bgr[rec["color"]])
        crop = drawn[y : y + h, x : x + w]
        np.testing.assert_array_equal(crop, once, err_msg=rec["color"])
        box_px = np.all(crop == bgr[rec["color"]], axis=2).mean()
        text = np.array(detect.text_bgr(bgr[rec["color"]]), int)
        box = np.array(bgr[rec["color"]], int)
        c = crop.astype(int)
        inked = np.abs(c - text).sum(axis=2) < np.abs(c - box).sum(axis=2)
        assert box_px > 0.5 and inked.sum() > 5 * len(detect.label_text(rec))  # box, text
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            apart = a[0] + a[2] <= b[0] or b[0] + b[2] <= a[0]
            assert apart or a[1] + a[3] <= b[1] or b[1] + b[3] <= a[1], (a, b)


def test_text_contrasts_with_its_box() -> None:
    """Dark text on light boxes, light text on dark ones: luma difference > 100 levels."""
    for c in CONFIG.task.classes:
        box = tuple(reversed(c.draw_rgb))
        luma = [0.114 * b + 0.587 * g + 0.299 * r for b, g, r in (box, detect.text_bgr(box))]
        assert abs(luma[0] - luma[1]) > 100, c.name


def test_crowded_labels_do_not_cover_one_another() -> None:
    """Four objects in a row 2.5 cm apart: their labels are stacked, not drawn over."""
    objects = [("red", -4.0 + 2.5 * i, 45.0) for i in range(4)]
    frame, drawn, records, found = _annotated(objects)
    assert len(found) == 4
    boxes = _boxes(records, found, frame.shape)
    for i, a in enumerate(boxes):
        for b in boxes[i + 1 :]:
            apart = a[0] + a[2] <= b[0] or b[0] + b[2] <= a[0]
            assert apart or a[1] + a[3] <= b[1] or b[1] + b[3] <= a[1], (a, b)
    red = tuple(reversed(CONFIG.task.class_named("red").draw_rgb))
    for (x, y, w, h), rec in zip(boxes, records, strict=True):
        once = np.zeros((h, w, 3), np.uint8)
        detect.draw_label(once, detect.label_text(rec), (0, 0, w, h), red)
        np.testing.assert_array_equal(drawn[y : y + h, x : x + w], once)
