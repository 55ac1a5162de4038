"""Independent checks of a path: continuity, end poses, curvature and clearance (dense and analytic)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from onboard.core.planner import ArcSegment, Path


def ang_diff(a: float, b: float) -> float:
    return abs(math.remainder(a - b, 2.0 * math.pi))


def check_continuity(path: Path, tol_m: float = 1e-6, tol_rad: float = 1e-9) -> None:
    """Each segment starts where the previous one ends, with the same heading."""
    for prev, nxt in zip(path.segments, path.segments[1:], strict=False):
        x0, y0, yaw0, _ = prev.pose_at(prev.length_m)
        x1, y1, yaw1, _ = nxt.pose_at(0.0)
        assert math.hypot(x1 - x0, y1 - y0) < tol_m, (prev, nxt)
        assert ang_diff(yaw0, yaw1) < tol_rad, (prev, nxt)


def check_ends(path: Path, start: Sequence[float], goal: Sequence[float | None]) -> None:
    s = path.sample(0.0)
    assert math.hypot(s.x_m - start[0], s.y_m - start[1]) < 1e-6
    assert ang_diff(s.yaw_rad, float(start[2])) < 1e-9
    x, y, yaw = path.end_pose
    gx, gy, gyaw = goal
    assert gx is not None and gy is not None
    assert math.hypot(x - gx, y - gy) < 1e-6
    if gyaw is not None:
        # Within 1e-9 rad inclusive: the planner treats headings within SNAP_RAD (1e-9) as equal, so a
        # goal 1e-9 rad off the start heading is a zero-length path, not a loop (hypothesis found it).
        assert ang_diff(yaw, gyaw) <= 1e-9 + 1e-15


def check_curvature(path: Path, radius_m: float) -> None:
    for seg in path.segments:
        if isinstance(seg, ArcSegment):
            assert seg.radius_m >= radius_m - 1e-12
            assert seg.sweep_rad >= 0.0
    n = max(2, int(path.length_m / 0.25))
    for i in range(n + 1):
        assert abs(path.sample(path.length_m * i / n).curvature_1pm) <= 1.0 / radius_m + 1e-12


def min_clearance_dense(
    path: Path, obstacles: Sequence[tuple[float, float, float]], step_m: float = 0.05
) -> float:
    """Smallest (distance to centre - inflated radius) over samples every ``step_m`` (m)."""
    best = math.inf
    n = max(2, int(path.length_m / step_m) + 1)
    for i in range(n + 1):
        s = path.sample(path.length_m * i / n)
        for ox, oy, orad in obstacles:
            best = min(best, math.hypot(s.x_m - ox, s.y_m - oy) - orad)
    return best


def min_clearance_analytic(path: Path, obstacles: Sequence[tuple[float, float, float]]) -> float:
    """Exact minimum over the segments, computed independently of the planner's collision code."""
    best = math.inf
    for seg in path.segments:
        for ox, oy, orad in obstacles:
            if isinstance(seg, ArcSegment):
                # Distance to the full circle is |d - rho| at the angle towards the centre, if swept.
                d = math.hypot(ox - seg.center_x_m, oy - seg.center_y_m)
                ang = math.atan2(oy - seg.center_y_m, ox - seg.center_x_m)
                # Arc position angles run phi0 -> phi0 + turn * sweep.
                x0, y0, _, _ = seg.pose_at(0.0)
                phi0 = math.atan2(y0 - seg.center_y_m, x0 - seg.center_x_m)
                rel = (seg.turn * (ang - phi0)) % (2 * math.pi)
                cand = [abs(d - seg.radius_m)] if rel <= seg.sweep_rad else []
                for s in (0.0, seg.length_m):
                    x, y, _, _ = seg.pose_at(s)
                    cand.append(math.hypot(x - ox, y - oy))
                best = min(best, min(cand) - orad)
            else:
                x0, y0, _, _ = seg.pose_at(0.0)
                ux, uy = math.cos(seg.yaw_rad), math.sin(seg.yaw_rad)
                t = min(max((ox - x0) * ux + (oy - y0) * uy, 0.0), seg.length_m)
                best = min(best, math.hypot(x0 + t * ux - ox, y0 + t * uy - oy) - orad)
    return best
