"""Plane geometry for the planner: turning circles, common tangents and exact collision tests.

Frame: NED (x north, y east, metres), yaw from north towards east in radians. A directed circle is a circle
flown in one sense: ``turn = +1`` is a right (clockwise seen from above, yaw increasing) turn, ``-1`` a left
turn. A vehicle at (x, y, yaw) on a circle of radius r with sense ``turn`` has its centre at
``(x - turn * r * sin(yaw), y + turn * r * cos(yaw))``, i.e. on its starboard side for a right turn.

Collision tests are analytic, on the real arcs and straight segments (never on sampled points or chords):
a path *enters* an obstacle disk when its distance to the centre drops below ``R - CLEARANCE_TOL_M``;
touching the inflated boundary (a tangent, or flying along it) is allowed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from onboard.core.planner.path import ArcSegment, Segment, StraightSegment

TWO_PI = 2.0 * math.pi
#: Sweeps within this of 0 or 2*pi (rad) are snapped to 0: rounding must never add a full loop of 2*pi*r.
SNAP_RAD = 1e-9
#: Allowed penetration of an inflated obstacle (m): rounding of tangent points is ~1e-12 m.
CLEARANCE_TOL_M = 1e-9

FloatArray = npt.NDArray[np.float64]


def sweep(angle_rad: float) -> float:
    """A turn angle mapped to [0, 2*pi) (rad), with values within SNAP_RAD of 0 or 2*pi snapped to 0.

    This is the wrap guard: a tangent heading that equals the start heading up to rounding must give a
    zero arc, not an extra loop of 2*pi*r (the classic Dubins bug).
    """
    a = angle_rad % TWO_PI
    if a > TWO_PI - SNAP_RAD or a < SNAP_RAD:
        return 0.0
    return a


def sweep_array(angle_rad: FloatArray) -> FloatArray:
    """Vectorised :func:`sweep`."""
    a = np.mod(angle_rad, TWO_PI)
    return np.where((a > TWO_PI - SNAP_RAD) | (a < SNAP_RAD), 0.0, a)


def circle_center(x_m: float, y_m: float, yaw_rad: float, radius_m: float, turn: int) -> tuple[float, float]:
    """Centre (m) of the turning circle of sense ``turn`` through the pose (x_m, y_m, yaw_rad)."""
    return (x_m - turn * radius_m * math.sin(yaw_rad), y_m + turn * radius_m * math.cos(yaw_rad))


def heading_on_circle(px_m: float, py_m: float, cx_m: float, cy_m: float, turn: int) -> float:
    """Yaw (rad) of a vehicle at (px, py) flying the circle centred (cx, cy) in sense ``turn``."""
    return math.atan2(turn * (px_m - cx_m), -turn * (py_m - cy_m))


@dataclass(frozen=True)
class Tangent:
    """A direction-consistent common tangent from a directed circle to another (or to a point).

    The vehicle leaves the first circle at ``leave`` with yaw ``yaw_rad`` and flies ``length_m`` straight to
    ``arrive`` on the second circle, where it continues in that circle's sense.
    """

    yaw_rad: float
    length_m: float
    leave: tuple[float, float]
    arrive: tuple[float, float]


def tangent(
    c0: tuple[float, float], r0_m: float, turn0: int, c1: tuple[float, float], r1_m: float, turn1: int
) -> Tangent | None:
    """The one flyable tangent from directed circle 0 to directed circle 1, or None if there is none.

    Same senses give the outer tangent, opposite senses the inner one; ``r1_m = 0`` gives the tangent from
    circle 0 to the point ``c1``. Derivation: with n(psi) = (sin psi, -cos psi) the leave point is
    c0 + turn0*r0*n and the arrival point c1 + turn1*r1*n, so c1 - c0 = Rot(psi) (L, -k) with
    k = turn0*r0 - turn1*r1; hence L = sqrt(d^2 - k^2) and psi = atan2(c1 - c0) + atan2(k, L).
    Coincident circles (d = 0, k = 0) have no defined tangent and return None (the caller flies one arc).
    """
    dx, dy = c1[0] - c0[0], c1[1] - c0[1]
    d2 = dx * dx + dy * dy
    k = turn0 * r0_m - turn1 * r1_m
    tol = 1e-9 * (1.0 + abs(r0_m) + abs(r1_m))
    disc = d2 - k * k
    if disc < -2.0 * tol * (abs(k) + tol) or d2 <= tol * tol:
        return None
    length = math.sqrt(max(disc, 0.0))
    psi = math.atan2(dy, dx) + math.atan2(k, length)
    s, c = math.sin(psi), math.cos(psi)
    leave = (c0[0] + turn0 * r0_m * s, c0[1] - turn0 * r0_m * c)
    arrive = (c1[0] + turn1 * r1_m * s, c1[1] - turn1 * r1_m * c)
    return Tangent(psi, length, leave, arrive)


# ----------------------------------------------------------------------------------------------- collisions


def segment_clearance_m(seg: Segment, cx_m: float, cy_m: float) -> float:
    """Smallest distance (m) from the point (cx, cy) to the segment (an exact minimum, not sampled)."""
    if isinstance(seg, StraightSegment):
        ux, uy = math.cos(seg.yaw_rad), math.sin(seg.yaw_rad)
        wx, wy = cx_m - seg.x0_m, cy_m - seg.y0_m
        u = min(max(wx * ux + wy * uy, 0.0), seg.length_m)
        return math.hypot(wx - u * ux, wy - u * uy)
    vx, vy = cx_m - seg.center_x_m, cy_m - seg.center_y_m
    dist = math.hypot(vx, vy)
    rho = seg.radius_m
    if dist <= 1e-12:
        return rho
    # Position angle of the arc start about its centre: p - c = turn*r*(sin yaw, -cos yaw).
    phi0 = seg.start_yaw_rad - seg.turn * math.pi / 2.0
    rel = (seg.turn * (math.atan2(vy, vx) - phi0)) % TWO_PI
    if rel <= seg.sweep_rad:
        return abs(dist - rho)
    # Outside the swept span the distance grows monotonically away from the nearest point: check the ends.
    x0, y0, _, _ = seg.pose_at(0.0)
    x1, y1, _, _ = seg.pose_at(seg.length_m)
    return min(math.hypot(cx_m - x0, cy_m - y0), math.hypot(cx_m - x1, cy_m - y1))


def segments_collide(segments: Sequence[Segment], obstacles: Sequence[tuple[float, float, float]]) -> bool:
    """True if any segment enters any (already inflated) obstacle disk (x_m, y_m, radius_m).

    Exact, vectorised over obstacles; the same test as :func:`segment_clearance_m`.
    """
    if not obstacles or not segments:
        return False
    obs = np.asarray(obstacles, dtype=np.float64)
    ox, oy, lim = obs[:, 0], obs[:, 1], obs[:, 2] - CLEARANCE_TOL_M
    for seg in segments:
        if isinstance(seg, StraightSegment):
            ux, uy = math.cos(seg.yaw_rad), math.sin(seg.yaw_rad)
            wx, wy = ox - seg.x0_m, oy - seg.y0_m
            u = np.clip(wx * ux + wy * uy, 0.0, seg.length_m)
            dist = np.hypot(wx - u * ux, wy - u * uy)
        else:
            vx, vy = ox - seg.center_x_m, oy - seg.center_y_m
            dc = np.hypot(vx, vy)
            phi0 = seg.start_yaw_rad - seg.turn * math.pi / 2.0
            rel = np.mod(seg.turn * (np.arctan2(vy, vx) - phi0), TWO_PI)
            x0, y0, _, _ = seg.pose_at(0.0)
            x1, y1, _, _ = seg.pose_at(seg.length_m)
            ends = np.minimum(np.hypot(ox - x0, oy - y0), np.hypot(ox - x1, oy - y1))
            # Within the swept span the nearest point is towards the centre; outside it, an end point.
            dist = np.where((rel <= seg.sweep_rad) & (dc > 1e-12), np.abs(dc - seg.radius_m), ends)
            dist = np.where(dc > 1e-12, dist, seg.radius_m)
        if bool(np.any(dist < lim)):
            return True
    return False


def point_inside(x_m: float, y_m: float, obstacles: Sequence[tuple[float, float, float]]) -> int | None:
    """Index of the first (inflated) obstacle that strictly contains the point, or None."""
    for i, (ox, oy, orad) in enumerate(obstacles):
        if math.hypot(x_m - ox, y_m - oy) < orad - CLEARANCE_TOL_M:
            return i
    return None


def circle_cuts(
    cx_m: float, cy_m: float, r_m: float, obstacles: Sequence[tuple[float, float, float]]
) -> list[int]:
    """Indices of the obstacle disks whose interior the full circle (cx, cy, r) passes through."""
    hits = []
    for i, (ox, oy, orad) in enumerate(obstacles):
        d = math.hypot(ox - cx_m, oy - cy_m)
        # The circle's nearest point to the obstacle centre is at |d - r|.
        if abs(d - r_m) < orad - CLEARANCE_TOL_M:
            hits.append(i)
    return hits


def blocked_intervals(
    cx_m: float, cy_m: float, r_m: float, obstacles: Sequence[tuple[float, float, float]], skip: int = -1
) -> list[tuple[float, float]]:
    """Arcs of the circle (cx, cy, r) inside obstacle disks, as (centre angle, half width) in rad.

    Angles are position angles about the circle centre, atan2(y - cy, x - cx). ``skip`` is the index of an
    obstacle this circle is the boundary of (its own disk is touched, never entered).
    """
    out: list[tuple[float, float]] = []
    for i, (ox, oy, orad) in enumerate(obstacles):
        if i == skip:
            continue
        rad = orad - CLEARANCE_TOL_M
        d = math.hypot(ox - cx_m, oy - cy_m)
        if d >= r_m + rad or d + rad <= r_m:
            continue  # apart/touching, or the disk lies inside the circle without reaching it
        if d + r_m <= rad:
            out.append((0.0, math.pi))  # the whole circle is inside the disk
            continue
        cos_w = (r_m * r_m + d * d - rad * rad) / (2.0 * r_m * d)
        out.append((math.atan2(oy - cy_m, ox - cx_m), math.acos(min(1.0, max(-1.0, cos_w)))))
    return out


def free_sweep(phi0_rad: float, turn: int, intervals: Sequence[tuple[float, float]]) -> float:
    """Largest sweep (rad) from position angle ``phi0_rad`` in sense ``turn`` before entering a blocked arc.

    Returns -1.0 if ``phi0_rad`` is already inside a blocked arc and ``inf`` if the circle is free.
    """
    best = math.inf
    for mid, half in intervals:
        rel = math.remainder(phi0_rad - mid, TWO_PI)
        if abs(rel) < half - SNAP_RAD:
            return -1.0
        ahead = (turn * (mid - phi0_rad) - half) % TWO_PI
        if ahead > TWO_PI - SNAP_RAD:
            ahead = 0.0  # standing on the entry edge: no room at all
        best = min(best, ahead)
    return best


def arc(
    cx_m: float, cy_m: float, r_m: float, turn: int, start_yaw_rad: float, sweep_rad: float
) -> ArcSegment:
    """An :class:`ArcSegment` (a thin constructor, for readability at call sites)."""
    return ArcSegment(cx_m, cy_m, r_m, turn, start_yaw_rad, sweep_rad)
