"""The tangent graph around circular obstacles, searched with A* on the paper's cost, eq. (2).

Paper section 3 models every obstacle as the smallest circle that surrounds it and joins the circles by
tangent lines; the points of contact are virtual goals. Here the circles are:

- the two start turning circles (right and left, radius r_min), and the same after a straight run of 1, 2
  and 4 r_min along the start heading (so the vehicle can first get clear of a nearby obstacle), sources
  only;
- the two goal turning circles, and the same before a straight run of 1, 2 and 4 r_min into the goal (or,
  for a free arrival heading, the goal point as a circle of radius 0), sinks only;
- every inflated obstacle circle, flown in either sense (radius R' = max(R + margin, r_min) >= r_min, so
  the vehicle can follow it).

A state is "arrived on circle j along the tangent from circle i": the tangent from i to j does not depend on
how the vehicle reached i, so the arrival point and heading are fixed by (i, j) and the graph is finite.
An edge is an arc on the current circle (in its sense) followed by a direction-consistent tangent to the
next circle. Arcs are checked against the arcs of the circle that lie inside other obstacles, tangents
with an exact segment-to-disk distance; the heuristic Wd * (straight-line distance to the goal) never
overestimates, so the first goal state popped is the cheapest path in the graph.

Pure: no clock, no I/O. Frame NED, metres, radians.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.cost import arc_cost_per_rad
from onboard.core.planner.geometry import (
    CLEARANCE_TOL_M,
    SNAP_RAD,
    FloatArray,
    arc,
    blocked_intervals,
    circle_center,
    free_sweep,
    segments_collide,
    sweep,
    sweep_array,
)
from onboard.core.planner.path import Segment, StraightSegment

Obstacle = tuple[float, float, float]

#: Extra start (goal) circles after (before) a straight run along the start (goal) heading of these many
#: turning radii: the pure tangent graph can only leave the start pose by turning, which fails when an
#: obstacle cuts both start circles although the way straight ahead is clear (and likewise at the goal).
STRAIGHT_RUN_FACTORS = (1.0, 2.0, 4.0)


@dataclass(frozen=True)
class _Tangents:
    """All tangents from one directed circle to every target circle (arrays over targets)."""

    target: np.ndarray  # target circle index (int)
    yaw_rad: FloatArray
    length_m: FloatArray
    leave_x_m: FloatArray
    leave_y_m: FloatArray
    arrive_x_m: FloatArray
    arrive_y_m: FloatArray
    ok: np.ndarray  # bool: exists and the straight enters no obstacle


@dataclass
class _State:
    g: float
    circle: int
    yaw_in_rad: float
    x_m: float
    y_m: float
    parent: tuple[int, ...] | None
    # The move from the parent: (parent circle, parent arrival yaw, arc sweep, tangent yaw, leave x, leave y,
    # straight length); for the final state on a goal circle: the final arc's sweep only.
    move: tuple[float, ...] | None


@dataclass(frozen=True)
class GraphResult:
    """The cheapest path found in the tangent graph."""

    segments: tuple[Segment, ...]
    cost: float
    expansions: int


class _Graph:
    def __init__(
        self,
        start: tuple[float, float, float],
        goal: tuple[float, float, float | None],
        config: PlannerConfig,
        obstacles: Sequence[Obstacle],
    ) -> None:
        r = config.turning_radius_m
        self.config = config
        self.obstacles = list(obstacles)
        x0, y0, yaw0 = start
        self.start = start
        cx: list[float] = []
        cy: list[float] = []
        rr: list[float] = []
        turn: list[int] = []
        phys: list[int] = []  # obstacle index of the circle, -1 for start/goal circles
        # Straight run (m) before a start circle / after a goal circle, and whether it is collision free.
        self.run_m: list[float] = []
        run_ok: list[bool] = []

        def add(x: float, y: float, radius: float, sense: int, obstacle: int, run: float, free: bool) -> None:
            cx.append(x)
            cy.append(y)
            rr.append(radius)
            turn.append(sense)
            phys.append(obstacle)
            self.run_m.append(run)
            run_ok.append(free)

        cs, sn = math.cos(yaw0), math.sin(yaw0)
        for d in (0.0, *(f * r for f in STRAIGHT_RUN_FACTORS)):
            px, py = x0 + d * cs, y0 + d * sn
            free = d == 0.0 or not segments_collide((StraightSegment(x0, y0, yaw0, d),), self.obstacles)
            for t in (1, -1):
                c = circle_center(px, py, yaw0, r, t)
                add(c[0], c[1], r, t, -1, d, free)
        self.n_start = len(cx)
        gx, gy, gyaw = goal
        self.goal_xy = (gx, gy)
        self.goal_yaw = gyaw
        if gyaw is None:
            # Free arrival heading: the goal is a point, i.e. a circle of radius 0 reached by a tangent.
            add(gx, gy, 0.0, 1, -1, 0.0, True)
        else:
            cs, sn = math.cos(gyaw), math.sin(gyaw)
            for d in (0.0, *(f * r for f in STRAIGHT_RUN_FACTORS)):
                px, py = gx - d * cs, gy - d * sn
                free = d == 0.0 or not segments_collide((StraightSegment(px, py, gyaw, d),), self.obstacles)
                for t in (1, -1):
                    c = circle_center(px, py, gyaw, r, t)
                    add(c[0], c[1], r, t, -1, d, free)
        self.n_goal = len(cx) - self.n_start
        for k, (ox, oy, orad) in enumerate(self.obstacles):
            for t in (1, -1):
                add(ox, oy, orad, t, k, 0.0, True)
        self.run_ok = np.array(run_ok, dtype=bool)
        self.cx = np.array(cx)
        self.cy = np.array(cy)
        self.r = np.array(rr)
        self.turn = np.array(turn, dtype=np.int64)
        self.phys = np.array(phys, dtype=np.int64)
        self.ox = np.array([o[0] for o in self.obstacles])
        self.oy = np.array([o[1] for o in self.obstacles])
        self.orad = np.array([o[2] for o in self.obstacles])
        self.coef = [arc_cost_per_rad(float(x), config) if x > 0.0 else 0.0 for x in rr]
        self._tangents: dict[int, _Tangents] = {}
        self._intervals: dict[int, list[tuple[float, float]]] = {}

    def is_goal(self, i: int) -> bool:
        return self.n_start <= i < self.n_start + self.n_goal

    def intervals(self, i: int) -> list[tuple[float, float]]:
        iv = self._intervals.get(i)
        if iv is None:
            iv = blocked_intervals(
                float(self.cx[i]), float(self.cy[i]), float(self.r[i]), self.obstacles, int(self.phys[i])
            )
            self._intervals[i] = iv
        return iv

    def tangents(self, i: int) -> _Tangents:
        """Tangents from circle i to all targets (goal circles and other obstacles' circles), cached."""
        cached = self._tangents.get(i)
        if cached is not None:
            return cached
        idx = np.arange(self.n_start, len(self.cx))
        if self.phys[i] >= 0:
            idx = idx[self.phys[idx] != self.phys[i]]
        a, ri = int(self.turn[i]), float(self.r[i])
        dx = self.cx[idx] - self.cx[i]
        dy = self.cy[idx] - self.cy[i]
        rj, tj = self.r[idx], self.turn[idx]
        d2 = dx * dx + dy * dy
        k = a * ri - tj * rj
        disc = d2 - k * k
        tol = 1e-9 * (1.0 + ri + rj)
        exists = (disc >= -2.0 * tol * (np.abs(k) + tol)) & (d2 > tol * tol)
        length = np.sqrt(np.maximum(disc, 0.0))
        psi = np.arctan2(dy, dx) + np.arctan2(k, length)
        s, c = np.sin(psi), np.cos(psi)
        px = self.cx[i] + a * ri * s
        py = self.cy[i] - a * ri * c
        qx = self.cx[idx] + tj * rj * s
        qy = self.cy[idx] - tj * rj * c
        ok = exists & self.run_ok[idx]
        if len(self.obstacles):
            # Exact distance from each obstacle centre to each straight (T x K), own circles excluded: a
            # tangent touches them by construction.
            vx, vy = (qx - px)[:, None], (qy - py)[:, None]
            wx, wy = self.ox[None, :] - px[:, None], self.oy[None, :] - py[:, None]
            vv = vx * vx + vy * vy
            u = np.clip((wx * vx + wy * vy) / np.where(vv > 0.0, vv, 1.0), 0.0, 1.0)
            ex, ey = wx - u * vx, wy - u * vy
            lim = self.orad[None, :] - CLEARANCE_TOL_M
            hit = ex * ex + ey * ey < np.where(lim > 0.0, lim * lim, 0.0)
            kk = np.arange(len(self.obstacles))[None, :]
            hit &= (kk != self.phys[i]) & (kk != self.phys[idx][:, None])
            ok = ok & ~hit.any(axis=1)
        tan = _Tangents(idx, psi, length, px, py, qx, qy, ok)
        self._tangents[i] = tan
        return tan

    def search(self, cost_bound: float) -> GraphResult | None:
        """A* over the tangent graph; paths costing ``cost_bound`` or more are pruned."""
        wd = self.config.weight_distance
        gx, gy = self.goal_xy
        states: dict[tuple[int, ...], _State] = {}
        best_g: dict[tuple[int, ...], float] = {}
        closed: set[tuple[int, ...]] = set()
        heap: list[tuple[float, int, float, tuple[int, ...]]] = []
        # Best cost so far of "arrived on circle j from circle i", as an array so that a whole expansion is
        # filtered at once; start and goal states (few) live in best_g.
        n = len(self.cx)
        best_arr = np.full((n, n), math.inf)
        seq = 0
        x0, y0, yaw0 = self.start
        cs, sn = math.cos(yaw0), math.sin(yaw0)
        for i in range(self.n_start):
            if not self.run_ok[i]:
                continue
            # "On start circle i": after the straight run (0 for the circles through the start pose).
            key: tuple[int, ...] = (-1, i)
            d = self.run_m[i]
            px, py = x0 + d * cs, y0 + d * sn
            g0 = wd * d
            states[key] = _State(g0, i, yaw0, px, py, None, None)
            best_g[key] = g0
            heap.append((g0 + wd * math.hypot(px - gx, py - gy), seq, g0, key))
            seq += 1
        heapq.heapify(heap)
        expansions = 0
        # Per circle, the states already expanded on it: (arrival yaw, cost, free sweep from there).
        expanded: dict[int, list[tuple[float, float, float]]] = {}
        while heap:
            _f, _, g, key = heapq.heappop(heap)
            if key in closed:
                continue
            best = best_arr[key[0], key[1]] if key[0] >= 0 else best_g.get(key, math.inf)
            if g > best:
                continue
            closed.add(key)
            st = states[key]
            if key[0] == -2:  # a goal state
                return GraphResult(self._rebuild(key, states), g, expansions)
            ci = st.circle
            a = int(self.turn[ci])
            ms = free_sweep(st.yaw_in_rad - a * math.pi / 2.0, a, self.intervals(ci))
            if ms < 0.0:
                continue
            # Dominance: if an expanded state E on this circle reaches this arrival point by flying on along
            # the circle (free arc) at no more cost, every continuation from here is also one from E.
            done = expanded.setdefault(ci, [])
            if any(
                (w := sweep(a * (st.yaw_in_rad - yaw_e))) <= ms_e and g_e + w * self.coef[ci] <= g + 1e-12
                for yaw_e, g_e, ms_e in done
            ):
                continue
            done.append((st.yaw_in_rad, g, ms))
            expansions += 1
            if self.is_goal(ci):
                assert self.goal_yaw is not None
                q = sweep(a * (self.goal_yaw - st.yaw_in_rad))
                if q > ms + SNAP_RAD:
                    continue
                g_end = g + q * self.coef[ci] + wd * self.run_m[ci]
                end_key = (-2, *key)
                if g_end < cost_bound and g_end < best_g.get(end_key, math.inf):
                    best_g[end_key] = g_end
                    states[end_key] = _State(g_end, ci, st.yaw_in_rad, gx, gy, key, (q, self.run_m[ci]))
                    heapq.heappush(heap, (g_end, seq, g_end, end_key))
                    seq += 1
                continue
            tan = self.tangents(ci)
            t = sweep_array(a * (tan.yaw_rad - st.yaw_in_rad))
            g2 = g + t * self.coef[ci] + wd * tan.length_m
            f2 = g2 + wd * np.hypot(tan.arrive_x_m - gx, tan.arrive_y_m - gy)
            good = np.flatnonzero(tan.ok & (t <= ms + SNAP_RAD) & (f2 < cost_bound))
            row = best_arr[ci]
            good = good[g2[good] < row[tan.target[good]]]
            row[tan.target[good]] = g2[good]
            for j in good.tolist():
                tgt = int(tan.target[j])
                point_goal = self.goal_yaw is None and self.is_goal(tgt)
                nkey: tuple[int, ...] = (-2, ci, tgt) if point_goal else (ci, tgt)
                if nkey in closed:
                    continue
                gj = float(g2[j])
                yaw_t = float(tan.yaw_rad[j])
                move = (
                    float(ci),
                    st.yaw_in_rad,
                    float(t[j]),
                    yaw_t,
                    float(tan.leave_x_m[j]),
                    float(tan.leave_y_m[j]),
                    float(tan.length_m[j]),
                )
                states[nkey] = _State(
                    gj, tgt, yaw_t, float(tan.arrive_x_m[j]), float(tan.arrive_y_m[j]), key, move
                )
                heapq.heappush(heap, (float(f2[j]), seq, gj, nkey))
                seq += 1
        return None

    def _rebuild(self, key: tuple[int, ...], states: dict[tuple[int, ...], _State]) -> tuple[Segment, ...]:
        chain: list[_State] = []
        k: tuple[int, ...] | None = key
        while k is not None:
            chain.append(states[k])
            k = states[k].parent
        chain.reverse()
        segs: list[Segment] = []
        x0, y0, yaw0 = self.start
        first = chain[0].circle
        if self.run_m[first] > 0.0:
            segs.append(StraightSegment(x0, y0, yaw0, self.run_m[first]))
        for st in chain[1:]:
            mv = st.move
            assert mv is not None
            if len(mv) == 2:  # the final arc on a goal circle, then the straight run into the goal
                q, run = mv
                c = st.circle
                cxy = (float(self.cx[c]), float(self.cy[c]))
                if q > 0.0:
                    segs.append(arc(*cxy, float(self.r[c]), int(self.turn[c]), st.yaw_in_rad, q))
                if run > 0.0:
                    assert self.goal_yaw is not None
                    gx, gy = self.goal_xy
                    cs, sn = math.cos(self.goal_yaw), math.sin(self.goal_yaw)
                    segs.append(StraightSegment(gx - run * cs, gy - run * sn, self.goal_yaw, run))
                continue
            src, yaw_in, t, yaw_t, lx, ly, length = mv
            c = int(src)
            if t > 0.0:
                segs.append(
                    arc(float(self.cx[c]), float(self.cy[c]), float(self.r[c]), int(self.turn[c]), yaw_in, t)
                )
            if length > 0.0:
                segs.append(StraightSegment(lx, ly, yaw_t, length))
        return tuple(segs)


def search(
    start: tuple[float, float, float],
    goal: tuple[float, float, float | None],
    config: PlannerConfig,
    obstacles: Sequence[Obstacle],
    cost_bound: float = math.inf,
) -> GraphResult | None:
    """Cheapest path (eq. 2) from ``start`` to ``goal`` in the tangent graph of ``obstacles``, or None.

    ``start`` is (x_m, y_m, yaw_rad); ``goal`` is (x_m, y_m, yaw_rad or None for a free arrival heading);
    ``obstacles`` are already inflated circles (x_m, y_m, radius_m) with radius >= r_min. Paths costing
    ``cost_bound`` or more are not searched (the caller already has one that good).
    """
    return _Graph(start, goal, config, obstacles).search(cost_bound)
