"""The stop after COMPLETE (surface) and in HOLD, and the run-in that slows to the arrival speed (issue 23,
item 3). Before: COMPLETE (surface) and HOLD were propeller 0 and fins neutral at once, whatever the
vehicle's speed, and the run-in asked for the full path speed up to the goal."""

from __future__ import annotations

import dataclasses
import math

import pytest

from onboard.core import guidance
from onboard.core.commands import Hold, SetMode
from onboard.core.mission.model import Goal
from onboard.core.mission.state import MissionState
from onboard.core.nav.types import nav_state_at
from onboard.core.planner.planner import plan
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
    # THEN the propeller reverses (at most [mission] brake_rps), the rudder is centred, the stern planes do
    # not pitch it nose down (deeper), and the actuators are live: armed, ARMED mode (the node obeys)
    last = outs[-1]
    assert last.propeller_rps < -1.0 and last.propeller_rps >= -ap.config.mission.brake_rps
    assert last.rudder_rad == 0.0 and last.stern_port_rad <= 0.0 and last.stern_starboard_rad <= 0.0
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
