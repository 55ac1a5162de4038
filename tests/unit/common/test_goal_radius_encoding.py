"""A goal's acceptance radius on the wire and in files (issue 24 item 1): MAVLink NAV_WAYPOINT param2 (0 = the
vehicle's default) in the one item encoding, ``radius_m`` in the one YAML parser; both round trip."""

from __future__ import annotations

import math

import pytest
import yaml

from auv_common import mission_items as enc
from auv_common import mission_yaml as my
from auv_common.mission_yaml import GoalPose


def test_param2_carries_the_goals_radius_and_reads_back() -> None:
    item = enc.goal_item(GoalPose(12.5, -3.0, 2.0, 90.0, radius_m=3.5))
    assert item.command == enc.WAYPOINT and item.param2 == 3.5
    assert enc.goal_of_item(item, None) == GoalPose(12.5, -3.0, 2.0, 90.0, radius_m=3.5)


def test_a_goal_without_a_radius_sends_0_the_vehicles_default() -> None:
    item = enc.goal_item(GoalPose(1.0, 2.0, 1.0))
    assert item.param2 == 0.0
    goal = enc.goal_of_item(item, None)
    assert goal is not None and goal.radius_m == 0.0


@pytest.mark.parametrize("param2", [math.nan, 0.0])
def test_param2_nan_or_0_from_other_stations_is_the_default(param2: float) -> None:
    # QGC and MAVProxy send 0; older ground stations (ours before issue 24) sent NaN
    item = enc.MissionItem(enc.FRAME_LOCAL, enc.WAYPOINT, 0.0, param2, 0.0, math.nan, 10_000, 0, 1.0)
    assert enc.radius_of_item(item) == 0.0


def test_param2_as_sent_is_kept_for_the_vehicle_to_judge() -> None:
    item = enc.MissionItem(enc.FRAME_LOCAL, enc.WAYPOINT, 0.0, -2.0, 0.0, math.nan, 10_000, 0, 1.0)
    assert enc.radius_of_item(item) == -2.0


def test_yaml_radius_m_per_goal_parses_and_writes_back() -> None:
    text = (
        "goals:\n"
        "  - {x_m: 15, y_m: 0, depth_m: 1, yaw_deg: 0, radius_m: 3}\n"
        "  - {x_m: 30, y_m: 5, depth_m: 1}\n"
    )
    plan = my.parse_plan(yaml.safe_load(text))
    assert [g.radius_m for g in plan.goals] == [3.0, 0.0]
    data = my.plan_data(plan)
    assert data["goals"][0]["radius_m"] == 3.0 and "radius_m" not in data["goals"][1]  # 0: the default
    assert my.parse_plan(data) == plan


@pytest.mark.parametrize(
    ("value", "problem"),
    [("true", "expected a number, got True"), ("'3 m'", "expected a number, got '3 m'")],
)
def test_yaml_radius_m_must_be_a_number(value: str, problem: str) -> None:
    data = yaml.safe_load(f"goals: [{{x_m: 1, y_m: 0, depth_m: 1, radius_m: {value}}}]")
    with pytest.raises(my.MissionYamlError) as err:
        my.parse_plan(data)
    assert str(err.value) == f"goals[0].radius_m: {problem}"


def test_a_start_pose_has_no_radius() -> None:
    with pytest.raises(my.MissionYamlError) as err:
        my.parse_goal(
            "start", {"x_m": 0, "y_m": 0, "depth_m": 1, "yaw_deg": 0, "radius_m": 3}, yaw_required=True
        )
    assert str(err.value).startswith("start.radius_m: unknown key")
