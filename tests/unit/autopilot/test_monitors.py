"""The executive's leg monitors and the feasibility check (onboard/core/executive/monitors.py), on toy inputs:
along-track progress over a window, cross-track widened by the navigation's uncertainty, the ETA, and the
goal made good against the estimated current, at START (the commander) and while RUNNING (goto)."""

from __future__ import annotations

import dataclasses
import math

import pytest

from onboard.core import commands as c
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.executive.monitors import (
    LegMonitor,
    expected_time_s,
    feasibility,
    latest_end_s,
    made_good_mps,
    water_speed_max_mps,
)
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionState
from onboard.core.nav.types import NavState, nav_state_at
from onboard.core.planner.path import Path
from onboard.core.planner.planner import plan
from tests.unit.autopilot.test_autopilot import core, started, tick

S = MissionState
GOAL = Goal(20.0, 0.0, 1.0, 0.0)


def config(**mission: object) -> CoreConfig:
    """The packaged configuration with a 30 s monitors' window (the default is 60 s), and ``mission``."""
    return core(**{"monitor_window_s": 30.0, **mission})


def straight(length_m: float = 20.0) -> Path:
    return plan((0.0, 0.0, 0.0), (length_m, 0.0, 0.0), config().planner, start_depth_m=1.0, goal_depth_m=1.0)


def nav(
    x: float = 0.0, y: float = 0.0, current: tuple[float, float] = (0.0, 0.0), std: float = 0.05
) -> NavState:
    return dataclasses.replace(
        nav_state_at(x, y, 1.0),
        current_north_mps=current[0],
        current_east_mps=current[1],
        current_std_mps=std,
        position_std_m=0.1,
    )


def fly(
    mon: LegMonitor,
    cfg: CoreConfig,
    path: Path,
    speed_mps: float,
    seconds: float,
    *,
    t0: float = 0.0,
    s0: float = 0.0,
    cross_m: float = 0.0,
    n: NavState | None = None,
    dt: float = 0.5,
) -> tuple[str, float]:
    """Advance the projection at ``speed_mps`` for ``seconds``: the first reason and its time ("" / end)."""
    t = t0
    while t <= t0 + seconds:
        s = s0 + speed_mps * (t - t0)
        why = mon.check(cfg, n or nav(s, cross_m), GOAL, (0, 1), path, s, cross_m, t)
        if why:
            return why, t
        t += dt
    return "", t


# --- the figures -------------------------------------------------------------------------------------


def test_the_top_speed_through_the_water_is_the_speed_map_at_the_propeller_limit() -> None:
    # GIVEN the packaged speed map (1.5375 m/s at 25 rps, 2.0 at 32.52) and LIM_RPS_MAX 30
    cfg = config()
    # WHEN the top speed is read THEN it is the map at 30 rps (about 1.85 m/s, the simulator's)
    assert water_speed_max_mps(cfg.control) == pytest.approx(1.5375 + 5.0 * 0.4625 / 7.52)
    # WHEN the limit is lowered to 25 rps THEN the top speed follows
    limits = dataclasses.replace(cfg.control.limits, propeller_max_rps=25.0)
    assert water_speed_max_mps(dataclasses.replace(cfg.control, limits=limits)) == pytest.approx(1.5375)


def test_made_good_holds_the_line_against_the_current() -> None:
    # GIVEN 1.845 m/s through the water
    top = 1.845
    # WHEN the current is astern, ahead, across (slower and faster than the vehicle)
    # THEN the speed made good along the line is U + c, U - c, sqrt(U^2 - c^2), or negative (swept off)
    assert made_good_mps(0.5, 0.0, 0.0, top) == pytest.approx(2.345)
    assert made_good_mps(-2.0, 0.0, 0.0, top) == pytest.approx(-0.155)
    assert made_good_mps(0.0, 1.0, 0.0, top) == pytest.approx(math.sqrt(top**2 - 1.0))
    assert made_good_mps(0.0, 2.0, 0.0, top) < 0.0


# --- along-track progress ----------------------------------------------------------------------------


def test_progress_below_the_minimum_over_a_window_ends_the_leg_with_the_figure() -> None:
    # GIVEN a leg watched with a 30 s window and 0.1 m/s of least progress
    cfg, path, mon = config(), straight(), LegMonitor()
    # WHEN the vehicle advances 0.05 m/s along the path
    why, t = fly(mon, cfg, path, 0.05, 60.0)
    # THEN after one window the leg has failed, the progress and the threshold named
    assert t == pytest.approx(30.0)
    assert why == (
        "goal 0: no progress, 1.5 m along the path or back onto it in 30 s "
        "(MIS_PROG_MPS 0.1 m/s: at least 3.0 m)"
    )


def test_coming_back_onto_the_path_is_progress_and_being_swept_off_it_is_not() -> None:
    # GIVEN a leg whose vehicle was swept 15 m off the path in a turn, its projection stuck near the end (the
    # cross-track monitor off: this is the progress monitor's)
    cfg, path = config(cross_track_max_m=0.0), straight()
    back, away = LegMonitor(), LegMonitor()
    t, why_back, why_away = 0.0, "", ""
    while t <= 60.0 and not (why_back or why_away):
        # WHEN it comes back at 0.2 m/s (the projection still), or is swept away at 0.2 m/s
        why_back = back.check(cfg, nav(18.0, 15.0), GOAL, (0, 1), path, 18.0, 15.0 - 0.2 * t, t)
        why_away = away.check(cfg, nav(18.0, 15.0), GOAL, (0, 1), path, 18.0, 15.0 + 0.2 * t, t)
        t += 0.5
    # THEN coming back is progress; being swept away is not, and after a window it is named
    assert why_back == ""
    assert why_away.startswith("goal 0: no progress, -6.0 m along the path or back onto it in 30 s")


def _set_back_then_under_way(setback_s: float) -> tuple[str, float, float]:
    """A vehicle that starts drifting with a 1.5 m/s head current: set back behind the path's start (the
    projection held at 0, on the path's line) for ``setback_s``, then making good 0.35 m/s; the first reason
    within 60 s, its time and the progress then."""
    cfg, path, mon = config(cross_track_max_m=0.0), straight(), LegMonitor()
    t, x, why = 0.0, 0.0, ""
    while t <= 60.0 and not why:
        x += (-0.75 if t < setback_s else 0.35) * 0.5
        why = mon.check(cfg, nav(x, 0.0), GOAL, (0, 1), path, max(x, 0.0), 0.0, t)
        t += 0.5
    return why, t, mon.progress_m


def test_the_way_back_to_the_path_s_start_after_a_setback_while_getting_under_way_is_progress() -> None:
    # GIVEN a vehicle set back 7.5 m behind its path's start while it gets under way (10 s), then making
    # good 0.35 m/s (the old monitor counted nothing until it was back at the start: 0.0 m in 30 s, HOLD)
    why, t, progress_m = _set_back_then_under_way(10.0)
    # THEN its way back to the start counts, its setback does not: no HOLD for want of progress
    assert why == "", (why, t)
    assert progress_m == pytest.approx(0.35 * 50.0, abs=0.5)


def test_a_setback_behind_the_start_after_the_start_allowance_is_lost_progress() -> None:
    # GIVEN a vehicle still swept back behind its path's start 20 s after it began
    why, _, _ = _set_back_then_under_way(25.0)
    # THEN what it lost after the allowance counts: no progress, named within a window
    assert why.startswith("goal 0: no progress, -"), why


def test_progress_at_the_guidance_speed_is_fine_and_a_re_plan_continues_the_sum() -> None:
    # GIVEN a leg flown at 0.5 m/s
    cfg, path, mon = config(), straight(), LegMonitor()
    assert fly(mon, cfg, path, 0.5, 20.0) == ("", pytest.approx(20.5))
    # WHEN the leg is re-planned (a new path, its projection from 0 again) and flown on at 0.5 m/s
    # THEN no window sees the jump back to 0 as lost ground
    assert fly(mon, cfg, straight(), 0.5, 40.0, t0=20.5)[0] == ""


def test_progress_is_judged_over_all_the_tries_at_a_goal_not_afresh_after_each_miss() -> None:
    # GIVEN a goal whose every try ends in a miss 20 s after it began (a 30 s window: no try lasts one)
    cfg, mon = config(eta_factor=0.0), LegMonitor()
    t, why = 0.0, ""
    # WHEN the vehicle loops on the spot, a new path per try, its projection never advancing
    while t <= 100.0 and not why:
        attempt = 1 + int(t // 20.0)
        path = straight() if t % 20.0 == 0.0 else mon._path or straight()
        why = mon.check(cfg, nav(), GOAL, (0, attempt), path, 0.0, 0.0, t)
        t += 0.5
    # THEN the goal has made no progress over a window of its tries, and that is named
    assert why.startswith("goal 0: no progress, 0.0 m along the path or back onto it in 30 s"), why
    assert t - 0.5 == pytest.approx(30.0)


def test_progress_zero_turns_the_progress_monitor_off() -> None:
    # GIVEN MIS_PROG_MPS 0 WHEN the vehicle stands still for two windows THEN nothing fires
    assert fly(LegMonitor(), config(progress_min_mps=0.0, eta_factor=0.0), straight(), 0.0, 60.0)[0] == ""


# --- cross-track -------------------------------------------------------------------------------------


def test_off_the_path_beyond_the_bound_for_its_own_time_ends_the_leg() -> None:
    # GIVEN a leg with MIS_XTRACK_M 15 and 3 sigma of widening (position 1-sigma 0.1 m: bound 15.3 m), the
    # monitors' window 30 s and the cross-track time MIS_XTRACK_S its default, 20 s (DUNE's is 10 s)
    cfg, path, mon = config(), straight(), LegMonitor()
    assert cfg.mission.cross_track_time_s == 20.0
    # WHEN the vehicle runs along 16 m off the path
    why, t = fly(mon, cfg, path, 1.0, 60.0, cross_m=16.0)
    # THEN after the cross-track time (not the progress window) it has failed, with the distance and the bound
    assert t == pytest.approx(20.0)
    assert why == (
        "goal 0: 16.0 m off the path for 20 s (MIS_XTRACK_S; MIS_XTRACK_M 15 m + 3 x the position's 1 sigma "
        "0.1 m = 15.3 m)"
    )


def test_the_cross_track_bound_widens_with_the_navigation_uncertainty() -> None:
    # GIVEN the same leg, the position known to 1 m (bound 18 m)
    cfg, path, mon = config(), straight(), LegMonitor()
    vague = dataclasses.replace(nav(0.0, 16.0), position_std_m=1.0)
    # WHEN the vehicle runs 16 m off the path THEN nothing fires
    assert fly(mon, cfg, path, 1.0, 60.0, cross_m=16.0, n=vague)[0] == ""


def test_a_brief_excursion_beyond_the_bound_is_not_a_failure() -> None:
    # GIVEN a leg WHEN the vehicle is 20 m off for 10 s, then back on the path THEN nothing fires
    cfg, path, mon = config(), straight(), LegMonitor()
    assert fly(mon, cfg, path, 1.0, 10.0, cross_m=20.0)[0] == ""
    assert fly(mon, cfg, path, 1.0, 40.0, t0=10.5, s0=10.5)[0] == ""


# --- ETA ---------------------------------------------------------------------------------------------


def test_a_leg_that_takes_eta_factor_times_its_expected_time_ends() -> None:
    # GIVEN a 20 m leg at 1 m/s in still water: expected 20 s + 10 s from rest; MIS_ETA_FACTOR 4
    cfg, path = config(progress_min_mps=0.0), straight()
    assert cfg.mission.eta_factor == 4.0
    assert expected_time_s(cfg, nav(), GOAL, path.length_m) == pytest.approx(30.0)
    # WHEN the vehicle creeps along THEN it fails after 120 s with the figures
    why, t = fly(LegMonitor(), cfg, path, 0.01, 200.0)
    assert t == pytest.approx(120.5)
    assert why == "goal 0: 120 s on it, over MIS_ETA_FACTOR 4 x its expected 30 s (20.0 m of path)"


def test_the_eta_runs_per_goal_over_its_tries() -> None:
    # GIVEN a 20 m leg (expected 30 s, MIS_ETA_FACTOR 4) flown well for 60 s
    cfg, path, mon = config(), straight(), LegMonitor()
    assert fly(mon, cfg, path, 0.5, 60.0)[0] == ""
    # WHEN it was a miss and the second try is flown well too
    t, second = 60.5, straight()
    while t < 200.0:
        why = mon.check(cfg, nav(), GOAL, (0, 2), second, 0.5 * (t - 60.5), 0.0, t)
        if why:
            break
        t += 0.5
    # THEN the goal has failed 120 s after its first try began
    assert t == pytest.approx(120.5) and why.startswith("goal 0: 120 s on it, over MIS_ETA_FACTOR 4")


def test_the_expected_time_counts_the_current() -> None:
    # GIVEN a 20 m leg north in a 1.6 m/s head current (1.845 m/s through the water: 0.245 m/s made good)
    cfg = config()
    # WHEN its expected time is read THEN it is the path at the speed made good, plus the start
    expected = expected_time_s(cfg, nav(current=(-1.65, 0.0)), GOAL, 20.0)
    assert expected == pytest.approx(20.0 / (water_speed_max_mps(cfg.control) - 1.6) + 10.0)
    # WHEN the current estimate is vague THEN the guidance speed is assumed
    assert expected_time_s(cfg, nav(current=(-1.65, 0.0), std=0.5), GOAL, 20.0) == pytest.approx(30.0)


def test_the_latest_end_is_each_goals_eta_in_the_true_current_plus_a_window() -> None:
    # GIVEN two legs of 20 m, north then east, MIS_ETA_FACTOR 4, the monitors' window 30 s
    cfg = config()
    legs = [(20.0, 0.0), (20.0, math.pi / 2.0)]
    # WHEN the water is still THEN each goal may take 4 x (20 s + 10 s from rest), plus one window
    assert latest_end_s(cfg, legs, (0.0, 0.0)) == pytest.approx(2 * 4.0 * 30.0 + 30.0)
    # WHEN a 1.5 m/s current flows south THEN each goal is expected at the speed made good against it
    top = water_speed_max_mps(cfg.control)
    ahead, across = top - 1.5, min(cfg.guidance.speed_mps, math.sqrt(top**2 - 1.5**2))
    assert latest_end_s(cfg, legs, (-1.5, 0.0)) == pytest.approx(
        4.0 * (20.0 / ahead + 10.0) + 4.0 * (20.0 / across + 10.0) + 30.0
    )
    # WHEN the current is faster than the vehicle THEN the goal counts at MIS_MG_MIN_MPS (the feasibility
    # monitor's, which ends it within its window); with the ETA off there is no bound
    assert latest_end_s(cfg, legs[:1], (-2.5, 0.0)) == pytest.approx(4.0 * (20.0 / 0.25 + 10.0) + 30.0)
    assert latest_end_s(config(eta_factor=0.0), legs, (0.0, 0.0)) == math.inf


# --- feasibility -------------------------------------------------------------------------------------


def test_a_goal_that_cannot_be_made_good_against_the_current_is_named_with_the_figures() -> None:
    # GIVEN the goal 20 m north and a current of 2.0 m/s flowing south, known to 0.05 m/s
    cfg = config()
    # WHEN feasibility is judged THEN it is refused with the current, the speed made good and the limit
    assert feasibility(cfg, nav(current=(-2.0, 0.0)), GOAL, 0) == (
        "current 2.00 m/s towards 180 deg; the vehicle makes good at most 0.00 m/s towards goal 0 "
        "(MIS_MG_MIN_MPS 0.25; 1.85 m/s through the water at 30 rps)"
    )
    # WHEN the same current flows north, or is known to 0.5 m/s only, or MIS_MG_MIN_MPS is 0 THEN no verdict
    assert feasibility(cfg, nav(current=(2.0, 0.0)), GOAL, 0) == ""
    assert feasibility(cfg, nav(current=(-2.0, 0.0), std=0.5), GOAL, 0) == ""
    assert feasibility(config(min_made_good_mps=0.0), nav(current=(-2.0, 0.0)), GOAL, 0) == ""


def test_while_running_an_infeasible_goal_for_its_own_time_ends_the_leg() -> None:
    # GIVEN a leg in a 2.0 m/s cross current (faster than the vehicle can stem), progress monitor off, the
    # monitors' window 30 s and the feasibility time MIS_MG_S its default, 20 s
    cfg, path, mon = config(progress_min_mps=0.0), straight(), LegMonitor()
    assert cfg.mission.feasibility_time_s == 20.0
    cross = nav(current=(0.0, 2.0))
    # WHEN it is flown THEN after the feasibility time (not the window) it has failed with the figures
    why, t = fly(mon, cfg, path, 0.5, 60.0, n=cross)
    assert t == pytest.approx(20.0)
    assert why.startswith(
        "current 2.00 m/s towards 90 deg; the vehicle makes good at most 0.00 m/s towards goal 0"
    )
    assert why.endswith(", for 20 s (MIS_MG_S)")


# --- in the vehicle: the commander at START, goto while RUNNING ---------------------------------------


def test_start_is_refused_with_the_figures_when_the_goal_cannot_be_made_good() -> None:
    # GIVEN an armed vehicle whose estimate reads a 2.0 m/s current flowing away from the goal
    ap = Autopilot(core())
    ap.replace_mission(Mission((GOAL,)))
    assert ap.handle(c.Arm()).accepted
    tick(ap, 0.0)
    assert ap.last_nav is not None and ap.last_nav.valid
    ap.last_nav = dataclasses.replace(ap.last_nav, current_north_mps=-2.0, current_std_mps=0.05)
    # WHEN START is asked for
    verdict = ap.handle(c.Start())
    # THEN it is refused (not now) with the figures, and the vehicle stays ARMED
    assert verdict.outcome is c.Outcome.TEMPORARILY_REJECTED
    assert verdict.reason.startswith("current 2.00 m/s towards 180 deg; the vehicle makes good at most")
    assert ap.status.state is S.ARMED


@pytest.mark.parametrize(("action", "state"), [("hold", S.HOLD), ("abort", S.ABORT)])
def test_a_mission_without_progress_ends_in_the_configured_action_with_the_reason(
    action: str, state: MissionState
) -> None:
    # GIVEN a vehicle homing to a goal 20 m away, the monitors' default window (60 s)
    ap = started((GOAL,), monitor_action=action)
    assert ap.config.mission.monitor_window_s == 60.0
    t = 0.05
    # WHEN it does not move for a window
    while ap.status.state is S.RUNNING and t < 90.0:
        tick(ap, t)
        t += 0.05
    # THEN the leg ends in the configured action with the figure in the reason, told to the operator
    assert ap.status.state is state
    assert "goal 0: no progress" in ap.status.reason and "MIS_PROG_MPS 0.1 m/s" in ap.status.reason
    assert any("no progress" in n.text for n in ap.take_notes())
    assert 60.0 <= t <= 62.0


def test_the_monitor_parameters_are_set_through_the_judge_within_their_rules() -> None:
    from onboard.core.params import BusLimits
    from onboard.protocol.codec import command_ranges

    # GIVEN a vehicle with the bus limits known
    ap = Autopilot(core(), bus_limits=BusLimits.from_ranges(command_ranges()))
    # WHEN the operator sets MIS_ETA_FACTOR 6, then 0 (off), then 0.5 (meaningless)
    # THEN the first two are in force, the third refused with the rule
    assert ap.handle(c.SetParam("MIS_ETA_FACTOR", 6.0)).accepted and ap.config.mission.eta_factor == 6.0
    assert ap.handle(c.SetParam("MIS_ETA_FACTOR", 0.0)).accepted and ap.config.mission.eta_factor == 0.0
    refused = ap.handle(c.SetParam("MIS_ETA_FACTOR", 0.5))
    assert not refused.accepted and "eta_factor must be 0 (off) or >= 1" in refused.reason
    assert ap.config.mission.eta_factor == 0.0
    # AND the progress window is an operator parameter too
    assert (
        ap.handle(c.SetParam("MIS_MON_WIN_S", 60.0)).accepted and ap.config.mission.monitor_window_s == 60.0
    )
