"""A goal's acceptance radius (issue 24 item 1): validated like every other value (finite, 0 = the default or
within MIS_ARRIVE_R_M's declared range, each refusal with its reason), resolved in one place
(``goal_radius_m``), and flown: guidance ends a goal's path within the goal's own radius and goto confirms the
arrival against it."""

from __future__ import annotations

import math

import pytest

from auv_common.config import declared_bounds
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, goal_radius_m
from onboard.core.mission.params import MissionParams
from onboard.core.mission.validate import check_goal_values, check_mission, goal_radius_bounds_m


def test_the_radius_in_force_is_the_goals_own_else_the_default() -> None:
    assert goal_radius_m(Goal(1.0, 2.0, 1.0, None, radius_m=3.0), 0.5) == 3.0
    assert goal_radius_m(Goal(1.0, 2.0, 1.0, None), 0.5) == 0.5  # 0: [mission] arrival_radius_m


def test_the_bounds_are_the_default_parameters_declared_range() -> None:
    assert goal_radius_bounds_m() == declared_bounds(MissionParams(), "arrival_radius_m") == (0.1, 50.0)


@pytest.mark.parametrize("radius_m", [0.0, 0.1, 3.0, 50.0])
def test_a_radius_of_0_or_within_the_range_is_accepted(radius_m: float) -> None:
    goal = Goal(10.0, 0.0, 1.0, 0.0, radius_m=radius_m)
    assert check_goal_values(0, goal) == []
    assert check_mission(Mission((goal,)), CoreConfig()).ok


@pytest.mark.parametrize(
    ("radius_m", "reason"),
    [
        (-1.0, "arrival radius -1 m is negative (0 = the vehicle's default"),
        (0.05, "arrival radius 0.05 m is below 0.1 m, the smallest that means one"),
        (80.0, "arrival radius 80 m is above 50 m, the widest MIS_ARRIVE_R_M allows"),
        (math.nan, "arrival_radius is not a finite number: nan"),
        (math.inf, "arrival_radius is not a finite number: inf"),
    ],
)
def test_a_bad_radius_is_refused_naming_the_goal_and_why(radius_m: float, reason: str) -> None:
    mission = Mission((Goal(10.0, 0.0, 1.0, 0.0), Goal(20.0, 0.0, 1.0, 0.0, radius_m=radius_m)))
    check = check_mission(mission, CoreConfig())
    (p,) = check.problems
    assert (p.item, p.index, p.field) == ("goal", 1, "arrival_radius")
    assert str(p).startswith(f"goal 1: {reason}"), str(p)


@pytest.mark.parametrize(("radius_m", "reached"), [(4.0, True), (0.0, False)])
def test_goto_judges_an_arrival_by_the_goals_own_radius(radius_m: float, reached: bool) -> None:
    import dataclasses

    from onboard.core.mission.state import MissionState
    from tests.unit.autopilot.test_autopilot import started, tick

    # GIVEN a goal with its own 4 m radius (or none: the default 0.5 m), the estimate 2 m short of it and good
    ap = started((Goal(20.0, 0.0, 1.0, 0.0, radius_m=radius_m),))
    tick(ap, 0.05)
    assert ap.last_nav is not None
    near = dataclasses.replace(ap.last_nav, x_m=18.0, y_m=0.0, position_std_m=0.1)
    # WHEN guidance says the goal line is crossed
    ap.executive.goto.arrived(ap.executive, ap, near)
    # THEN within its own radius the goal is reached (the mission COMPLETE); with the default, a miss
    assert (ap.status.state is MissionState.COMPLETE) is reached, ap.status.reason
    assert ap.goals_reached == (1 if reached else 0)


def test_the_mission_file_door_keeps_the_radius_and_encodes_it_as_param2() -> None:
    from onboard.adapters.mavlink.mission_protocol import items_from_mission
    from onboard.app.mission_file import parse_mission

    mission = parse_mission({"goals": [{"x_m": 10, "y_m": 0, "depth_m": 1, "radius_m": 3}]})
    assert mission.goals[0].radius_m == 3.0
    (item,), _ = items_from_mission(mission)
    assert item.param2 == 3.0
