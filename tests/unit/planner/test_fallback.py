"""Unit tests of the planner's tighter-radius fallback (``[planner] min_turning_radius_m``)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.validate import check_mission
from onboard.core.planner import PlannerConfig, PlannerError, plan
from onboard.core.planner.path import StraightSegment

# Random mission r44 of hil_sim/campaigns/random.yaml: an obstacle 4.3 m off the start's beam blocks both
# 2.93 m turning circles (inflated to 2.93 m, its radius being 1.83 + 1 m of margin < 2.93 m).
START = (-7.51, 15.4, math.radians(161.4))
GOAL = (-21.61, -26.34, math.radians(203.2))
FENCE = ((-16.19, -15.97, 3.41), (-11.76, 15.64, 1.83))
NOMINAL = PlannerConfig(turning_radius_m=2.93, obstacle_margin_m=1.0)
WITH_FALLBACK = dataclasses.replace(NOMINAL, min_turning_radius_m=2.5)


def test_blocked_turning_circles_plan_again_at_the_tighter_radius_and_say_so() -> None:
    with pytest.raises(PlannerError) as refused:
        plan(START, GOAL, NOMINAL, FENCE)
    assert refused.value.reason == "turning_circle_blocked"
    assert "[1]" in str(refused.value)  # the refusal names the obstacle
    path = plan(START, GOAL, WITH_FALLBACK, FENCE)
    radii = {round(s.radius_m, 9) for s in path.segments if hasattr(s, "radius_m")}
    # turns at 2.5 m (and arcs round the obstacles at their inflated radii, 2.83 and 4.41 m), none at 2.93 m
    assert 2.5 in radii and 2.93 not in radii and min(radii) == 2.5
    assert path.note.startswith("planned with the tighter turning radius 2.5 m: at 2.93 m, both start")
    # a plan that needs no fallback says nothing
    assert plan(START, GOAL, WITH_FALLBACK, ()).note == ""


def test_when_the_tighter_radius_fails_too_the_refusal_is_the_planning_radius_one() -> None:
    # Random mission r0: two obstacles on either side of the start block its turning circles at 2.5 m too
    start, goal = (7.51, 23.83, math.radians(81.1)), (-29.68, 19.27, math.radians(168.5))
    fence = ((-14.71, -3.3, 1.84), (3.21, 29.73, 2.51), (7.33, 29.34, 3.38), (-20.39, 6.75, 1.65))
    with pytest.raises(PlannerError) as refused:
        plan(start, goal, WITH_FALLBACK, fence)
    # nor does a smaller margin help a vehicle facing an obstacle (from rest it cannot turn in time)
    with pytest.raises(PlannerError):
        plan(start, goal, dataclasses.replace(WITH_FALLBACK, min_obstacle_margin_m=0.3), fence)
    with pytest.raises(PlannerError) as nominal:
        plan(start, goal, NOMINAL, fence)
    assert str(refused.value) == str(nominal.value)
    assert "(r = 2.93 m) cut inflated obstacle(s) [1, 2]" in str(refused.value)


def test_a_helix_that_fits_only_at_the_tighter_radius_is_retried() -> None:
    # GIVEN 7 m of depth over a 12 m straight between two rows of obstacles 8 m off it (issue 23: a depth
    # change too steep for the leg is flown on a helix): no 2.93 m circle fits beside it, a 2.5 m one does
    fence = [(x, y, 1.0) for x in range(-6, 22, 2) for y in (-8.0, 8.0)]
    with pytest.raises(PlannerError) as refused:
        plan((0.0, 0.0, 0.0), (12.0, 0.0, 0.0), NOMINAL, fence, start_depth_m=1.0, goal_depth_m=8.0)
    assert refused.value.reason == "depth_slope"
    path = plan((0.0, 0.0, 0.0), (12.0, 0.0, 0.0), WITH_FALLBACK, fence, start_depth_m=1.0, goal_depth_m=8.0)
    assert path.word.endswith("+helix 2R")
    assert path.note.startswith(
        "planned with the tighter turning radius 2.5 m: at 2.93 m, depth change +7.00 m"
    )


def test_the_validator_judges_goals_with_the_tightest_radius_the_planner_may_use() -> None:
    # GIVEN a goal 2.7 m from a small obstacle: inside its 2.93 m inflation floor, outside 2.5 m
    fence = (Obstacle(20.0, 2.7, 0.5),)
    mission = Mission((Goal(20.0, 0.0, 1.0, 0.0),), fence)
    nominal = CoreConfig(planner=NOMINAL)
    fallback = CoreConfig(planner=WITH_FALLBACK)
    assert check_mission(mission, nominal).first is not None
    assert check_mission(mission, fallback).first is None
    # and the planner plans to it (at the tighter radius)
    path = plan((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), WITH_FALLBACK, [(20.0, 2.7, 0.5)])
    assert path.note


def test_a_goal_within_an_obstacles_margin_plans_with_the_reduced_margin_and_says_so() -> None:
    # GIVEN a goal 0.7 m from the edge of a 4 m obstacle: inside its 1 m margin, outside 0.5 m
    fence = [(20.0, 4.7, 4.0)]
    cfg = dataclasses.replace(WITH_FALLBACK, min_obstacle_margin_m=0.5)
    with pytest.raises(PlannerError) as refused:
        plan((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), WITH_FALLBACK, fence)
    assert refused.value.reason == "goal_in_obstacle"
    path = plan((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), cfg, fence)
    said = "planned with the tighter turning radius 2.5 m and the obstacle margin reduced to 0.5 m: at 2.93 m"
    assert path.note.startswith(said + ", goal")
    # the validator judges the goal with the same margin
    mission = Mission((Goal(20.0, 0.0, 1.0, 0.0),), (Obstacle(20.0, 4.7, 4.0),))
    assert check_mission(mission, CoreConfig(planner=WITH_FALLBACK)).first is not None
    assert check_mission(mission, CoreConfig(planner=cfg)).first is None
    with pytest.raises(PlannerError, match="min_obstacle_margin_m"):
        PlannerConfig(min_obstacle_margin_m=-1.0)


def test_a_path_starts_with_the_run_up_where_it_is_free() -> None:
    cfg = PlannerConfig(turning_radius_m=2.93, start_run_up_m=2.0)
    # GIVEN a start heading east and a goal to the north-east (the paper's planning example)
    path = plan((0.0, 0.0, math.pi / 2), (30.0, 20.0, 0.0), cfg)
    first = path.segments[0]
    # THEN it runs 2 m straight along the start heading before the first turn
    assert isinstance(first, StraightSegment) and first.length_m == pytest.approx(2.0)
    assert first.yaw_rad == pytest.approx(math.pi / 2) and path.word.startswith("S")
    # an obstacle over the run-up, or a goal too near for it: the path turns from the start
    blocked = plan((0.0, 0.0, math.pi / 2), (30.0, 20.0, 0.0), cfg, [(-1.5, 4.0, 0.5)])
    assert not (isinstance(blocked.segments[0], StraightSegment) and blocked.segments[0].length_m == 2.0)
    near = plan((0.0, 0.0, 0.0), (5.0, 4.0, None), cfg)
    assert near.segments[0].kind != "S"
    with pytest.raises(PlannerError, match="start_run_up_m"):
        PlannerConfig(start_run_up_m=-1.0)
