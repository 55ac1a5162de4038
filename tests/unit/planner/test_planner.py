"""Planner behaviour: errors with reasons, obstacles, costs, config."""

from __future__ import annotations

import math

import pytest

from auv_common.config import ConfigError, from_table
from onboard.core.planner import PlannerConfig, PlannerConfigError, PlannerError, candidates, inflate, plan
from onboard.core.planner.cost import cost_terms, rudder_rad

from .helpers import check_continuity, check_ends, min_clearance_analytic, min_clearance_dense

CFG = PlannerConfig(turning_radius_m=3.0, obstacle_margin_m=1.0)


def _ring(cx: float, cy: float, ring_r: float, n: int, rad: float) -> list[tuple[float, float, float]]:
    return [
        (cx + ring_r * math.cos(2 * math.pi * i / n), cy + ring_r * math.sin(2 * math.pi * i / n), rad)
        for i in range(n)
    ]


def _corridor(half_width_m: float) -> list[tuple[float, float, float]]:
    """Obstacles of 1 m radius every 2 m along y = +-half_width_m from x = -6 to 44 m: beside the straight
    path from (0, 0) to (40, 0), no circle of 3 m radius fits at 8 m (issue 23's helix)."""
    return [(float(x), y, 1.0) for x in range(-6, 46, 2) for y in (-half_width_m, half_width_m)]


@pytest.mark.parametrize(
    ("kwargs", "reason"),
    [
        ({"start": (math.nan, 0.0, 0.0)}, "nan"),
        ({"goal": (10.0, math.inf, 0.0)}, "nan"),
        ({"goal": (10.0, 0.0, math.nan)}, "nan"),
        ({"obstacles": [(5.0, math.nan, 1.0)]}, "nan"),
        ({"goal_depth_m": math.nan}, "nan"),
        ({"obstacles": [(5.0, 5.0, 0.0)]}, "radius"),
        ({"obstacles": [(5.0, 5.0, -1.0)]}, "radius"),
        ({"obstacles": [(5.0, 5.0, math.inf)]}, "radius"),
        ({"obstacles": [(1.0, 0.0, 1.0)]}, "start_in_obstacle"),
        ({"obstacles": [(40.0, 1.0, 1.0)]}, "goal_in_obstacle"),
        ({"obstacles": _ring(40.0, 0.0, 20.0, 40, 2.5)}, "unreachable"),
        ({"obstacles": _ring(0.0, 0.0, 6.0, 8, 2.0)}, "turning_circle_blocked"),
        ({"goal_depth_m": 50.0, "obstacles": _corridor(8.0)}, "depth_slope"),  # no helix circle fits
    ],
)
def test_each_error_reason(kwargs: dict[str, object], reason: str) -> None:
    args: dict[str, object] = {"start": (0.0, 0.0, 0.0), "goal": (40.0, 0.0, 0.0), "config": CFG}
    args.update(kwargs)
    with pytest.raises(PlannerError) as info:
        plan(**args)  # type: ignore[arg-type]
    assert info.value.reason == reason
    assert str(info.value)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_bad_turning_radius_is_a_planner_and_config_error(bad: float) -> None:
    with pytest.raises(PlannerError) as info:
        PlannerConfig(turning_radius_m=bad)
    assert info.value.reason == "radius"
    assert isinstance(info.value, ConfigError)
    from onboard.core.planner import dubins

    with pytest.raises(PlannerError, match="radius"):
        dubins.all_words((0, 0, 0), (1, 1, 1), bad)


def test_config_from_table() -> None:
    table = {
        "turning_radius_m": 2,
        "obstacle_margin_m": 0.5,
        "weight_distance": 1.0,
        "weight_yaw": 0.5,
        "weight_rudder": 0.0,
        "max_depth_slope": 0.2,
        "rudder_map_radius_m": [2.0, 4.0],
        "rudder_map_rudder_deg": [20.0, 10.0],
        "csc_only": True,
    }
    cfg = from_table(PlannerConfig, table, "onboard.toml [planner]")
    assert cfg.turning_radius_m == 2.0
    assert cfg.rudder_map_radius_m == (2.0, 4.0)
    assert cfg.csc_only is True
    with pytest.raises(ConfigError, match="unknown key"):
        from_table(PlannerConfig, {"radius": 2.0}, "x [planner]")
    with pytest.raises(ConfigError, match=r"x \[planner\].*turning_radius_m"):
        from_table(PlannerConfig, {"turning_radius_m": -2.0}, "x [planner]")
    with pytest.raises(ConfigError, match="increasing"):
        from_table(
            PlannerConfig, {"rudder_map_radius_m": [4.0, 2.0], "rudder_map_rudder_deg": [1.0, 2.0]}, "x"
        )
    with pytest.raises(PlannerConfigError):
        PlannerConfig(weight_distance=0.0, weight_yaw=0.0, weight_rudder=0.0)


def test_obstacle_on_the_straight_is_avoided() -> None:
    # GIVEN an obstacle on the straight line WHEN planning THEN the path goes around it, analytically clear
    obstacles = [(20.0, 0.5, 3.0)]
    path = plan((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), CFG, obstacles)
    inflated = inflate(obstacles, CFG)
    assert path.length_m > 40.0
    assert min_clearance_analytic(path, inflated) >= -1e-9
    assert min_clearance_dense(path, inflated) >= -1e-9
    check_continuity(path)
    check_ends(path, (0.0, 0.0, 0.0), (40.0, 0.0, 0.0))
    assert len(path.word) > 3  # a tangent-graph path: the sequence of segment kinds
    assert len(path.virtual_goals) >= 2


def test_obstacle_not_in_the_way_changes_nothing() -> None:
    free = plan((0.0, 0.0, 0.0), (40.0, 10.0, 0.0), CFG)
    with_obs = plan((0.0, 0.0, 0.0), (40.0, 10.0, 0.0), CFG, [(0.0, -30.0, 2.0)])
    assert with_obs.length_m == free.length_m
    assert with_obs.word == free.word


def test_inflation_floor_is_turning_radius() -> None:
    assert inflate([(0.0, 0.0, 0.5)], CFG) == ((0.0, 0.0, 3.0),)
    assert inflate([(0.0, 0.0, 4.0)], CFG) == ((0.0, 0.0, 5.0),)


def test_weights_change_the_choice() -> None:
    # A heavy yaw weight prefers a path with less turning even if it is longer.
    start, goal = (0.0, 0.0, 0.0), (2.0, 9.0, 0.0)
    short = plan(start, goal, PlannerConfig(turning_radius_m=3.0))
    yawy = plan(start, goal, PlannerConfig(turning_radius_m=3.0, weight_yaw=100.0))
    assert (
        cost_terms(yawy.segments, PlannerConfig()).yaw_change_rad
        <= cost_terms(short.segments, PlannerConfig()).yaw_change_rad
    )
    assert yawy.length_m >= short.length_m


def test_cost_terms_and_rudder_map() -> None:
    cfg = PlannerConfig(
        turning_radius_m=2.0,
        weight_distance=1.0,
        weight_yaw=2.0,
        weight_rudder=3.0,
        rudder_map_radius_m=(2.0, 4.0),
        rudder_map_rudder_deg=(20.0, 10.0),
    )
    # Interpolated in curvature: 1/3 m^-1 lies 1/3 of the way from 1/4 to 1/2 -> 10 + 10/3 deg.
    assert math.degrees(rudder_rad(3.0, cfg)) == pytest.approx(10.0 + 10.0 / 3.0)
    assert math.degrees(rudder_rad(1.0, cfg)) == pytest.approx(20.0)  # tighter than the table: held
    assert math.degrees(rudder_rad(8.0, cfg)) == pytest.approx(5.0)  # towards (0 curvature, 0 rudder)
    path = plan((0.0, 0.0, 0.0), (4.0, 4.0, math.pi), cfg)  # half a circle of r = 2 (a U-turn)
    terms = cost_terms(path.segments, cfg)
    assert terms.distance_m == pytest.approx(path.length_m)
    expected = terms.distance_m + 2.0 * terms.yaw_change_rad + 3.0 * terms.rudder_rad_m
    assert path.cost == pytest.approx(expected)
    assert terms.yaw_change_rad == pytest.approx(math.pi)
    assert terms.rudder_rad_m == pytest.approx(math.radians(20.0) * 2.0 * math.pi)


def test_candidates_for_plotting() -> None:
    cands = candidates((0.0, 0.0, math.radians(90)), (30.0, 20.0, 0.0), PlannerConfig(turning_radius_m=2.0))
    assert cands[0].word == "LSL"
    assert {c.word for c in cands} == {"LSL", "LSR", "RSL", "RSR"}  # no CCC word exists here
    assert cands == sorted(cands, key=lambda c: c.cost)
    free = candidates((0.0, 0.0, 0.0), (10.0, 10.0, None), PlannerConfig(turning_radius_m=2.0))
    assert len({c.word for c in free}) == len(free)


def test_free_goal_yaw_uses_arc_then_straight() -> None:
    path = plan((0.0, 0.0, 0.0), (0.0, 20.0, None), PlannerConfig(turning_radius_m=3.0))
    assert path.word == "RS"
    # Exact: arc then tangent to the point: sqrt(d^2 - r^2) + r * angle.
    d = math.hypot(0.0 - 0.0, 20.0 - 3.0)
    tangent = math.sqrt(d * d - 9.0)
    angle = math.pi / 2 + math.atan2(3.0, tangent)  # past east: the tangent leans back to the point
    assert path.length_m == pytest.approx(tangent + 3.0 * angle)


def test_free_goal_yaw_with_obstacles() -> None:
    obstacles = [(0.0, 10.0, 2.0)]
    path = plan((0.0, 0.0, math.pi / 2), (0.0, 20.0, None), CFG, obstacles)
    assert min_clearance_analytic(path, inflate(obstacles, CFG)) >= -1e-9
    check_ends(path, (0.0, 0.0, math.pi / 2), (0.0, 20.0, None))


def test_depth_error_says_why_and_how_much() -> None:
    # too steep for the path and no helix circle fits beside it (issue 23: where one fits it is flown)
    with pytest.raises(PlannerError, match=r"needs 200\.00 m .* no circle of radius 3 m fits") as info:
        plan((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), CFG, _corridor(8.0), start_depth_m=0.0, goal_depth_m=50.0)
    assert info.value.reason == "depth_slope"
    helix = plan((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), CFG, start_depth_m=0.0, goal_depth_m=50.0)
    assert helix.length_m >= 200.0 and helix.word.endswith("+helix 9R")
    ok = plan((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), CFG, start_depth_m=0.0, goal_depth_m=10.0)
    assert ok.end_depth_m == 10.0
    assert ok.sample(20.0).depth_m == pytest.approx(5.0)
    assert ok.sample(20.0).pitch_rad < 0.0  # diving is nose down


def test_mission_obstacles_are_accepted() -> None:
    from onboard.core.mission.model import Obstacle

    path = plan((0.0, 0.0, 0.0), (40.0, 0.0, 0.0), CFG, [Obstacle(20.0, 0.5, 3.0)])
    assert path.length_m > 40.0
