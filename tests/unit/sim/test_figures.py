"""The demo's figures (hil_sim.figures): path-frame errors on synthetic tracks with known answers, and the
figures read back as matplotlib objects (labels, legend placement, tick labels), not as pixels."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure

from hil_sim import figures
from hil_sim.figures import PaperValue, path_frame_errors, project_on_path
from hil_sim.metrics import compute_metrics

STEP_M = 0.05


def straight(x0: float = -13.0, x1: float = 15.0, yaw_deg: float = 0.0) -> list[list[float]]:
    """A straight polyline of ``STEP_M`` samples from x0 to x1 (m) along ``yaw_deg`` from (x0, 0)."""
    n = round((x1 - x0) / STEP_M)
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    return [[x0 + k * STEP_M * c, k * STEP_M * s, yaw_deg] for k in range(n + 1)]


def ell() -> list[list[float]]:
    """North 10 m from (0, 0), then east 10 m (a corner at (10, 0))."""
    north = [[k * STEP_M, 0.0, 0.0] for k in range(201)]
    east = [[10.0, k * STEP_M, 90.0] for k in range(1, 201)]
    return north + east


def quarter_turn(radius_m: float = 5.0) -> list[list[float]]:
    """A right quarter circle about (0, 0): from (0, -radius) heading north to (radius, 0) heading east."""
    n = 400
    out = []
    for k in range(n + 1):
        a = -0.5 * math.pi + 0.5 * math.pi * k / n  # the point's angle about the centre, from +x (north)
        out.append([radius_m * math.cos(a), radius_m * math.sin(a), math.degrees(a) + 90.0])
    return out


# --- path-frame errors ------------------------------------------------------------------------------
@pytest.mark.parametrize("offset_m", [0.03, -0.03, 0.0])
def test_a_track_offset_from_a_straight_path_has_that_cross_track(offset_m: float) -> None:
    # GIVEN a straight path north and a track beside it, offset_m to the east (starboard)
    x = np.linspace(-12.0, 14.0, 53)
    y = np.full_like(x, offset_m)
    # WHEN it is projected on the path
    s_m, cross_m = project_on_path(x, y, straight())
    # THEN the cross-track is the offset (+ = starboard), the arc length the distance from the start
    assert cross_m == pytest.approx(np.full_like(x, offset_m), abs=1e-9)
    assert s_m == pytest.approx(x + 13.0, abs=1e-9)
    # AND e_y = desired - actual = -offset (paper eq. 4; e_y = y_d - y_a for a path along +x)
    e = path_frame_errors(np.arange(x.size) * 0.5, x, y, straight())
    assert e.e_y_m == pytest.approx(np.full_like(x, -offset_m), abs=1e-9)


def test_the_cross_track_sign_follows_the_path_not_the_world_axes() -> None:
    # GIVEN a path heading east (yaw 90 deg): starboard is south (-x)
    path = straight(0.0, 20.0, 90.0)
    # WHEN points lie 0.03 m south and 0.05 m north of it
    s_m, cross_m = project_on_path([-0.03, 0.05], [5.0, 12.0], path)
    # THEN south is + (starboard) and north is -, and the arc length runs along y
    assert cross_m == pytest.approx([0.03, -0.05], abs=1e-9)
    assert s_m == pytest.approx([5.0, 12.0], abs=1e-9)


def test_the_cross_track_on_an_arc_is_the_radial_offset() -> None:
    # GIVEN a right quarter turn of radius 5 m and points 0.1 m outside it (to port of a right turn)
    a = np.linspace(-0.45 * math.pi, -0.05 * math.pi, 9)
    s_m, cross_m = project_on_path(5.1 * np.cos(a), 5.1 * np.sin(a), quarter_turn())
    # THEN the cross-track is -0.1 m (to the chord-sampled polyline: within its sagitta) and s = r * angle
    assert cross_m == pytest.approx(np.full(a.size, -0.1), abs=1e-4)
    assert s_m == pytest.approx(5.0 * (a + 0.5 * math.pi), abs=1e-3)


def test_e_x_is_the_arc_length_between_the_reference_and_the_vehicle() -> None:
    # GIVEN an L-shaped path, both starting at its start; then the vehicle 1 m before the corner and the
    # reference 2 m after it
    t = [0.0, 1.0, 2.0]
    vehicle_x, vehicle_y = [0.0, 5.0, 9.0], [0.0, 0.0, 0.0]
    ref_x, ref_y = [0.0, 8.0, 10.0], [0.0, 0.0, 2.0]
    e = path_frame_errors(t, vehicle_x, vehicle_y, ell(), t, ref_x, ref_y)
    # THEN e_x at the end is 3 m along the path (not the 2.24 m straight line): the reference is ahead
    assert e.e_x_m == pytest.approx([0.0, 3.0, 3.0], abs=1e-9)
    assert e.e_y_m == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)


def test_e_x_is_nan_where_no_reference_was_logged_and_repeated_times_keep_the_last() -> None:
    t = np.arange(5) * 1.0
    x = -13.0 + t
    # The log: a NaN row (IDLE), two rows at t = 1 (the last is the one flown), none after t = 3
    ref_t = [0.0, 1.0, 1.0, 2.0, 3.0]
    ref_x = [math.nan, 0.0, -11.0, -10.0, -9.0]
    e = path_frame_errors(t, x, np.zeros_like(t), straight(), ref_t, ref_x, [0.0] * 5)
    assert math.isnan(e.e_x_m[0]) and math.isnan(e.e_x_m[4])
    assert e.e_x_m[1:4] == pytest.approx([1.0, 1.0, 1.0])


def wavy_track() -> tuple[list[float], list[float], list[float]]:
    """A track along the straight path weaving +-0.03 m, crossing the goal line x = 15 m between rows."""
    t = [0.1 * k for k in range(291)]
    x = [-13.0 + 0.0972 * k for k in range(291)]  # passes x = 15 m between rows 288 and 289
    y = [0.03 * math.sin(0.05 * k) for k in range(291)]
    return t, x, y


def test_the_largest_cross_track_is_the_metrics_one_and_the_track_ends_at_the_arrival() -> None:
    # GIVEN a weaving track past the goal, judged by the metrics
    t, x, y = wavy_track()
    rows = [
        {"t_s": a, "x_m": b, "y_m": c, "depth_m": 1.0, "yaw_deg": 0.0}
        for a, b, c in zip(t, x, y, strict=True)
    ]
    m = compute_metrics(rows, straight(), (15.0, 0.0, 0.0))
    # WHEN the errors are cut at the metrics' arrival
    e = path_frame_errors(t, x, y, straight(), t_goal_s=m["arrival_time_s"])
    summary = figures.summarize(e)
    # THEN the last row is the arrival (on the goal line), and the errors agree with the metrics'
    assert e.t_s[-1] == pytest.approx(m["arrival_time_s"])
    assert e.x_m[-1] == pytest.approx(15.0)
    assert summary.max_abs_e_y_m == pytest.approx(m["max_cross_track_m"], abs=1e-12)
    assert summary.e_y_goal_m == pytest.approx(m["final_y_error_m"], abs=1e-9)  # path along +x: e_y = y error
    assert summary.max_abs_e_y_m == pytest.approx(0.03, abs=1e-4)


def test_the_summary_states_the_reference_lead_with_its_numbers() -> None:
    # GIVEN a reference 1.5 m ahead at t = 0, 4 m ahead at t = 2 s, 0.5 m at t = 4 s
    t = [0.0, 1.0, 2.0, 3.0, 4.0]
    x = [-13.0, -12.5, -12.0, -10.0, -7.0]
    ref_x = [xv + d for xv, d in zip(x, [1.5, 2.5, 4.0, 2.0, 0.5], strict=True)]
    e = path_frame_errors(t, x, [0.0] * 5, straight(), t, ref_x, [0.0] * 5, t_goal_s=None)
    s = figures.summarize(e)
    assert s.max_e_x_m == pytest.approx(4.0) and s.t_max_e_x_s == pytest.approx(2.0)
    assert "up to 4.00 m at t = 2.0 s" in figures.lag_caption(s)


def test_the_paper_values_read_as_the_demo_prints_them() -> None:
    from hil_sim.demo import PAPER

    assert figures.paper_text(PAPER["paper-straight"], "simulation") == "0.13 m at goal"
    assert figures.paper_text(PAPER["paper-straight"], "basin") == "< 0.05 m at goal"
    assert figures.paper_text(PAPER["paper-turn"], "simulation") == "0.2 m at goal, y 0.4 m (max at the turn)"
    assert figures.paper_text(PAPER["paper-turn"], "basin") == "y < 0.1 m at goal"
    assert figures.paper_text((), "basin") == "-"


@pytest.mark.parametrize(
    ("value", "expected"), [(0.3, 1.0), (1.0, 1.0), (4.9, 2.0), (105.0, 100.0), (60.0, 50.0)]
)
def test_nice_floor(value: float, expected: float) -> None:
    assert figures.nice_floor(value) == expected


# --- the figures, read back -------------------------------------------------------------------------
def agg_renderer(fig: Figure) -> Any:
    """The renderer of ``fig``'s own Agg canvas (the figures draw on one, whatever pyplot's backend)."""
    canvas = fig.canvas
    assert isinstance(canvas, FigureCanvasAgg)
    canvas.draw()
    return canvas.get_renderer()


def overlapping_tick_labels(fig: Figure) -> list[str]:
    """Pairs of visible tick labels of one axis whose boxes overlap, over every axes of ``fig``."""
    renderer = agg_renderer(fig)
    bad = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            boxes = [
                (label.get_text(), label.get_window_extent(renderer))
                for label in axis.get_ticklabels()
                if label.get_visible() and label.get_text()
            ]
            for i, (ta, a) in enumerate(boxes):
                bad += [f"{ta} / {tb}" for tb, b in boxes[i + 1 :] if a.overlaps(b)]
    return bad


def assert_legend_outside_the_data(fig: Figure) -> None:
    renderer = agg_renderer(fig)
    legends = [*fig.legends, *(legend for ax in fig.axes if (legend := ax.get_legend()) is not None)]
    assert legends, "no legend"
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            assert not box.overlaps(ax.get_window_extent(renderer)), "the legend covers the data"
            for label in (ax.xaxis.label, *ax.get_xticklabels()):
                if label.get_visible() and label.get_text():
                    assert not box.overlaps(label.get_window_extent(renderer)), (
                        f"legend on {label.get_text()}"
                    )


def assert_png(path: str) -> None:
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_the_straight_path_figure_exaggerates_its_lateral_axis(tmp_path: Path) -> None:
    # GIVEN a track within +-0.03 m of a 28 m straight line (invisible at equal scale)
    t, x, y = wavy_track()
    e = path_frame_errors(t, x, y, straight(), t_goal_s=28.8)
    # WHEN the path figure is drawn
    fig = figures.path_figure(straight(), e, "straight")
    (ax,) = fig.axes
    # THEN the lateral axis is exaggerated by the factor its label and title state
    assert ax.get_xlabel() == "x north (m)"
    assert "exaggerated ×100" in ax.get_ylabel() and "exaggerated ×100" in ax.get_title()
    assert ax.get_aspect() == 100.0
    lo, hi = sorted(ax.get_ylim())
    assert lo <= -0.03 and hi >= 0.03 and hi - lo < 0.2  # the deviation fills the axes, not 1/1000 of it
    assert ax.yaxis_inverted()  # east down: north right, a map turned a quarter turn
    # AND start, goal and the largest cross-track are in the legend, which sits outside the data
    legend = ax.get_legend()
    assert legend is not None
    labels = [text.get_text() for text in legend.get_texts()]
    assert any(label.startswith("start (-13, 0) m") for label in labels)
    assert any(label.startswith("goal (15, 0) m") for label in labels)
    assert any(label.startswith("max cross-track 0.030 m") for label in labels)
    assert_legend_outside_the_data(fig)
    assert overlapping_tick_labels(fig) == []
    assert_png(figures.save_png(fig, tmp_path / "straight-path.png"))


def test_a_turn_is_drawn_at_equal_scale_with_a_zoom_on_the_largest_deviation(tmp_path: Path) -> None:
    # GIVEN a track 0.05 m outside a 5 m quarter turn
    path = quarter_turn()
    a = np.linspace(-0.5 * math.pi, 0.0, 200)
    t = np.linspace(0.0, 10.0, a.size)
    e = path_frame_errors(t, 5.05 * np.cos(a), 5.05 * np.sin(a), path, t_goal_s=10.0)
    fig = figures.path_figure(path, e, "turn")
    ax = fig.axes[0]
    assert ax.get_aspect() == 1.0 and "exaggerated" not in ax.get_ylabel()
    (inset,) = ax.child_axes
    assert isinstance(inset, Axes)
    assert "equal scale" in inset.get_title() and inset.get_aspect() == 1.0
    assert_legend_outside_the_data(fig)
    assert overlapping_tick_labels(fig) == []
    assert_png(figures.save_png(fig, tmp_path / "turn-path.png"))


def test_the_error_figure_has_e_x_above_e_y_with_the_paper_values(tmp_path: Path) -> None:
    # GIVEN a weaving track and a reference 2 m ahead of it until t = 20 s
    t, x, y = wavy_track()
    ref_t = [v for v in t if v <= 20.0]
    ref_x = [xv + 2.0 for xv, tv in zip(x, t, strict=True) if tv <= 20.0]
    e = path_frame_errors(t, x, y, straight(), ref_t, ref_x, [0.0] * len(ref_t), t_goal_s=28.8)
    paper = (PaperValue("simulation", 0.13), PaperValue("basin", 0.05, below=True))
    # WHEN the error figure is drawn
    fig = figures.error_figure(straight(), e, paper, "straight")
    ax_x, ax_y = fig.axes
    # THEN the axes are the path-frame errors against time, each labelled with its unit
    assert ax_x.get_ylabel() == "e_x along-track (m)"
    assert ax_y.get_ylabel() == "e_y cross-track (m)"
    assert ax_y.get_xlabel() == "time (s)"
    # AND e_x's title states the reference's lead; e_y's the largest cross-track and the value at the goal
    assert "reference point is ahead of the vehicle: up to 2.00 m" in ax_x.get_title()
    assert "max |e_y| 0.030 m" in ax_y.get_title()
    # AND the paper's values are marked at +-0.13 and +-0.05 m, named in the legend
    bands = [c for c in ax_y.collections if isinstance(c, LineCollection)]
    levels = sorted({round(float(seg[0][1]), 6) for coll in bands for seg in coll.get_segments()})
    assert levels == [-0.13, -0.05, 0.05, 0.13]
    (legend,) = fig.legends
    labels = [text.get_text() for text in legend.get_texts()]
    assert "paper simulation: 0.13 m at goal" in labels
    assert "paper basin experiment: < 0.05 m at goal" in labels
    # AND the curves are the computed errors (e_y plotted is -y for a path along +x)
    (ey_line,) = [line for line in ax_y.get_lines() if line.get_label() == "ours: e_y cross-track"]
    assert np.asarray(ey_line.get_ydata()) == pytest.approx(-e.y_m, abs=1e-9)
    assert_legend_outside_the_data(fig)
    assert overlapping_tick_labels(fig) == []
    assert_png(figures.save_png(fig, tmp_path / "straight-error.png"))


def test_the_error_figure_shades_the_turn() -> None:
    path = quarter_turn()
    a = np.linspace(-0.5 * math.pi, 0.0, 200)
    t = np.linspace(0.0, 10.0, a.size)
    e = path_frame_errors(t, 5.1 * np.cos(a), 5.1 * np.sin(a), path, t_goal_s=10.0)
    spans = figures.turn_spans(path, e)
    assert spans == [pytest.approx((0.0, 10.0), abs=0.1)]


def test_a_reference_beyond_the_end_runs_on_along_the_extension() -> None:
    # GIVEN the paper's reference, 3 m ahead and running on past the goal (x = 15 m) at the final heading
    t = np.arange(28.0)
    x = -13.0 + t
    e = path_frame_errors(t, x, np.zeros_like(t), straight(), t, x + 3.0, np.zeros_like(t))
    # THEN e_x stays 3 m beyond the end too (clamped to the end it would fall to 1 m at x = 14 m)
    assert e.e_x_m == pytest.approx(np.full_like(t, 3.0), abs=1e-9)
