"""Arrival and tracking metrics from the simulator's truth against a planned path (one judge for
``auv-hil scenario`` and the campaigns).

Arrival: the first truth row whose along-track coordinate reaches the goal line (through the goal,
perpendicular to the arrival heading) while its nearest path segment is near the end of the path. The final
errors are measured at the crossing, interpolated within the period, or at the last row (then
``completed`` is false). Cross-track: the distance from the truth to the planned polyline, up to arrival,
searched in a window that moves along the path (a path that passes near itself is not short-cut).
Course over ground: the direction of the truth's displacement over the period of the crossing (with a
current it differs from the heading by the crab angle).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from onboard.protocol.conventions import wrap_pi

WINDOW_BACK = 20  # segments searched behind the last nearest one
WINDOW_AHEAD = 200  # ... and ahead of it


def read_truth(path: str | Path) -> list[dict[str, float]]:
    """The truth CSV of ``auv-hil run --truth-log`` as rows of floats (the state name column left out)."""
    with open(path, newline="") as f:
        return [{k: float(v) for k, v in r.items() if k != "onboard_state"} for r in csv.DictReader(f)]


class _Polyline:
    """Segments of a planned polyline as arrays, for windowed nearest-segment queries."""

    def __init__(self, points: Sequence[Sequence[float]]) -> None:
        p = np.asarray([(q[0], q[1]) for q in points], dtype=float).reshape(-1, 2)
        if len(p) == 1:
            p = np.vstack([p, p])
        self.x0, self.y0 = p[:-1, 0], p[:-1, 1]
        self.dx, self.dy = p[1:, 0] - self.x0, p[1:, 1] - self.y0
        self.seg2 = self.dx * self.dx + self.dy * self.dy
        self.count = len(self.x0)

    def nearest(self, x: float, y: float, lo: int, hi: int) -> tuple[float, int]:
        """Distance (m) from (x, y) to segments lo..hi-1 (clipped to the path) and the nearest one's index."""
        lo, hi = max(lo, 0), min(hi, self.count)
        if hi <= lo:
            lo, hi = max(self.count - 1, 0), self.count
        sl = slice(lo, hi)
        dx, dy, seg2 = self.dx[sl], self.dy[sl], self.seg2[sl]
        rx, ry = x - self.x0[sl], y - self.y0[sl]
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(seg2 > 0.0, (rx * dx + ry * dy) / np.where(seg2 > 0.0, seg2, 1.0), 0.0)
        t = np.clip(t, 0.0, 1.0)
        d = np.hypot(rx - t * dx, ry - t * dy)
        i = int(np.argmin(d))
        return float(d[i]), lo + i


def compute_metrics(
    truth: Sequence[Mapping[str, float]],
    samples: Sequence[Sequence[float]],
    goal: tuple[float, float, float | None],
    goal_depth_m: float = 1.0,
    until_row: int | None = None,
) -> dict[str, Any]:
    """Arrival and tracking metrics (see the module docstring).

    Args:
        truth: rows with ``t_s``, ``x_m``, ``y_m``, ``depth_m``, ``yaw_deg`` (one per control period).
        samples: the planned polyline ``[[x_m, y_m, yaw_deg], ...]`` from start to goal.
        goal: ``(x_m, y_m, yaw_deg)``; yaw None (a free arrival heading) takes the path's final heading.
        goal_depth_m: the goal's depth (m).
        until_row: None: the arrival is the first crossing of the goal line. A row index: the last crossing
            at or before that row (e.g. where the vehicle declared its arrival, after a miss and a second
            approach), or the first one after it if there is none before.
    """
    if not truth:
        raise ValueError("empty truth log")
    poly = _Polyline(samples)
    gx, gy, gyaw_deg = goal
    if gyaw_deg is None:
        gyaw_deg = float(samples[-1][2]) if samples and len(samples[-1]) > 2 else 0.0
    gyaw = math.radians(gyaw_deg)
    ux, uy = math.cos(gyaw), math.sin(gyaw)
    idx = 0
    dists: list[float] = []  # cross-track of each row
    arrival: dict[str, float] | None = None
    arrival_row = len(truth) - 1
    arrival_cross = 0.0
    near_end = max(poly.count - 1, 0)
    prev: Mapping[str, float] | None = None
    prev_along = -math.inf
    was_past = False
    for k, row in enumerate(truth):
        along_goal = (row["x_m"] - gx) * ux + (row["y_m"] - gy) * uy
        d, idx = poly.nearest(row["x_m"], row["y_m"], idx - WINDOW_BACK, idx + WINDOW_AHEAD)
        past = idx >= near_end - WINDOW_BACK and along_goal >= 0.0
        if until_row is not None and arrival is not None and k > until_row:
            break
        if past and not was_past:
            # Interpolate to the crossing of the goal line, so the period's sampling adds no error.
            arrival = dict(row)
            if prev is not None and prev_along < 0.0 <= along_goal:
                w = -prev_along / (along_goal - prev_along)
                arrival = {key: prev[key] + w * (row[key] - prev[key]) for key in row if key != "yaw_deg"}
                arrival["yaw_deg"] = prev["yaw_deg"] + w * math.degrees(
                    wrap_pi(math.radians(row["yaw_deg"] - prev["yaw_deg"]))
                )
            arrival_cross, _ = poly.nearest(
                arrival["x_m"], arrival["y_m"], idx - WINDOW_BACK, idx + WINDOW_AHEAD
            )
            arrival_row = k
            if until_row is None:
                break
        dists.append(d)
        was_past = past
        prev, prev_along = row, along_goal
    cross = [*dists[:arrival_row], arrival_cross] if arrival is not None else dists
    final = arrival if arrival is not None else dict(truth[-1])
    ex, ey = gx - final["x_m"], gy - final["y_m"]
    return {
        "completed": arrival is not None,
        "arrival_time_s": final["t_s"],
        "arrival_row": arrival_row,
        "final_position_error_m": math.hypot(ex, ey),
        "final_x_error_m": ex,
        "final_y_error_m": ey,
        "final_depth_error_m": goal_depth_m - final["depth_m"],
        "final_yaw_error_deg": math.degrees(wrap_pi(gyaw - math.radians(final["yaw_deg"]))),
        "final_course_error_deg": _course_error_deg(truth, arrival_row, gyaw),
        "max_cross_track_m": max(cross) if cross else math.nan,
        "rms_cross_track_m": math.sqrt(sum(c * c for c in cross) / len(cross)) if cross else math.nan,
    }


def _course_error_deg(truth: Sequence[Mapping[str, float]], row: int, goal_yaw_rad: float) -> float:
    """Goal yaw minus the course over ground over the period ending at ``row`` (deg; nan when still)."""
    if row < 1:
        return math.nan
    a, b = truth[row - 1], truth[row]
    dx, dy = b["x_m"] - a["x_m"], b["y_m"] - a["y_m"]
    if math.hypot(dx, dy) < 1e-6:
        return math.nan
    return math.degrees(wrap_pi(goal_yaw_rad - math.atan2(dy, dx)))


def goal_crossings(
    truth: Sequence[Mapping[str, float]],
    samples: Sequence[Sequence[float]],
    goal: tuple[float, float, float | None],
) -> list[dict[str, Any]]:
    """Every crossing of the goal line (the rule of :func:`compute_metrics`: along-track reaches the line
    through the goal, perpendicular to its heading, while the nearest path segment is near the path's end),
    in order: ``row`` (the first row past the line), the interpolated ``t_s``, ``x_m``, ``y_m``,
    ``position_error_m`` and the ``course_error_deg`` over that row's period (nan when still).

    An intermediate goal is judged at any of them (a miss, a re-plan and a second approach cross twice),
    the last goal at the one the vehicle claimed (:func:`compute_metrics` ``until_row``)."""
    if not truth:
        return []
    poly = _Polyline(samples)
    gx, gy, gyaw_deg = goal
    if gyaw_deg is None:
        gyaw_deg = float(samples[-1][2]) if samples and len(samples[-1]) > 2 else 0.0
    gyaw = math.radians(gyaw_deg)
    ux, uy = math.cos(gyaw), math.sin(gyaw)
    near_end = max(poly.count - 1, 0)
    idx = 0
    out: list[dict[str, Any]] = []
    prev: Mapping[str, float] | None = None
    prev_along = -math.inf
    was_past = False
    for k, row in enumerate(truth):
        along_goal = (row["x_m"] - gx) * ux + (row["y_m"] - gy) * uy
        _, idx = poly.nearest(row["x_m"], row["y_m"], idx - WINDOW_BACK, idx + WINDOW_AHEAD)
        past = idx >= near_end - WINDOW_BACK and along_goal >= 0.0
        if past and not was_past:
            x, y, t = row["x_m"], row["y_m"], row["t_s"]
            if prev is not None and prev_along < 0.0 <= along_goal:
                w = -prev_along / (along_goal - prev_along)
                x, y = prev["x_m"] + w * (x - prev["x_m"]), prev["y_m"] + w * (y - prev["y_m"])
                t = prev["t_s"] + w * (t - prev["t_s"])
            out.append({
                "row": k, "t_s": t, "x_m": x, "y_m": y, "position_error_m": math.hypot(gx - x, gy - y),
                "course_error_deg": _course_error_deg(truth, k, gyaw),
            })  # fmt: skip
        was_past = past
        prev, prev_along = row, along_goal
    return out
