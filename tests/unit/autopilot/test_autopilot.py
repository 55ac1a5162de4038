"""The autopilot: the one judge of commands, planning off the tick, arrival and misses, a mission's end."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from auv_common.config import from_table, load_toml
from onboard.core import commands as c
from onboard.core import nav
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.state import MissionEvent, MissionState
from onboard.core.planner.errors import PlannerError
from onboard.core.plans import compute_plan
from onboard.protocol import messages as m

DT = 0.05
S = MissionState


def sensors(
    t: float, x: float = 0.0, y: float = 0.0, depth: float = 1.0, yaw: float = 0.0, u: float = 0.0
) -> dict[type, object]:
    msgs = [
        m.AhrsAttitude(0.0, 0.0, yaw, t),
        m.AhrsRates(0.0, 0.0, 0.0, t),
        m.DepthMeas(depth, t),
        m.DvlVelocity(u, 0.0, 0.0, True, t),
        m.PositionFix(x, y, t),
    ]
    return {type(msg): msg for msg in msgs}


ONBOARD_TOML = Path(__file__).parents[3] / "onboard" / "config" / "onboard.toml"


def load_core() -> CoreConfig:
    """The core tables of the onboard.toml the vehicle flies with (no bus, loop or link)."""
    data = load_toml(ONBOARD_TOML)
    tables = {f.name for f in dataclasses.fields(CoreConfig)}
    return from_table(CoreConfig, {k: v for k, v in data.items() if k in tables}, "onboard.toml")


def core(**mission: object) -> CoreConfig:
    cfg = load_core()
    if mission:
        cfg = dataclasses.replace(cfg, mission=dataclasses.replace(cfg.mission, **mission))  # type: ignore[arg-type]
    return cfg


def run_plans(ap: Autopilot) -> bool:
    """What the loop's planning worker does, synchronously: True if a plan was asked for."""
    req = ap.take_plan_request()
    if req is None:
        return False
    try:
        result = compute_plan(req)
    except PlannerError as exc:
        ap.plan_done(req.request_id, exc)
    else:
        ap.plan_done(req.request_id, result)
    return True


def tick(ap: Autopilot, t: float, *, jump: bool = False, **kw: float):  # type: ignore[no-untyped-def]
    """One tick with the sensors at ``kw``; ``jump``: the filter takes the fix afresh (a test teleport)."""
    if jump:
        ap.nav_state = nav.NavFilterState.initial()
    ap.before_step()  # what the loop does first: the core's own sources (autostart)
    run_plans(ap)
    out = ap.step(sensors(t, **kw), t, DT)
    run_plans(ap)
    return out


def started(goals: tuple[Goal, ...], obstacles: tuple[Obstacle, ...] = (), **mission: object) -> Autopilot:
    ap = Autopilot(core(**mission))
    assert ap.replace_mission(Mission(goals, obstacles)).accepted
    ap.request_autostart()
    tick(ap, 0.0)  # navigation valid from this step on
    ap.before_step()  # the autostart's START (and its plan, below) before the next step
    run_plans(ap)
    return ap


def test_autostart_waits_for_valid_navigation_then_plans_off_the_tick() -> None:
    # GIVEN an armed autostart and no sensor data yet
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.request_autostart()
    ap.before_step()
    out = ap.step({}, 0.0, DT)
    assert out.status.state is S.ARMED and out.propeller_rps == 0.0 and not ap.plan_pending
    # WHEN navigation becomes valid THEN the next step starts, with its plan asked for before it
    ap.before_step()
    out = ap.step(sensors(0.05), 0.05, DT)
    assert out.status.state is S.ARMED  # (valid from this step on)
    ap.before_step()
    assert ap.status.state is S.RUNNING and ap.plan_pending and ap.path is None
    assert run_plans(ap)  # the loop's worker, before the step
    out = ap.step(sensors(0.1), 0.1, DT)
    assert ap.path is not None and ap.path.length_m > 19.0 and out.propeller_rps > 0.0


def test_start_without_navigation_is_temporarily_rejected_with_the_reason() -> None:
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    assert ap.handle(c.Arm()).accepted
    v = ap.handle(c.Start())
    assert v.outcome is c.Outcome.TEMPORARILY_REJECTED and "navigation" in v.reason
    assert ap.ready == (False, "navigation not valid yet")


def test_commands_the_old_endpoint_acked_and_the_core_refused_now_have_one_verdict() -> None:
    # ARM in COMPLETE: accepted, and it really arms (goal 0, fly again)
    ap = started((Goal(2.0, 0.0, 1.0, None),))
    ap.status = dataclasses.replace(ap.status, state=S.COMPLETE, goal_index=1)
    v = ap.handle(c.Arm())
    assert v.accepted and ap.status.state is S.ARMED and ap.status.goal_index == 0
    # a forced disarm in RUNNING: accepted and carried out, propeller 0 in the same tick
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    for k in range(1, 10):
        out = tick(ap, k * DT)
    assert out.status.state is S.RUNNING and out.propeller_rps > 0.0
    assert not ap.handle(c.Disarm()).accepted
    v = ap.handle(c.Disarm(forced=True))
    assert v.accepted and ap.status.state is S.IDLE
    out = tick(ap, 0.5)
    assert out.propeller_rps == 0.0 and not ap.actuators_live


def test_every_refusal_has_a_reason() -> None:
    ap = Autopilot(core())
    for cmd in (c.Arm(), c.Start(), c.Hold(), c.Resume(), c.SetCurrent(3), c.SetMode("loiter")):
        v = ap.handle(cmd)
        assert not v.accepted and len(v.reason) > 10, (cmd, v)


def test_an_empty_mission_while_running_holds_and_resume_is_refused() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    assert ap.handle(c.ReplaceMission(Mission(()), True)).accepted
    assert ap.status.state is S.HOLD and ap.actuators_live  # still armed, holding
    v = ap.handle(c.Resume())
    assert not v.accepted and "no goals" in v.reason
    out = tick(ap, 0.1)
    assert out.propeller_rps == 0.0


def test_a_new_mission_while_running_holds_until_start_and_keeps_the_armed_state() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0), Goal(40.0, 0.0, 1.0, 0.0)))
    ap.status = dataclasses.replace(ap.status, goal_index=1)
    v = ap.handle(c.ReplaceMission(Mission((Goal(10.0, 5.0, 1.0, None),)), True))
    assert v.accepted and ap.status.state is S.HOLD and ap.status.goal_index == 0 and ap.actuators_live
    assert ap.handle(c.Start()).accepted and ap.status.state is S.RUNNING


def test_a_fence_upload_keeps_the_state_and_the_current_goal() -> None:
    # RUNNING at goal 1: a fence change re-plans the leg but never resets the progress
    ap = started((Goal(20.0, 0.0, 1.0, 0.0), Goal(40.0, 0.0, 1.0, 0.0)))
    assert ap.handle(c.SetCurrent(1)).accepted
    tick(ap, 0.05)
    tick(ap, 0.1)
    assert ap.path is not None and ap.path_goal_index == 1
    fenced = Mission(ap.mission.goals, (Obstacle(20.0, 10.0, 1.0),))
    v = ap.handle(c.ReplaceMission(fenced, goals_changed=False))
    assert v.accepted and ap.status.state is S.RUNNING and ap.status.goal_index == 1
    assert ap.path is not None  # the old path is flown until the new one arrives
    tick(ap, 0.15)
    assert ap.mission.obstacles and ap.path_goal_index == 1
    # COMPLETE: a fence upload does not re-arm
    ap.status = dataclasses.replace(ap.status, state=S.COMPLETE, goal_index=2)
    assert ap.handle(c.ReplaceMission(Mission(ap.mission.goals), goals_changed=False)).accepted
    assert ap.status.state is S.COMPLETE


def test_a_leg_that_cannot_be_planned_holds_with_the_planner_reason_and_resume_plans_again() -> None:
    # GIVEN a mission accepted (leg 0 is planned at START, from where the vehicle is) and a vehicle that
    # sits inside an obstacle of the fence
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), (Obstacle(0.0, 0.0, 1.0),))
    out = tick(ap, 0.05)
    assert out.status.state is S.HOLD and "start_in_obstacle" in out.planner_error
    notes = ap.take_notes()
    assert any("cannot plan goal 0" in n.text and n.severity is c.Severity.WARNING for n in notes)
    ap.handle(c.ReplaceMission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)), goals_changed=False))
    assert ap.handle(c.Resume()).accepted
    tick(ap, 0.1)
    out = tick(ap, 0.15)
    assert out.status.state is S.RUNNING and ap.path is not None and out.propeller_rps > 0.0


def test_stale_navigation_aborts_with_propeller_off_at_once_and_nose_up() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    for k in range(1, 20):
        out = tick(ap, k * DT)
    assert out.propeller_rps > 0.0
    out = ap.step(sensors(0.0), 5.0, DT)  # the same samples, 5 s old
    assert out.status.state is S.ABORT and out.propeller_rps == 0.0  # no ramp-down: not live
    for k in range(1, 20):  # the fins move at their rate limit towards the abort position
        out = ap.step(sensors(0.0), 5.0 + k * DT, DT)
    assert "navigation stale" in out.status.reason and out.mode is m.ActuatorMode.ABORT
    assert out.stern_port_rad < 0.0 and out.stern_starboard_rad < 0.0  # negative stern = nose up
    assert math.isclose(out.rudder_rad, 0.0, abs_tol=1e-9)


def test_armed_sends_safe_and_a_latched_actuator_failsafe_blocks_the_start() -> None:
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.handle(c.Arm())
    cache = sensors(0.0)
    cache[m.PropStatus] = m.PropStatus(0.0, False, True, False, 0, 0.0)  # failsafe latched
    out = ap.step(cache, 0.0, DT)
    assert out.mode is m.ActuatorMode.SAFE and ap.actuators_live
    v = ap.handle(c.Start())
    assert v.outcome is c.Outcome.TEMPORARILY_REJECTED and "failsafe" in v.reason
    cache[m.PropStatus] = m.PropStatus(0.0, False, False, False, 0, 0.05)  # cleared by the SAFE command
    ap.step(cache, 0.05, DT)
    assert ap.handle(c.Start()).accepted


def test_actuator_failsafe_while_running_aborts() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    cache = sensors(0.05)
    cache[m.PropStatus] = m.PropStatus(0.0, False, True, False, 0, 0.05)
    out = ap.step(cache, 0.05, DT)
    assert out.status.state is S.ABORT and "actuator" in out.status.reason


def test_a_new_start_plans_afresh_from_where_the_vehicle_is() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    tick(ap, 0.05)
    first_path = ap.path
    ap.handle(c.Abort())
    ap.handle(c.Disarm())
    ap.handle(c.Arm())
    tick(ap, 1.0, yaw=1.0)
    assert ap.handle(c.Start()).accepted
    tick(ap, 1.05, yaw=1.0)
    tick(ap, 1.1, yaw=1.0)
    assert ap.path is not None and ap.path is not first_path
    assert abs(ap.path.sample(0.0).yaw_rad - 1.0) < 0.01


def test_start_continues_from_the_restored_progress_and_at_an_item() -> None:
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0), Goal(40.0, 0.0, 1.0, 0.0))))
    assert ap.restore_progress(1)
    ap.handle(c.Arm())
    tick(ap, 0.0)
    assert ap.handle(c.Start()).accepted and ap.status.goal_index == 1
    ap.handle(c.Hold())
    assert ap.handle(c.Start(first_goal=0)).accepted and ap.status.goal_index == 0
    assert ap.status.state is S.RUNNING


def test_autostart_is_not_left_pending_when_arming_fails_or_after_abort() -> None:
    ap = Autopilot(core())
    ap.request_autostart()  # no mission: ARM refused
    assert not ap.autostart_pending
    # and the operator is told why (no ground station asked, so no COMMAND_ACK carries it)
    texts = [n.text for n in ap.take_notes()]
    assert any(t.startswith("autostart: arm refused: ") for t in texts), texts
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.request_autostart()
    ap.handle(c.Abort())
    assert not ap.autostart_pending


def _fly_to(ap: Autopilot, x: float, y: float, t0: float) -> None:
    """Put the vehicle's estimate just past the goal line of goal 0 at (x, y) (heading north)."""
    for k in range(3):
        tick(ap, t0 + k * DT, x=x - 0.3 + 0.3 * k, y=y, u=1.0)


def test_a_goal_is_reached_only_within_the_arrival_radius_else_re_planned_then_held() -> None:
    # GIVEN a goal at (20, 0) heading north and the vehicle crossing its goal line 2 m to the side
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), max_tries=2)
    tick(ap, 0.05)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    tick(ap, 0.1, x=20.1, y=2.0, jump=True)
    # THEN it is a miss: not COMPLETE, a re-plan to the same goal from where it is, with a note
    assert ap.status.state is S.RUNNING and ap.goals_reached == 0 and ap.attempt == 2
    assert any("missed by 2.00 m" in n.text for n in ap.take_notes())
    # WHEN it misses again THEN it holds with the reason (max_tries = 2)
    tick(ap, 0.15, x=20.1, y=2.0)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    tick(ap, 0.2, x=20.1, y=2.0)
    assert ap.status.state is S.HOLD and "missed by" in ap.status.reason and "2 tries" in ap.status.reason


def test_surface_end_action_stops_at_once_and_disarms() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    for k in range(1, 10):
        out = tick(ap, k * DT)
    assert out.propeller_rps > 0.0
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    out = tick(ap, 0.5, x=20.05, y=0.1, jump=True)
    assert out.status.state is S.COMPLETE and ap.goals_reached == 1
    assert out.propeller_rps == 0.0 and out.rudder_rad == 0.0 and out.stern_port_rad == 0.0
    assert out.mode is m.ActuatorMode.SAFE and not ap.actuators_live
    for k in range(1, 50):  # nothing drives on past the goal
        out = tick(ap, 0.5 + k * DT, x=20.05 + 0.01 * k)
        assert out.propeller_rps == 0.0


def test_loiter_end_action_circles_the_last_goal_and_stays_armed() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), end_action="loiter")
    tick(ap, 0.05)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    out = tick(ap, 0.1, x=20.05, jump=True)
    assert out.status.state is S.COMPLETE and ap.actuators_live
    tick(ap, 0.15, x=20.1)
    out = tick(ap, 0.2, x=20.15)
    assert ap.path_kind == "loiter" and ap.path is not None and out.propeller_rps > 0.0
    r = 2.0 * ap.config.planner.turning_radius_m
    far = ap.path.sample(ap.path.length_m / 2.0)  # somewhere on the circle
    assert math.isclose(math.hypot(far.x_m - 20.0, far.y_m), r, rel_tol=1e-6)


def test_mode_ready_is_refused_where_it_would_change_nothing_that_is_true() -> None:
    """DO_SET_MODE MANUAL ("ready") was ACCEPTED "nothing to change" while the vehicle circled its last goal
    (propeller on) and in ABORT: the operator was told the vehicle was ready while it drove on."""
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), end_action="loiter")
    tick(ap, 0.05)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    out = tick(ap, 0.1, x=20.05, jump=True)
    assert out.status.state is S.COMPLETE and ap.actuators_live
    v = ap.handle(c.SetMode("ready"))
    assert v.outcome is c.Outcome.DENIED and v.reason == "COMPLETE (loitering): disarm to stop"
    assert ap.handle(c.Abort("test")).accepted
    v = ap.handle(c.SetMode("ready"))
    assert v.outcome is c.Outcome.DENIED and v.reason == "ABORT: disarm to acknowledge it"
    assert ap.handle(c.Disarm()).accepted and ap.handle(c.SetMode("ready")).accepted  # IDLE: nothing to do


def test_a_plan_that_misses_its_deadline_holds_with_the_reason() -> None:
    ap = Autopilot(core(plan_deadline_s=0.2))
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.request_autostart()
    ap.step(sensors(0.0), 0.0, DT)
    ap.before_step()
    req = ap.take_plan_request()
    assert req is not None  # the worker never answers
    ap.step(sensors(0.05), 0.05, DT)
    out = ap.step(sensors(0.3), 0.3, DT)
    assert out.status.state is S.HOLD and "deadline" in out.status.reason
    ap.plan_done(req.request_id, compute_plan(req))  # a late answer is dropped
    assert ap.path is None


def test_an_encode_fault_while_running_aborts_with_the_reason() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    ap.note_encode_fault("FIN_CMD", "rudder 0.8 out of range")
    out = tick(ap, 0.05)
    assert out.status.state is S.ABORT and "not encodable" in out.status.reason


def test_mission_events_still_apply_directly() -> None:
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    assert ap.apply(MissionEvent.ARM).accepted
    # the state table still refuses what it refuses (readiness is the judge's: handle(Start))
    assert not ap.apply(MissionEvent.HOLD).accepted


def test_a_parameter_is_judged_by_the_core_and_the_verdict_carries_the_value_in_force() -> None:
    from onboard.core.params import BusLimits
    from onboard.protocol.codec import command_ranges

    ap = Autopilot(core(), bus_limits=BusLimits.from_ranges(command_ranges()))
    before = ap.config
    v = ap.handle(c.SetParam("LIM_RPS_MAX", 0.0))  # max must stay above min
    assert not v.accepted and ap.config == before and v.value == before.control.limits.propeller_max_rps
    v = ap.handle(c.SetParam("LIM_RUDDER_DEG", 45.0))  # beyond the DBC's FIN_CMD range
    assert not v.accepted and ap.config == before
    v = ap.handle(c.SetParam("PD_KP5", -0.5))
    assert v.accepted and v.value == -0.5 and ap.config.control.gains.Kp5 == -0.5
    assert not ap.handle(c.SetParam("NOPE", 1.0)).accepted
    # a change that would leave the mission in force out of its limits is refused too
    ap.replace_mission(Mission((Goal(20.0, 0.0, 8.0, 0.0),)))
    v = ap.handle(c.SetParam("FS_MAX_DEPTH_M", 5.0))
    assert not v.accepted and "goal 0" in v.reason and ap.config.failsafe.max_depth_m == v.value == 20.0


def test_an_arrival_the_estimate_cannot_confirm_holds_with_the_reason() -> None:
    # GIVEN a vehicle whose estimate says "at the goal" but whose position is known only to 3.6 m (sea fixes)
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    tick(ap, 0.05)
    assert ap.last_nav is not None
    at_goal = dataclasses.replace(
        ap.last_nav, x_m=20.0, y_m=0.05, position_std_m=3.6, position_std_x_m=2.55, position_std_y_m=2.55
    )
    ap.executive.goto.arrived(ap.executive, ap, at_goal)
    # THEN it does not claim the goal: it holds and says why (the 95 % region: 2.45 x 2.55 m)
    assert ap.status.state is S.HOLD and ap.goals_reached == 0
    assert "cannot be confirmed" in ap.status.reason and "6.2 m" in ap.status.reason


def test_a_fence_that_arrives_while_the_plan_is_computed_is_planned_round() -> None:
    # GIVEN a START whose plan (round the old, empty fence) is still with the worker
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(40.0, 0.0, 1.0, 0.0),)))
    tick(ap, 0.0)
    assert ap.handle(c.Arm()).accepted and ap.handle(c.Start()).accepted
    old = ap.take_plan_request()
    assert old is not None and old.obstacles == ()
    # WHEN a fence with an obstacle on the leg is accepted meanwhile
    fence = (Obstacle(20.0, 0.0, 3.0),)
    assert ap.handle(c.ReplaceMission(Mission(ap.mission.goals, fence), goals_changed=False)).accepted
    # THEN the old answer is dropped and the new request carries the new obstacles
    ap.plan_done(old.request_id, compute_plan(old))
    assert ap.path is None
    new = ap.take_plan_request()
    assert new is not None and new.obstacles == fence
    ap.plan_done(new.request_id, compute_plan(new))
    assert ap.path is not None and ap.path.length_m > 40.5  # round the obstacle


def test_a_mission_out_of_the_limits_in_force_is_refused_by_the_core_too() -> None:
    # the upload was checked, then the failsafe depth was lowered before the core took the mission
    ap = Autopilot(core())
    ap.config = dataclasses.replace(
        ap.config, failsafe=dataclasses.replace(ap.config.failsafe, max_depth_m=10.0)
    )
    v = ap.handle(c.ReplaceMission(Mission((Goal(20.0, 0.0, 15.0, 0.0),)), True))
    assert not v.accepted and "depth 15" in v.reason and ap.mission.goals == ()


def test_a_loiter_that_falls_back_to_surfacing_is_not_armed() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), (Obstacle(20.0, 5.86, 0.5),), end_action="loiter")
    tick(ap, 0.05)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    tick(ap, 0.1, x=20.05, jump=True)  # COMPLETE: the loiter circle (5.86 m) cuts the obstacle
    tick(ap, 0.15, x=20.05)  # the loiter plan is refused by the worker
    out = tick(ap, 0.2, x=20.05)
    assert out.status.state is S.COMPLETE and ap.path_kind == "surface"
    assert not ap.actuators_live and out.propeller_rps == 0.0 and out.mode is m.ActuatorMode.SAFE


def test_a_plan_at_the_tighter_turning_radius_warns_the_operator() -> None:
    # GIVEN random mission r44 (both 2.93 m start circles blocked), the vehicle at its start pose
    x, y, yaw = -7.51, 15.4, math.radians(161.4)
    fence = (Obstacle(-16.19, -15.97, 3.41), Obstacle(-11.76, 15.64, 1.83))
    ap = Autopilot(core())
    assert ap.replace_mission(Mission((Goal(-21.61, -26.34, 1.0, math.radians(203.2)),), fence)).accepted
    ap.request_autostart()
    for k in range(3):
        tick(ap, k * DT, x=x, y=y, yaw=yaw)
    # THEN it flies (RUNNING, a path) and says which radius it planned with, and why
    assert ap.status.state is S.RUNNING and ap.path is not None
    notes = [n.text for n in ap.take_notes()]
    assert any("goal 0: planned with the tighter turning radius 2.5 m" in t for t in notes), notes


def _drifting(t: float, cross_mps: float, u: float = 1.0) -> dict[type, object]:
    """Sensors of a vehicle heading north at ``u`` m/s through the water, set east by ``cross_mps``: the
    tests' phases (at rest to 1 s, under way from 1 s, set east from 3 s) with continuous positions (the
    packaged fixes are good to 4 mm: a teleport is refused by the gate, five in a row restart the
    estimate)."""
    cache = sensors(t, x=u * max(t - 1.0, 0.0), y=cross_mps * max(t - 3.0, 0.0), u=u)
    cache[m.DvlVelocity] = m.DvlVelocity(u, cross_mps, 0.0, True, t)
    return cache


def _fly_drifting(ap: Autopilot, t0: float, seconds: float, cross_mps: float, u: float = 1.0) -> float:
    t = t0
    for _ in range(round(seconds / DT)):
        t += DT
        ap.before_step()
        run_plans(ap)
        ap.step(_drifting(t, cross_mps, u), t, DT)
    return t


def test_a_path_is_planned_again_when_the_current_turns_out_other_than_planned_for() -> None:
    # GIVEN a goal 60 m ahead, planned in still water (the estimate at START)
    ap = Autopilot(core())
    assert ap.replace_mission(Mission((Goal(60.0, 10.0, 1.0, math.radians(90.0)),))).accepted
    ap.request_autostart()
    t = _fly_drifting(ap, 0.0, 1.0, 0.0, u=0.0)  # at rest in still water: START
    t = _fly_drifting(ap, t, 2.0, 0.0)
    assert ap.status.state is S.RUNNING and ap.path is not None
    first = ap.path
    ap.take_notes()
    # WHEN the DVL shows a 0.3 m/s current across the heading for a few seconds
    _fly_drifting(ap, t, 12.0, 0.3)
    # THEN the path is planned again for it (wider turns: once on the way, once it is learnt, 5 s apart)
    # and the operator is told each time
    notes = [n.text for n in ap.take_notes() if "re-planned" in n.text]
    assert len(notes) == 2, notes
    said = [float(n.split("estimated, ")[1].split(" m/s")[0]) for n in notes]
    assert 0.1 <= said[0] < 0.2 and said[1] >= said[0] + 0.09, notes
    assert ap.path is not first and ap.status.state is S.RUNNING
    # and the new path's reference starts at the vehicle's 1 m/s, not from rest
    assert ap.guidance_state.ref_speed_mps == 1.0


def test_a_re_plan_that_fails_keeps_the_path_flown() -> None:
    ap = Autopilot(core())
    assert ap.replace_mission(Mission((Goal(60.0, 10.0, 1.0, math.radians(90.0)),))).accepted
    ap.request_autostart()
    t = _fly_drifting(ap, 0.0, 1.0, 0.0, u=0.0)
    t = _fly_drifting(ap, t, 2.0, 0.0)
    first = ap.path
    for _ in range(200):  # until the estimate asks for a re-plan; the worker's answer: no way
        t += DT
        ap.step(_drifting(t, 0.3), t, DT)
        req = ap.take_plan_request()
        if req is not None:
            break
    assert req is not None and req.replan and req.planned_current_mps == 0.0
    ap.plan_done(req.request_id, PlannerError("no_path", "blocked"))
    # THEN it keeps flying the path it has, RUNNING, with no planner error shown
    assert ap.status.state is S.RUNNING and ap.path is first and ap.planner_error == ""
    # and it does not ask again at once (the interval between re-plans)
    ap.step(_drifting(t + DT, 0.3), t + DT, DT)
    assert ap.take_plan_request() is None
