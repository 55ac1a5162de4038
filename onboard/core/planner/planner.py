"""Homing path planner (paper section 3): virtual goals on tangent lines, scored by the cost of eq. (2).

``plan(start, goal, config, obstacles, start_depth_m, goal_depth_m) -> Path`` is the one entry point the
vehicle uses; ``candidates(...)`` returns the scored candidate words for plots (paper Fig. 4 and 5).

How a path is chosen:

1. Candidates are the Dubins words from start to goal (the paper's four direction-consistent CSC tangent
   words, plus RLR and LRL unless ``config.csc_only``), each scored with eq. (2).
2. Without obstacles the cheapest candidate is flown. With Wpsi = WdR = 0 this is the true Dubins shortest
   path (and with ``csc_only`` the paper's best tangent word).
3. With obstacles (inflated to R' = max(R + margin, r_min)): if the cheapest candidate is collision free it
   is flown (the obstacles do not change the answer). Otherwise the tangent graph over the start, obstacle
   and goal circles is searched with A* (``graph.py``), bounded by the best collision-free candidate, and
   the cheaper of the two is flown. Every path is checked analytically against every inflated obstacle
   before it is returned; a path that enters one is never returned.
4. Free arrival heading (goal yaw None): the candidates are the two arc-then-straight paths (the exact
   shortest path to a point that lies outside both start circles) plus every Dubins word to a 10 deg grid
   of arrival headings (which covers goals inside a start circle); the graph search ends at the goal point.
5. Depth: a linear profile from start to goal depth along the horizontal path. If the chosen path is too
   short for the depth change at ``max_depth_slope``, full circles of the turning radius are added (a
   helix: the vehicle descends or climbs on a loiter circle) until it is long enough, at the start (after
   the run-up) or, where the start is blocked, at a later junction towards the goal (:func:`_helix`); each
   circle is checked against the obstacles like every other segment and keeps off the goal. Only where
   no circle fits does the planner raise ``PlannerError("depth_slope")``, saying how much path is missing.

Errors: :class:`~onboard.core.planner.errors.PlannerError` with ``reason`` in ``errors.REASONS``.
Identical start
and goal poses give a zero-length path, never a loop. Pure: no clock, no I/O. Frame NED, metres, radians.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

from onboard.core.planner import dubins, graph
from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.cost import cost_terms
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.geometry import circle_center, circle_cuts, point_inside, segments_collide
from onboard.core.planner.path import ArcSegment, Path, Segment, StraightSegment

Pose = tuple[float, float, float]
GoalPose = tuple[float, float, float | None]

#: Arrival-heading grid for a free goal yaw (rad): 36 headings, 10 deg apart.
FREE_YAW_GRID_RAD = tuple(math.radians(10.0 * i) for i in range(36))


class CircleLike(Protocol):
    """Anything with a circle's centre and radius, e.g. ``onboard.core.mission.model.Obstacle``."""

    @property
    def x_m(self) -> float: ...
    @property
    def y_m(self) -> float: ...
    @property
    def radius_m(self) -> float: ...


ObstacleInput = tuple[float, float, float] | CircleLike


@dataclass(frozen=True)
class Candidate:
    """A scored candidate path (for plots and diagnostics).

    ``word`` is a Dubins word (NED letters) or, for a tangent-graph path, the sequence of segment kinds;
    ``cost`` is J of eq. (2); ``collides`` is True if it enters an inflated obstacle.
    """

    word: str
    segments: tuple[Segment, ...]
    length_m: float
    cost: float
    collides: bool


def _as_circle(o: ObstacleInput) -> tuple[float, float, float]:
    if isinstance(o, tuple):
        if len(o) != 3:
            raise PlannerError("nan", f"an obstacle is (x_m, y_m, radius_m), got {o!r}")
        return (float(o[0]), float(o[1]), float(o[2]))
    return (float(o.x_m), float(o.y_m), float(o.radius_m))


def circles(obstacles: Iterable[ObstacleInput]) -> tuple[tuple[float, float, float], ...]:
    """The obstacles as ``(x_m, y_m, radius_m)`` circles, not inflated (nor validated: :func:`inflate`)."""
    return tuple(_as_circle(o) for o in obstacles)


def inflate(
    obstacles: Iterable[ObstacleInput], config: PlannerConfig
) -> tuple[tuple[float, float, float], ...]:
    """Obstacle circles inflated to R' = max(R + margin, r_min) (m), after validating them.

    The margin is clearance; the floor r_min lets the vehicle fly along an obstacle's boundary (it cannot
    follow an arc tighter than its turning radius).
    """
    out = []
    for o in obstacles:
        x, y, rad = _as_circle(o)
        if not (math.isfinite(x) and math.isfinite(y)) or math.isnan(rad):
            raise PlannerError("nan", f"obstacle ({x}, {y}, {rad}) is not finite")
        if not (math.isfinite(rad) and rad > 0.0):
            raise PlannerError("radius", f"obstacle radius must be positive and finite, got {rad!r}")
        out.append((x, y, max(rad + config.obstacle_margin_m, config.turning_radius_m)))
    return tuple(out)


def _validate_poses(start: Pose, goal: GoalPose, start_depth_m: float, goal_depth_m: float) -> None:
    if len(start) != 3 or not all(math.isfinite(v) for v in start):
        raise PlannerError("nan", f"start pose {start!r} must be three finite numbers (x_m, y_m, yaw_rad)")
    gyaw = goal[2] if len(goal) == 3 else 0.0
    if len(goal) != 3 or not (math.isfinite(goal[0]) and math.isfinite(goal[1])):
        raise PlannerError(
            "nan", f"goal pose {goal!r} must be (x_m, y_m, yaw_rad or None) with finite numbers"
        )
    if gyaw is not None and not math.isfinite(gyaw):
        raise PlannerError("nan", f"goal yaw {gyaw!r} is not finite")
    for name, v in (("start_depth_m", start_depth_m), ("goal_depth_m", goal_depth_m)):
        if not math.isfinite(v):
            raise PlannerError("nan", f"{name} is not finite: {v!r}")


def _words(start: Pose, goal: GoalPose, config: PlannerConfig) -> list[dubins.DubinsWord]:
    r = config.turning_radius_m
    gx, gy, gyaw = goal
    if gyaw is not None:
        return dubins.all_words(start, (gx, gy, gyaw), r, config.csc_only)
    words: list[dubins.DubinsWord] = []
    for turn in (1, -1):
        w = dubins.arc_then_straight(start, (gx, gy), r, turn)
        if w is not None:
            words.append(w)
    for yaw in FREE_YAW_GRID_RAD:
        words.extend(dubins.all_words(start, (gx, gy, yaw), r, config.csc_only))
    return words


def _score(
    words: Iterable[dubins.DubinsWord], config: PlannerConfig, obstacles: Sequence[tuple[float, float, float]]
) -> list[Candidate]:
    out = [
        Candidate(
            w.word,
            w.segments,
            w.length_m,
            cost_terms(w.segments, config).total,
            bool(obstacles) and segments_collide(w.segments, obstacles),
        )
        for w in words
    ]
    # Ties (e.g. a U-turn that is LSL and LRL at once) go to the shorter path, then to the first word.
    out.sort(key=lambda c: (c.cost, c.length_m))
    return out


def candidates(
    start: Pose,
    goal: GoalPose,
    config: PlannerConfig | None = None,
    obstacles: Iterable[ObstacleInput] = (),
) -> list[Candidate]:
    """The scored Dubins candidates from start to goal, cheapest first (for plots like the paper's Fig. 4).

    For a free goal yaw, each word appears once, at its cheapest collision-free arrival heading if any.
    Inputs as for :func:`plan`; raises :class:`PlannerError` for bad input.
    """
    cfg = config or PlannerConfig()
    _validate_poses(start, goal, 0.0, 0.0)
    inflated = inflate(obstacles, cfg)
    scored = _score(_words(start, goal, cfg), cfg, inflated)
    if goal[2] is not None:
        return scored
    best: dict[str, Candidate] = {}
    for c in scored:  # cheapest first; a collision-free one replaces a colliding one
        if c.word not in best or (best[c.word].collides and not c.collides):
            best[c.word] = c
    return sorted(best.values(), key=lambda c: (c.cost, c.length_m))


def virtual_goals(segments: Sequence[Segment]) -> tuple[tuple[float, float], ...]:
    """The points of contact between consecutive segments (m): the paper's virtual goals."""
    out = []
    for seg in segments[1:]:
        x, y, _, _ = seg.pose_at(0.0)
        out.append((x, y))
    return tuple(out)


def _diagnose(
    start: Pose, goal: GoalPose, config: PlannerConfig, obstacles: Sequence[tuple[float, float, float]]
) -> PlannerError:
    r = config.turning_radius_m
    ends: list[tuple[str, Pose]] = [("start", start)]
    if goal[2] is not None:
        ends.append(("goal", (goal[0], goal[1], goal[2])))
    for name, pose in ends:
        cuts = [circle_cuts(*circle_center(*pose, r, t), r, obstacles) for t in (1, -1)]
        if all(cuts):
            which = sorted(set(cuts[0]) | set(cuts[1]))
            return PlannerError(
                "turning_circle_blocked",
                f"both {name} turning circles (r = {r:g} m) cut inflated obstacle(s) {which} "
                "and no path exists",
            )
    return PlannerError("unreachable", f"no collision-free path to the goal among {len(obstacles)} obstacles")


def _best(
    start: Pose, goal: GoalPose, cfg: PlannerConfig, inflated: Sequence[tuple[float, float, float]]
) -> tuple[str, tuple[Segment, ...], float]:
    """(word, segments, cost) of the best collision-free path, starting with a straight of
    ``start_run_up_m`` along the start heading where it is free and the goal farther than it and two turning
    radii (a vehicle at rest has no steerage until it moves), then :func:`_best_to_goal`."""
    run_up = cfg.start_run_up_m
    sx, sy, syaw = start
    if run_up > 0.0 and math.hypot(goal[0] - sx, goal[1] - sy) > run_up + 2.0 * cfg.turning_radius_m:
        first = StraightSegment(sx, sy, syaw, run_up)
        ex, ey = sx + run_up * math.cos(syaw), sy + run_up * math.sin(syaw)
        if point_inside(ex, ey, inflated) is None and not segments_collide((first,), inflated):
            try:
                word, segments, _ = _best_to_goal((ex, ey, syaw), goal, cfg, inflated)
            except PlannerError:
                pass  # no way on from the run-up's end: turn from the start instead
            else:
                segments = (first, *segments)
                return "S" + word, segments, cost_terms(segments, cfg).total
    return _best_to_goal(start, goal, cfg, inflated)


def _best_to_goal(
    start: Pose, goal: GoalPose, cfg: PlannerConfig, inflated: Sequence[tuple[float, float, float]]
) -> tuple[str, tuple[Segment, ...], float]:
    """(word, segments, cost) of the best collision-free path, through the goal's run-in when it has a
    heading and ``goal_run_in_m`` > 0 (a straight of that length ending at the goal), else direct."""
    run_in = cfg.goal_run_in_m
    if run_in > 0.0 and goal[2] is not None:
        gx, gy, gyaw = goal[0], goal[1], float(goal[2])
        px, py = gx - run_in * math.cos(gyaw), gy - run_in * math.sin(gyaw)
        last = StraightSegment(px, py, gyaw, run_in)
        if point_inside(px, py, inflated) is None and not segments_collide((last,), inflated):
            try:
                word, segments, _ = _best_direct(start, (px, py, gyaw), cfg, inflated)
            except PlannerError:
                pass  # no way to the run-in's start: straight to the goal instead
            else:
                segments = (*segments, last)
                return word + "S", segments, cost_terms(segments, cfg).total
    return _best_direct(start, goal, cfg, inflated)


def _best_direct(
    start: Pose, goal: GoalPose, cfg: PlannerConfig, inflated: Sequence[tuple[float, float, float]]
) -> tuple[str, tuple[Segment, ...], float]:
    """(word, segments, cost) of the best collision-free path from ``start`` to ``goal`` (PlannerError if
    none)."""
    scored = _score(_words(start, goal, cfg), cfg, inflated)
    free = [c for c in scored if not c.collides]
    chosen: tuple[str, tuple[Segment, ...], float] | None = None
    if free:
        chosen = (free[0].word, free[0].segments, free[0].cost)
    if inflated and scored[0].collides:
        found = graph.search(start, goal, cfg, inflated, cost_bound=chosen[2] if chosen else math.inf)
        if found is not None and (chosen is None or found.cost < chosen[2]):
            word = "".join(s.kind for s in found.segments)
            chosen = (word, found.segments, cost_terms(found.segments, cfg).total)
    if chosen is None:
        raise _diagnose(start, goal, cfg, inflated)
    word, segments, cost = chosen
    # Belt and braces: an exact check of the path that is about to be flown.
    if segments_collide(segments, inflated):
        raise PlannerError("unreachable", "internal check: the best path enters an obstacle; refusing it")
    return word, segments, cost


#: A helix circle keeps this far (m) from the goal point: the arrival test (within ``[mission]
#: arrival_radius_m`` of the goal, 0.5 m by default, with its heading) must not fire on the helix, and a
#: goal's closest approach stays its arrival.
HELIX_GOAL_CLEARANCE_M = 2.0


def _helix_junctions(segments: Sequence[Segment], cfg: PlannerConfig) -> list[int]:
    """Where helix circles may go, best first: ``j`` = before ``segments[j]`` (0 = at the start pose).

    At the start, so the depth change begins where the vehicle is and the goal's end (its run-in, its
    arrival heading) is flown as planned; after the run-up when the path has one (steerage first, as for
    any turn); then every later junction in path order, towards the goal, where the start is blocked.
    """
    n = len(segments)
    first = segments[0] if segments else None
    if isinstance(first, StraightSegment) and n > 1 and first.length_m <= cfg.start_run_up_m + 1e-9:
        return [*range(1, n), 0]
    return list(range(n)) or [0]


def _helix(
    start: Pose,
    segments: tuple[Segment, ...],
    dz_m: float,
    goal_xy: tuple[float, float],
    cfg: PlannerConfig,
    inflated: Sequence[tuple[float, float, float]],
) -> tuple[tuple[Segment, ...], str]:
    """``segments`` with full circles of the turning radius added where the path is too short for the
    depth change ``dz_m`` at ``max_depth_slope``, and their count and sense (e.g. ``"2R"``).

    The fewest full circles (each one segment of 2*pi*r: a projection on an arc is taken within one turn)
    that make the path long enough, all at one junction (:func:`_helix_junctions`), tangent to the path
    there: the vehicle flies a helix on a loiter circle of its turning radius and the whole leg keeps one
    linear depth profile, within the slope everywhere. The sense of the neighbouring arc first (the circle
    is then that arc's own), else either. A circle must not enter an inflated obstacle nor pass within
    :data:`HELIX_GOAL_CLEARANCE_M` of the goal; where none fits, ``PlannerError("depth_slope")`` says so.
    """
    r = cfg.turning_radius_m
    slope = cfg.max_depth_slope
    length = sum(s.length_m for s in segments)
    need = abs(dz_m) / slope
    lap = 2.0 * math.pi * r
    turns = max(1, math.ceil((need - length) / lap - 1e-9))
    n = len(segments)
    for j in _helix_junctions(segments, cfg):
        x, y, yaw = segments[j].pose_at(0.0)[:3] if j < n else start
        near = [
            s.turn for s in (segments[j : j + 1] + segments[max(j - 1, 0) : j]) if isinstance(s, ArcSegment)
        ]
        for turn in dict.fromkeys([*near, 1, -1]):
            cx, cy = circle_center(x, y, yaw, r, turn)
            if abs(math.hypot(goal_xy[0] - cx, goal_xy[1] - cy) - r) < HELIX_GOAL_CLEARANCE_M:
                continue
            circle = ArcSegment(cx, cy, r, turn, yaw, 2.0 * math.pi)
            if segments_collide((circle,), inflated):
                continue
            return (*segments[:j], *(circle,) * turns, *segments[j:]), f"{turns}{circle.kind}"
    raise PlannerError(
        "depth_slope",
        f"depth change {dz_m:+.2f} m needs {need:.2f} m of path at slope {slope:g}, but the path is "
        f"{length:.2f} m and no circle of radius {r:g} m fits along it for a helix (each enters an obstacle "
        f"or passes within {HELIX_GOAL_CLEARANCE_M:g} m of the goal)",
    )


def plan(
    start: Pose,
    goal: GoalPose,
    config: PlannerConfig | None = None,
    obstacles: Iterable[ObstacleInput] = (),
    start_depth_m: float = 0.0,
    goal_depth_m: float = 0.0,
) -> Path:
    """Plan the homing path from ``start`` to ``goal`` (paper section 3, cost eq. 2).

    Args:
        start: (x_m, y_m, yaw_rad) in NED, yaw from north towards east.
        goal: (x_m, y_m, yaw_rad) or (x_m, y_m, None) for a free arrival heading.
        config: planner parameters (turning radius, margin, weights, depth slope, rudder map).
        obstacles: circles (x_m, y_m, radius_m) or objects with those attributes; inflated here.
        start_depth_m, goal_depth_m: depths (m, positive down) at the two ends; linear in between.

    Returns:
        An immutable :class:`Path` with ``word``, ``virtual_goals``, ``cost`` (J) and the depth profile.

    Raises:
        PlannerError: with ``reason`` in ``errors.REASONS``; never returns a colliding path.
    """
    cfg = config or PlannerConfig()
    _validate_poses(start, goal, start_depth_m, goal_depth_m)
    start = (float(start[0]), float(start[1]), float(start[2]))
    obstacles = tuple(obstacles)
    try:
        return _plan(start, goal, cfg, obstacles, float(start_depth_m), float(goal_depth_m))
    except PlannerError as exc:
        if exc.reason not in TIGHTER_RADIUS_HELPS:
            raise
        for tight in cfg.fallbacks:
            if tight.obstacle_margin_m != cfg.obstacle_margin_m and exc.reason not in SMALLER_MARGIN_HELPS:
                continue
            try:
                path = _plan(start, goal, tight, obstacles, float(start_depth_m), float(goal_depth_m))
            except PlannerError:
                continue
            what = []
            if tight.turning_radius_m != cfg.turning_radius_m:
                what.append(f"the tighter turning radius {tight.turning_radius_m:g} m")
            if tight.obstacle_margin_m != cfg.obstacle_margin_m:
                what.append(f"the obstacle margin reduced to {tight.obstacle_margin_m:g} m")
            note = f"planned with {' and '.join(what)}: at {cfg.turning_radius_m:g} m, {exc}"
            return replace(path, note=note)
        raise  # the refusal at the planning radius names what blocks it


#: Refusals a tighter turning radius may lift (smaller turning circles, and obstacles inflated to at least
#: the radius grow less); a depth slope is refused only where no helix circle fits, which a smaller one may.
TIGHTER_RADIUS_HELPS = frozenset(
    {"turning_circle_blocked", "unreachable", "start_in_obstacle", "goal_in_obstacle", "depth_slope"}
)
#: Refusals a smaller obstacle margin may lift: a start or goal within the margin. Not a vehicle facing an
#: obstacle with its turning circles blocked: from rest it runs metres straight before its fins bite
#: (random mission r0 planned with 0.5 m of margin and crossed the obstacle's edge by 0.2 m).
SMALLER_MARGIN_HELPS = frozenset({"start_in_obstacle", "goal_in_obstacle"})


def _plan(
    start: Pose,
    goal: GoalPose,
    cfg: PlannerConfig,
    obstacles: Sequence[ObstacleInput],
    start_depth_m: float,
    goal_depth_m: float,
) -> Path:
    """:func:`plan` at the configured turning radius (no fallback)."""
    inflated = inflate(obstacles, cfg)
    hit = point_inside(start[0], start[1], inflated)
    if hit is not None:
        raise PlannerError(
            "start_in_obstacle", f"start ({start[0]:g}, {start[1]:g}) is inside inflated obstacle {hit}"
        )
    hit = point_inside(goal[0], goal[1], inflated)
    if hit is not None:
        raise PlannerError(
            "goal_in_obstacle", f"goal ({goal[0]:g}, {goal[1]:g}) is inside inflated obstacle {hit}"
        )

    word, segments, cost = _best(start, goal, cfg, inflated)
    length = sum(s.length_m for s in segments)
    dz = goal_depth_m - start_depth_m
    if abs(dz) > cfg.max_depth_slope * length + 1e-9:
        segments, turns = _helix(start, segments, dz, (goal[0], goal[1]), cfg, inflated)
        word = f"{word}+helix {turns}"
        cost = cost_terms(segments, cfg).total
    return Path(
        segments=segments,
        start_depth_m=start_depth_m,
        end_depth_m=goal_depth_m,
        virtual_goals=virtual_goals(segments),
        word=word,
        cost=cost,
        start_pose=start,
    )
