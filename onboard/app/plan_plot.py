"""Plot of a planning result like the paper's Fig. 4 and 5 (not pure: it draws with matplotlib).

Map view of the NED plane: east to the right, north up. Turning circles dashed, obstacles filled with their
inflated circle dashed, candidate words thin (red dotted when they hit an obstacle), the chosen path thick,
virtual goals as dots. Uses the Agg canvas directly (no pyplot, no global state, no display needed).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.geometry import circle_center
from onboard.core.planner.path import Path, Segment
from onboard.core.planner.planner import Candidate, GoalPose, Pose


def _polyline(segments: Sequence[Segment], step_m: float) -> tuple[list[float], list[float]]:
    """(east, north) points along the segments every ``step_m`` (m) or closer."""
    east: list[float] = []
    north: list[float] = []
    for seg in segments:
        n = max(2, math.ceil(seg.length_m / step_m) + 1)
        for i in range(n):
            x, y, _, _ = seg.pose_at(seg.length_m * i / (n - 1))
            north.append(x)
            east.append(y)
    return east, north


def plot_plan(
    filename: str,
    start: Pose,
    goal: GoalPose,
    config: PlannerConfig,
    path: Path,
    candidates: Sequence[Candidate] = (),
    obstacles: Sequence[tuple[float, float, float]] = (),
    inflated: Sequence[tuple[float, float, float]] = (),
) -> None:
    """Draw the plan into ``filename`` (PNG). Poses in NED (m, rad); obstacles as (x_m, y_m, radius_m)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    fig = Figure(figsize=(7.0, 6.0), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    r = config.turning_radius_m
    ends: list[Pose] = [start]
    if goal[2] is not None:
        ends.append((goal[0], goal[1], goal[2]))
    for pose in ends:
        for turn in (1, -1):
            cx, cy = circle_center(*pose, r, turn)
            ax.add_patch(Circle((cy, cx), r, fill=False, ls="--", lw=0.8, ec="0.55"))
    for ox, oy, orad in obstacles:
        ax.add_patch(Circle((oy, ox), orad, fc="0.35", ec="0.2", alpha=0.6))
    for ox, oy, orad in inflated:
        ax.add_patch(Circle((oy, ox), orad, fill=False, ls=":", lw=1.0, ec="tab:red"))
    scale = max(1.0, path.length_m)
    for c in candidates:
        e, n = _polyline(c.segments, scale / 300.0)
        label = f"{c.word} {c.length_m:.2f} m" + (" (hits)" if c.collides else "")
        if c.collides:
            ax.plot(e, n, color="tab:red", ls=":", lw=0.8, label=label)
        else:
            ax.plot(e, n, color="0.6", lw=0.8, label=label)
    e, n = _polyline(path.segments, scale / 500.0)
    if not e:
        e, n = [start[1]], [start[0]]
    ax.plot(e, n, color="tab:blue", lw=2.2, label=f"chosen {path.word} {path.length_m:.2f} m")
    if path.virtual_goals:
        vx, vy = zip(*path.virtual_goals, strict=True)
        ax.plot(vy, vx, "o", color="tab:orange", ms=5, label="virtual goals")
    arrow = 0.15 * scale
    for (x, y, yaw), col in ((start, "tab:green"), (path.end_pose, "tab:purple")):
        ax.annotate(
            "",
            xy=(y + arrow * math.sin(yaw), x + arrow * math.cos(yaw)),
            xytext=(y, x),
            arrowprops={"arrowstyle": "->", "color": col, "lw": 1.5},
        )
    ax.plot([start[1]], [start[0]], "s", color="tab:green", label="start")
    ax.plot([goal[1]], [goal[0]], "*", color="tab:purple", ms=10, label="goal")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east y (m)")
    ax.set_ylabel("north x (m)")
    ax.set_title(f"Homing path, r = {r:g} m, J = {path.cost:.2f}")
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, loc="best")
    fig.savefig(filename)
