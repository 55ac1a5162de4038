"""The stop after COMPLETE (surface) and in HOLD, and the run-in that slows to the arrival speed (issue 23,
item 3). Before: COMPLETE (surface) and HOLD were propeller 0 and fins neutral at once, whatever the
vehicle's speed, and the run-in asked for the full path speed up to the goal."""

from __future__ import annotations

import dataclasses
import math

import pytest

from onboard.core import guidance
from onboard.core.autopilot import Autopilot
from onboard.core.commands import Disarm, Hold, SetMode
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.state import MissionState
from onboard.core.nav.types import nav_state_at
from onboard.core.planner.path import StraightSegment
from onboard.core.planner.planner import plan
from onboard.core.plans import PlanRequest, compute_plan, last_goal_run_in_m
from onboard.protocol import messages as m
from tests.unit.autopilot.test_autopilot import load_core, started, tick

S = MissionState
GOAL = (Goal(20.0, 0.0, 1.0, 0.0),)


def _complete_at_speed(u_mps: float):  # type: ignore[no-untyped-def]
    """A mission COMPLETE (surface end action) with the vehicle at the goal moving ahead at ``u_mps``."""
    ap = started(GOAL)
    tick(ap, 0.05, u=u_mps)
    ex = ap.executive
    ex.goto.arrived(ex, ap, dataclasses.replace(ap.last_nav, x_m=20.0, position_std_m=0.1))  # type: ignore[arg-type]
    assert ap.status.state is S.COMPLETE
    return ap


def test_after_complete_a_moving_vehicle_brakes_then_goes_still() -> None:
    # GIVEN a mission COMPLETE (surface) while the vehicle still moves at 0.5 m/s
    ap = _complete_at_speed(0.5)
    # WHEN the ticks go on at that speed
    outs = [tick(ap, 0.1 + 0.05 * k, x=20.0 + 0.025 * k, u=0.5) for k in range(20)]
    # THEN the propeller reverses (at most [mission] brake_rps), the rudder is hard over (faster than
    # surface.HARD_OVER_MPS: the turn sheds the way ahead), the stern planes do not pitch it nose down
    # (deeper), and the actuators are live: armed, ARMED mode (the node obeys)
    last = outs[-1]
    assert last.propeller_rps < -1.0 and last.propeller_rps >= -ap.config.mission.brake_rps
    rudder_limit_rad = math.radians(ap.config.control.limits.rudder_limit_deg)
    assert abs(last.rudder_rad) == pytest.approx(rudder_limit_rad)
    assert last.stern_port_rad <= 0.0 and last.stern_starboard_rad <= 0.0
    assert ap.actuators_live and last.mode is m.ActuatorMode.ARMED and ap.executive.stop.braking
    verdict = ap.handle(SetMode("ready", "test"))  # the operator's "ready" is no lie either
    assert not verdict.accepted and "braking" in verdict.reason, verdict
    # WHEN it has stopped THEN propeller 0, fins neutral, disarmed (SAFE), as the surface end action was
    out = tick(ap, 1.2, x=20.5, u=0.0)
    out = tick(ap, 1.25, x=20.5, u=0.0)
    assert out.propeller_rps == 0.0 and out.rudder_rad == 0.0 and out.stern_port_rad == 0.0
    assert not ap.actuators_live and out.mode is m.ActuatorMode.SAFE
    assert ap.status.state is S.COMPLETE


def test_a_hold_brakes_a_moving_vehicle_the_same_way() -> None:
    # GIVEN a vehicle flying its leg at 1 m/s
    ap = started(GOAL)
    for k in range(5):
        tick(ap, 0.05 * (k + 1), x=0.05 * k, u=1.0)
    # WHEN the operator holds
    assert ap.handle(Hold("test")).accepted and ap.status.state is S.HOLD
    outs = [tick(ap, 0.3 + 0.05 * k, x=0.3 + 0.05 * k, u=1.0) for k in range(20)]
    # THEN the propeller reverses, live (HOLD is armed); stopped, the propeller is 0
    assert outs[-1].propeller_rps < -1.0 and outs[-1].mode is m.ActuatorMode.ARMED
    out = tick(ap, 1.4, x=1.4, u=0.0)
    out = tick(ap, 1.45, x=1.4, u=0.0)
    assert out.propeller_rps == 0.0 and not ap.executive.stop.braking and ap.status.state is S.HOLD


@pytest.mark.parametrize("left_m", [0.0, 2.0, 8.0])
def test_the_run_in_to_the_last_goal_slows_the_speed_reference_to_the_arrival_speed(left_m: float) -> None:
    # GIVEN the packaged guidance on a 30 m straight, the vehicle ``left_m`` before its end, at full speed
    cfg = load_core()
    path = plan((0.0, 0.0, 0.0), (30.0, 0.0, 0.0), cfg.planner, start_depth_m=1.0, goal_depth_m=1.0)
    nav = nav_state_at(x_m=30.0 - left_m, y_m=0.0, depth_m=1.0, yaw_rad=0.0, u_mps=1.0)
    state = guidance.GuidanceState(ref_speed_mps=1.0, s_ref_m=30.0, s_proj_m=30.0 - left_m)
    mission = cfg.mission
    # WHEN guidance steps on the run-in (the executive asks for it on the last goal's path)
    ref, _, _ = guidance.step(
        nav, path, state, cfg.guidance, 0.05,
        arrival_speed_mps=mission.arrival_speed_mps, run_in_decel_mps2=mission.run_in_decel_mps2,
    )  # fmt: skip
    # THEN its speed is at most sqrt(arrival^2 + 2 decel left) (the arrival speed at the goal), and the
    # moving reference is not behind the vehicle by more than RUN_IN_LAG_M
    bound = math.sqrt(mission.arrival_speed_mps**2 + 2.0 * mission.run_in_decel_mps2 * left_m)
    assert ref.speed_mps <= bound + 1e-9 and ref.e_along_m >= -guidance.guidance.RUN_IN_LAG_M - 1e-9
    # and without the run-in (an intermediate goal) it is the path speed, as before
    ref, _, _ = guidance.step(nav, path, state, cfg.guidance, 0.05)
    assert ref.speed_mps == pytest.approx(cfg.guidance.speed_mps)


def test_the_last_goal_is_approached_along_a_straight_long_enough_for_the_run_in() -> None:
    # GIVEN the paper's turn onto its goal (arriving heading 270 deg out of a turn), packaged configuration
    goals = (Goal(10.0, -2.0, 1.0, math.radians(270.0)),)
    ap = Autopilot(load_core())
    assert ap.replace_mission(Mission(goals)).accepted
    ap.request_autostart()
    tick(ap, 0.0, x=-15.0, y=5.0)
    ap.before_step()
    # WHEN the vehicle plans its leg to the last goal (at START)
    req = ap.take_plan_request()
    assert req is not None and req.kind == "goal"
    path = compute_plan(req)
    # THEN the path ends in a straight as long as the run-in's deceleration from the path speed to the
    # arrival speed ((1 - 0.25^2) / (2 x 0.025) = 18.75 m), so the run-in slows on it, not in the turn
    mission, speed = ap.config.mission, ap.config.guidance.speed_mps
    slowing_m = (speed**2 - mission.arrival_speed_mps**2) / (2.0 * mission.run_in_decel_mps2)
    last = path.segments[-1]
    assert isinstance(last, StraightSegment) and last.length_m >= slowing_m - 1e-6, path.segments
    # and the arc before it is flown at the path speed: the run-in's speed limit does not bind there
    s_arc = path.length_m - last.length_m - 0.5
    at = path.sample(s_arc)
    nav = nav_state_at(x_m=at.x_m, y_m=at.y_m, depth_m=1.0, yaw_rad=at.yaw_rad, u_mps=speed)
    state = guidance.GuidanceState(ref_speed_mps=speed, s_ref_m=s_arc, s_proj_m=s_arc)
    ref, _, dbg = guidance.step(
        nav, path, state, ap.config.guidance, 0.05,
        arrival_speed_mps=mission.arrival_speed_mps, run_in_decel_mps2=mission.run_in_decel_mps2,
    )  # fmt: skip
    assert not dbg.run_in and ref.speed_mps == pytest.approx(speed)


def test_an_intermediate_goal_keeps_the_planners_run_in() -> None:
    # GIVEN two goals THEN only the last one's straight is the run-in's length
    goals = (Goal(20.0, 0.0, 1.0, 0.0), Goal(40.0, 0.0, 1.0, 0.0))
    ap = started(goals)
    assert ap.executive.goal_run_in_m(ap, 0) == ap.config.planner.goal_run_in_m
    assert ap.executive.goal_run_in_m(ap, 1) == pytest.approx(18.75)


def test_without_a_run_in_the_last_goal_keeps_the_planners_run_in() -> None:
    assert last_goal_run_in_m(5.0, 1.0, 0.0, 0.025) == 5.0
    assert last_goal_run_in_m(5.0, 1.0, 0.25, 0.025) == pytest.approx(18.75)
    assert last_goal_run_in_m(30.0, 1.0, 0.25, 0.025) == 30.0


def test_a_long_run_in_that_does_not_fit_falls_back_to_the_planners_own() -> None:
    # GIVEN a goal whose 18.75 m run-in would start inside an obstacle
    cfg = load_core()
    goal = Goal(20.0, 0.0, 1.0, 0.0)
    req = PlanRequest(
        1, "goal", 0, (0.0, 10.0, 0.0), 1.0, goal, (Obstacle(8.0, 0.0, 2.0),), cfg.planner, 6.0, 0.0, 2.0,
        goal_run_in_m=18.75,
    )  # fmt: skip
    # WHEN planned THEN the path is the planner's own: its 5 m run-in (no error, no path into the obstacle)
    path = compute_plan(req)
    last = path.segments[-1]
    assert isinstance(last, StraightSegment)
    assert last.length_m == pytest.approx(cfg.planner.goal_run_in_m)


def test_on_the_run_in_the_depth_change_is_done_before_the_vehicle_is_slow() -> None:
    # GIVEN the packaged configuration on a 50 m straight diving 1 -> 10 m (depth.yaml's dive10)
    cfg = load_core()
    path = plan((0.0, 0.0, 0.0), (50.0, 0.0, 0.0), cfg.planner, start_depth_m=1.0, goal_depth_m=10.0)
    mission = cfg.mission
    slope = cfg.planner.max_depth_slope

    def depth_ref_at(s_m: float) -> tuple[float, float]:
        nav = nav_state_at(x_m=s_m, y_m=0.0, depth_m=5.0, yaw_rad=0.0, u_mps=1.0)
        state = guidance.GuidanceState(ref_speed_mps=1.0, s_ref_m=s_m, s_proj_m=s_m)
        ref, _, _ = guidance.step(
            nav, path, state, cfg.guidance, 0.05,
            arrival_speed_mps=mission.arrival_speed_mps, run_in_decel_mps2=mission.run_in_decel_mps2,
            run_in_depth_slope=slope,
        )  # fmt: skip
        return ref.depth_m, ref.speed_mps

    # WHEN guidance steps on the run-in THEN the goal's depth is reached where the run-in's speed
    # reference is still RUN_IN_DEPTH_SPEED_MPS, no steeper than the planner's limit (the stern planes'
    # lift goes with the speed squared: flown on to the goal slowly, the dive ended 0.43 m short)
    fast = guidance.guidance.RUN_IN_DEPTH_SPEED_MPS
    slow_m = (fast**2 - mission.arrival_speed_mps**2) / (2.0 * mission.run_in_decel_mps2)
    done_m = max(path.length_m - slow_m, 9.0 / slope)
    assert done_m < path.length_m - 5.0
    assert depth_ref_at(done_m)[0] == pytest.approx(10.0)
    assert depth_ref_at(done_m / 2.0)[0] == pytest.approx(1.0 + 4.5)
    depth, speed = depth_ref_at(done_m - 0.5)
    assert depth < 10.0 and speed >= fast
    # and the last metres are level at the goal's depth
    assert depth_ref_at(45.0)[0] == pytest.approx(10.0)


def test_a_new_path_that_loops_back_across_its_start_is_flown_from_its_start() -> None:
    # GIVEN a goal 12 m straight ahead whose 18.75 m run-in begins behind the vehicle: the path loops back
    # and its run-in passes through the vehicle's position (legs_3d.yaml's steep leg between two goals)
    cfg = load_core()
    req = PlanRequest(
        1, "goal", 0, (0.0, 0.0, 0.0), 1.0, Goal(12.0, 0.0, 8.0, 0.0), (), cfg.planner, 6.0, 0.0, 2.0,
        goal_run_in_m=18.75,
    )  # fmt: skip
    path = compute_plan(req)
    assert path.length_m > 30.0
    # WHEN guidance takes the new path (its memory fresh) with the vehicle at its start
    nav = nav_state_at(x_m=0.0, y_m=0.01, depth_m=1.0, yaw_rad=0.0, u_mps=1.0)
    ref, _, _ = guidance.step(nav, path, guidance.GuidanceState(), cfg.guidance, 0.05)
    # THEN the vehicle is at the path's start, not on the run-in (before: projected onto the run-in, it flew
    # straight to the goal, 10.5 m off the path and 5.8 m short of the goal's depth)
    assert ref.along_track_m < 1.0


def test_after_complete_a_vehicle_the_water_carries_astern_holds_position_at_the_goal() -> None:
    # GIVEN a mission COMPLETE (surface) at the goal (20, 0), heading north, while a head current the
    # estimate cannot see carries the vehicle astern over ground (head_current.yaml: swept 8-13 m back in
    # 20 s once the propeller stopped)
    ap = _complete_at_speed(0.0)
    outs = [tick(ap, 0.1 + 0.05 * k, x=20.0 - 0.02 * k, u=-0.4) for k in range(20)]
    # THEN it holds position: a leg into the drift (north) ending at the goal, the propeller forward, live
    ex = ap.executive
    assert ex.path_kind == "hold" and ex.path is not None, ex.path_kind
    end = ex.path.sample(ex.path.length_m)
    assert (end.x_m, end.y_m) == pytest.approx((20.0, 0.0)) and end.yaw_rad == pytest.approx(0.0, abs=1e-6)
    assert outs[-1].propeller_rps > 1.0 and ap.actuators_live and outs[-1].mode is m.ActuatorMode.ARMED
    assert ap.status.state is S.COMPLETE
    assert ex.surface.progress(ex, ap).text == "holding position"
    # WHEN the operator disarms THEN the hold ends: IDLE, propeller 0, not live
    assert ap.handle(Disarm(source="test")).accepted
    out = tick(ap, 1.2, x=19.6, u=-0.4)
    assert ap.status.state is S.IDLE and out.propeller_rps == 0.0 and not ap.actuators_live
    assert ex.path_kind != "hold"


def test_a_stopped_vehicle_in_still_water_does_not_hold() -> None:
    # GIVEN a mission COMPLETE (surface) in still water, the vehicle stopping 2 m past its goal
    ap = _complete_at_speed(0.3)
    for k in range(40):
        tick(ap, 0.1 + 0.05 * k, x=20.0 + 0.01 * k, u=max(0.3 - 0.02 * k, 0.0))
    # THEN, stopped and still, it does not hold: propeller 0, not live
    out = tick(ap, 2.2, x=20.4, u=0.0)
    out = tick(ap, 2.25, x=20.4, u=0.0)
    assert ap.executive.path_kind != "hold" and out.propeller_rps == 0.0 and not ap.actuators_live
