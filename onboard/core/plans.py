"""Plans the core asks for: what a request carries and the pure function that answers it.

The core never plans inside its step (:mod:`onboard.core.executive`): it puts a :class:`PlanRequest`
out and the loop's worker (:mod:`onboard.app.planning`) runs :func:`compute_plan` on it off the control
thread. Both are pure: the planner, the goal, the obstacles and the configuration travel in the request.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from onboard.core.mission.model import Goal
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import ArcSegment, Path, StraightSegment, clearance_m, departure_m
from onboard.core.planner.planner import circles, inflate, plan
from onboard.protocol.conventions import wrap_pi

#: A loiter path ends on its circle drawn this many times, one segment of one lap each (a projection on an
#: arc is taken modulo one turn, so one segment never sweeps more): the lap flown and one lap of look-ahead.
#: The loiter maneuver evaluates it modulo one lap (:func:`onboard.core.executive.loiter.wrap_lap`): a
#: circle, with no end.
LOITER_CIRCLE_LAPS = 2


@dataclass(frozen=True)
class PlanRequest:
    """A plan the core needs, computed by :func:`compute_plan` off the control thread.

    ``kind``: ``goal`` (from the vehicle's pose to goal ``goal_index``) or ``loiter`` (onto a circle of
    ``loiter_radius_m`` around the goal, then round it). ``t_s`` is when it was asked for (the core's time).
    ``current_mps`` is the estimated water current's speed and ``speed_mps`` the path speed over ground, for
    the planner's ``current_aware`` turning radius (:func:`current_radius_m`).
    """

    request_id: int
    kind: str
    goal_index: int
    start: tuple[float, float, float]
    start_depth_m: float
    goal: Goal
    obstacles: tuple[Any, ...]
    planner: Any
    loiter_radius_m: float
    t_s: float
    deadline_s: float
    current_mps: float = 0.0
    speed_mps: float = 1.0
    replan: bool = False  # a path is flown and stays if this one fails (planned again for the current)
    planned_current_mps: float = 0.0  # the current the flown path was planned for (m/s), when replan
    cross_track_bound_m: float = 0.0  # the largest cross-track measured on the mission so far (m)
    held_path: Path | None = None  # when replan: the path flown (a re-plan departing far is not taken)
    goal_run_in_m: float = 0.0  # the goal's straight run-in where longer than the planner's (m): the last's


def last_goal_run_in_m(
    goal_run_in_m: float, speed_mps: float, arrival_speed_mps: float, run_in_decel_mps2: float
) -> float:
    """The straight (m) the mission's last goal is approached along: the planner's ``goal_run_in_m``, or
    longer, the run-in's deceleration from the path speed ``speed_mps`` to ``arrival_speed_mps`` at
    ``run_in_decel_mps2`` ((v^2 - a^2) / 2 d: 18.75 m for 1 -> 0.25 m/s at 0.025 m/s^2), so the run-in slows
    on the straight, not in the last turn. Slowing in a turn, the fins lost their force and a following
    current the estimate had not yet seen (0.03 of 0.5 m/s) carried the vehicle through it, 12 deg off the
    goal's course (current campaign, 0.5 m/s towards 0 deg), and out of a turn onto the goal the vehicle
    arrived faster than the stop takes up in its 3 m (the run-in's reverse propeller works on straights
    only). ``goal_run_in_m`` without a run-in (``arrival_speed_mps`` 0)."""
    if arrival_speed_mps <= 0.0 or run_in_decel_mps2 <= 0.0:
        return goal_run_in_m
    slowing_m = max(speed_mps**2 - arrival_speed_mps**2, 0.0) / (2.0 * run_in_decel_mps2)
    return max(goal_run_in_m, slowing_m)


def plan_to_goal(
    start: tuple[float, float, float],
    goal: tuple[float, float, float | None],
    config: Any,
    obstacles: Any = (),
    *,
    start_depth_m: float = 0.0,
    goal_depth_m: float = 0.0,
    run_in_m: float = 0.0,
) -> Path:
    """The planner's path to ``goal`` (:func:`~onboard.core.planner.planner.plan`), along a straight run-in
    of ``run_in_m`` where that is longer than the planner's ``goal_run_in_m`` and fits (it is then the
    path's last segment: the last goal's, :func:`last_goal_run_in_m`), else the planner's own (its short
    run-in, or direct). Raises PlannerError as ``plan``."""
    if run_in_m > config.goal_run_in_m and goal[2] is not None:
        path = plan(
            start, goal, replace(config, goal_run_in_m=run_in_m), obstacles,
            start_depth_m=start_depth_m, goal_depth_m=goal_depth_m,
        )  # fmt: skip
        last = path.segments[-1] if path.segments else None
        if isinstance(last, StraightSegment) and last.length_m >= run_in_m - 1e-6:
            return path
    return plan(start, goal, config, obstacles, start_depth_m=start_depth_m, goal_depth_m=goal_depth_m)


#: The widest a current makes the turns: the current counted is at most this fraction of the path speed.
MAX_CURRENT_FRACTION = 0.6


def current_radius_m(turning_radius_m: float, speed_mps: float, current_mps: float) -> float:
    """The turning radius (m) a vehicle can fly over ground at ``speed_mps`` in a current ``current_mps``
    (both m/s): its turn rate is speed through the water / radius, and a following current leaves it
    U - c of water speed, so r * U / (U - c), with c at most :data:`MAX_CURRENT_FRACTION` of U."""
    c = min(max(current_mps, 0.0), MAX_CURRENT_FRACTION * speed_mps)
    return turning_radius_m * speed_mps / (speed_mps - c)


#: Less than this (m) of the margin grown for the current is not tried on its own (the nominal is next).
MIN_GROWN_MARGIN_M = 0.25


def _said_margin(path: Path, nominal: Any, grown_m: float, used_m: float | None = None) -> Path:
    """``path``, planned with a smaller margin (``used_m``; the nominal one) where the grown one found no
    way: its note says so."""
    if grown_m <= 0.0:
        return path
    used = nominal.obstacle_margin_m if used_m is None else used_m
    text = (
        f"the obstacle margin grown for the current ({nominal.obstacle_margin_m + grown_m:.1f} m) finds no "
        f"way: planned with {used:.3g} m"
    )
    return replace(path, note=f"{path.note}; {text}" if path.note else text)


def compute_plan(request: PlanRequest) -> Path:
    """The path a :class:`PlanRequest` asks for (pure; raises PlannerError). The loop's worker runs it.

    A re-plan for the current (``replan``) that departs farther than ``[planner] replan_hold_m`` from the
    path flown (``held_path``) is refused ("departs") where the path flown keeps the margin grown for this
    current from every obstacle: the executive keeps the path flown, as for any re-plan that fails (issue
    23 item 4: hold the path). Where it does not, the re-plan is taken: clearance before path-keeping."""
    path = _compute_plan(request)
    held, cfg = request.held_path, request.planner
    if request.replan and held is not None and cfg.replan_hold_m > 0.0:
        away_m = departure_m(path, held)
        # the clearance the path flown keeps beyond the nominal margin, against the margin grown
        kept_m = clearance_m(held, circles(request.obstacles)) - cfg.obstacle_margin_m
        grown_m = cfg.grown_margin_m(request.current_mps, request.cross_track_bound_m)
        if away_m > cfg.replan_hold_m and kept_m >= grown_m:
            raise PlannerError(
                "departs",
                f"the path planned for {request.current_mps:.2f} m/s departs {away_m:.1f} m from the path "
                f"flown (more than {cfg.replan_hold_m:g} m): the path flown holds",
            )
    return path


def _compute_plan(request: PlanRequest) -> Path:
    g = request.goal
    if request.kind == "goal":
        nominal = request.planner

        def to_goal(config: Any) -> Path:
            return plan_to_goal(
                request.start,
                (g.x_m, g.y_m, g.yaw_rad),
                config,
                request.obstacles,
                start_depth_m=request.start_depth_m,
                goal_depth_m=g.depth_m,
                run_in_m=request.goal_run_in_m,
            )

        # The margin grown for the current and the cross-track measured (issue 23 item 4): first with it,
        # then with the nominal margin (said in the path's note); each with the wider turns first where
        # the planner is current-aware (the run-in keeps its length: a longer one moved the whole path).
        grown_m = (
            0.0
            if not request.obstacles
            else nominal.grown_margin_m(request.current_mps, request.cross_track_bound_m)
        )
        radius = nominal.turning_radius_m
        if nominal.current_aware and request.current_mps > 0.0:
            radius = current_radius_m(nominal.turning_radius_m, request.speed_mps, request.current_mps)
        tries: list[tuple[Any, bool]] = []  # (configuration, with less than the grown margin)
        # the grown margin, then half of it (a start among obstacles that leaves no way with the whole
        # margin kept the nominal 1 m: clutter_current r4 entered an obstacle in its first turn)
        for part, short in ((1.0, False), (0.5, True)):
            if grown_m * part < MIN_GROWN_MARGIN_M:
                continue
            margin_m = nominal.obstacle_margin_m + grown_m * part
            wide = replace(nominal.without_fallbacks(), obstacle_margin_m=margin_m)
            if radius > nominal.turning_radius_m:
                tries.append((replace(wide, turning_radius_m=radius), short))
            tries.append((wide, short))
        if radius > nominal.turning_radius_m:  # no tighter fallback of their own: the nominal radius next
            tries.append((replace(nominal.without_fallbacks(), turning_radius_m=radius), True))
        for config, short in tries:
            try:
                path = to_goal(config)
            except PlannerError:
                continue
            return _said_margin(path, nominal, grown_m, config.obstacle_margin_m) if short else path
        return _said_margin(to_goal(nominal), nominal, grown_m)
    # loiter: onto the circle straight ahead of the vehicle, clockwise, then round it
    r = request.loiter_radius_m
    for i, (ox, oy, orad) in enumerate(inflate(request.obstacles, request.planner)):
        if abs(math.hypot(ox - g.x_m, oy - g.y_m) - r) < orad:
            raise PlannerError("turning_circle_blocked", f"the loiter circle ({r:g} m) cuts obstacle {i}")
    heading = request.start[2]
    entry_yaw = wrap_pi(heading + math.pi / 2.0)
    entry = (g.x_m + r * math.cos(heading), g.y_m + r * math.sin(heading), entry_yaw)
    run_in = plan(
        request.start,
        entry,
        request.planner,
        request.obstacles,
        start_depth_m=request.start_depth_m,
        goal_depth_m=g.depth_m,
    )
    lap = ArcSegment(g.x_m, g.y_m, r, 1, entry_yaw, 2.0 * math.pi)
    return Path(
        (*run_in.segments, *(lap,) * LOITER_CIRCLE_LAPS),
        start_depth_m=g.depth_m,
        end_depth_m=g.depth_m,
        virtual_goals=run_in.virtual_goals,
        word=run_in.word + "R",
        cost=run_in.cost,
        start_pose=run_in.start_pose,
    )
