"""The autopilot composition: events, autostart, planning, a mission without goals, failsafe on stale nav."""

from __future__ import annotations

import math

from onboard.autopilot import Autopilot
from onboard.config import load_config
from onboard.mission.model import Goal, Mission
from onboard.mission.state import MissionEvent, MissionState
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
    ap = Autopilot(load_config())
    ap.replace_mission(Mission(goals))
    ap.request_autostart()
    ap.step(sensors(0.0), 0.0, DT)
    return ap


def test_autostart_waits_for_valid_navigation() -> None:
    # GIVEN an armed autostart and no sensor data yet
    ap = Autopilot(load_config())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    ap.request_autostart()
    out = ap.step({}, 0.0, DT)
    # THEN it stays ARMED with a neutral command; WHEN navigation becomes valid THEN it starts and plans
    assert out.status.state is MissionState.ARMED and out.propeller_rps == 0.0
    out = ap.step(sensors(0.05), 0.05, DT)
    assert out.status.state is MissionState.RUNNING
    assert ap.path is not None and ap.path.length_m > 19.0


def test_start_is_refused_without_navigation() -> None:
    ap = Autopilot(load_config())
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
    ap = Autopilot(load_config())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),), ()))
    from onboard.mission.model import Obstacle

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
