"""A campaign spec's goal radius flies and judges (issue 24 item 1): the paper's straight line with sea-grade
fixes (2 m every 5 s) COMPLETEs with a 4 m radius (MAVLink param2's meaning), judged by that radius (the
truth within it where the vehicle said COMPLETE: no false COMPLETE); with the packaged 0.5 m the vehicle
cannot confirm it and says so, never a false COMPLETE."""

from __future__ import annotations

from auv_campaign.runner import fly
from auv_campaign.spec import parse_spec

START = {"x_m": -13, "y_m": 0, "depth_m": 1, "yaw_deg": 0}


def _run(goal: dict[str, float]):  # type: ignore[no-untyped-def]
    spec = {
        "name": "radius",
        "missions": [{"name": "straight", "start": START, "goals": [goal]}],
        "sweep": {"profile": ["sea"]},
    }
    (run,) = parse_spec(spec, "radius.yaml").runs
    return fly(run).row


def test_a_sea_mission_completes_within_the_goals_own_radius() -> None:
    row = _run({"x_m": 15, "y_m": 0, "depth_m": 1, "yaw_deg": 0, "radius_m": 4})
    assert row["final_state"] == "COMPLETE", row["final_reason"]
    assert row["false_complete"] is False and row["success"] is True, row
    (goal,) = row["goal_figures"]
    assert goal["radius_m"] == 4.0 and goal["position_error_m"] <= 4.0


def test_without_a_radius_the_sea_mission_is_never_a_false_complete() -> None:
    row = _run({"x_m": 15, "y_m": 0, "depth_m": 1, "yaw_deg": 0})
    assert not row["false_complete"], row["final_reason"]
    assert row["final_state"] != "COMPLETE" or row["success"], row["final_reason"]
