"""The one mission item encoding (``auv_common.mission_items``) and the one YAML mission parser
(``auv_common.mission_yaml``), which the vehicle, the ground station and campaigns share: round trips."""

from __future__ import annotations

import math

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from auv_common import mission_items as enc
from auv_common import mission_yaml as my
from auv_common.mission_items import MissionItem, Origin
from auv_common.mission_yaml import Circle, GoalPose

local_e4 = st.integers(enc.INT32_MIN, enc.INT32_MAX)  # every local x / y MISSION_ITEM_INT carries
finite = st.floats(allow_nan=False, allow_infinity=False, width=32)  # MAVLink's float fields
yaw_deg = st.one_of(st.none(), st.floats(-360.0, 360.0, width=32))
metres = st.floats(-200_000.0, 200_000.0)  # inside the encodable +-214748.3647 m
origin = st.builds(Origin, st.floats(-80.0, 80.0), st.floats(-180.0, 180.0), st.floats(-100.0, 100.0))


@given(x=local_e4, y=local_e4, depth_m=finite, yaw=yaw_deg)
def test_a_local_waypoint_item_reads_as_a_goal_and_encodes_back_to_the_same_item(
    x: int, y: int, depth_m: float, yaw: float | None
) -> None:
    # GIVEN a local-frame waypoint item as our ground station and the vehicle write it
    item = enc.goal_item(GoalPose(x / enc.LOCAL_SCALE, y / enc.LOCAL_SCALE, depth_m, yaw))
    assert (item.x, item.y) == (x, y)  # metres -> int32 is exact on the 1e-4 m grid
    # WHEN it is read as a plain goal (no origin: a local item needs none) and encoded again
    goal = enc.goal_of_item(item, None)
    assert goal is not None
    # THEN it is the same item (a free yaw is NaN on the wire, None in the file)
    assert enc.goal_item(goal).key() == item.key()
    assert goal.depth_m == depth_m and goal.yaw_deg == yaw


@given(x_m=metres, y_m=metres, radius_m=st.floats(0.01, 1e4))
def test_an_obstacle_encodes_within_half_a_grid_step_and_reads_back(
    x_m: float, y_m: float, radius_m: float
) -> None:
    item = enc.obstacle_item(Circle(x_m, y_m, radius_m))
    circle = enc.circle_of_item(item, None)
    assert circle is not None and circle.radius_m == radius_m
    assert abs(circle.x_m - x_m) <= 0.5 / enc.LOCAL_SCALE + 1e-9
    assert abs(circle.y_m - y_m) <= 0.5 / enc.LOCAL_SCALE + 1e-9
    assert enc.obstacle_item(circle) == item


@given(o=origin, north_m=st.floats(-5000.0, 5000.0), east_m=st.floats(-5000.0, 5000.0), alt_m=finite)
def test_a_global_item_projects_about_the_origin_and_back(
    o: Origin, north_m: float, east_m: float, alt_m: float
) -> None:
    # GIVEN a point near the origin as lat/lon degrees (the flat-earth inverse)
    lat, lon = enc.local_to_global(north_m, east_m, o)
    # THEN the projection gives the metres back
    x_m, y_m = enc.global_to_local(lat, lon, o)
    assert x_m == pytest.approx(north_m, abs=1e-6) and y_m == pytest.approx(east_m, abs=1e-6)
    # AND an item in each global frame reads as the vehicle reads it: depth = -altitude (relative to the
    # origin's altitude in the AMSL frames)
    for frame in enc.GLOBAL_FRAMES:
        item = MissionItem(
            frame, enc.WAYPOINT, 0.0, 0.0, 0.0, math.nan, round(lat * 1e7), round(lon * 1e7), alt_m
        )
        where = enc.item_position(item, o)
        assert where is not None
        want_depth = -(alt_m - o.alt_m) if frame in enc.AMSL_FRAMES else -alt_m
        assert where[2] == want_depth
        assert where[0] == pytest.approx(north_m, abs=0.02) and where[1] == pytest.approx(east_m, abs=0.02)
        assert enc.item_position(item, None) is None  # no origin: no metres


@given(
    items=st.lists(st.builds(lambda x, y: enc.goal_item(GoalPose(x / 1e4, y / 1e4, 1.0)), local_e4, local_e4))
)
def test_the_home_placeholder_is_the_first_amsl_waypoint_only(items: list[MissionItem]) -> None:
    home = enc.home_item(35.1, 129.04, 0.0)
    assert enc.home_offset(items) == 0  # local goals are never home
    assert enc.home_offset([home, *items]) == 1
    relative = MissionItem(enc.RELATIVE_FRAMES[0], enc.WAYPOINT, 0, 0, 0, 0, home.x, home.y, 0.0)
    assert enc.home_offset([relative, *items]) == 0  # a relative-altitude first item is a goal


@given(
    item=st.builds(
        MissionItem,
        st.sampled_from(enc.VEHICLE_FRAMES),
        st.sampled_from((enc.WAYPOINT, enc.FENCE_CIRCLE)),
        *(st.one_of(st.just(math.nan), finite) for _ in range(4)),
        local_e4,
        local_e4,
        st.one_of(st.just(math.nan), finite),
        st.integers(0, 1),
    )
)
def test_a_stored_item_round_trips_through_json(item: MissionItem) -> None:
    assert MissionItem.from_json(item.to_json()).key() == item.key()


@pytest.mark.parametrize("value", [math.inf, math.nan, 214_748.4, -214_748.5])
def test_a_position_no_int32_carries_is_refused_by_the_encoding(value: float) -> None:
    assert not enc.fits_local(value)
    with pytest.raises(enc.EncodingError):
        enc.goal_item(GoalPose(value, 0.0, 1.0))
    assert enc.fits_local(214_748.3647) and enc.fits_local(-214_748.3648)


# ---- the YAML format ----------------------------------------------------------------------------------
numbers = st.one_of(st.integers(-(10**6), 10**6), st.floats(allow_nan=False, allow_infinity=False))
goals = st.builds(GoalPose, numbers, numbers, numbers, st.one_of(st.none(), numbers))
circles = st.builds(Circle, numbers, numbers, numbers)


@given(plan=st.builds(my.MissionPlan, st.lists(goals).map(tuple), st.lists(circles).map(tuple)))
def test_a_plan_written_as_yaml_parses_back_to_the_same_plan(plan: my.MissionPlan) -> None:
    text = yaml.safe_dump(my.plan_data(plan), sort_keys=False)
    assert my.parse_plan(yaml.safe_load(text)) == plan


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"goals": [{"x_m": 1, "y_m": 2}]}, "goals[0].depth_m: missing"),
        ({"goals": [{"x_m": 1, "y_m": 2, "depth_m": True}]}, "goals[0].depth_m: expected a number, got True"),
        (
            {"goals": [{"x_m": "1e-3", "y_m": 0, "depth_m": 1}]},
            "goals[0].x_m: expected a number, got '1e-3' (YAML",
        ),
        ({"goals": [{"x_m": 1, "y_m": 0, "depth_m": 1, "speed": 2}]}, "goals[0].speed: unknown key (known: "),
        ({"obstacles": [{"x_m": 0, "y_m": 0}]}, "obstacles[0].radius_m: missing"),
        ({"goals": {"x_m": 1}}, "goals: expected a list"),
        ({"waypoints": []}, "waypoints: unknown key (known: goals, obstacles)"),
        ([1, 2], "expected a mapping with goals and/or obstacles"),
        ({"goals": [{"x_m": 10**400, "y_m": 0, "depth_m": 1}]}, "goals[0].x_m: 1000"),
    ],
)
def test_a_format_problem_is_one_line_naming_the_key(data: object, message: str) -> None:
    with pytest.raises(my.MissionYamlError) as err:
        my.parse_plan(data)
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_values_are_the_vehicles_to_judge_not_the_parsers() -> None:
    # a NaN depth, an infinite x, a yaw of 999 deg, a radius of 0 are well formed: the validator refuses them
    plan = my.parse_plan(
        {
            "goals": [{"x_m": math.inf, "y_m": 0, "depth_m": math.nan, "yaw_deg": 999}],
            "obstacles": [{"x_m": 0, "y_m": 0, "radius_m": 0}],
        }
    )
    assert plan.goals[0].yaw_deg == 999 and plan.obstacles[0].radius_m == 0
