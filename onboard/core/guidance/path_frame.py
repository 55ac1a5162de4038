"""Path geometry for guidance: the path extended beyond its end, projection, and path-frame errors.

Path frame at a path point with tangent yaw psi_p (rad, NED): the along-track axis points along the
tangent and the cross-track axis 90 deg clockwise of it (to starboard of a vehicle flying the path). For
a path along +x (psi_p = 0) the along/cross axes are exactly the world x/y axes, so the path-frame errors
are the paper's e_x, e_y (eq. 4).
"""

from __future__ import annotations

import math

from onboard.core.planner.path import ArcSegment, Path, PathSample, StraightSegment
from onboard.protocol.conventions import wrap_pi


def sample_extended(path: Path, s_m: float) -> PathSample:
    """The path sample at arc length ``s_m`` (m); beyond the end, a straight extension at the final heading
    and final depth (curvature 0, pitch 0). Before the start it clamps to the start."""
    length = path.length_m
    if s_m <= length:
        return path.sample(s_m)
    end = path.sample(length)
    x_m, y_m = _extension_xy(end, s_m - length)
    return PathSample(
        s_m=s_m, x_m=x_m, y_m=y_m, yaw_rad=end.yaw_rad, curvature_1pm=0.0, depth_m=end.depth_m, pitch_rad=0.0
    )


def _extension_xy(end: PathSample, d_m: float) -> tuple[float, float]:
    """(x_m, y_m) of the straight extension ``d_m`` metres beyond the path end ``end``."""
    return end.x_m + d_m * math.cos(end.yaw_rad), end.y_m + d_m * math.sin(end.yaw_rad)


def depth_rate_per_m(path: Path, s_m: float) -> float:
    """d(depth)/ds (dimensionless, + = diving) of the extended path at ``s_m``."""
    return 0.0 if s_m > path.length_m else path.depth_slope


def path_frame(dx_m: float, dy_m: float, yaw_path_rad: float) -> tuple[float, float]:
    """Resolve a world (NED) vector (dx_m, dy_m) in the path frame: (along-track, cross-track) in m."""
    c, s = math.cos(yaw_path_rad), math.sin(yaw_path_rad)
    return c * dx_m + s * dy_m, -s * dx_m + c * dy_m


def _local_closest(
    seg: StraightSegment | ArcSegment, x_m: float, y_m: float, lo: float, hi: float
) -> tuple[float, float]:
    """(t, d2): the local arc length t in [lo, hi] of the point of ``seg`` closest to (x_m, y_m) (nearest end
    if outside) and its squared distance d2 (m^2)."""
    if isinstance(seg, StraightSegment):
        t = (x_m - seg.x0_m) * math.cos(seg.yaw_rad) + (y_m - seg.y0_m) * math.sin(seg.yaw_rad)
        t = min(max(t, lo), hi)
        return t, _dist2(seg.pose_at(t), x_m, y_m)
    vx, vy = x_m - seg.center_x_m, y_m - seg.center_y_m
    # On the arc, (x, y) - centre = turn * r * (sin yaw, -cos yaw) (see ArcSegment.pose_at).
    yaw = math.atan2(vx, -vy) if seg.turn > 0 else math.atan2(-vx, vy)
    delta = (seg.turn * (yaw - seg.start_yaw_rad)) % (2.0 * math.pi)
    t = seg.radius_m * delta
    if lo <= t <= hi:
        return t, _dist2(seg.pose_at(t), x_m, y_m)
    d_lo = _dist2(seg.pose_at(lo), x_m, y_m)
    d_hi = _dist2(seg.pose_at(hi), x_m, y_m)
    return (lo, d_lo) if d_lo <= d_hi else (hi, d_hi)


def _dist2(pose: tuple[float, float, float, float], x_m: float, y_m: float) -> float:
    return (pose[0] - x_m) ** 2 + (pose[1] - y_m) ** 2


def project(path: Path, x_m: float, y_m: float, s_lo_m: float = 0.0, s_hi_m: float = math.inf) -> float:
    """Arc length (m) of the point of the extended path closest to (x_m, y_m), searched in [s_lo_m, s_hi_m].

    The search window keeps the projection local (a path that passes near itself does not make it jump).
    The result can exceed ``path.length_m`` (on the straight extension) when ``s_hi_m`` allows it.
    """
    length = path.length_m
    lo_w = max(0.0, s_lo_m)
    hi_w = max(lo_w, s_hi_m)
    best_s, best_d2 = lo_w, math.inf
    s0 = 0.0  # start of the segment: the same running sum as Path.segment_start_s
    for seg in path.segments:
        if s0 > hi_w:
            break  # this segment and the rest start beyond the window
        seg_len = seg.length_m
        lo, hi = max(0.0, lo_w - s0), min(seg_len, hi_w - s0)
        if lo <= hi:
            t, d2 = _local_closest(seg, x_m, y_m, lo, hi)
            if d2 < best_d2:
                best_s, best_d2 = s0 + t, d2
        s0 += seg_len
    if hi_w >= length:
        end = path.sample(length)
        c, s = math.cos(end.yaw_rad), math.sin(end.yaw_rad)
        along = c * (x_m - end.x_m) + s * (y_m - end.y_m)  # path_frame's along-track component
        s_ext = min(max(length + max(0.0, along), lo_w, length), hi_w)  # >= length
        px, py = (end.x_m, end.y_m) if s_ext <= length else _extension_xy(end, s_ext - length)
        d2 = (px - x_m) ** 2 + (py - y_m) ** 2
        if d2 < best_d2:
            best_s = s_ext
    return best_s


def yaw_error(yaw_desired_rad: float, yaw_actual_rad: float) -> float:
    """e_psi = psi_d - psi_a wrapped to (-pi, pi] (rad), eq. 4 for an angle."""
    return wrap_pi(yaw_desired_rad - yaw_actual_rad)
