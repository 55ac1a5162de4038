"""Margins that grow with the current (issue 23, item 4): the obstacle margin of a goal plan grows with the
estimated current and the cross-track measured on the mission; a re-plan for the current holds the path."""

from __future__ import annotations

import math

import pytest

from onboard.core.mission.model import Goal
from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.path import Path
from onboard.core.planner.planner import plan
from onboard.core.plans import PlanRequest, compute_plan

# A straight north from (0, 0) to (40, 0); an obstacle of 1 m radius 2.5 m east of its middle: the nominal
# inflation (1 + 1 m margin, turning radius 1 m) lets the straight pass it.
PLANNER = PlannerConfig(turning_radius_m=1.0, obstacle_margin_m=1.0)
GOAL = Goal(40.0, 0.0, 1.0, 0.0)
FENCE = ((20.0, 2.5, 1.0),)


def _request(current_mps: float, bound_m: float = 0.0, planner: PlannerConfig = PLANNER) -> PlanRequest:
    return PlanRequest(
        1, "goal", 0, (0.0, 0.0, 0.0), 1.0, GOAL, FENCE, planner, 2.0, 0.0, 2.0, current_mps, 1.0,
        cross_track_bound_m=bound_m,
    )  # fmt: skip


def _clearance_m(current_mps: float, bound_m: float = 0.0, planner: PlannerConfig = PLANNER) -> float:
    """The closest the planned path comes to the obstacle's edge (m)."""
    path = compute_plan(_request(current_mps, bound_m, planner))
    ox, oy, r = FENCE[0]
    n = int(path.length_m / 0.05)
    return min(math.hypot(p.x_m - ox, p.y_m - oy) for p in (path.sample(k * 0.05) for k in range(n + 1))) - r


def test_the_margin_grows_with_the_current_and_the_measured_cross_track() -> None:
    cfg = PlannerConfig(current_margin_s=4.0, current_margin_max_m=3.0)
    assert cfg.grown_margin_m(0.0) == 0.0
    assert cfg.grown_margin_m(0.3) == pytest.approx(1.2)
    assert cfg.grown_margin_m(0.3, 2.0) == pytest.approx(2.0)  # the measured bound, where larger
    assert cfg.grown_margin_m(2.0) == pytest.approx(3.0)  # capped
    assert cfg.grown_margin_m(math.nan, math.nan) == 0.0
    assert PlannerConfig(current_margin_s=0.0).grown_margin_m(0.5) == 0.0  # off: the fixed margin


def test_in_still_water_the_path_passes_the_obstacle_at_the_fixed_margin() -> None:
    assert 1.0 - 1e-6 <= _clearance_m(0.0) < 2.0


def test_in_a_current_the_path_passes_the_obstacle_wider() -> None:
    # GIVEN a 0.5 m/s current (4 s x 0.5 = 2 m more margin): THEN the path keeps 1 + 2 m from the obstacle
    assert _clearance_m(0.5) >= 3.0 - 1e-6


def test_a_measured_cross_track_widens_the_margin_in_still_water() -> None:
    # GIVEN the vehicle measured 1.5 m off its path earlier on the mission: THEN 1 + 1.5 m of margin
    assert _clearance_m(0.0, 1.5) >= 2.5 - 1e-6


def test_a_goal_within_the_grown_margin_plans_with_half_of_it_and_says_so() -> None:
    # GIVEN a goal 3.2 m from the obstacle's edge: inside the grown (1 + 3 m) margin, outside 1 + 1.5 m
    goal = Goal(20.0, 6.7, 1.0, 0.0)
    req = PlanRequest(1, "goal", 0, (0.0, 6.7, 0.0), 1.0, goal, FENCE, PLANNER, 2.0, 0.0, 2.0, 1.0, 1.0)
    # THEN it is planned, not refused, and the note says with which margin (the nominal 1 m before)
    path = compute_plan(req)
    assert "the obstacle margin grown for the current (4.0 m) finds no way: planned with 2.5 m" in path.note


@pytest.mark.parametrize(("centre_m", "used"), [(5.5, "2.5 m"), (4.0, "1 m")])
def test_where_the_grown_margin_finds_no_way_a_smaller_one_plans_and_says_so(
    centre_m: float, used: str
) -> None:
    # GIVEN the vehicle facing an obstacle (radius 1 m) 5.5 / 4.0 m ahead of it, a goal behind it, in 1 m/s of
    # current: grown by 3 m it blocks both turning circles; grown by half of that (1.5 m) it leaves a way
    # from 5.5 m (planned with the nominal 1 m before), not from 4.0 m: the nominal margin then
    fence = ((centre_m, 0.0, 1.0),)
    goal = Goal(-20.0, 0.0, 1.0, math.pi)
    req = PlanRequest(1, "goal", 0, (0.0, 0.0, 0.0), 1.0, goal, fence, PLANNER, 2.0, 0.0, 2.0, 1.0, 1.0)
    path = compute_plan(req)
    assert f"the obstacle margin grown for the current (4.0 m) finds no way: planned with {used}" in path.note


def test_a_re_plan_for_the_current_starts_on_the_path_flown_not_where_the_drift_put_the_vehicle() -> None:
    from onboard.core.autopilot import Autopilot
    from onboard.core.mission.model import Mission
    from tests.unit.autopilot.test_autopilot import DT, _drifting, _fly_drifting, core

    # GIVEN a goal 60 m ahead, planned in still water, then a 0.3 m/s current sets the vehicle east
    ap = Autopilot(core())
    assert ap.replace_mission(Mission((Goal(60.0, 10.0, 1.0, math.radians(90.0)),))).accepted
    ap.request_autostart()
    t = _fly_drifting(ap, 0.0, 1.0, 0.0, u=0.0)
    t = _fly_drifting(ap, t, 2.0, 0.0)
    first = ap.path
    assert first is not None
    req = None
    for _ in range(400):  # until the estimate asks for a re-plan
        t += DT
        ap.step(_drifting(t, 0.3), t, DT)
        req = ap.take_plan_request()
        if req is not None:
            break
    assert req is not None and req.replan
    # THEN the new path starts on the path flown, at the vehicle's projection with the path's heading,
    # while the vehicle itself is off it: the path is held, guidance brings the vehicle back
    s = ap.guidance_state.s_proj_m
    assert s is not None
    on = first.sample(s)
    assert req.start == pytest.approx((on.x_m, on.y_m, on.yaw_rad))
    nav = ap.last_nav
    assert nav is not None and math.hypot(nav.x_m - on.x_m, nav.y_m - on.y_m) > 0.3
    # and the measured cross-track travels with it (the margin grows to it)
    assert req.cross_track_bound_m > 0.3


def _straight(x_m: float, y_m: float, yaw_rad: float, goal: Goal) -> Path:

    return plan((x_m, y_m, yaw_rad), (goal.x_m, goal.y_m, goal.yaw_rad), PLANNER)


def test_how_far_a_path_departs_from_another() -> None:
    from onboard.core.planner.path import departure_m

    a = _straight(0.0, 0.0, 0.0, Goal(40.0, 0.0, 1.0, 0.0))
    b = _straight(0.0, 2.0, 0.0, Goal(40.0, 2.0, 1.0, 0.0))
    assert departure_m(a, a) == pytest.approx(0.0)
    assert departure_m(b, a) == pytest.approx(2.0, abs=0.01)


def test_a_re_plan_for_the_current_that_departs_far_from_the_path_flown_is_not_taken() -> None:
    from onboard.core.planner.errors import PlannerError

    # GIVEN a path flown north along y = 0 and a re-plan (1 m/s of current) whose path lies 2 m east of it
    held = _straight(0.0, 0.0, 0.0, Goal(40.0, 0.0, 1.0, 0.0))
    goal = Goal(40.0, 2.0, 1.0, 0.0)

    def replan(hold_m: float) -> Path:
        cfg = PlannerConfig(turning_radius_m=1.0, replan_hold_m=hold_m)
        req = PlanRequest(
            2, "goal", 0, (0.0, 2.0, 0.0), 1.0, goal, (), cfg, 2.0, 0.0, 2.0, 1.0, 1.0,
            replan=True, held_path=held,
        )  # fmt: skip
        return compute_plan(req)

    # THEN it is refused with the figure where the hold is 1.5 m (the executive keeps the path flown) ...
    with pytest.raises(PlannerError, match=r"departs 2\.0 m from the path flown \(more than 1\.5 m\)"):
        replan(1.5)
    # ... and taken within 3 m, or with the hold off
    assert replan(3.0).length_m == pytest.approx(40.0)
    assert replan(0.0).length_m == pytest.approx(40.0)


def test_a_departing_re_plan_is_taken_where_the_path_flown_lacks_the_margin_grown_for_the_current() -> None:
    # GIVEN the path flown north along y = 0 passes 1.5 m from an obstacle's edge (the nominal 1 m kept) and
    # a re-plan in 0.5 m/s (2 m more margin) that departs from it by more than the hold
    held = _straight(0.0, 0.0, 0.0, Goal(40.0, 0.0, 1.0, 0.0))
    cfg = PlannerConfig(turning_radius_m=1.0, replan_hold_m=0.5)
    req = PlanRequest(
        2, "goal", 0, (0.0, 0.0, 0.0), 1.0, GOAL, FENCE, cfg, 2.0, 0.0, 2.0, 0.5, 1.0,
        replan=True, held_path=held,
    )  # fmt: skip
    # THEN the re-plan is taken: clearance before path-keeping (it passes the obstacle 1 + 2 m wide)
    path = compute_plan(req)
    ox, oy, r = FENCE[0]
    n = int(path.length_m / 0.05)
    pts = (path.sample(k * 0.05) for k in range(n + 1))
    assert min(math.hypot(p.x_m - ox, p.y_m - oy) for p in pts) - r >= 3.0 - 1e-6
