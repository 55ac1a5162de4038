"""Unit tests of course-over-ground steering (``[guidance] steer = "course"``) and the current-aware plan."""

from __future__ import annotations

import dataclasses
import math

import pytest

from onboard.core.control import ControlParams
from onboard.core.control import step as control_step
from onboard.core.control.pd import ControllerState, ImprovedGains
from onboard.core.guidance import GuidanceParams, GuidanceState, step
from onboard.core.mission.model import Goal
from onboard.core.nav import nav_state_at
from onboard.core.planner import PlannerConfig, PlannerError, plan
from onboard.core.planner.path import ArcSegment, Path, StraightSegment
from onboard.core.plans import PlanRequest, compute_plan, current_radius_m

COURSE = GuidanceParams(steer="course", lateral="path")
NORTH = Path(segments=(StraightSegment(0.0, 0.0, 0.0, 50.0),), start_depth_m=1.0, end_depth_m=1.0)


def in_current(cn: float, ce: float, *, yaw: float = 0.0, u: float = 1.0, v: float = 0.0, x: float = 5.0):
    nav = nav_state_at(x, 0.0, 1.0, yaw, u_mps=u)
    return dataclasses.replace(nav, v_mps=v, current_north_mps=cn, current_east_mps=ce, current_std_mps=0.01)


def test_course_steering_heads_into_a_cross_current() -> None:
    # GIVEN a path north and a 0.3 m/s current towards the east, the vehicle on the path heading north
    r, _, dbg = step(in_current(0.0, 0.3), NORTH, GuidanceState(), COURSE, 0.05)
    # THEN it is told to head west of north so that its water velocity + current points north
    assert r.yaw_rad == pytest.approx(math.atan2(-0.3, 1.0))
    assert dbg.crab_rad == pytest.approx(-r.yaw_rad)
    # and the water speed that takes is the hypotenuse (the propeller's feed-forward)
    assert r.water_speed_mps == pytest.approx(math.hypot(1.0, 0.3))


def test_heading_steering_ignores_the_current() -> None:
    r, _, _ = step(in_current(0.0, 0.3), NORTH, GuidanceState(), GuidanceParams(lateral="path"), 0.05)
    assert r.yaw_rad == pytest.approx(0.0)
    assert r.water_speed_mps == r.speed_mps


def test_a_head_current_asks_for_more_water_speed_and_the_crab_is_clamped() -> None:
    r, _, _ = step(in_current(-0.5, 0.0), NORTH, GuidanceState(), COURSE, 0.05)
    assert r.yaw_rad == pytest.approx(0.0) and r.water_speed_mps == pytest.approx(1.5)
    # a current as fast as the vehicle across the path: the crab stops at crab_max_deg
    r, _, dbg = step(in_current(0.0, 5.0), NORTH, GuidanceState(), COURSE, 0.05)
    assert abs(dbg.crab_rad) == pytest.approx(math.radians(COURSE.crab_max_deg))


def test_arrival_judges_the_course_over_ground_not_the_heading() -> None:
    # GIVEN a vehicle 0.1 m before the path's end, heading 20 deg off the final heading but moving along it
    # (crabbing: its body velocity is a ground track due north)
    yaw = math.radians(-20.0)
    nav = in_current(0.0, 0.34, yaw=yaw, u=math.cos(yaw), v=-math.sin(yaw), x=49.9)
    state = GuidanceState(s_proj_m=49.8)
    # THEN "course" arrives and "heading" does not (the 10 deg tolerance)
    assert step(nav, NORTH, state, COURSE, 0.0)[0].arrived
    assert not step(nav, NORTH, state, GuidanceParams(lateral="path"), 0.0)[0].arrived


def test_the_controller_feeds_forward_the_water_speed() -> None:
    params = ControlParams()
    still, _, _ = step(in_current(0.0, 0.0), NORTH, GuidanceState(), COURSE, 0.05)
    head, _, _ = step(in_current(-0.5, 0.0), NORTH, GuidanceState(), COURSE, 0.05)
    _, _, d_still = control_step(in_current(0.0, 0.0), still, ControllerState(), params, 0.05)
    _, _, d_head = control_step(in_current(-0.5, 0.0), head, ControllerState(), params, 0.05)
    assert d_still.rps_ff == pytest.approx(params.speed_to_rps(still.speed_mps))
    assert d_head.rps_ff == pytest.approx(params.speed_to_rps(1.5 * still.speed_mps))


def test_the_run_in_ends_the_path_with_a_straight_along_the_goal_heading() -> None:
    cfg = PlannerConfig(turning_radius_m=3.0, goal_run_in_m=4.0)
    path = plan((0.0, 0.0, 0.0), (20.0, -10.0, -math.pi / 2), cfg)
    last = path.segments[-1]
    assert isinstance(last, StraightSegment) and last.length_m >= 4.0 - 1e-9
    assert last.yaw_rad == pytest.approx(-math.pi / 2)
    assert path.word.endswith("S")
    end = path.sample(path.length_m)
    assert (end.x_m, end.y_m) == pytest.approx((20.0, -10.0), abs=1e-9)


def test_a_blocked_run_in_plans_direct() -> None:
    # GIVEN an obstacle over the run-in's start (6 m before the goal along its heading)
    cfg = PlannerConfig(turning_radius_m=3.0, goal_run_in_m=4.0, obstacle_margin_m=0.0)
    goal = (20.0, -10.0, -math.pi / 2)
    cfg = dataclasses.replace(cfg, goal_run_in_m=6.0)
    path = plan((0.0, 0.0, 0.0), goal, cfg, [(20.0, -1.5, 0.5)])  # inflated to the turning radius, 3 m
    # THEN the path goes to the goal without the run-in (its last piece is the arrival arc)
    assert not isinstance(path.segments[-1], StraightSegment)
    end = path.sample(path.length_m)
    assert (end.x_m, end.y_m) == pytest.approx((20.0, -10.0), abs=1e-9)


def test_the_turning_radius_widens_with_a_current_and_falls_back() -> None:
    assert current_radius_m(3.0, 1.0, 0.0) == 3.0
    assert current_radius_m(3.0, 1.0, 0.5) == pytest.approx(6.0)
    assert current_radius_m(3.0, 1.0, 5.0) == pytest.approx(3.0 / (1.0 - 0.6))
    cfg = PlannerConfig(turning_radius_m=3.0, current_aware=True)
    goal = Goal(30.0, 0.0, 1.0, math.pi)  # a U-turn: its arcs show the radius

    def request(current: float, planner: PlannerConfig = cfg) -> PlanRequest:
        return PlanRequest(1, "goal", 0, (0.0, 0.0, 0.0), 1.0, goal, (), planner, 6.0, 0.0, 2.0, current, 1.0)

    def radii(req: PlanRequest) -> set[float]:
        return {round(s.radius_m, 6) for s in compute_plan(req).segments if isinstance(s, ArcSegment)}

    assert radii(request(0.5)) == {6.0}
    assert radii(request(0.0)) == {3.0}
    # current_aware off: nominal whatever the current
    assert radii(request(0.5, dataclasses.replace(cfg, current_aware=False))) == {3.0}


def test_when_the_wide_turns_find_no_path_the_nominal_radius_plans() -> None:
    # GIVEN a goal 4 m from a small obstacle: inflated to a 3 m turning radius it is clear, to 6 m it is not
    cfg = PlannerConfig(turning_radius_m=3.0, current_aware=True, obstacle_margin_m=0.0)
    fence = ((30.0, 4.0, 1.0),)
    goal = Goal(30.0, 0.0, 1.0, math.pi)
    with pytest.raises(PlannerError):
        plan((0.0, 0.0, 0.0), (30.0, 0.0, math.pi), dataclasses.replace(cfg, turning_radius_m=6.0), fence)
    # WHEN the plan is asked for in a 0.5 m/s current (which widens the turns to 6 m)
    req = PlanRequest(1, "goal", 0, (0.0, 0.0, 0.0), 1.0, goal, fence, cfg, 6.0, 0.0, 2.0, 0.5, 1.0)
    path = compute_plan(req)
    # THEN it is planned with the nominal radius
    assert {round(s.radius_m, 6) for s in path.segments if isinstance(s, ArcSegment)} == {3.0}


def test_the_fin_schedule_scales_the_feedback_by_the_water_speed() -> None:
    # GIVEN a yaw error and the schedule at 1 m/s (feed-forward off so only feedback shows)
    gains = ImprovedGains(feedforward=False, roll_kp=0.0, roll_kd=0.0, schedule_speed_mps=1.0)
    params = ControlParams(improved=gains)
    ref, _, _ = step(in_current(0.0, 0.0), NORTH, GuidanceState(), GuidanceParams(), 0.05)
    ref = dataclasses.replace(ref, e_yaw_rad=0.05, e_cross_m=0.0, yaw_rate_radps=0.0)

    def rudder(water_speed_mps: float) -> float:
        nav = dataclasses.replace(in_current(0.0, 0.0), water_speed_mps=water_speed_mps, r_radps=0.0)
        return control_step(nav, ref, ControllerState(), params, 0.05)[2].raw.rudder_rad

    # THEN half the water speed gives the feedback x 4 capped at 2.5, double gives x 1/4 floored at 1/2.5
    assert rudder(1.0) == pytest.approx(gains.Kp6 * 0.05)
    assert rudder(0.8) == pytest.approx(rudder(1.0) / 0.64)
    assert rudder(0.5) == pytest.approx(2.5 * rudder(1.0))
    assert rudder(2.0) == pytest.approx(rudder(1.0) / 2.5)
    assert rudder(float("nan")) == pytest.approx(rudder(1.0))


def test_on_an_arc_in_a_current_the_yaw_rate_feed_forward_counts_the_changing_crab() -> None:
    # GIVEN a right arc of radius 5 m (course rate U / 5) and a 0.3 m/s current towards the north-east
    arc = Path(segments=(ArcSegment(0.0, 5.0, 5.0, +1, 0.0, math.pi),), start_depth_m=1.0, end_depth_m=1.0)
    params = dataclasses.replace(COURSE, lookahead_m=1e6)  # no LOS correction: chi_d = the path tangent
    cn, ce = 0.3 * math.cos(math.pi / 4), 0.3 * math.sin(math.pi / 4)
    nav = dataclasses.replace(in_current(cn, ce, x=0.0), y_m=0.0)
    r, _, _ = step(nav, arc, GuidanceState(), params, 0.0)
    # THEN r_d = (d chi / dt) (d psi_d / d chi), the derivative taken numerically from the heading rule
    u, chi, eps = COURSE.speed_mps, 0.0, 1e-6

    def psi(c: float) -> float:
        return math.atan2(u * math.sin(c) - ce, u * math.cos(c) - cn)

    dpsi_dchi = (psi(chi + eps) - psi(chi - eps)) / (2 * eps)
    assert r.yaw_rate_radps == pytest.approx(r.speed_mps / 5.0 * dpsi_dchi, rel=1e-5)
    assert abs(dpsi_dchi - 1.0) > 0.05  # the crab does change along this arc
    # and in still water the feed-forward is the course rate itself
    still, _, _ = step(dataclasses.replace(nav, current_north_mps=0.0, current_east_mps=0.0), arc,
                       GuidanceState(), params, 0.0)  # fmt: skip
    assert still.yaw_rate_radps == pytest.approx(still.speed_mps / 5.0)


def test_the_los_speed_loop_integrates_the_speed_error_over_ground_and_is_limited() -> None:
    # GIVEN LOS with the speed loop, a vehicle on the path making 0.6 m/s over ground against 1 m/s asked
    params = GuidanceParams(mode="los", speed_loop_limit_m=0.5)
    nav = in_current(0.0, 0.0, u=0.6)
    state = GuidanceState()
    r, state, _ = step(nav, NORTH, state, params, 0.5)
    # THEN e_x is the integral of the speed error (0.4 m/s for 0.5 s), up to the limit (anti-windup)
    assert r.e_along_m == pytest.approx(0.2)
    for _ in range(10):
        r, state, _ = step(nav, NORTH, state, params, 0.5)
    assert r.e_along_m == pytest.approx(0.5)
    # faster than asked: it unwinds at once
    r, state, _ = step(in_current(0.0, 0.0, u=1.4), NORTH, state, params, 0.5)
    assert r.e_along_m == pytest.approx(0.3)
    # and the textbook LOS (no speed loop) has no along-track error
    assert step(nav, NORTH, GuidanceState(), GuidanceParams(mode="los"), 0.5)[0].e_along_m == 0.0


def test_los_previews_the_curvature_ahead_of_the_projection() -> None:
    # GIVEN 10 m of straight then a right arc of radius 5 m, the vehicle 0.5 m before the arc
    path = Path(
        segments=(StraightSegment(0.0, 0.0, 0.0, 10.0), ArcSegment(10.0, 5.0, 5.0, +1, 0.0, math.pi / 2)),
        start_depth_m=1.0,
        end_depth_m=1.0,
    )
    nav = dataclasses.replace(in_current(0.0, 0.0), x_m=9.5)
    plain = GuidanceParams(mode="los")
    preview = GuidanceParams(mode="los", curvature_preview_s=1.0)
    assert step(nav, path, GuidanceState(), plain, 0.0)[0].curvature_1pm == 0.0
    assert step(nav, path, GuidanceState(), preview, 0.0)[0].curvature_1pm == pytest.approx(0.2)


def test_in_a_current_the_nominal_radius_comes_before_the_tighter_fallback() -> None:
    # GIVEN random mission r44 (both 2.93 m start circles blocked; a 2.5 m fallback plans it), 0.1 m/s
    planner = PlannerConfig(turning_radius_m=2.93, current_aware=True, min_turning_radius_m=2.5)
    fence = ((-16.19, -15.97, 3.41), (-11.76, 15.64, 1.83))
    goal = Goal(-21.61, -26.34, 1.0, math.radians(203.2))
    start = (-7.51, 15.4, math.radians(161.4))
    req = PlanRequest(1, "goal", 0, start, 1.0, goal, fence, planner, 6.0, 0.0, 2.0, 0.1, 1.0)
    # THEN the note names the nominal radius the fallback replaced, not the current-widened one
    note = compute_plan(req).note
    assert note.startswith("planned with the tighter turning radius 2.5 m: at 2.93 m,"), note


def test_the_run_in_keeps_its_length_when_the_turns_widen_in_a_current() -> None:
    # GIVEN a goal with a heading, a 5 m run-in at the 3 m radius, planned in a 0.5 m/s current (6 m turns)
    cfg = PlannerConfig(turning_radius_m=3.0, goal_run_in_m=5.0, current_aware=True)
    goal = Goal(30.0, -10.0, 1.0, -math.pi / 2)
    req = PlanRequest(1, "goal", 0, (0.0, 0.0, 0.0), 1.0, goal, (), cfg, 6.0, 0.0, 2.0, 0.5, 1.0)
    last = compute_plan(req).segments[-1]
    # THEN the straight before the goal is the 5 m run-in (issue 23 item 4: a run-in widened with the
    # turns, 10 m here, moved the whole path 4-6 m off the first plan at 0.5 m/s; the arrival course held)
    assert isinstance(last, StraightSegment) and last.length_m == pytest.approx(5.0)


STEERAGE = dataclasses.replace(COURSE, min_water_speed_mps=0.8)


def test_a_following_current_speeds_the_vehicle_up_to_keep_steerage_way() -> None:
    # GIVEN a 0.5 m/s current along the path north (1 m/s over ground would leave 0.5 m/s through the water)
    r, _, _ = step(in_current(0.5, 0.0), NORTH, GuidanceState(), STEERAGE, 0.05)
    # THEN the speed over ground asked for rises to current + 0.8, and 0.8 m/s is left through the water
    assert r.speed_mps == pytest.approx(1.3) and r.water_speed_mps == pytest.approx(0.8)
    # with a cross component too: c_along + sqrt(0.8^2 - c_across^2)
    r, _, _ = step(in_current(0.4, 0.3), NORTH, GuidanceState(), STEERAGE, 0.05)
    assert r.speed_mps == pytest.approx(0.4 + math.sqrt(0.64 - 0.09))
    assert r.water_speed_mps == pytest.approx(0.8)


def test_steerage_way_changes_nothing_in_still_water_a_head_current_or_when_off() -> None:
    for cn, ce in ((0.0, 0.0), (-0.4, 0.0), (0.0, 0.9)):  # still; head current; a cross current beyond 0.8
        assert step(in_current(cn, ce), NORTH, GuidanceState(), STEERAGE, 0.05)[0].speed_mps == 1.0
    assert step(in_current(0.5, 0.0), NORTH, GuidanceState(), COURSE, 0.05)[0].speed_mps == 1.0
    with pytest.raises(ValueError, match="min_water_speed_mps"):
        GuidanceParams(min_water_speed_mps=1.5)


def test_the_lookahead_grows_with_the_speed_over_ground() -> None:
    # GIVEN a vehicle 1 m to starboard of a path north, LOS with a 2 m lookahead or 2 s of lookahead time
    los = GuidanceParams(mode="los", lookahead_m=2.0)
    timed = dataclasses.replace(los, lookahead_time_s=2.0)
    for u, delta in ((0.5, 2.0), (1.0, 2.0), (1.5, 3.0)):
        nav = nav_state_at(5.0, 1.0, 1.0, 0.0, u_mps=u)
        r_fixed, _, _ = step(nav, NORTH, GuidanceState(), los, 0.05)
        r_timed, _, _ = step(nav, NORTH, GuidanceState(), timed, 0.05)
        # THEN the heading towards the path is atan(1 m / Delta), Delta = max(2 m, 2 s x speed)
        assert r_fixed.yaw_rad == pytest.approx(-math.atan(1.0 / 2.0))
        assert r_timed.yaw_rad == pytest.approx(-math.atan(1.0 / delta))
