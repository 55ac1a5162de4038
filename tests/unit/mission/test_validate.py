"""The one mission validator: limits from CoreConfig, all limit problems reported, then every leg planned."""

from __future__ import annotations

import math

import pytest

from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, MissionError, Obstacle
from onboard.core.mission.params import MissionParams
from onboard.core.mission.validate import (
    MISSION_INDEX,
    MissionCheck,
    Problem,
    check_goal_values,
    check_mission,
)
from onboard.core.safety.failsafe import FailsafeParams

CFG = CoreConfig(failsafe=FailsafeParams(max_depth_m=20.0))


def g(x: float, y: float, depth: float = 1.0, yaw_deg: float | None = None) -> Goal:
    return Goal(x, y, depth, None if yaw_deg is None else math.radians(yaw_deg))


FEASIBLE = Mission((g(20, 0, 1, 0), g(40, 10, 2), g(10, 30, 3)), (Obstacle(30, 5, 1.0),))


def test_a_feasible_three_goal_mission_is_ok() -> None:
    check = check_mission(FEASIBLE, CFG)
    assert check.ok and check.problems == () and check.first is None
    assert str(check) == "mission ok"


def test_goal_inside_an_obstacle_is_refused_naming_the_goal_and_the_obstacle() -> None:
    m = Mission((g(20, 0), g(40, 10), g(10, 30)), (Obstacle(30, 5, 1.0), Obstacle(10, 31, 1.5)))
    check = check_mission(m, CFG)
    assert not check.ok
    (p,) = check.problems
    assert (p.item, p.index, p.field) == ("goal", 2, "plan")
    assert str(p).startswith("goal 2: ") and "obstacle 1" in str(p)


def test_depth_at_or_below_the_failsafe_limit_is_refused() -> None:
    check = check_mission(Mission((g(10, 0, 1), g(30, 0, 25))), CFG)
    assert check.problems == (
        Problem("goal", 1, "depth", "depth 25 m is below the failsafe depth limit 20 m"),
    )
    assert str(check.first) == "goal 1: depth 25 m is below the failsafe depth limit 20 m"
    # at the limit: a goal there could never be completed (the failsafe aborts at that depth)
    assert check_mission(Mission((g(10, 0, 20.0),)), CFG).first.field == "depth"  # type: ignore[union-attr]
    # issue 23: the stop after a goal needs STOP_DEPTH_MARGIN_M (0.25 m) above the limit (19.9 m was accepted)
    assert check_mission(Mission((g(10, 0, 19.7),)), CFG).ok


def test_depth_above_the_surface_is_refused_by_the_validator_not_the_model() -> None:
    m = Mission((g(10, 0, -1.0),))
    m.validate()  # the model checks only finiteness: one copy of "depth >= 0", here:
    assert check_mission(m, CFG).first == Problem("goal", 0, "depth", "depth -1 m is above the surface")
    # a configuration-free rule: every door asks it (campaign specs, persisted plans) with check_goal_values
    above = Problem("goal", 0, "depth", "depth -1 m is above the surface")
    assert check_goal_values(0, m.goals[0]) == [above]


def test_too_many_goals_are_refused() -> None:
    cap = CoreConfig().mission.max_goals
    m = Mission(tuple(g(float(i % 100), 0.0) for i in range(cap + 1)))
    check = check_mission(m, CoreConfig())
    assert check.problems == (
        Problem("mission", MISSION_INDEX, "count", f"{cap + 1} goals exceed the capacity {cap} (max_goals)"),
    )
    assert str(check.first).startswith("mission: 1001 goals")


def test_capacities_come_from_the_mission_table() -> None:
    cfg = CoreConfig(mission=MissionParams(max_goals=2, max_obstacles=1))
    m = Mission((g(10, 0), g(20, 0), g(30, 0)), (Obstacle(0, 50, 1), Obstacle(0, -50, 1)))
    assert [p.field for p in check_mission(m, cfg).problems] == ["count", "count"]
    assert check_mission(Mission(()), CFG).ok  # no goals is "no mission" (a clear): valid


def test_a_goal_outside_the_operating_area_is_refused() -> None:
    check = check_mission(Mission((g(10, 0), g(5000, 0))), CFG)
    assert check.problems == (
        Problem("goal", 1, "x", "x 5000 m is outside the failsafe operating area [-500, 500] m"),
    )
    cfg = CoreConfig(failsafe=FailsafeParams(area_y_min_m=-20.0, area_y_max_m=20.0))
    assert check_mission(Mission((g(10, 30),)), cfg).first.field == "y"  # type: ignore[union-attr]


def test_nan_and_infinity_are_refused_and_every_limit_problem_is_reported() -> None:
    m = Mission(
        (g(math.nan, 0), g(10, 0, math.inf), Goal(20, 0, 1, math.nan), g(30, 0, 30)),
        (Obstacle(0, 0, math.nan),),
    )
    check = check_mission(m, CFG)
    fields = [(p.item, p.index, p.field) for p in check.problems]
    assert fields == [
        ("goal", 0, "x"),
        ("goal", 1, "depth"),
        ("goal", 2, "yaw"),
        ("goal", 3, "depth"),
        ("obstacle", 0, "radius"),
    ]
    assert str(check.problems[0]) == "goal 0: x is not a finite number: nan"
    with pytest.raises(MissionError, match="goal 0: x_m is not a finite number"):
        m.validate()


def test_obstacle_rules() -> None:
    base = (g(10, 0),)
    bad_radius = check_mission(Mission(base, (Obstacle(50, 50, 0.0),)), CFG)
    assert bad_radius.first == Problem("obstacle", 0, "radius", "radius 0 m must be positive")
    # an obstacle that overlaps the area boundary is fine; one that cannot reach into the area is not
    assert check_mission(Mission(base, (Obstacle(505, 0, 10.0),)), CFG).ok
    far = check_mission(Mission(base, (Obstacle(0, -600, 10.0),)), CFG)
    assert far.first is not None and (far.first.item, far.first.field) == ("obstacle", "y")
    # whether a centre fits a MAVLink item is the encoding's rule, not the core's (test_mission_file.py)
    huge = check_mission(Mission(base, (Obstacle(1e6, 0, 999e3),)), CFG)
    assert huge.first is not None and "not encodable" not in huge.first.reason


def test_a_yaw_within_360_deg_or_none_is_accepted_and_beyond_is_refused_naming_the_goal() -> None:
    """Issue 21 row 16: the yaw rule, as the door received it (not wrapped): None or within +-360 deg."""
    turn = math.radians(360.0)
    assert check_mission(Mission((Goal(10, 0, 1, 6.0), Goal(30, 0, 1, None))), CFG).ok
    assert check_mission(Mission((Goal(10, 0, 1, turn), Goal(30, 0, 1, -turn))), CFG).ok
    for yaw in (7.0, -7.0, math.radians(999.0), 1e300, math.inf):
        first = check_mission(Mission((Goal(10, 0, 1, None), Goal(30, 0, 1, yaw))), CFG).first
        assert first is not None and (first.item, first.index, first.field) == ("goal", 1, "yaw"), first
    assert str(check_goal_values(1, Goal(0, 0, 1, math.radians(999.0)))[0]).startswith(
        "goal 1: yaw 999 deg is outside [-360, 360] deg"
    )


def test_limit_problems_skip_planning() -> None:
    # goal 1 is too deep and leg 1 -> 2 could not be planned either (depth slope): only the limit is reported
    m = Mission((g(10, 0, 1), g(10.5, 0, 21), g(11, 0, 1)))
    assert [p.field for p in check_mission(m, CFG).problems] == ["depth"]


def test_an_infeasible_leg_names_the_goal_and_the_planner_reason() -> None:
    m = Mission((g(10, 0, 1), g(12, 0, 15)))  # 14 m of depth in 2 m of path: a helix (issue 23)
    assert check_mission(m, CFG).ok
    # heading north from goal 0 between two rows of obstacles: no helix circle fits, refused at upload
    fence = tuple(Obstacle(x, y, 1.0) for x in range(0, 24, 2) for y in (-8.0, 8.0))
    fenced = Mission((g(10, 0, 1, 0), g(12, 0, 15)), fence)
    (p,) = check_mission(fenced, CFG).problems
    assert (p.item, p.index, p.field) == ("goal", 1, "plan")
    assert "depth_slope" in p.reason and "from goal 0" in p.reason and "helix" in p.reason


def test_leg_zero_is_planned_from_the_start_pose_when_given() -> None:
    m = Mission((g(20, 0, 1, 0), g(40, 0, 2, 0)))
    assert check_mission(m, CFG).ok
    assert check_mission(m, CFG, start_pose=(0.0, 0.0, 0.0, 0.0)).ok
    # from 15 m deep, 20 m of path cannot climb to 1 m: a helix (issue 23), unless obstacles block it
    assert check_mission(m, CFG, start_pose=(0.0, 0.0, 15.0, 0.0)).ok
    fence = tuple(Obstacle(x, y, 1.0) for x in range(-6, 26, 2) for y in (-8.0, 8.0))
    check = check_mission(Mission(m.goals, fence), CFG, start_pose=(0.0, 0.0, 15.0, 0.0))
    (p,) = check.problems
    assert (p.index, p.field) == (0, "plan") and "the start pose" in p.reason and "depth_slope" in p.reason
    # a start pose inside an (inflated) obstacle
    m2 = Mission((g(20, 0, 1, 0),), (Obstacle(0, 1, 1.0),))
    assert "start_in_obstacle" in check_mission(m2, CFG, start_pose=(0.0, 0.0, 1.0, 0.0)).problems[0].reason
    # an unknown (non-finite) start pose is no start pose
    assert check_mission(m, CFG, start_pose=(math.nan, 0.0, 15.0, 0.0)).ok


def test_a_free_yaw_leg_starts_with_the_previous_leg_end_yaw() -> None:
    # goal 0 has a free yaw: leg 1 starts where leg 0 (from the start pose) ended, heading north
    m = Mission((g(20, 0, 1), g(20, 6, 1, 0)))
    assert check_mission(m, CFG, start_pose=(0.0, 0.0, 1.0, 0.0)).ok


def test_the_deadline_stops_planning() -> None:
    check = check_mission(FEASIBLE, CFG, expired=lambda: True)
    assert check.problems == (
        Problem("mission", MISSION_INDEX, "plan", "the deadline passed while planning the leg to goal 1"),
    )


def test_mission_check_summary() -> None:
    c = MissionCheck((Problem("goal", 1, "x", "a"), Problem("goal", 2, "y", "b")))
    assert not c.ok and str(c) == "goal 1: a (and 1 more)"
