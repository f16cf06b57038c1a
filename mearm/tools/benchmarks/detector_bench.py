"""The ``vision`` section: the detector's ms per frame beside its NumPy/SciPy port."""

from __future__ import annotations

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, section


@section("vision")
def bench_vision(options: BenchOptions) -> list[Row]:
    """Detector ms per 640x480 frame vs a NumPy/SciPy port of the recipe; accuracy."""
    from mearm.tools.vision_bench import (  # noqa: PLC0415
        run_calibration_study,
        run_detection_peers,
        run_vision_accuracy,
        run_vision_bench,
    )

    rows = run_vision_bench(max(20, 10 * options.repeat))
    rows += run_detection_peers(max(20, 10 * options.repeat))
    rows += run_vision_accuracy() + run_calibration_study()
    return [Row(**r) for r in rows]
