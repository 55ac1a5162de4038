"""The executive's maneuvers, one by one: goto (arrival, misses, progress), loiter (a circle), surface."""

from __future__ import annotations

import dataclasses
import math

from onboard.core.executive import Goto, Surface
from onboard.core.executive.loiter import lap_m, wrap_lap
from onboard.core.mission.model import Goal
from onboard.core.mission.state import MissionState
from onboard.core.plans import LOITER_CIRCLE_LAPS, compute_plan
from onboard.protocol import messages as m
from tests.unit.autopilot.test_autopilot import DT, run_plans, sensors, started, tick

S = MissionState
TWO_GOALS = (Goal(20.0, 0.0, 1.0, 0.0), Goal(40.0, 0.0, 1.0, 0.0))


def test_goto_reaches_a_goal_within_the_radius_and_asks_for_the_next_leg_from_there() -> None:
    # GIVEN a vehicle homing to goal 0 of two
    ap = started(TWO_GOALS)
    tick(ap, 0.05)
    ex = ap.executive
    assert isinstance(ex.active(ap), Goto) and ex.path_goal_index == 0
    nav = dataclasses.replace(ap.last_nav, x_m=20.05, y_m=0.1, position_std_m=0.1)  # type: ignore[arg-type]
    # WHEN its estimate crosses the goal line 0.11 m from the goal
    ex.goto.arrived(ex, ap, nav)
    # THEN goal 0 counts, goal 1 is the current one and its leg is asked for (the old path is dropped)
    assert ap.status.state is S.RUNNING and ap.status.goal_index == 1
    assert ex.goto.goals_reached == 1 and ex.goto.attempt == 1
    assert ex.path is None and ex.plan_waiting is not None and ex.plan_waiting.goal_index == 1
    assert ex.goto.progress(ex, ap).text == "goal 1 of 2, try 1, 1 reached"
    assert ex.goto.progress(ex, ap).fraction == 0.5 and not ex.goto.done(ap)


def test_goto_after_the_last_goal_completes_and_hands_over_to_the_end_action() -> None:
    # GIVEN a vehicle homing to its only goal, the surface end action
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    tick(ap, 0.05)
    ex = ap.executive
    # WHEN it arrives
    ex.goto.arrived(ex, ap, dataclasses.replace(ap.last_nav, x_m=20.0, position_std_m=0.1))  # type: ignore[arg-type]
    # THEN the mission is COMPLETE, goto is done, and the executive flies Surface: nothing
    assert ap.status.state is S.COMPLETE and ex.goto.done(ap)
    assert isinstance(ex.active(ap), Surface) and ex.path is None


def test_goto_a_miss_re_plans_the_same_goal_then_holds_after_max_tries() -> None:
    # GIVEN a vehicle homing to goal 0, two tries allowed
    ap = started(TWO_GOALS, max_tries=2)
    tick(ap, 0.05)
    ex = ap.executive
    off = dataclasses.replace(ap.last_nav, x_m=20.0, y_m=3.0, position_std_m=0.1)  # type: ignore[arg-type]
    # WHEN it crosses the goal line 3 m to the side
    ex.goto.arrived(ex, ap, off)
    # THEN it is a miss: try 2, the same goal planned again from here, the operator told
    assert ap.status.state is S.RUNNING and ap.status.goal_index == 0 and ex.goto.attempt == 2
    assert ex.plan_waiting is not None and ex.plan_waiting.goal_index == 0
    assert any("missed by 3.00 m" in n.text and "try 2 of 2" in n.text for n in ap.take_notes())
    # WHEN it misses again THEN it holds with the reason, no path flown
    ex.goto.arrived(ex, ap, off)
    assert ap.status.state is S.HOLD and "after 2 tries" in ap.status.reason and ex.path is None


def test_surface_flies_nothing_and_has_ended() -> None:
    # GIVEN a mission complete with the surface end action
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    tick(ap, 0.05)
    ap.executive.goto.arrived(
        ap.executive,
        ap,
        dataclasses.replace(ap.last_nav, x_m=20.0, position_std_m=0.1),  # type: ignore[arg-type]
    )
    surface = ap.executive.active(ap)
    assert isinstance(surface, Surface)
    # WHEN it steps THEN nothing is flown, no plan asked for: propeller 0, fins neutral, not armed
    assert surface.step(ap.executive, ap, ap.last_nav, DT) is None and surface.done(ap)  # type: ignore[arg-type]
    out = tick(ap, 0.1, x=20.0)
    assert out.reference is None and out.propeller_rps == 0.0 and out.rudder_rad == 0.0
    assert out.mode is m.ActuatorMode.SAFE and not ap.actuators_live and not ap.plan_pending


def _on_circle(t: float, cx: float, cy: float, r: float, angle: float, speed: float) -> dict[type, object]:
    """Sensors of a vehicle on the clockwise circle round (cx, cy) at ``angle`` (rad from north)."""
    x, y = cx + r * math.cos(angle), cy + r * math.sin(angle)
    return sensors(t, x=x, y=y, yaw=angle + math.pi / 2.0, u=speed)


def test_loiter_is_a_circle_flown_for_ever_from_one_plan() -> None:
    """A loiter was 1000 laps of a path, re-planned whenever guidance's end-of-path arrival latched (the
    vehicle passing the circle's entry point, the path's end); now the circle is evaluated modulo one lap."""
    # GIVEN a mission complete with the loiter end action, its loiter planned
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), end_action="loiter")
    tick(ap, 0.05)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, arrived=True)
    tick(ap, 0.1, x=20.05, jump=True)
    tick(ap, 0.15, x=20.1)
    assert ap.status.state is S.COMPLETE and ap.actuators_live
    path = ap.path
    assert path is not None and ap.path_kind == "loiter"
    circle = path.segments[-1]
    cx, cy, r = circle.center_x_m, circle.center_y_m, circle.radius_m  # type: ignore[union-attr]
    lap = lap_m(path)
    run_in = path.length_m - LOITER_CIRCLE_LAPS * lap
    # AND the vehicle at the circle's entry point (heading 0 when planned: due north of the goal, eastwards),
    # guidance there too
    t = 0.2
    ap.nav_state = type(ap.nav_state).initial()
    ap.step(_on_circle(t, cx, cy, r, 0.0, 1.0), t, DT)
    ap.guidance_state = dataclasses.replace(ap.guidance_state, s_proj_m=run_in, s_ref_m=run_in)
    # WHEN it flies three laps on the circle (its estimate on it, at 1 m/s)
    plans, worst_m, furthest_m = 0, 0.0, 0.0
    for k in range(1, round(3.0 * lap / DT)):
        t += DT
        ap.before_step()
        plans += run_plans(ap)
        out = ap.step(_on_circle(t, cx, cy, r, k * DT / r, 1.0), t, DT)
        plans += run_plans(ap)
        ref = out.reference
        assert ref is not None and out.propeller_rps > 0.0
        worst_m = max(worst_m, abs(math.hypot(ref.x_m - cx, ref.y_m - cy) - r))
        furthest_m = max(furthest_m, ap.guidance_state.s_proj_m or 0.0)
    # THEN it still flies the one plan, armed, its reference on the circle all the way round
    assert plans == 0 and ap.path is path and ap.actuators_live and ap.status.state is S.COMPLETE
    assert worst_m < 0.05
    assert furthest_m < run_in + 1.5 * lap + 0.5  # moved back a lap each time: never near the path's end


def test_wrap_lap_moves_guidance_back_one_lap_past_a_lap_and_a_half_and_never_latches_arrival() -> None:
    # GIVEN a loiter path (a run-in, then the circle twice) and guidance 1.6 laps along the circle
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),), end_action="loiter")
    tick(ap, 0.05)
    req = dataclasses.replace(ap.take_plan_request() or _loiter_request(ap), kind="loiter")
    path = compute_plan(req)
    lap = lap_m(path)
    run_in = path.length_m - 2.0 * lap
    state = dataclasses.replace(
        ap.guidance_state, s_proj_m=run_in + 1.6 * lap, s_ref_m=run_in + 1.7 * lap, arrived=True
    )
    # WHEN it is wrapped THEN both arc lengths are one lap back, at the same point of the circle
    wrapped = wrap_lap(path, state)
    assert wrapped.s_proj_m is not None
    assert math.isclose(wrapped.s_proj_m, run_in + 0.6 * lap) and math.isclose(
        wrapped.s_ref_m, run_in + 0.7 * lap
    )
    a, b = path.sample(state.s_proj_m), path.sample(wrapped.s_proj_m)  # type: ignore[arg-type]
    assert math.isclose(a.x_m, b.x_m, abs_tol=1e-9) and math.isclose(a.y_m, b.y_m, abs_tol=1e-9)
    assert not wrapped.arrived
    # AND before a lap and a half nothing moves
    early = dataclasses.replace(state, s_proj_m=run_in + 1.2 * lap, arrived=False)
    assert wrap_lap(path, early) is early


def _loiter_request(ap):  # type: ignore[no-untyped-def]
    ap.executive.ask_plan(ap, "loiter")
    return ap.take_plan_request()
