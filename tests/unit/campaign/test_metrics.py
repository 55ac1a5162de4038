"""The figures of a run from synthetic truth rows: the crossing judged, false COMPLETE, clearance,
saturation, and what a run that never moved reports."""

from __future__ import annotations

import math

import pytest

from auv_campaign.metrics import run_row
from auv_campaign.spec import parse_spec
from hil_sim.bench_program import TRUTH_COLUMNS
from hil_sim.metrics import compute_metrics
from onboard.core.control.actuators import ActuatorLimits

COL = {c: i for i, c in enumerate(TRUTH_COLUMNS)}
LIMITS = ActuatorLimits()
LINE = [[x / 10.0, 0.0, 0.0] for x in range(0, 101)]  # the nominal path: x 0 -> 10 m along y = 0


def _spec(obstacles: list[dict[str, float]] | None = None):  # type: ignore[no-untyped-def]
    mission = {"name": "m", "start": {"x_m": 0, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
               "goals": [{"x_m": 10, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]}  # fmt: skip
    if obstacles:
        mission["obstacles"] = obstacles
    return parse_spec({"name": "t", "missions": [mission]}, "t.yaml").runs[0]


def _row(
    t: float, x: float, y: float, state: str = "RUNNING", rudder: float = 0.0, rps: float = 20.0
) -> list:
    r: list = [0.0] * len(TRUTH_COLUMNS)
    r[COL["t_s"]], r[COL["x_m"]], r[COL["y_m"]], r[COL["depth_m"]] = t, x, y, 1.0
    r[COL["rudder_cmd_rad"]], r[COL["propeller_cmd_rps"]] = rudder, rps
    r[COL["onboard_state"]] = state
    return r


def _straight(y: float, state_at_end: str = "COMPLETE", until_x: float = 10.5) -> list[list]:
    rows, x, t = [], 0.0, 0.0
    while x <= until_x + 1e-9:
        rows.append(_row(t, x, y, state_at_end if x >= 10.0 else "RUNNING"))
        x, t = x + 0.05, t + 0.05
    return rows


def _row_of(truth: list[list], **kw: object) -> dict:
    args = {"planned": True, "final_state": "COMPLETE", "final_reason": "", "time_limit_s": 60.0,
            "arrival_radius_m": 0.5, "limits": LIMITS, **kw}  # fmt: skip
    return run_row(_spec(), truth, LINE, **args)


def test_a_clean_arrival_is_a_success_judged_on_the_truth() -> None:
    row = _row_of(_straight(0.1))
    assert row["completed"] and row["success"] and not row["false_complete"]
    assert row["final_position_error_m"] == pytest.approx(0.1, abs=1e-6)
    assert row["final_course_error_deg"] == pytest.approx(0.0, abs=1e-6)
    assert row["min_clearance_m"] is None  # no obstacle


def test_complete_declared_far_from_the_goal_is_a_false_complete() -> None:
    row = _row_of(_straight(0.8))  # the truth crosses 0.8 m off: beyond the 0.5 m arrival radius
    assert row["false_complete"] and not row["success"]


def test_the_crossing_judged_is_the_one_the_vehicle_claimed() -> None:
    # a first pass 0.25 m off (the vehicle called it a miss), a loop back, a second pass 0.45 m off: COMPLETE
    first = [_row(0.05 * i, 0.05 * i, 0.25) for i in range(0, 211)]  # to x = 10.5
    t0 = first[-1][0]
    loop = [_row(t0 + 0.05 * (i + 1), 10.5 - 0.05 * (i + 1), 0.25 + 0.01 * (i + 1)) for i in range(40)]
    x_back = loop[-1][1]
    second = []
    t = loop[-1][0]
    x = x_back
    while x < 10.6:
        t, x = t + 0.05, x + 0.05
        second.append(_row(t, x, 0.45, "COMPLETE" if x >= 10.0 else "RUNNING"))
    truth = first + loop + second
    row = _row_of(truth)
    assert row["final_position_error_m"] == pytest.approx(0.45, abs=1e-6)
    assert row["success"] is False  # 0.45 m > the 0.3 m success bound
    assert row["time_to_goal_s"] > t0
    # without a claim, the first crossing is the arrival
    rows = [{"t_s": r[0], "x_m": r[1], "y_m": r[2], "depth_m": r[3], "yaw_deg": 0.0} for r in truth]
    assert compute_metrics(rows, LINE, (10.0, 0.0, 0.0))["final_position_error_m"] == pytest.approx(0.25)


def test_clearance_is_negative_inside_an_obstacle_and_saturation_is_counted() -> None:
    truth = _straight(0.0)
    for r in truth[:10]:
        r[COL["rudder_cmd_rad"]] = LIMITS.rudder_limit_rad
    spec = _spec([{"x_m": 5.0, "y_m": 0.5, "radius_m": 1.0}])
    row = run_row(spec, truth, LINE, planned=True, final_state="COMPLETE", final_reason="",
                  time_limit_s=60.0, arrival_radius_m=0.5, limits=LIMITS)  # fmt: skip
    assert row["min_clearance_m"] == pytest.approx(-0.5, abs=1e-6)
    assert row["success"] is False  # it went through the obstacle
    assert row["fin_saturation_fraction"] == pytest.approx(10 / len(truth))
    assert math.isfinite(row["control_effort_rad"])


def test_a_run_that_never_moved_reports_nothing_it_does_not_know() -> None:
    row = _row_of([], planned=False, final_state="HOLD", final_reason="never under way: cannot plan goal 0")
    assert row["planned"] is False and row["completed"] is False and row["success"] is False
    assert row["final_position_error_m"] is None and row["time_to_goal_s"] is None
    assert row["final_reason"].startswith("never under way")
