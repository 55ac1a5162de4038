"""3-D legs (issue 23, item 5): a depth change too steep for the planned path is flown on a helix.

The planner adds full circles of its turning radius (a descent or ascent on a loiter circle) until the whole
path, at one linear depth profile, is within ``max_depth_slope``; each circle is checked against the
obstacles like every other segment and keeps off the goal (the arrival test must not fire on it). Only where
no circle fits is the leg refused (``depth_slope``), with the reason.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest

from onboard.core.planner import ArcSegment, Path, PlannerConfig, PlannerError, inflate, plan
from onboard.core.planner.planner import HELIX_GOAL_CLEARANCE_M

from .helpers import check_continuity, check_ends, min_clearance_analytic

#: The onboard's planner (onboard/config/onboard.toml [planner]).
ONBOARD = PlannerConfig(
    turning_radius_m=2.93,
    obstacle_margin_m=1.0,
    max_depth_slope=0.25,
    goal_run_in_m=5.0,
    start_run_up_m=1.0,
    min_turning_radius_m=2.5,
    min_obstacle_margin_m=0.5,
)
TURN_START = (0.0, 0.0, 0.0)
TURN_GOAL = (10.0, 10.0, math.pi / 2)


def _slopes(path: Path, n: int = 400) -> list[float]:
    """|d depth / d s| between samples every length/n along the path (m per m)."""
    pts = [path.sample(path.length_m * i / n) for i in range(n + 1)]
    return [abs(b.depth_m - a.depth_m) / (b.s_m - a.s_m) for a, b in itertools.pairwise(pts)]


def _circles(path: Path) -> list[ArcSegment]:
    return [
        s for s in path.segments if isinstance(s, ArcSegment) and s.sweep_rad == pytest.approx(2 * math.pi)
    ]


def test_a_turn_diving_1_to_10_m_is_flown_on_a_helix() -> None:
    # GIVEN a quarter turn whose path (17 m) is too short for 9 m of depth at 0.25 (36 m): refused before
    # issue 23 with "depth change +9.00 m needs 36.00 m of path at slope 0.25, but the path is 17.02 m"
    path = plan(TURN_START, TURN_GOAL, ONBOARD, start_depth_m=1.0, goal_depth_m=10.0)
    # THEN full circles of the turning radius are added (two: 17 + 2 x 18.4 m), after the 1 m run-up
    circles = _circles(path)
    assert len(circles) == 2
    assert all(c.radius_m == 2.93 for c in circles)
    assert path.segments[1:3] == tuple(circles)
    assert 9.0 / 0.25 <= path.length_m <= 9.0 / 0.25 + 2.0 * math.pi * 2.93
    # and the slope is within the limit everywhere, the depth runs 1 -> 10 m, the ends are the asked ones
    assert max(_slopes(path)) <= 0.25 + 1e-9
    assert path.sample(0.0).depth_m == 1.0
    assert path.sample(path.length_m).depth_m == pytest.approx(10.0)
    check_continuity(path)
    check_ends(path, TURN_START, TURN_GOAL)
    assert path.word.endswith("+helix 2R")  # the log and the plan tool say so


@pytest.mark.parametrize(
    ("goal", "dz"),
    [
        ((0.0, 8.0, math.pi), 7.0),  # a U-turn diving 1 -> 8 m
        ((12.0, 0.0, 0.0), 7.0),  # 7 m over a 12 m straight
        ((12.0, 0.0, 0.0), -7.0),  # and climbing
        ((10.0, -10.0, -math.pi / 2), 9.0),  # the turn to port
    ],
)
def test_steep_legs_are_planned_within_the_slope(goal: tuple[float, float, float], dz: float) -> None:
    path = plan(TURN_START, goal, ONBOARD, start_depth_m=8.0 - dz, goal_depth_m=8.0)
    assert _circles(path)
    assert max(_slopes(path)) <= 0.25 + 1e-9
    check_continuity(path)
    check_ends(path, TURN_START, goal)
    # no circle passes the goal: the arrival test cannot fire on the helix
    for c in _circles(path):
        assert abs(math.hypot(goal[0] - c.center_x_m, goal[1] - c.center_y_m) - c.radius_m) >= (
            HELIX_GOAL_CLEARANCE_M - 1e-9
        )


def test_a_leg_within_the_slope_gets_no_circle() -> None:
    path = plan(TURN_START, (40.0, 0.0, 0.0), ONBOARD, start_depth_m=1.0, goal_depth_m=10.0)
    assert not _circles(path)
    assert path.length_m == pytest.approx(40.0)
    assert "helix" not in path.word


def test_the_helix_keeps_clear_of_obstacles() -> None:
    # GIVEN an obstacle on the starboard start circle: the helix turns to port there, or further on
    fence = [(1.0, 5.0, 1.0)]
    path = plan(TURN_START, (12.0, 0.0, 0.0), ONBOARD, fence, start_depth_m=1.0, goal_depth_m=8.0)
    assert _circles(path)
    assert min_clearance_analytic(path, inflate(fence, ONBOARD)) >= -1e-9
    assert max(_slopes(path)) <= 0.25 + 1e-9


def test_no_circle_fits_is_refused_with_the_reason() -> None:
    # GIVEN obstacles on both sides of a 12 m corridor: no circle fits anywhere along it
    fence = [(x, y, 1.5) for x in range(-4, 20, 2) for y in (-4.0, 4.0)]
    cfg = dataclasses.replace(ONBOARD, min_turning_radius_m=0.0, min_obstacle_margin_m=None)
    with pytest.raises(PlannerError) as refused:
        plan(TURN_START, (12.0, 0.0, 0.0), cfg, fence, start_depth_m=1.0, goal_depth_m=8.0)
    assert refused.value.reason == "depth_slope"
    text = str(refused.value)
    assert "needs 28.00 m of path" in text and "no circle of radius 2.93 m fits" in text


def test_start_equals_goal_with_a_depth_change_is_refused() -> None:
    # GIVEN no run-in (the paper): the path is of zero length, and a circle from the goal pose would pass
    # the goal (the arrival test would end the leg at once)
    paper_end = dataclasses.replace(ONBOARD, goal_run_in_m=0.0)
    with pytest.raises(PlannerError) as refused:
        plan((5.0, 5.0, 0.0), (5.0, 5.0, 0.0), paper_end, start_depth_m=1.0, goal_depth_m=3.0)
    assert refused.value.reason == "depth_slope"
