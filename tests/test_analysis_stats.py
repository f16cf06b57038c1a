"""Table 8 and Table 6 statistics: equal to NumPy's on the same data, route selection."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mearm.analysis import (
    Moments,
    error_table,
    iteration_stats,
    route_errors_cm,
    select_routes,
)
from mearm.analysis.synthetic import write_synthetic_log
from mearm.exceptions import AnalysisError
from mearm.runlog import read_runlog


@pytest.fixture(scope="module")
def log_and_errors(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray]:
    path = tmp_path_factory.mktemp("stats") / "trials.jsonl"
    errors = write_synthetic_log(path, n_routes=600, seed=3)
    return path, errors


def test_table8_matches_numpy_on_the_logged_errors(log_and_errors) -> None:
    """Every cell of Table 8 equals NumPy's mean / std(ddof=1) / max / min of the same data."""
    path, errors = log_and_errors
    routes = read_runlog(path).routes
    e = route_errors_cm(routes)
    np.testing.assert_allclose(e, errors, atol=1e-12)
    table = error_table(e)
    columns = {
        "x": errors[:, 0],
        "y": errors[:, 1],
        "z": errors[:, 2],
        "xy": np.sqrt(errors[:, 0] ** 2 + errors[:, 1] ** 2),
        "xyz": np.sqrt((errors**2).sum(axis=1)),
    }
    for name, values in columns.items():
        row = table.rows()[name]
        expected = (values.mean(), values.std(ddof=1), values.max(), values.min())
        np.testing.assert_allclose(row.as_tuple(), expected, rtol=1e-12, err_msg=name)
        assert row.n == len(errors)
    assert table.n == len(errors)


def test_table8_on_a_hand_made_sample() -> None:
    e = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, -2.0], [1.0, 2.0, 2.0]])
    t = error_table(e)
    assert t.xy.as_tuple()[2:] == (5.0, 0.0)
    np.testing.assert_allclose(t.xyz.as_tuple(), (10 / 3, np.std([5, 2, 3], ddof=1), 5.0, 2.0))
    np.testing.assert_allclose(t.z.mean, 0.0)


def test_one_value_has_no_std() -> None:
    m = Moments.of([0.5])
    assert (m.mean, m.max, m.min, m.n) == (0.5, 0.5, 0.5, 1) and np.isnan(m.std)


@pytest.mark.parametrize("bad", [np.zeros((0, 3)), np.zeros((4, 2)), np.zeros(3)])
def test_table8_refuses_bad_shapes(bad: np.ndarray) -> None:
    with pytest.raises(AnalysisError, match=r"shape \(N, 3\)|no routes"):
        error_table(bad)


def test_select_routes_by_step_and_attempt(log_and_errors) -> None:
    routes = read_runlog(log_and_errors[0]).routes
    picks = select_routes(routes, step="pick")
    places = select_routes(routes, step="place")
    first_picks = select_routes(routes, step="pick", first_attempt=True)
    assert len(picks) + len(places) == len(routes) == 600
    assert all(r.step == "pick" for r in picks) and all(r.step == "place" for r in places)
    retries = [r for r in picks if r.attempt > 1]
    assert retries, "the fixture should hold retried picks"
    assert len(first_picks) == len(picks) - len(retries)
    with pytest.raises(AnalysisError, match="step must be one of"):
        select_routes(routes, step="drop")  # type: ignore[arg-type]


def test_iteration_stats_match_numpy(log_and_errors) -> None:
    routes = read_runlog(log_and_errors[0]).routes
    st = iteration_stats(routes)
    it = np.array([r.iterations for r in routes])
    init = np.array([r.initial_error_cm for r in routes])
    final = np.array([r.final_error_cm for r in routes])
    assert st.n == len(routes)
    assert st.iterations.as_tuple() == pytest.approx(
        (it.mean(), it.std(ddof=1), it.max(), it.min())
    )
    assert st.initial_error_cm.mean == pytest.approx(init.mean())
    assert st.final_error_cm.max == pytest.approx(final.max())
    assert st.statuses == {"converged": len(routes)}


def test_iteration_stats_need_routes() -> None:
    with pytest.raises(AnalysisError, match="no routes"):
        iteration_stats([])
