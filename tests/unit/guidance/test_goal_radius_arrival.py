"""A goal's own acceptance radius ends its path in guidance (issue 24 item 1): within the radius of the end,
heading aligned; but never on a loop of the path that passes within the radius (a helix circle near the
goal, a depth still to lose): the path left must be about as short as the distance."""

from __future__ import annotations

import math

from onboard.core.guidance.guidance import GuidanceParams, GuidanceState, step
from onboard.core.nav import nav_state_at
from onboard.core.planner.path import ArcSegment, Path, StraightSegment

DT = 0.05
PARAMS = GuidanceParams(arrival_yaw_tol_deg=10.0).with_arrival_radius(0.5)


def _straight(length_m: float) -> Path:
    return Path(segments=(StraightSegment(0.0, 0.0, 0.0, length_m),), start_depth_m=1.0, end_depth_m=1.0)


def test_the_goals_radius_ends_the_path_where_the_default_does_not() -> None:
    path = _straight(20.0)
    nav = nav_state_at(17.0, 0.0, 1.0, 0.0)  # 3 m short, heading along
    own, _, _ = step(nav, path, GuidanceState(s_proj_m=16.9), PARAMS, DT, arrival_radius_m=4.0)
    default, _, _ = step(nav, path, GuidanceState(s_proj_m=16.9), PARAMS, DT)
    assert own.arrived and not default.arrived


def test_a_loop_of_the_path_within_the_radius_is_no_arrival() -> None:
    # GIVEN a path north 5 m, a full right circle of 3 m (a helix's) back to (5, 0), then 3 m on to the goal
    # at (8, 0): entering the circle, the vehicle is 3 m from the goal heading along the goal's yaw
    path = Path(
        segments=(
            StraightSegment(0.0, 0.0, 0.0, 5.0),
            ArcSegment(5.0, 3.0, 3.0, 1, 0.0, 2.0 * math.pi),
            StraightSegment(5.0, 0.0, 0.0, 3.0),
        ),
        start_depth_m=1.0,
        end_depth_m=6.0,
    )
    nav = nav_state_at(5.05, 0.01, 1.0, 0.0)
    r, state, _ = step(nav, path, GuidanceState(s_proj_m=4.9), PARAMS, DT, arrival_radius_m=4.0)
    # THEN it is not arrived: the circle is still to fly
    assert state.s_proj_m is not None and state.s_proj_m < 6.0
    assert not r.arrived
