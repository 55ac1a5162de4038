"""The paper's figures of one run: the path against the planned path (Figs. 7, 9, 11, 13) and the errors
e_x, e_y in the path frame against time (Figs. 8, 10, 12, 14).

Pure: arrays in (NED metres, seconds; poses' yaw in degrees), PNG files out. Each figure is a
``matplotlib.figure.Figure`` of its own (no pyplot state, the Agg backend), returned so that tests read its
axes back; :func:`save_png` writes it.

Path frame (the convention of ``onboard/core/guidance/path_frame.py``): at the point of the planned path
nearest the vehicle the along-track axis points along the path and the cross-track axis 90 deg clockwise of
it (to starboard). The errors are desired - actual (paper eq. 4):

- ``e_x`` (along-track): the arc length of the guidance's reference point minus the vehicle's, both
  measured along the planned path: + = the reference is ahead of the vehicle (the vehicle lags). It exists
  while the vehicle logs a reference (until it declares its arrival).
- ``e_y`` (cross-track): minus the vehicle's signed distance from the planned path (+ = to starboard), so
  + = the vehicle is to port of the path and must move to starboard.

The distance comes from :mod:`hil_sim.metrics` (its windowed nearest-segment walk over the same polyline),
so the largest ``|e_y|`` up to the arrival is the metrics' ``max_cross_track_m``; this module only adds the
sign and the arc length of the nearest point. For a path along +x (north) the path frame is the world
frame and e_x, e_y are the paper's. The paper's own values (:class:`PaperValue`) are world-axis errors
against a reference moving at uniform speed from the first instant.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from hil_sim.metrics import WINDOW_AHEAD, WINDOW_BACK, _Polyline

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

FloatArray = npt.NDArray[np.float64]

DPI = 100
#: Height / width of the path plot's axes when its lateral axis is exaggerated.
EXAGGERATED_BOX_RATIO = 0.3
#: The path plot's lateral span, as a multiple of the data's own (room around the deviation).
LATERAL_MARGIN = 1.4
#: At equal scale, an inset zooms on the largest deviation when it is under this fraction of the x span.
INSET_BELOW = 0.02
#: The paper's colours: the reference path red solid, the vehicle blue dotted.
PLANNED_STYLE: dict[str, Any] = {"color": "tab:red", "linestyle": "-", "linewidth": 1.6}
VEHICLE_STYLE: dict[str, Any] = {"color": "tab:blue", "linestyle": ":", "linewidth": 2.2}
PAPER_STYLE: dict[str, dict[str, Any]] = {
    "simulation": {"color": "tab:purple", "linestyle": "--", "linewidth": 1.3},
    "basin": {"color": "tab:green", "linestyle": "-.", "linewidth": 1.3},
}
SOURCE_NAME = {"simulation": "simulation", "basin": "basin experiment"}


# --- the paper's reported values --------------------------------------------------------------------
@dataclass(frozen=True)
class PaperValue:
    """One error the paper reports for a scenario, as the demo prints it and the error figure marks it.

    - ``source``: ``"simulation"`` (its Figs. 8, 10) or ``"basin"`` (the experiment in KORDI's Ocean
      Engineering Basin, Figs. 12, 14).
    - ``value_m``: the magnitude (m); ``below``: the paper says "less than".
    - ``axis``: ``"error"`` (the position error) or ``"y"`` (its y-axis error).
    - ``at_goal``: the value at the goal; else a peak, ``where`` says where it occurs.
    """

    source: Literal["simulation", "basin"]
    value_m: float
    axis: Literal["error", "y"] = "error"
    below: bool = False
    at_goal: bool = True
    where: str = ""

    @property
    def text(self) -> str:
        """E.g. ``"0.13 m at goal"``, ``"y < 0.1 m at goal"``, ``"y 0.4 m (max at the turn)"``."""
        axis = "y " if self.axis == "y" else ""
        bound = "< " if self.below else ""
        where = "at goal" if self.at_goal else f"({self.where or 'max'})"
        return f"{axis}{bound}{self.value_m:g} m {where}"


def paper_text(values: Sequence[PaperValue], source: str) -> str:
    """The values of one source joined for a table cell ("-" when the paper reports none)."""
    return ", ".join(v.text for v in values if v.source == source) or "-"


# --- path-frame errors ------------------------------------------------------------------------------
def project_on_path(
    x_m: npt.ArrayLike, y_m: npt.ArrayLike, samples: Sequence[Sequence[float]]
) -> tuple[FloatArray, FloatArray]:
    """Each point's nearest point on the planned polyline, walked in order as the metrics walk it (from the
    path's start, in a window that moves along it: the points should start near the start).

    Args:
        x_m, y_m: the points (NED, m), in time order.
        samples: the planned polyline ``[[x_m, y_m, ...], ...]`` from start to goal.
    Returns:
        ``(s_m, cross_track_m)``: the arc length (m) of the nearest point (before the start and beyond the
        end, along the straight extension of the first and last segment) and the signed distance (m, + = to
        starboard of the path, the metrics' distance with a sign).
    """
    xs, ys = np.asarray(x_m, dtype=float).ravel(), np.asarray(y_m, dtype=float).ravel()
    poly = _Polyline(samples)
    seg_len = np.sqrt(poly.seg2)
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    s_out = np.full(xs.shape, math.nan)
    cross = np.full(xs.shape, math.nan)
    idx = 0
    for k, (x, y) in enumerate(zip(xs, ys, strict=True)):
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        d, idx = poly.nearest(x, y, idx - WINDOW_BACK, idx + WINDOW_AHEAD)
        rx, ry = x - poly.x0[idx], y - poly.y0[idx]
        dx, dy, seg2 = poly.dx[idx], poly.dy[idx], poly.seg2[idx]
        t = (rx * dx + ry * dy) / seg2 if seg2 > 0.0 else 0.0
        lo = -math.inf if idx == 0 else 0.0  # the extensions: along-track only (d stays the metrics')
        hi = math.inf if idx == poly.count - 1 else 1.0
        s_out[k] = cum[idx] + min(max(t, lo), hi) * seg_len[idx]
        side = dx * ry - dy * rx  # > 0: to the right of the segment's direction (x north, y east)
        cross[k] = d if side >= 0.0 else -d
    return s_out, cross


@dataclass(frozen=True)
class PathFrameErrors:
    """The path-frame errors of a run, one value per truth row (see the module docstring).

    ``t_s`` (s) and ``x_m``, ``y_m`` (NED, m): the track (up to the goal when one was given); ``s_m`` the
    vehicle's arc length along the planned path (m); ``e_x_m`` along-track (m, NaN where no reference was
    logged); ``e_y_m`` cross-track (m); ``ref_s_m`` the reference's arc length (m, NaN where none);
    ``t_goal_s`` the arrival the track ends at (s; None: the goal was not reached, the whole track).
    """

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    s_m: FloatArray
    e_x_m: FloatArray
    e_y_m: FloatArray
    ref_s_m: FloatArray
    t_goal_s: float | None = None


def path_frame_errors(
    t_s: npt.ArrayLike,
    x_m: npt.ArrayLike,
    y_m: npt.ArrayLike,
    samples: Sequence[Sequence[float]],
    ref_t_s: npt.ArrayLike = (),
    ref_x_m: npt.ArrayLike = (),
    ref_y_m: npt.ArrayLike = (),
    t_goal_s: float | None = None,
) -> PathFrameErrors:
    """e_x, e_y of the vehicle track (``t_s``, ``x_m``, ``y_m``: the simulator's truth, NED m, s, in time
    order) against the planned polyline ``samples``; the reference point (``ref_*``: the onboard's logged
    reference, same clock; non-finite rows and repeated times dropped, the last of a time kept) gives e_x.

    With ``t_goal_s`` (the metrics' arrival: the crossing of the goal line) the track ends there: the rows
    after it are dropped and the position interpolated at ``t_goal_s`` is the last row, so the last e_y is
    the metrics' cross-track at the arrival (a row beyond the path's end would measure its distance to the
    end point instead)."""
    t = np.asarray(t_s, dtype=float).ravel()
    xs, ys = np.asarray(x_m, dtype=float).ravel(), np.asarray(y_m, dtype=float).ravel()
    if t_goal_s is not None and t.size:
        keep = t < t_goal_s
        gx, gy = np.interp(t_goal_s, t, xs), np.interp(t_goal_s, t, ys)
        t = np.append(t[keep], t_goal_s)
        xs, ys = np.append(xs[keep], gx), np.append(ys[keep], gy)
    s_m, cross = project_on_path(xs, ys, samples)
    rt = np.asarray(ref_t_s, dtype=float).ravel()
    rx, ry = np.asarray(ref_x_m, dtype=float).ravel(), np.asarray(ref_y_m, dtype=float).ravel()
    ok = np.isfinite(rt) & np.isfinite(rx) & np.isfinite(ry)
    rt, rx, ry = rt[ok], rx[ok], ry[ok]
    order = np.argsort(rt, kind="stable")
    rt, rx, ry = rt[order], rx[order], ry[order]
    last = np.append(rt[1:] != rt[:-1], True) if rt.size else np.zeros(0, dtype=bool)
    rt, rx, ry = rt[last], rx[last], ry[last]
    ref_s = np.full(t.shape, math.nan)
    if rt.size:
        rs, _ = project_on_path(rx, ry, samples)
        inside = (t >= rt[0] - 1e-9) & (t <= rt[-1] + 1e-9)
        ref_s[inside] = np.interp(t[inside], rt, rs)
    return PathFrameErrors(
        t_s=t, x_m=xs, y_m=ys, s_m=s_m, e_x_m=ref_s - s_m, e_y_m=-cross, ref_s_m=ref_s, t_goal_s=t_goal_s
    )


@dataclass(frozen=True)
class ErrorSummary:
    """What the figures' titles say, from :class:`PathFrameErrors` (m, s, m/s; NaN = not defined).

    Over the track (up to the goal): the largest ``|e_y|`` and when; e_y at the goal (NaN when the goal was
    not reached); the largest e_x (the reference's lead) and when; e_x at the last logged reference
    (``t_last_ref_s``: the vehicle stops logging one when it declares its arrival); the reference's top
    speed along the path and when the reference and the vehicle first made 95 % of it.
    """

    t_goal_s: float | None
    max_abs_e_y_m: float
    t_max_e_y_s: float
    e_y_goal_m: float
    max_e_x_m: float
    t_max_e_x_s: float
    e_x_last_ref_m: float
    t_last_ref_s: float
    ref_top_speed_mps: float
    t_ref_at_speed_s: float
    t_vehicle_at_speed_s: float


def summarize(errors: PathFrameErrors) -> ErrorSummary:
    """The :class:`ErrorSummary` of ``errors``."""
    t = errors.t_s
    nan = math.nan

    def peak(values: FloatArray) -> tuple[float, float]:
        ok = np.isfinite(values)
        if not ok.any():
            return nan, nan
        i = int(np.argmax(np.where(ok, values, -np.inf)))
        return float(values[i]), float(t[i])

    max_ey, t_ey = peak(np.abs(errors.e_y_m))
    max_ex, t_ex = peak(errors.e_x_m)
    e_y_goal = float(errors.e_y_m[-1]) if errors.t_goal_s is not None and t.size else nan
    ref_ok = np.isfinite(errors.e_x_m)
    e_x_last = float(errors.e_x_m[ref_ok][-1]) if ref_ok.any() else nan
    t_last = float(t[ref_ok][-1]) if ref_ok.any() else nan
    top, t_ref_fast, t_veh_fast = nan, nan, nan
    if ref_ok.sum() >= 3:
        tr = t[ref_ok]
        ref_speed = np.gradient(errors.ref_s_m[ref_ok], tr)
        veh_speed = np.gradient(errors.s_m[ref_ok], tr)
        top = float(np.max(ref_speed))
        t_ref_fast = _first_time(tr, ref_speed >= 0.95 * top)
        t_veh_fast = _first_time(tr, veh_speed >= 0.95 * top)
    return ErrorSummary(
        t_goal_s=errors.t_goal_s,
        max_abs_e_y_m=max_ey,
        t_max_e_y_s=t_ey,
        e_y_goal_m=e_y_goal,
        max_e_x_m=max_ex,
        t_max_e_x_s=t_ex,
        e_x_last_ref_m=e_x_last,
        t_last_ref_s=t_last,
        ref_top_speed_mps=top,
        t_ref_at_speed_s=t_ref_fast,
        t_vehicle_at_speed_s=t_veh_fast,
    )


def _first_time(t: FloatArray, flags: npt.NDArray[np.bool_]) -> float:
    return float(t[int(np.argmax(flags))]) if flags.any() else math.nan


def lag_caption(summary: ErrorSummary) -> str:
    """The reference's lead over the vehicle in words, with its numbers (the e_x panel's title)."""
    s = summary
    if not math.isfinite(s.max_e_x_m):
        return "e_x along-track: no reference logged"
    text = (
        "e_x along-track = how far the reference point is ahead of the vehicle: "
        f"up to {s.max_e_x_m:.2f} m at t = {s.t_max_e_x_s:.1f} s"
    )
    if math.isfinite(s.t_ref_at_speed_s):
        vehicle = (
            f"the vehicle after {s.t_vehicle_at_speed_s:.1f} s"
            if math.isfinite(s.t_vehicle_at_speed_s)
            else "the vehicle never"
        )
        speed = f"{s.ref_top_speed_mps:.1f} m/s after {s.t_ref_at_speed_s:.1f} s"
        text += f"\n(the reference makes {speed}, {vehicle})"
    if s.t_goal_s is not None:
        text += f"; {s.e_x_last_ref_m:.2f} m when the vehicle declared arrival (t = {s.t_last_ref_s:.1f} s)"
    return text


# --- figures ----------------------------------------------------------------------------------------
def new_figure(width_in: float, height_in: float) -> Figure:
    """A figure not owned by pyplot (no global state) on an Agg canvas of its own."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_png(fig: Figure, path: str | Path, dpi: int = DPI) -> str:
    """Write ``fig`` as a PNG (its folder made if needed); returns the file name."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi, bbox_inches="tight", pad_inches=0.1)
    return str(out)


def nice_floor(value: float) -> float:
    """The largest of 1, 2, 5 x 10^k not above ``value``; 1 below 1."""
    if not math.isfinite(value) or value < 1.0:
        return 1.0
    k = math.floor(math.log10(value))
    return next(m * 10.0**k for m in (5.0, 2.0, 1.0) if m * 10.0**k <= value * (1.0 + 1e-12))


def _heading_marker(yaw_deg: float) -> tuple[int, int, float]:
    """A triangle marker pointing along ``yaw_deg`` (from north towards east) in the path plot, where north
    points right and east down (display angle -yaw); the regular triangle points up (90 deg) unrotated."""
    return (3, 0, -yaw_deg - 90.0)


def path_figure(
    samples: Sequence[Sequence[float]], errors: PathFrameErrors, title: str, width_in: float = 9.0
) -> Figure:
    """The vehicle's track (``errors.x_m``, ``errors.y_m``: up to the goal) against the planned path seen
    from above (paper Figs. 7, 9).

    NED turned a quarter turn: x north to the right, y east downwards (a map, not its mirror image). When
    the deviation would not show at equal scale (a straight line) the lateral axis is exaggerated by a round
    factor, stated in its label and the title; otherwise, when the largest deviation is under
    :data:`INSET_BELOW` of the plot's span, an inset shows it at equal scale. Start and goal are triangles
    pointing along their yaw; the largest ``|e_y|`` is ringed. The legend sits below the axes.

    Args:
        samples: the planned polyline ``[[x_m, y_m, yaw_deg], ...]`` from start to goal.
        errors: the track and its errors (:func:`path_frame_errors`).
        title: the first title line.
    """
    summary = summarize(errors)
    px = np.asarray([p[0] for p in samples], dtype=float)
    py = np.asarray([p[1] for p in samples], dtype=float)
    tx, ty = errors.x_m, errors.y_m
    all_x, all_y = np.concatenate([px, tx]), np.concatenate([py, ty])
    all_x, all_y = all_x[np.isfinite(all_x)], all_y[np.isfinite(all_y)]
    x_lo, x_hi = float(all_x.min()), float(all_x.max())
    y_lo, y_hi = float(all_y.min()), float(all_y.max())
    pad = max(0.04 * (x_hi - x_lo), 0.5)
    x_lo, x_hi = x_lo - pad, x_hi + pad
    span_x = x_hi - x_lo
    need_y = max(LATERAL_MARGIN * (y_hi - y_lo), 0.01)
    factor = nice_floor(EXAGGERATED_BOX_RATIO * span_x / need_y)
    if factor >= 2.0:
        span_y = EXAGGERATED_BOX_RATIO * span_x / factor
    else:
        factor = 1.0
        span_y = y_hi - y_lo + 2.0 * pad
    y_mid = 0.5 * (y_lo + y_hi)
    box_ratio = factor * span_y / span_x
    axes_w_in = width_in - 1.0
    fig = new_figure(width_in, axes_w_in * box_ratio + 2.0)
    ax = fig.add_subplot()
    ax.plot(px, py, **PLANNED_STYLE, label="planned path (reference)")
    ax.plot(tx, ty, **VEHICLE_STYLE, label="vehicle (simulator truth)")
    ax.set_xlim(x_lo, x_hi)
    ax.set_ylim(y_mid + 0.5 * span_y, y_mid - 0.5 * span_y)  # inverted: east down
    ax.set_aspect(factor, adjustable="box")
    i_max = _index_at(errors.t_s, summary.t_max_e_y_s)
    _mark_poses(ax, samples, tx, ty, i_max, summary)
    ax.set_xlabel("x north (m)")
    if factor > 1.0:
        ax.set_ylabel(f"y east (m), down\nexaggerated ×{factor:g}")
        title = (
            f"{title}\nlateral axis (y east) exaggerated ×{factor:g}: at equal scale the track is one line"
        )
    else:
        ax.set_ylabel("y east (m), down")
        if i_max is not None and summary.max_abs_e_y_m < INSET_BELOW * span_x:
            _zoom_inset(ax, samples, tx, ty, i_max, summary.max_abs_e_y_m)
    ax.set_title(title, fontsize=10)
    ax.grid(True, alpha=0.4)
    # Below the x label (0.5 in under the axes), anchored to the axes: an axes of fixed aspect does not
    # reach the figure's bottom edge, where a figure legend would sit.
    below = 0.5 / (axes_w_in * box_ratio)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -below), ncols=3, fontsize=8, frameon=False)
    return fig


def _index_at(t_s: FloatArray, t: float) -> int | None:
    return int(np.argmin(np.abs(t_s - t))) if t_s.size and math.isfinite(t) else None


def _mark_poses(
    ax: Axes,
    samples: Sequence[Sequence[float]],
    tx: FloatArray,
    ty: FloatArray,
    i_max: int | None,
    summary: ErrorSummary,
) -> None:
    """Start and goal (triangles along their yaw) and the largest cross-track error (a ring)."""
    for pose, name, colour in ((samples[0], "start", "tab:green"), (samples[-1], "goal", "black")):
        yaw = float(pose[2]) if len(pose) > 2 else 0.0
        ax.plot(
            [pose[0]], [pose[1]], linestyle="none", marker=_heading_marker(yaw), markersize=13, color=colour,
            markeredgecolor="black", label=f"{name} ({pose[0]:g}, {pose[1]:g}) m, {yaw % 360.0:g}°", zorder=5,
        )  # fmt: skip
    if i_max is not None:
        ax.plot(
            [tx[i_max]], [ty[i_max]], linestyle="none", marker="o", markersize=10, markerfacecolor="none",
            markeredgecolor="tab:orange", markeredgewidth=2, zorder=6,
            label=f"max cross-track {summary.max_abs_e_y_m:.3f} m (t = {summary.t_max_e_y_s:.1f} s)",
        )  # fmt: skip


def _zoom_inset(
    ax: Axes, samples: Sequence[Sequence[float]], tx: FloatArray, ty: FloatArray, i_max: int, dev_m: float
) -> None:
    """An equal-scale inset around the largest deviation, in the axes corner with the fewest data points."""
    from matplotlib.patches import Rectangle

    half = max(6.0 * dev_m, 0.5)
    cx, cy = float(tx[i_max]), float(ty[i_max])
    size = 0.34
    to_axes = ax.transData + ax.transAxes.inverted()
    ax.figure.canvas.draw()  # the layout, so the data-to-axes transform is the final one
    pts = to_axes.transform(
        np.column_stack([np.r_[tx, [p[0] for p in samples]], np.r_[ty, [p[1] for p in samples]]])
    )
    corners = [(0.08, 0.56), (0.6, 0.56), (0.08, 0.1), (0.6, 0.1)]

    def crowd(c: tuple[float, float]) -> int:
        inside = (pts[:, 0] > c[0] - 0.02) & (pts[:, 0] < c[0] + size + 0.02)
        inside &= (pts[:, 1] > c[1] - 0.02) & (pts[:, 1] < c[1] + size + 0.02)
        return int(inside.sum())

    corner = min(corners, key=crowd)
    inset = ax.inset_axes((corner[0], corner[1], size, size))
    inset.plot([p[0] for p in samples], [p[1] for p in samples], **PLANNED_STYLE)
    inset.plot(tx, ty, **VEHICLE_STYLE)
    inset.plot([cx], [cy], linestyle="none", marker="o", markersize=10, markerfacecolor="none",
               markeredgecolor="tab:orange", markeredgewidth=2)  # fmt: skip
    inset.set_xlim(cx - half, cx + half)
    inset.set_ylim(cy + half, cy - half)
    inset.set_aspect(1.0, adjustable="box")
    inset.set_title(f"zoom at equal scale ({2 * half:.1f} m wide)", fontsize=7)
    inset.tick_params(labelsize=7)
    inset.grid(True, alpha=0.4)
    for spine in inset.spines.values():
        spine.set_edgecolor("tab:orange")
    # The zoomed region framed in the same colour (no connector lines: they would cross the data).
    ax.add_patch(
        Rectangle((cx - half, cy - half), 2 * half, 2 * half, fill=False, edgecolor="tab:orange", zorder=4)
    )


def error_figure(
    samples: Sequence[Sequence[float]], errors: PathFrameErrors, paper: Sequence[PaperValue], title: str
) -> Figure:
    """e_x (above) and e_y (below) against time up to the goal (paper Figs. 8, 10), path frame.

    e_y carries the paper's reported values (:class:`PaperValue`): a value at the goal as a short +-band
    ending at the goal's time, a peak as a +-band over the whole run; e_x's title states the reference's
    lead with its numbers; grey spans are the times the vehicle is on a turn of ``samples`` (the planned
    polyline ``[[x_m, y_m, yaw_deg], ...]``). The legend sits below the axes.
    """
    summary = summarize(errors)
    t = errors.t_s
    t_end = float(t[-1]) if t.size else 0.0
    t_goal = summary.t_goal_s
    fig = new_figure(9.0, 6.8)
    ax_x, ax_y = fig.subplots(2, 1, sharex=True)
    fig.suptitle(title, fontsize=11)

    ax_x.plot(t, errors.e_x_m, color="tab:blue", linewidth=1.6)
    ax_x.set_ylabel("e_x along-track (m)")
    ax_x.set_title(lag_caption(summary), fontsize=9)

    ax_y.plot(t, errors.e_y_m, color="tab:blue", linewidth=1.6, label="ours: e_y cross-track")
    ax_y.set_ylabel("e_y cross-track (m)")
    ax_y.set_xlabel("time (s)")
    at_goal = "goal not reached" if t_goal is None else f"{summary.e_y_goal_m:+.3f} m at the goal"
    ax_y.set_title(
        f"e_y cross-track to the planned path: max |e_y| {summary.max_abs_e_y_m:.3f} m "
        f"at t = {summary.t_max_e_y_s:.1f} s, {at_goal}",
        fontsize=9,
    )
    for k, (t0, t1) in enumerate(turn_spans(samples, errors)):
        for ax in (ax_x, ax_y):
            ax.axvspan(
                t0, t1, color="0.85", zorder=0, label="vehicle on a turn of the path" if k == 0 else None
            )
    top = _mark_paper(ax_y, paper, t_goal if t_goal is not None else t_end, t_end)
    if t_goal is not None:
        ax_y.plot(
            [t_goal], [summary.e_y_goal_m], linestyle="none", marker="o", color="black", markersize=6,
            label=f"ours at the goal: {summary.e_y_goal_m:+.3f} m", zorder=5,
        )  # fmt: skip
    peak = summary.max_abs_e_y_m if math.isfinite(summary.max_abs_e_y_m) else 0.0
    lim = 1.25 * max(top, peak, 0.01)
    ax_y.set_ylim(-lim, lim)
    for ax in (ax_x, ax_y):
        ax.axhline(0.0, color="grey", linewidth=0.8)
        ax.grid(True, alpha=0.4)
        if t_goal is not None:
            ax.axvline(t_goal, color="black", linestyle=":", linewidth=1.0)
    if t_goal is not None:
        ax_y.plot(
            [],
            [],
            color="black",
            linestyle=":",
            linewidth=1.0,
            label=f"goal line crossed, t = {t_goal:.1f} s",
        )
    ax_x.set_xlim(0.0, max(t_end, 1e-3) * 1.01)
    handles, labels = ax_y.get_legend_handles_labels()
    note = "the paper's values are its world-axis errors against a reference at uniform speed"
    fig.legend(
        handles, labels, loc="outside lower center", ncols=3, fontsize=8, frameon=False,
        title=note if paper else None, title_fontsize=8,
    )  # fmt: skip
    return fig


def turn_spans(
    samples: Sequence[Sequence[float]], errors: PathFrameErrors, min_turn_deg: float = 10.0
) -> list[tuple[float, float]]:
    """The times (s) the vehicle's arc length ``errors.s_m`` lies on a turn of the planned polyline: runs of
    samples whose yaw (deg) changes, each turning more than ``min_turn_deg`` in all."""
    if len(samples) < 2 or any(len(p) < 3 for p in samples):
        return []
    p = np.asarray([(q[0], q[1], q[2]) for q in samples], dtype=float)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(p[:, 0]), np.diff(p[:, 1])))])
    dyaw = np.abs((np.diff(p[:, 2]) + 180.0) % 360.0 - 180.0)
    turning = dyaw > 1e-6
    spans = []
    k = 0
    while k < turning.size:
        if not turning[k]:
            k += 1
            continue
        j = k
        while j + 1 < turning.size and turning[j + 1]:
            j += 1
        if dyaw[k : j + 1].sum() > min_turn_deg:
            on = (errors.s_m >= s[k]) & (errors.s_m <= s[j + 1])
            if on.any():
                spans.append((float(errors.t_s[on][0]), float(errors.t_s[on][-1])))
        k = j + 1
    return spans


def _mark_paper(ax: Axes, paper: Sequence[PaperValue], t_goal: float, t_end: float) -> float:
    """Draw the paper's values on ``ax`` as +-bands (see :func:`error_figure`); returns the largest (m)."""
    top = 0.0
    width = max(0.12 * t_end, 1.0)
    for v in paper:
        style = PAPER_STYLE[v.source]
        label = f"paper {SOURCE_NAME[v.source]}: {v.text}"
        for sign in (1.0, -1.0):
            text = label if sign > 0 else "_nolegend_"
            if v.at_goal:
                ax.hlines(sign * v.value_m, t_goal - width, t_goal, **style, label=text)
            else:
                ax.axhline(sign * v.value_m, **style, label=text)
        top = max(top, v.value_m)
    return top
