"""`mearm analyze` says on every figure where a log's data came from.

Only report.md used to say "the simulated arm … not hardware": the tables on stdout, the
JSON and the PNG files (copied into docs on their own) did not. A simulated log's
figures are labelled simulated, a synthetic log's synthetic, on stdout, in the JSON and
on each plot (drawn above it and kept in the PNG's ``Source`` text field).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from PIL import Image

from mearm.analysis.synthetic import write_synthetic_log
from mearm.analyze import LOG_OUTPUT_NAMES, main

SIMULATED = "the simulated arm (servo backend 'sim', quantization 'microsecond'): not hardware"
SYNTHETIC = "synthetic data from mearm.analysis.synthetic: neither a simulation nor hardware"


def _simulated_log(path: Path) -> Path:
    """A log as a simulated run writes it: the synthetic one without its flag (sim.yaml)."""
    write_synthetic_log(path, n_routes=120, seed=2)
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    for record in lines:
        record.pop("synthetic", None)
    path.write_text("".join(json.dumps(r) + "\n" for r in lines))
    return path


@pytest.mark.parametrize("kind", ["simulated", "synthetic"])
def test_every_figure_of_a_log_names_its_source(
    kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "trials.jsonl"
    if kind == "simulated":
        label = SIMULATED
        _simulated_log(log)
    else:
        label = SYNTHETIC
        write_synthetic_log(log, n_routes=120, seed=2)
    out = tmp_path / "report"
    assert main([str(log), "--out", str(out)]) == 0
    assert capsys.readouterr().out.splitlines()[0] == f"{log}: {label}"
    for name in LOG_OUTPUT_NAMES:
        with Image.open(out / name) as png:
            assert png.info.get("Source") == label, name
    assert main([str(log), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["analysis"]["produced_by"] == label
