"""The validator keeps the stopping zone past every goal clear (issue 23, item 3): the vehicle stops within
``[mission] stop_distance_m`` after COMPLETE or in a HOLD, so an obstacle in that zone, or a goal too close
to the failsafe depth limit for the stop, is refused at upload with the reason (before: accepted, and the
vehicle glided 15-20 m into the obstacle or sank on to the depth limit and ABORTed)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.params import MissionParams
from onboard.core.mission.validate import STOP_DEPTH_MARGIN_M, check_limits, check_mission
from onboard.core.safety.failsafe import FailsafeParams

CFG = CoreConfig(failsafe=FailsafeParams(max_depth_m=20.0), mission=MissionParams(stop_distance_m=3.0))


def straight(obstacle: Obstacle, yaw_deg: float | None = 0.0, depth_m: float = 1.0) -> Mission:
    """The paper's straight: one goal at (15, 0) arrived at heading ``yaw_deg`` (None: free), one obstacle."""
    yaw = None if yaw_deg is None else math.radians(yaw_deg)
    return Mission((Goal(15.0, 0.0, depth_m, yaw),), (obstacle,))


@pytest.mark.parametrize(
    ("obstacle", "yaw_deg"),
    [
        (Obstacle(19.5, 0.0, 2.0), 0.0),  # edge 2.5 m past the goal, on its heading
        (Obstacle(18.5, 1.2, 1.5), 0.0),  # off the heading, reaching into the zone's far end
        (Obstacle(15.0, -4.5, 2.0), -90.0),  # edge 2.5 m past, arriving towards -y (the turn's wall)
        (Obstacle(15.0, -4.5, 2.0), None),  # free heading: the disc of 3 m round the goal
    ],
)
def test_an_obstacle_in_the_stopping_zone_is_refused_with_the_reason(
    obstacle: Obstacle, yaw_deg: float | None
) -> None:
    # GIVEN a goal whose stopping zone (3 m past it) an obstacle reaches into (the goal itself is clear)
    mission = straight(obstacle, yaw_deg)
    # WHEN the mission is checked (at upload, and whenever the core takes it)
    check = check_mission(mission, CFG)
    # THEN it is refused naming the goal, the zone and the obstacle
    assert not check.ok
    p = check.first
    assert p is not None and (p.item, p.index, p.field) == ("goal", 0, "plan"), check
    assert "stopping zone" in p.reason and "obstacle 0" in p.reason, p.reason
    assert not check_limits(mission, CFG).ok  # the cheap check the core asks says the same


@pytest.mark.parametrize(
    ("obstacle", "yaw_deg"),
    [
        (Obstacle(19.0, 0.0, 1.0), 0.0),  # the dock: edge 3 m past the goal, the zone's end
        (Obstacle(10.0, 0.0, 2.0), 0.0),  # behind the goal (and clear of the approach's inflation)
        (Obstacle(17.0, 4.0, 1.0), 0.0),  # 3 m beside the zone
    ],
)
def test_an_obstacle_clear_of_the_stopping_zone_is_accepted(
    obstacle: Obstacle, yaw_deg: float | None
) -> None:
    assert check_mission(straight(obstacle, yaw_deg), CFG).ok


def test_stop_distance_zero_turns_the_rule_off() -> None:
    cfg = dataclasses.replace(CFG, mission=MissionParams(stop_distance_m=0.0))
    assert check_mission(straight(Obstacle(19.5, 0.0, 2.0)), cfg).ok


def test_a_goal_too_close_to_the_depth_limit_for_the_stop_is_refused() -> None:
    # GIVEN goals just above the 20 m failsafe depth limit, no obstacle
    def one(depth_m: float) -> Mission:
        return Mission((Goal(15.0, 0.0, depth_m, 0.0),))

    # THEN a goal within the stop's depth margin of it is refused naming the limit; 0.5 m above it flies
    check = check_mission(one(20.0 - STOP_DEPTH_MARGIN_M / 2), CFG)
    assert not check.ok
    p = check.first
    assert p is not None and (p.item, p.index, p.field) == ("goal", 0, "depth"), check
    assert "depth limit 20 m" in p.reason and "stop" in p.reason, p.reason
    assert check_mission(one(19.5), CFG).ok
