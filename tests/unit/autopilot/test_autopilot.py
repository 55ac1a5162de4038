"""The autopilot composition: events, autostart, planning, a mission without goals, failsafe on stale nav."""

from __future__ import annotations

import math

from onboard.app.config import load_config
from onboard.core.autopilot import Autopilot
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionEvent, MissionState
from onboard.protocol import messages as m

DT = 0.05


def sensors(
    t: float, x: float = 0.0, y: float = 0.0, depth: float = 1.0, yaw: float = 0.0
) -> dict[type, object]:
    msgs = [
        m.AhrsAttitude(0.0, 0.0, yaw, t),
        m.AhrsRates(0.0, 0.0, 0.0, t),
        m.DepthMeas(depth, t),
        m.DvlVelocity(0.0, 0.0, 0.0, True, t),
        m.PositionFix(x, y, t),
    ]
    return {type(msg): msg for msg in msgs}


def started(goals: tuple[Goal, ...]) -> Autopilot:
    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission(goals))
    ap.request_autostart()
    ap.step(sensors(0.0), 0.0, DT)
    return ap


def test_autostart_waits_for_valid_navigation() -> None:
    # GIVEN an armed autostart and no sensor data yet
    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.request_autostart()
    out = ap.step({}, 0.0, DT)
    # THEN it stays ARMED with a neutral command; WHEN navigation becomes valid THEN it starts and plans
    assert out.status.state is MissionState.ARMED and out.propeller_rps == 0.0
    out = ap.step(sensors(0.05), 0.05, DT)
    assert out.status.state is MissionState.RUNNING
    assert ap.path is not None and ap.path.length_m > 19.0


def test_start_is_refused_without_navigation() -> None:
    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.apply(MissionEvent.ARM)
    assert not ap.apply(MissionEvent.START).accepted


def test_resume_into_a_mission_without_goals_holds_instead_of_crashing() -> None:
    # GIVEN a running mission that is held, then replaced by an empty one (a clear), then resumed
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    ap.apply(MissionEvent.HOLD)
    ap.replace_mission(Mission(()))
    ap.apply(MissionEvent.RESUME)
    # WHEN the next tick runs THEN there is nothing to plan: back to HOLD with the reason, neutral output
    out = ap.step(sensors(0.1), 0.1, DT)
    assert out.status.state is MissionState.HOLD
    assert "no goal" in out.status.reason
    assert out.propeller_rps == 0.0


def test_unreachable_goal_holds_with_the_planner_reason() -> None:
    # GIVEN a goal inside an obstacle (the planner refuses it)
    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),), ()))
    from onboard.core.mission.model import Obstacle

    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),), (Obstacle(20.0, 0.0, 3.0),)))
    ap.request_autostart()
    out = ap.step(sensors(0.0), 0.0, DT)
    assert out.status.state is MissionState.HOLD
    assert "goal_in_obstacle" in out.planner_error


def test_stale_navigation_aborts_with_propeller_off_and_nose_up() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    out = ap.step(sensors(0.0), 5.0, DT)  # the same samples, 5 s old
    for k in range(1, 20):  # the fins move at their rate limit towards the abort position
        out = ap.step(sensors(0.0), 5.0 + k * DT, DT)
    assert out.status.state is MissionState.ABORT and "navigation stale" in out.status.reason
    assert out.mode is m.ActuatorMode.ABORT
    assert out.propeller_rps == 0.0
    assert out.stern_port_rad < 0.0 and out.stern_starboard_rad < 0.0  # negative stern = nose up
    assert math.isclose(out.rudder_rad, 0.0, abs_tol=1e-9)


def test_armed_sends_safe_and_a_latched_actuator_failsafe_blocks_the_start() -> None:
    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.apply(MissionEvent.ARM)
    cache = sensors(0.0)
    cache[m.PropStatus] = m.PropStatus(0.0, False, True, False, 0, 0.0)  # failsafe latched
    out = ap.step(cache, 0.0, DT)
    assert out.mode is m.ActuatorMode.SAFE  # ARMED: propeller off, fins neutral, and it clears the latch
    assert not ap.apply(MissionEvent.START).accepted
    cache[m.PropStatus] = m.PropStatus(0.0, False, False, False, 0, 0.05)  # cleared by the SAFE command
    ap.step(cache, 0.05, DT)
    assert ap.apply(MissionEvent.START).accepted


def test_actuator_failsafe_while_running_aborts() -> None:
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    cache = sensors(0.05)
    cache[m.PropStatus] = m.PropStatus(0.0, False, True, False, 0, 0.05)
    out = ap.step(cache, 0.05, DT)
    assert out.status.state is MissionState.ABORT and "actuator" in out.status.reason


def test_a_new_start_plans_afresh_from_where_the_vehicle_is() -> None:
    # GIVEN a mission started, aborted, disarmed, then (the vehicle turned) armed and started again
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    first_path = ap.path
    ap.apply(MissionEvent.ABORT)
    ap.apply(MissionEvent.DISARM)
    ap.apply(MissionEvent.ARM)
    ap.step(sensors(1.0, yaw=1.0), 1.0, DT)
    assert ap.apply(MissionEvent.START).accepted
    ap.step(sensors(1.05, yaw=1.0), 1.05, DT)
    # THEN a new path is planned from the pose at the new start (heading 1 rad), not the old one (north)
    assert ap.path is not None and ap.path is not first_path
    assert abs(ap.path.sample(0.0).yaw_rad - 1.0) < 0.01


def test_resume_after_a_planning_failure_plans_again() -> None:
    from onboard.core.mission.model import Obstacle

    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),), (Obstacle(20.0, 0.0, 3.0),)))
    ap.request_autostart()
    ap.step(sensors(0.0), 0.0, DT)
    assert ap.status.state is MissionState.HOLD
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))  # the operator removes the obstacle
    assert ap.apply(MissionEvent.RESUME).accepted
    out = ap.step(sensors(0.05), 0.05, DT)
    assert out.status.state is MissionState.RUNNING and ap.path is not None and out.propeller_rps > 0.0


def test_autostart_is_not_left_pending_when_arming_fails_or_after_abort() -> None:
    ap = Autopilot(load_config().core)
    ap.request_autostart()  # no mission: ARM rejected
    assert not ap.autostart_pending
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.request_autostart()
    ap.apply(MissionEvent.ABORT)
    assert not ap.autostart_pending


def test_mavlink_start_at_an_item_and_start_in_hold_resumes() -> None:
    from onboard.adapters.mavlink import api
    from onboard.adapters.mavlink import bridge as link_bridge

    ap = Autopilot(load_config().core)
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0), Goal(40.0, 0.0, 1.0, 0.0))))
    ap.apply(MissionEvent.ARM)
    ap.step(sensors(0.0), 0.0, DT)
    link_bridge.apply_event(ap, api.StartMission(first_index=1))
    assert ap.status.state is MissionState.RUNNING and ap.status.goal_index == 1
    ap.apply(MissionEvent.HOLD)
    link_bridge.apply_event(ap, api.StartMission())
    assert ap.status.state is MissionState.RUNNING


def test_a_parameter_that_breaks_the_configuration_is_refused_not_a_crash() -> None:
    from onboard.adapters.mavlink import bridge as link_bridge

    ap = Autopilot(load_config().core)
    before = ap.config
    assert not link_bridge.apply_param(ap, "LIM_RPS_MAX", 0.0)  # max must stay above min
    assert ap.config == before
    assert link_bridge.apply_param(ap, "PD_KP5", -0.5)
    assert ap.config.control.gains.Kp5 == -0.5
