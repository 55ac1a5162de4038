"""The one mission validator: every door (mission files, MAVLink uploads, persisted missions) runs it.

:func:`check_mission` returns a :class:`MissionCheck` whose ``problems`` are empty for a valid mission. Pure:
no clock, no I/O; a caller with a deadline passes ``expired`` (polled between legs).

Rules (every limit comes from :class:`~onboard.core.config.CoreConfig`; there is no second copy of one):

1. Values: every number is finite (:meth:`Goal.invalid_fields`, the model's one rule); a goal's depth is
   not above the surface (>= 0, positive down); a goal's yaw is
   None (free; NaN on the wire) or within +-360 deg (:data:`YAW_LIMIT_RAD`), judged as the door received
   it, before any wrap into (-180, 180] (:func:`check_goal_values`, which every door asks: MAVLink items,
   mission files, persisted plans, campaign specs). A goal's acceptance radius (``radius_m``; MAVLink
   param2) is 0 (the vehicle's default, ``[mission] arrival_radius_m``) or within that parameter's declared
   range (:func:`goal_radius_bounds_m`, one owner of the bounds: ``MIS_ARRIVE_R_M``'s declaration).
2. Counts: ``1 <= len(goals) <= [mission] max_goals`` and ``len(obstacles) <= [mission] max_obstacles``.
3. Goals: x and y inside the failsafe operating rectangle ``[failsafe] area_x_min_m..area_x_max_m`` x
   ``area_y_min_m..area_y_max_m`` (a goal outside it would abort the run on arrival); depth in
   ``[0, [failsafe] max_depth_m)`` (a goal at or below the failsafe depth could never be completed).
4. Obstacles: radius > 0; the centre inside the operating rectangle expanded by the obstacle's radius on
   every side (an obstacle that cannot reach into the area is a mistake, typically a wrong origin or unit,
   and is refused rather than silently ignored; one that overlaps the boundary is legitimate).
5. Geometry: no goal inside an inflated obstacle (radius ``max(R + margin, r_min)``, the planner's own
   inflation), reported naming the goal and the obstacle. The stopping zone past every goal (the vehicle
   stops after COMPLETE, and in a HOLD that may come at any goal: :mod:`onboard.core.executive.surface`):
   the segment of ``[mission] stop_distance_m`` from the goal along its yaw (a free yaw: the disc of that
   radius) enters no obstacle (its radius, not inflated: the vehicle has stopped, it only must not be
   inside), and the goal's depth is more than :data:`STOP_DEPTH_MARGIN_M` above ``[failsafe] max_depth_m``
   (the stop holds the depth it began at, the goal's within the depth loop's error) (:func:`_check_stops`).
6. Feasibility: the planner (:func:`onboard.core.planner.planner.plan`) plans every leg: leg i from goal
   i-1 to goal i (i >= 1) and leg 0 from ``start_pose`` when it is given. The start yaw of leg i is goal
   i-1's yaw or, when that is None (free), the end yaw of the previous leg's path. Without a previous path
   (no start pose, goal 0 free) the arrival heading at goal 0 is unknown: leg 1 is tried heading straight
   at goal 1 and then every 45 deg, and is feasible if any of them is; a failure reports the straight one.
   A depth change too steep for a leg's path is flown on a helix (the planner adds full circles of its
   turning radius), so a leg between goals is refused for its slope only where no circle fits among the
   obstacles, judged here at upload; leg 0's helix needs the vehicle's pose (at START when not given).

All problems of rules 1 to 4 are reported (not only the first); rule 5 runs only when 1 to 4 pass, and
planning (rule 6) only when 1 to 5 pass (a plan between refused goals means nothing).

No link's encoding is judged here (the core speaks metres and radians): whether a position fits a MAVLink
mission item is the encoding's rule (:func:`auv_common.mission_items.fits_local`), asked by the doors that
encode (the ``--mission`` file, :mod:`onboard.app.mission_file`).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from auv_common.config import declared_bounds
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.params import MissionParams
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.geometry import point_inside
from onboard.core.planner.path import Path
from onboard.core.planner.planner import inflate, plan

Item = Literal["goal", "obstacle", "mission"]
Field = Literal["x", "y", "depth", "yaw", "radius", "arrival_radius", "count", "plan", "format"]
#: ``Problem.index`` of a problem of the whole mission (``item == "mission"``).
MISSION_INDEX = -1

_FIELD_OF: dict[str, Field] = {
    "x_m": "x",
    "y_m": "y",
    "depth_m": "depth",
    "yaw_rad": "yaw",
    "radius_m": "radius",
}
#: The largest |yaw| of a goal, rad (360 deg; MAVLink's param4 is degrees): a heading anyone means is
#: within one turn either way. A larger one (999) is a typing or unit mistake, refused, never wrapped into
#: some other heading (the first version's rule, MAV_MISSION_INVALID_PARAM4 on MAVLink).
YAW_LIMIT_RAD = math.radians(360.0)
#: The depth a goal keeps above ``[failsafe] max_depth_m``, m: the vehicle stops at the depth it arrived at
#: (the stop's stern planes hold it or rise), which is the goal's within the depth loop's error (the depth
#: campaign: final depth errors of centimetres; a goal 0.5 m above the limit is flown). Before issue 23 a
#: goal at 19.5 m sank on to the 20 m limit after COMPLETE and ABORTed.
STOP_DEPTH_MARGIN_M = 0.25
#: Start headings of leg 1 when goal 0's arrival heading is unknown (after the straight one), rad.
_FALLBACK_YAWS_RAD = tuple(math.radians(45.0 * k) for k in range(1, 8))

StartPose = tuple[float, float, float, float]


@dataclass(frozen=True)
class Problem:
    """One reason a mission is refused: which item (``index`` into goals or obstacles; -1 for the whole
    mission), which field, and a human reason. ``str()`` is e.g. "goal 2: depth 25 m is below the failsafe
    depth limit 20 m"."""

    item: Item
    index: int
    field: Field
    reason: str

    def __str__(self) -> str:
        if self.item == "mission":
            return f"mission: {self.reason}"
        return f"{self.item} {self.index}: {self.reason}"


@dataclass(frozen=True)
class MissionCheck:
    """The verdict of :func:`check_mission`: ``problems`` (empty = valid)."""

    problems: tuple[Problem, ...] = ()

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def first(self) -> Problem | None:
        """The first problem (None when valid)."""
        return self.problems[0] if self.problems else None

    def __str__(self) -> str:
        if not self.problems:
            return "mission ok"
        more = f" (and {len(self.problems) - 1} more)" if len(self.problems) > 1 else ""
        return f"{self.problems[0]}{more}"


def _fmt(v: float) -> str:
    return f"{v:g}"


def _check_counts(mission: Mission, config: CoreConfig) -> list[Problem]:
    mp = config.mission
    out = []
    n = len(mission.goals)
    if n > mp.max_goals:  # no goals is "no mission" (a clear, a fence before its goals): valid
        out.append(
            Problem(
                "mission", MISSION_INDEX, "count", f"{n} goals exceed the capacity {mp.max_goals} (max_goals)"
            )
        )
    m = len(mission.obstacles)
    if m > mp.max_obstacles:
        out.append(
            Problem(
                "mission",
                MISSION_INDEX,
                "count",
                f"{m} obstacles exceed the capacity {mp.max_obstacles} (max_obstacles)",
            )
        )
    return out


def _not_finite(item: Item, index: int, obj: Goal | Obstacle) -> list[Problem]:
    out = []
    for name in obj.invalid_fields():
        field = _FIELD_OF[name]
        if item == "goal" and field == "radius":  # a goal's radius is its acceptance radius (param2)
            field = "arrival_radius"
        out.append(Problem(item, index, field, f"{field} is not a finite number: {getattr(obj, name)!r}"))
    return out


@functools.cache
def goal_radius_bounds_m() -> tuple[float, float]:
    """The range of a goal's own acceptance radius (m): ``[mission] arrival_radius_m``'s declared range
    (MIS_ARRIVE_R_M), so a goal may ask for exactly what the default may be set to."""
    return declared_bounds(MissionParams(), "arrival_radius_m")


def _radius_problem(index: int, radius_m: float) -> Problem | None:
    """A goal's acceptance radius: 0 (the default) or within :func:`goal_radius_bounds_m`, with why not."""
    if radius_m == 0.0:
        return None
    lo, hi = goal_radius_bounds_m()
    text = f"arrival radius {_fmt(radius_m)} m"
    if radius_m < 0.0:
        why = f"{text} is negative (0 = the vehicle's default, [mission] arrival_radius_m)"
    elif radius_m < lo:
        why = (
            f"{text} is below {_fmt(lo)} m, the smallest that means one (the estimate is good to decimetres "
            "at best: every arrival would be a miss; 0 = the vehicle's default)"
        )
    elif radius_m > hi:
        why = (
            f"{text} is above {_fmt(hi)} m, the widest MIS_ARRIVE_R_M allows (a goal 'reached' that far off "
            "says nothing of where the vehicle is: a unit or typing mistake)"
        )
    else:
        return None
    return Problem("goal", index, "arrival_radius", why)


def check_goal_values(index: int, goal: Goal) -> list[Problem]:
    """The configuration-free rules of one goal: every number finite; the depth not above the surface
    (>= 0, positive down); the yaw None (free) or within +-:data:`YAW_LIMIT_RAD`; the acceptance radius 0
    (the default) or within :func:`goal_radius_bounds_m`. A door asks it with the yaw as received (degrees
    to radians, not wrapped)."""
    out = _not_finite("goal", index, goal)
    if "radius_m" not in goal.invalid_fields():
        radius = _radius_problem(index, goal.radius_m)
        if radius is not None:
            out.append(radius)
    if "depth_m" not in goal.invalid_fields() and goal.depth_m < 0.0:
        out.append(Problem("goal", index, "depth", f"depth {_fmt(goal.depth_m)} m is above the surface"))
    yaw = goal.yaw_rad
    if yaw is not None and "yaw_rad" not in goal.invalid_fields() and abs(yaw) > YAW_LIMIT_RAD:
        limit_deg = _fmt(math.degrees(YAW_LIMIT_RAD))
        out.append(
            Problem(
                "goal",
                index,
                "yaw",
                f"yaw {_fmt(math.degrees(yaw))} deg is outside [-{limit_deg}, {limit_deg}] deg "
                "(no yaw = a free heading)",
            )
        )
    return out


def check_obstacle_values(index: int, obstacle: Obstacle) -> list[Problem]:
    """The configuration-free rules of one obstacle: every number finite and the radius > 0.

    (The state store applies these to a persisted fence; the limits need the configuration.)
    """
    out = _not_finite("obstacle", index, obstacle)
    if not out and obstacle.radius_m <= 0.0:
        out.append(
            Problem("obstacle", index, "radius", f"radius {_fmt(obstacle.radius_m)} m must be positive")
        )
    return out


def _check_goal(i: int, g: Goal, config: CoreConfig) -> list[Problem]:
    out = check_goal_values(i, g)
    bad = set(g.invalid_fields())
    fs = config.failsafe
    axes: tuple[tuple[str, Field, float, float, float], ...] = (
        ("x", "x", g.x_m, fs.area_x_min_m, fs.area_x_max_m),
        ("y", "y", g.y_m, fs.area_y_min_m, fs.area_y_max_m),
    )
    for name, field, v, lo, hi in axes:
        if f"{name}_m" in bad:
            continue
        if not lo <= v <= hi:
            out.append(
                Problem(
                    "goal",
                    i,
                    field,
                    f"{name} {_fmt(v)} m is outside the failsafe operating area [{_fmt(lo)}, {_fmt(hi)}] m",
                )
            )
    if "depth_m" not in bad and g.depth_m >= 0.0:  # above the surface: check_goal_values'
        if g.depth_m >= fs.max_depth_m:
            out.append(
                Problem(
                    "goal",
                    i,
                    "depth",
                    f"depth {_fmt(g.depth_m)} m is below the failsafe depth limit {_fmt(fs.max_depth_m)} m",
                )
            )
    return out


def _check_obstacle(i: int, o: Obstacle, config: CoreConfig) -> list[Problem]:
    out = check_obstacle_values(i, o)
    if out:
        return out
    fs = config.failsafe
    r = o.radius_m
    axes: tuple[tuple[str, Field, float, float, float], ...] = (
        ("x", "x", o.x_m, fs.area_x_min_m, fs.area_x_max_m),
        ("y", "y", o.y_m, fs.area_y_min_m, fs.area_y_max_m),
    )
    for name, field, v, lo, hi in axes:
        if not lo - r <= v <= hi + r:
            out.append(
                Problem(
                    "obstacle",
                    i,
                    field,
                    f"centre {name} {_fmt(v)} m with radius {_fmt(r)} m does not reach the failsafe "
                    f"operating area [{_fmt(lo)}, {_fmt(hi)}] m",
                )
            )
    return out


def _check_geometry(mission: Mission, config: CoreConfig) -> list[Problem]:
    if not mission.obstacles:
        return []
    pc = config.planner.tightest  # a goal the planner's fallback radius clears is a goal it can plan to
    inflated = inflate(mission.obstacles, pc)
    out = []
    for i, g in enumerate(mission.goals):
        j = point_inside(g.x_m, g.y_m, inflated)
        if j is None:
            continue
        o = mission.obstacles[j]
        out.append(
            Problem(
                "goal",
                i,
                "plan",
                f"({_fmt(g.x_m)}, {_fmt(g.y_m)}) is inside obstacle {j} at ({_fmt(o.x_m)}, {_fmt(o.y_m)}), "
                f"radius {_fmt(o.radius_m)} m inflated to {_fmt(inflated[j][2])} m (margin "
                f"{_fmt(pc.obstacle_margin_m)} m, turning radius {_fmt(pc.turning_radius_m)} m)",
            )
        )
    return out


def _segment_distance_m(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """The distance (m) from point p to the segment a-b."""
    dx, dy = bx - ax, by - ay
    seg2 = dx * dx + dy * dy
    t = 0.0 if seg2 == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / seg2, 0.0), 1.0)
    return math.hypot(px - (ax + t * dx), py - (ay + t * dy))


def _check_stops(mission: Mission, config: CoreConfig) -> list[Problem]:
    """Rule 5's stopping zones: past every goal, ``stop_distance_m`` along its yaw clear of every obstacle
    and the goal's depth :data:`STOP_DEPTH_MARGIN_M` above the failsafe depth limit."""
    stop_m = config.mission.stop_distance_m
    if stop_m <= 0.0:
        return []
    limit_m = config.failsafe.max_depth_m
    out = []
    for i, g in enumerate(mission.goals):
        if g.depth_m + STOP_DEPTH_MARGIN_M >= limit_m:
            out.append(
                Problem(
                    "goal",
                    i,
                    "depth",
                    f"depth {_fmt(g.depth_m)} m leaves less than {_fmt(STOP_DEPTH_MARGIN_M)} m above the "
                    f"failsafe depth limit {_fmt(limit_m)} m for the stop after it",
                )
            )
        if g.yaw_rad is None:
            ex, ey, zone = g.x_m, g.y_m, f"the disc of {_fmt(stop_m)} m round it (free heading)"
            reach_m = stop_m
        else:
            ex, ey = g.x_m + stop_m * math.cos(g.yaw_rad), g.y_m + stop_m * math.sin(g.yaw_rad)
            zone = f"{_fmt(stop_m)} m past it along {_fmt(round(math.degrees(g.yaw_rad), 1))} deg"
            reach_m = 0.0
        for j, o in enumerate(mission.obstacles):
            if _segment_distance_m(o.x_m, o.y_m, g.x_m, g.y_m, ex, ey) - reach_m < o.radius_m:
                out.append(
                    Problem(
                        "goal",
                        i,
                        "plan",
                        f"its stopping zone ({zone}, stop_distance_m) enters obstacle {j} at "
                        f"({_fmt(o.x_m)}, {_fmt(o.y_m)}), radius {_fmt(o.radius_m)} m",
                    )
                )
    return out


def _plan_leg(
    start: tuple[float, float, float], start_depth_m: float, goal: Goal, mission: Mission, config: CoreConfig
) -> Path:
    return plan(
        start,
        (goal.x_m, goal.y_m, goal.yaw_rad),
        config.planner,
        mission.obstacles,
        start_depth_m=start_depth_m,
        goal_depth_m=goal.depth_m,
    )


def _plan_problem(i: int, origin: str, exc: PlannerError) -> Problem:
    return Problem("goal", i, "plan", f"no path from {origin} ({exc.reason}): {exc}")


def _check_legs(
    mission: Mission,
    config: CoreConfig,
    start_pose: StartPose | None,
    expired: Callable[[], bool] | None,
) -> list[Problem]:
    out: list[Problem] = []
    goals = mission.goals
    prev_end_yaw: float | None = None  # end yaw of the previous leg's path, when it was planned
    if start_pose is not None:
        sx, sy, sdepth, syaw = start_pose
        try:
            path = _plan_leg((sx, sy, syaw), sdepth, goals[0], mission, config)
            prev_end_yaw = path.end_pose[2]
        except PlannerError as exc:
            out.append(_plan_problem(0, "the start pose", exc))
    for i in range(1, len(goals)):
        if expired is not None and expired():
            out.append(
                Problem(
                    "mission",
                    MISSION_INDEX,
                    "plan",
                    f"the deadline passed while planning the leg to goal {i}",
                )
            )
            return out
        prev = goals[i - 1]
        goal = goals[i]
        known_yaw = prev.yaw_rad if prev.yaw_rad is not None else prev_end_yaw
        if known_yaw is not None:
            yaws: tuple[float, ...] = (known_yaw,)
        else:
            direct = math.atan2(goal.y_m - prev.y_m, goal.x_m - prev.x_m)
            yaws = (direct, *(direct + d for d in _FALLBACK_YAWS_RAD))
        first_error: PlannerError | None = None
        prev_end_yaw = None
        for yaw in yaws:
            try:
                path = _plan_leg((prev.x_m, prev.y_m, yaw), prev.depth_m, goal, mission, config)
            except PlannerError as exc:
                first_error = first_error or exc
                continue
            prev_end_yaw = path.end_pose[2]
            break
        else:
            assert first_error is not None
            out.append(_plan_problem(i, f"goal {i - 1}", first_error))
    return out


def _usable_start(start_pose: StartPose | None) -> StartPose | None:
    if start_pose is None or len(start_pose) != 4:
        return None
    if not all(isinstance(v, int | float) and math.isfinite(v) for v in start_pose):
        return None  # a pose with a non-finite value is not known
    return start_pose


def check_mission(
    mission: Mission,
    config: CoreConfig,
    start_pose: StartPose | None = None,
    *,
    expired: Callable[[], bool] | None = None,
) -> MissionCheck:
    """Check ``mission`` against the limits of ``config`` and plan every leg (see the module docstring).

    Args:
        mission: the candidate mission (goals and obstacles, SI units, radians).
        config: the core configuration; the limits are its ``failsafe`` and ``mission`` tables, the
            feasibility its ``planner`` table.
        start_pose: (x_m, y_m, depth_m, yaw_rad) of the vehicle when known: leg 0 is planned from it. A pose
            with a non-finite value counts as unknown.
        expired: polled before each leg; True stops planning with a ``mission``/``plan`` problem (the
            caller's deadline: this module has no clock).

    Returns:
        A :class:`MissionCheck`; ``ok`` when there is no problem.
    """
    problems = list(check_limits(mission, config).problems)
    if not problems:
        problems += _check_legs(mission, config, _usable_start(start_pose), expired)
    return MissionCheck(tuple(problems))


def check_limits(mission: Mission, config: CoreConfig) -> MissionCheck:
    """:func:`check_mission` without the planning of the legs (cheap enough for the control thread): the
    limits, and goals clear of the (inflated) obstacles. The core asks it when it takes a mission (the
    configuration may have changed since the upload was checked) and before a parameter change that would
    leave the mission in force out of its limits."""
    problems = _check_counts(mission, config)
    for i, g in enumerate(mission.goals):
        problems += _check_goal(i, g, config)
    for i, o in enumerate(mission.obstacles):
        problems += _check_obstacle(i, o, config)
    if not problems:
        problems += _check_geometry(mission, config)
    if not problems:  # a goal inside an obstacle has its stopping zone there too: said once
        problems += _check_stops(mission, config)
    return MissionCheck(tuple(problems))


__all__ = [
    "MISSION_INDEX",
    "YAW_LIMIT_RAD",
    "MissionCheck",
    "Problem",
    "check_goal_values",
    "check_limits",
    "check_mission",
    "check_obstacle_values",
    "goal_radius_bounds_m",
]
