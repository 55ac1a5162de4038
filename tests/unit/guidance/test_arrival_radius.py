"""The arrival distance has one owner, the mission's ``arrival_radius_m`` (MIS_ARRIVE_R_M): guidance ends a
path within it of the goal (heading aligned) and the mission judges the arrival with it (issue 22, item 2:
guidance had its own ``arrival_position_tol_m`` 0.25 m beside the mission's 0.5 m)."""

from __future__ import annotations

import math

import pytest

from auv_common.config import ConfigError, from_table
from onboard.core import commands as c
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.guidance.guidance import GuidanceParams, GuidanceState, step
from onboard.core.nav import nav_state_at
from onboard.core.params import BusLimits
from onboard.core.planner.path import Path, StraightSegment
from onboard.protocol.codec import command_ranges

BUS = BusLimits.from_ranges(command_ranges())


def _straight(length_m: float) -> Path:
    return Path(segments=(StraightSegment(0.0, 0.0, 0.0, length_m),), start_depth_m=1.0, end_depth_m=1.0)


@pytest.mark.parametrize("radius_m", [0.5, 2.0])
def test_guidance_ends_the_path_within_the_mission_arrival_radius_set_over_the_link(radius_m: float) -> None:
    # GIVEN MIS_ARRIVE_R_M set the way a ground station sets it
    ap = Autopilot(CoreConfig(), bus_limits=BUS)
    assert ap.handle(c.SetParam("MIS_ARRIVE_R_M", radius_m)).accepted
    path = _straight(20.0)
    # WHEN the vehicle, heading along the path, is just inside / just outside the radius before the end
    inside = step(nav_state_at(20.0 - 0.9 * radius_m, 0.0, 1.0), path, GuidanceState(s_proj_m=18.0),
                  ap.config.guidance, 0.05)[0]  # fmt: skip
    outside = step(nav_state_at(20.0 - 1.1 * radius_m, 0.0, 1.0), path, GuidanceState(s_proj_m=17.0),
                   ap.config.guidance, 0.05)[0]  # fmt: skip
    # THEN the path is done inside it, not outside
    assert inside.arrived and not outside.arrived
    assert ap.config.guidance.arrival_radius_m == radius_m  # guidance asks the mission's radius


def test_a_config_with_the_removed_guidance_tolerance_is_refused_with_the_reason() -> None:
    with pytest.raises(
        ConfigError, match=r"arrival_position_tol_m was removed.*\[mission\] arrival_radius_m"
    ):
        from_table(GuidanceParams, {"arrival_position_tol_m": 0.25}, "onboard.toml [guidance]")


def test_the_default_is_the_mission_default() -> None:
    assert GuidanceParams().arrival_radius_m == CoreConfig().mission.arrival_radius_m
    assert math.isclose(CoreConfig().guidance.arrival_radius_m, 0.5)
