"""Scenario metrics from the truth log and the planned polyline (pure)."""

from __future__ import annotations

import pytest

from hil_sim.metrics import compute_metrics

LINE = [[float(x), 0.0, 0.0] for x in range(0, 11)]  # a straight path north from (0, 0) to (10, 0)


def row(t: float, x: float, y: float) -> dict[str, float]:
    return {"t_s": t, "x_m": x, "y_m": y, "depth_m": 1.0, "yaw_deg": 0.0}


def test_arrival_is_interpolated_to_the_goal_line() -> None:
    # GIVEN truth samples 0.5 m apart with 0.2 m offset, crossing x = 10 between 9.8 and 10.3
    truth = [row(0.1 * i, 0.5 * i, 0.2) for i in range(20)] + [row(2.0, 9.8, 0.2), row(2.1, 10.3, 0.1)]
    m = compute_metrics(truth, LINE, (10.0, 0.0, 0.0))
    # THEN the final errors are at the crossing (y interpolated 40 % of the way), not at the next sample
    assert m["completed"]
    assert m["arrival_time_s"] == pytest.approx(2.04)
    assert m["final_y_error_m"] == pytest.approx(-0.16)
    assert m["final_x_error_m"] == pytest.approx(0.0, abs=1e-9)
    assert m["max_cross_track_m"] == pytest.approx(0.2)


def test_no_extrapolation_when_the_previous_sample_is_already_past_the_line() -> None:
    truth = [row(0.0, 10.04, 0.3), row(0.1, 10.041, 0.3)]  # starts past the goal line
    m = compute_metrics(truth, LINE, (10.0, 0.0, 0.0))
    assert m["arrival_time_s"] == pytest.approx(0.0)
    assert m["final_y_error_m"] == pytest.approx(-0.3)


def test_not_arriving_reports_the_last_sample() -> None:
    m = compute_metrics([row(0.0, 0.0, 0.0), row(1.0, 5.0, 0.5)], LINE, (10.0, 0.0, 0.0))
    assert not m["completed"] and m["final_x_error_m"] == pytest.approx(5.0)
