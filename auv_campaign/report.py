"""The products of a campaign: ``runs.csv``, ``summary.json`` and a self-contained ``report.html``.

A finished run is one JSON file ``OUT/runs/RUN_ID.json``::

    {"run_id": ..., "spec": {...RunSpec as a dict...}, "row": {...one value per results.COLUMNS...},
     "track": {"t_s": [...], "x_m": [...], "y_m": [...], "depth_m": [...]},   # truth, NED, decimated
     "path": [[x_m, y_m], ...]}                                   # nominal path ([] if not planned)

:func:`load_runs` reads them back, :func:`write_csv` writes one CSV row a run, :func:`summarize` counts and
ranks them (success per sweep axis value, error statistics, the ten worst runs by
:func:`auv_campaign.results.severity`, uncapped), :func:`write_report` draws the HTML page and
:func:`write_all` does all three. Everything written is JSON-safe (no NaN) and every string from the data
is HTML-escaped in the page. Matplotlib is imported lazily, with the Agg backend, only by the functions
that draw.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import json
import logging
import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from auv_campaign.results import COLUMNS, severity
from auv_campaign.spec import current_label, seed_label

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

_log = logging.getLogger(__name__)

#: The metrics of ``summary["metrics"]`` (each: median, p90, max over the runs where it is defined).
METRIC_COLUMNS = (
    "final_position_error_m",
    "final_course_error_deg",
    "final_heading_error_deg",
    "max_cross_track_m",
    "rms_cross_track_m",
    "min_clearance_m",
    "time_to_goal_s",
    "glide_after_end_m",
    "max_depth_after_end_m",
)
#: How many of the costliest runs the summary and the report show.
WORST_COUNT = 10
#: Figures: resolution (dots per inch), most track points drawn, least span of a track plot (m).
DPI = 80
MAX_TRACK_POINTS = 2000
MIN_TRACK_SPAN_M = 2.0
#: The histograms of the report: (row column, title, axis label).
HISTOGRAMS = (
    ("final_position_error_m", "Final position error", "error (m)"),
    ("final_course_error_deg", "Final course error", "error (deg)"),
    ("max_cross_track_m", "Max cross-track", "cross-track (m)"),
)
#: A histogram uses a log x axis when its positive values span more than this ratio.
_LOG_SPAN_RATIO = 50.0
_NONE_TEXT = "—"

Run = dict[str, Any]
Row = dict[str, Any]


# --------------------------------------------------------------------------------------------- reading


def load_runs(out_dir: Path) -> list[Run]:
    """Every ``out_dir/runs/*.json`` as a dict, sorted by run id.

    A file that cannot be read, is not JSON, or is not an object with a ``row`` object is skipped; the
    number skipped (and which) is logged as a warning. A missing ``runs`` folder gives ``[]``.
    """
    runs: list[Run] = []
    skipped: list[str] = []
    for path in sorted((Path(out_dir) / "runs").glob("*.json")):
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError):
            skipped.append(path.name)
            continue
        if not isinstance(data, dict) or not isinstance(data.get("row"), dict):
            skipped.append(path.name)
            continue
        data["run_id"] = str(data.get("run_id") or data["row"].get("run_id") or path.stem)
        runs.append(data)
    if skipped:
        _log.warning("skipped %d unreadable run file(s): %s", len(skipped), ", ".join(skipped))
    runs.sort(key=lambda run: str(run["run_id"]))
    return runs


# --------------------------------------------------------------------------------------------- runs.csv


def _csv_cell(value: Any) -> str:
    """One CSV cell: ``None`` (and a NaN) -> empty, a bool -> ``true``/``false``, a float -> 6 significant
    digits, anything else -> ``str``."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def write_csv(rows: list[Row], path: Path) -> None:
    """Write ``runs.csv``: the header is :data:`auv_campaign.results.COLUMNS`, then one line a run (a
    column missing from a row is an empty cell; a key not in the columns is not written)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", encoding="utf-8", newline="") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(COLUMNS)
        for row in rows:
            writer.writerow([_csv_cell(row.get(column)) for column in COLUMNS])


# --------------------------------------------------------------------------------------------- summary


def _number(value: Any) -> float | None:
    """``value`` as a finite float, or ``None`` (None, bool, not a number, NaN or infinite)."""
    if value is None or isinstance(value, bool):
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def _values(rows: Iterable[Row], column: str) -> list[float]:
    """The finite numbers of ``column`` over ``rows`` (undefined values left out)."""
    return [v for v in (_number(row.get(column)) for row in rows) if v is not None]


def _median(values: Sequence[float]) -> float | None:
    import numpy as np

    return float(np.median(values)) if values else None


def _stats(values: Sequence[float]) -> dict[str, float | None]:
    """``{"median", "p90", "max"}`` of ``values`` (linear-interpolated 90th percentile); all ``None`` if
    there are none."""
    import numpy as np

    if not values:
        return {"median": None, "p90": None, "max": None}
    return {
        "median": float(np.median(values)),
        "p90": float(np.percentile(values, 90.0)),
        "max": float(max(values)),
    }


def axis_label(row: Row, axis: str) -> str:
    """The label of ``row`` on a sweep axis, as the spec names it (:func:`auv_campaign.spec.seed_label`,
    :func:`~auv_campaign.spec.current_label`; ``mission``, ``profile``, ``onboard``, ``vehicle`` as they are);
    any other axis: ``str(row[axis])``."""
    if axis == "current":
        speed = _number(row.get("current_speed_mps")) or 0.0
        direction = _number(row.get("current_dir_deg")) or 0.0
        return current_label(speed, direction)
    if axis == "seed" and isinstance(row.get("seed"), int):
        return seed_label(row["seed"])
    return str(row.get(axis))


def _rate(count: int, total: int) -> float:
    return count / total if total else 0.0


def _count(rows: Iterable[Row], column: str) -> int:
    return sum(1 for row in rows if row.get(column))


def _json_safe(value: Any) -> Any:
    """``value`` with every non-finite float replaced by ``None`` and numpy scalars made plain."""
    if isinstance(value, dict):
        return {str(k): _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    if value is None or isinstance(value, bool | str | int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "item"):  # a numpy scalar
        return _json_safe(value.item())
    return str(value)


def summarize(
    rows: list[Row],
    axes: dict[str, list[str]],
    name: str,
    rerun_command: Callable[[str], str] | None = None,
) -> dict[str, Any]:
    """The content of ``summary.json``.

    ``axes`` maps each sweep axis to the ordered labels of its values (see :func:`axis_label`); a label seen
    in the rows but not listed is appended (sorted) so that no run goes uncounted. ``rerun_command`` gives
    the shell command that re-flies one run (its ``rerun`` entry in ``worst``; ``None`` without it).

    Keys: ``name``, counts ``runs``, ``errors`` (rows with a non-empty error), ``planned``, ``completed``
    (the vehicle said COMPLETE), ``arrived`` (the truth crossed the last goal's line), ``success``,
    ``false_complete``, ``time_limit_reached``, ``penetrated`` (runs inside an obstacle at some time),
    ``success_rate`` (0 if no runs); ``per_axis`` {axis: {label: {runs,
    success, success_rate, false_complete, median_final_position_error_m, median_max_cross_track_m}}};
    ``metrics`` {column: {median, p90, max}} over the defined values (None if none); ``worst``: the
    :data:`WORST_COUNT` runs of highest :func:`auv_campaign.results.severity` (uncapped: a 55 m miss ranks
    above a 14 m one; ties by run id), each {run_id, cost (the severity), success, final_state,
    final_reason, final_position_error_m, rerun}. JSON-safe.
    """
    n = len(rows)
    success = _count(rows, "success")
    per_axis: dict[str, dict[str, dict[str, Any]]] = {}
    for axis, labels in axes.items():
        groups: dict[str, list[Row]] = {str(label): [] for label in labels}
        extra: dict[str, list[Row]] = {}
        for row in rows:
            label = axis_label(row, axis)
            (groups if label in groups else extra).setdefault(label, []).append(row)
        groups.update(sorted(extra.items()))
        per_axis[axis] = {
            label: {
                "runs": len(group),
                "success": _count(group, "success"),
                "success_rate": _rate(_count(group, "success"), len(group)),
                "false_complete": _count(group, "false_complete"),
                "median_final_position_error_m": _median(_values(group, "final_position_error_m")),
                "median_max_cross_track_m": _median(_values(group, "max_cross_track_m")),
            }
            for label, group in groups.items()
        }
    ranked = sorted(rows, key=lambda row: (-severity(row), str(row.get("run_id"))))
    worst = [
        {
            "run_id": str(row.get("run_id")),
            "cost": severity(row),
            "success": bool(row.get("success")),
            "final_state": row.get("final_state"),
            "final_reason": row.get("final_reason"),
            "final_position_error_m": _number(row.get("final_position_error_m")),
            "rerun": rerun_command(str(row.get("run_id"))) if rerun_command is not None else None,
        }
        for row in ranked[:WORST_COUNT]
    ]
    summary = {
        "name": name,
        "runs": n,
        "errors": _count(rows, "error"),
        "planned": _count(rows, "planned"),
        "completed": _count(rows, "completed"),
        "arrived": _count(rows, "arrived"),
        "success": success,
        "false_complete": _count(rows, "false_complete"),
        "time_limit_reached": _count(rows, "time_limit_reached"),
        "penetrated": sum(
            1 for row in rows if (c := _number(row.get("min_clearance_m"))) is not None and c < 0.0
        ),
        "success_rate": _rate(success, n),
        "per_axis": per_axis,
        "metrics": {column: _stats(_values(rows, column)) for column in METRIC_COLUMNS},
        "worst": worst,
    }
    result: dict[str, Any] = _json_safe(summary)
    return result


# --------------------------------------------------------------------------------------------- figures


def new_figure(width_in: float, height_in: float) -> Figure:
    """A figure not owned by pyplot (no global state), drawn with the Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), dpi=DPI, layout="constrained")


def png_img(fig: Figure, alt: str) -> str:
    """``fig`` as an ``<img>`` tag with an inline base64 PNG."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    data = base64.b64encode(buf.getvalue()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def _no_data(ax: Axes, text: str = "no data") -> None:
    ax.text(0.5, 0.5, text, ha="center", va="center", transform=ax.transAxes, color="grey")
    ax.set_xticks([])
    ax.set_yticks([])


def _histogram_img(values: Sequence[float], title: str, xlabel: str) -> str:
    """A histogram of ``values``; a log x axis when the (non-negative) values span more than
    :data:`_LOG_SPAN_RATIO` (zeros drawn at half the least positive value); "no data" when empty."""
    import numpy as np

    fig = new_figure(4.2, 2.8)
    ax = fig.add_subplot()
    ax.set_title(f"{title} (n={len(values)})", fontsize=10)
    if not values:
        _no_data(ax)
        return png_img(fig, title)
    data = np.asarray(values, dtype=float)
    positive = data[data > 0.0]
    if data.min() >= 0.0 and positive.size and positive.max() / positive.min() > _LOG_SPAN_RATIO:
        floor = float(positive.min()) / 2.0
        data = np.maximum(data, floor)
        ax.hist(data, bins=np.geomspace(floor, float(data.max()), 25).tolist(), color="tab:blue", alpha=0.8)
        ax.set_xscale("log")
    else:
        ax.hist(data, bins=20, color="tab:blue", alpha=0.8)
    ax.axvline(float(np.median(data)), color="black", linestyle="--", linewidth=1.0, label="median")
    ax.legend(fontsize=8)
    ax.set_xlabel(xlabel, fontsize=9)
    ax.set_ylabel("runs", fontsize=9)
    ax.tick_params(labelsize=8)
    return png_img(fig, title)


def _bar_img(axis: str, stats: dict[str, dict[str, Any]]) -> str:
    """Success rate (%) per value of one sweep axis, each bar annotated ``success/runs``."""
    labels = list(stats)
    rates = [100.0 * float(stats[label]["success_rate"] or 0.0) for label in labels]
    fig = new_figure(min(12.0, max(4.2, 0.45 * len(labels) + 1.5)), 2.8)
    ax = fig.add_subplot()
    positions = list(range(len(labels)))
    ax.bar(positions, rates, color="tab:green", alpha=0.8)
    for x, label, rate in zip(positions, labels, rates, strict=True):
        text = f"{stats[label]['success']}/{stats[label]['runs']}"
        ax.text(x, min(rate, 100.0) + 2.0, text, ha="center", va="bottom", fontsize=7)
    ax.set_xticks(positions, labels, rotation=45 if len(labels) > 6 else 0, fontsize=8)
    ax.set_ylim(0.0, 115.0)
    ax.set_ylabel("success (%)", fontsize=9)
    ax.set_title(f"Success rate per {axis}", fontsize=10)
    ax.tick_params(axis="y", labelsize=8)
    return png_img(fig, f"success rate per {axis}")


def _floats(values: Any) -> list[float]:
    """A list from JSON as floats (``None`` and non-numbers -> NaN, which matplotlib leaves as a gap)."""
    if not isinstance(values, list):
        return []
    out = []
    for v in values:
        number = _number(v)
        out.append(math.nan if number is None else number)
    return out


def _dict(value: Any) -> dict[str, Any]:
    """``value`` if it is a dict (from JSON), else an empty one."""
    return value if isinstance(value, dict) else {}


def decimate(values: Sequence[float], max_points: int = MAX_TRACK_POINTS) -> list[float]:
    """Every k-th value so that at most ``max_points`` remain, the last one always kept."""
    if len(values) <= max_points:
        return list(values)
    step = math.ceil((len(values) - 1) / (max_points - 1))
    kept = list(values[::step])
    if (len(values) - 1) % step:
        kept[-1] = values[-1]
    return kept


def plot_limits(
    east_m: Sequence[float], north_m: Sequence[float], min_span_m: float = MIN_TRACK_SPAN_M
) -> tuple[tuple[float, float], tuple[float, float]]:
    """Square limits ``((east_lo, east_hi), (north_lo, north_hi))`` (m) around the finite points, with a 5 %
    margin and at least ``min_span_m`` wide so that a straight track does not collapse to a line."""
    points = [(e, n) for e, n in zip(east_m, north_m, strict=True) if math.isfinite(e) and math.isfinite(n)]
    if not points:
        half = min_span_m / 2.0
        return (-half, half), (-half, half)
    es = [p[0] for p in points]
    ns = [p[1] for p in points]
    span = max(max(es) - min(es), max(ns) - min(ns)) * 1.1
    half = max(span, min_span_m) / 2.0
    ce = (max(es) + min(es)) / 2.0
    cn = (max(ns) + min(ns)) / 2.0
    return (ce - half, ce + half), (cn - half, cn + half)


def _track_img(run: Run | None, run_id: str) -> str:
    """:func:`track_figure` as an inline image."""
    return png_img(track_figure(run, run_id), f"track of {run_id}")


def save_track_png(run: Run, path: Path, dpi: int = 110) -> Path:
    """:func:`track_figure` of one run as a PNG file (``auv-hil campaign --only RUN_ID --plot``)."""
    fig = track_figure(run, run["run_id"], size_in=6.0)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    return path


def paper_errors(
    truth: Sequence[Sequence[Any]], reference: Sequence[tuple[float, float, float, float]]
) -> tuple[list[float], list[float], list[float]]:
    """The paper's errors (eq. 4 in the path frame: Figs. 8, 10) of one run: (t_s, e_x, e_y), e = the
    onboard's reference point - the simulator's truth at the same time, resolved along (x) and across (y,
    + = the reference to starboard of the vehicle) the reference's heading. ``truth``: rows of
    ``TRUTH_COLUMNS`` (t_s, x_m, y_m first), in time order; ``reference``: (t_s, x_m, y_m, yaw_rad) per
    tick."""
    import bisect

    times = [float(r[0]) for r in truth]
    t_s: list[float] = []
    e_x: list[float] = []
    e_y: list[float] = []
    for t, xr, yr, yaw in reference if times else ():
        row = truth[min(bisect.bisect_left(times, t), len(times) - 1)]
        dx, dy = xr - float(row[1]), yr - float(row[2])
        t_s.append(t)
        e_x.append(dx * math.cos(yaw) + dy * math.sin(yaw))
        e_y.append(-dx * math.sin(yaw) + dy * math.cos(yaw))
    return t_s, e_x, e_y


def save_errors_png(
    truth: Sequence[Sequence[Any]],
    reference: Sequence[tuple[float, float, float, float]],
    path: Path,
    title: str,
    dpi: int = 110,
) -> Path:
    """:func:`paper_errors` against time as a PNG, e_x above e_y, each with its peak and last value
    (``auv-hil campaign --only RUN_ID --plot``)."""
    t_s, e_x, e_y = paper_errors(truth, reference)
    fig = new_figure(6.0, 4.0)
    axes = fig.subplots(2, 1, sharex=True)
    fig.suptitle(f"{title}: reference - truth, path frame", fontsize=9)
    for ax, values, name in ((axes[0], e_x, "e_x along (m)"), (axes[1], e_y, "e_y across (m)")):
        if not values:
            _no_data(ax)
            continue
        t0 = t_s[0]
        ax.plot([t - t0 for t in t_s], values, color="tab:blue", linewidth=1.0)
        ax.axhline(0.0, color="grey", linewidth=0.6)
        ax.set_ylabel(name, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        peak = max(range(len(values)), key=lambda i: abs(values[i]))
        ax.annotate(
            f"peak {values[peak]:.2f} m at {t_s[peak] - t0:.1f} s, last {values[-1]:.2f} m",
            xy=(0.99, 0.95), xycoords="axes fraction", ha="right", va="top", fontsize=7,
        )  # fmt: skip
    axes[1].set_xlabel("time since the path began (s)", fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi, bbox_inches="tight")
    return path


def track_figure(run: Run | None, run_id: str, size_in: float = 3.4) -> Figure:
    """One run seen from above, NED: north (x) up, east (y) right. The truth track (blue) over the nominal
    path (red dashed), obstacles (grey circles), start (green triangle) and goals (black x, an arrow for the
    goal yaw), equal aspect with a span of at least :data:`MIN_TRACK_SPAN_M`."""
    from matplotlib.patches import Circle

    fig = new_figure(size_in, size_in)
    ax = fig.add_subplot()
    ax.set_title(run_id, fontsize=7)
    if run is None:
        _no_data(ax, "run file not loaded")
        return fig
    track = _dict(run.get("track"))
    tx, ty = _floats(track.get("x_m")), _floats(track.get("y_m"))
    tx, ty = decimate(tx[: len(ty)]), decimate(ty[: len(tx)])
    path = [p for p in run.get("path") or [] if isinstance(p, list | tuple) and len(p) >= 2]
    px, py = _floats([p[0] for p in path]), _floats([p[1] for p in path])
    mission = _dict(_dict(run.get("spec")).get("mission"))
    start = _floats(mission.get("start"))
    goals = [g for g in mission.get("goals") or [] if isinstance(g, list) and len(g) >= 2]
    obstacles = [o for o in mission.get("obstacles") or [] if isinstance(o, list) and len(o) >= 3]

    east: list[float] = [*ty, *py]
    north: list[float] = [*tx, *px]
    if len(start) >= 2:
        east.append(start[1])
        north.append(start[0])
    for goal in goals:
        g = _floats(goal)
        east.append(g[1])
        north.append(g[0])
    for obstacle in obstacles:
        ox, oy, r = _floats(obstacle)[:3]
        if math.isfinite(r):
            east += [oy - r, oy + r]
            north += [ox - r, ox + r]
    (e_lo, e_hi), (n_lo, n_hi) = plot_limits(east, north)
    arrow = 0.12 * (e_hi - e_lo)

    for obstacle in obstacles:
        ox, oy, r = _floats(obstacle)[:3]
        if math.isfinite(ox) and math.isfinite(oy) and math.isfinite(r):
            ax.add_patch(Circle((oy, ox), r, facecolor="lightgrey", edgecolor="grey", zorder=1))
    if px:
        ax.plot(py, px, color="red", linestyle="--", linewidth=1.0, label="path", zorder=2)
    if tx:
        ax.plot(ty, tx, color="blue", linewidth=1.2, label="track", zorder=3)
    if len(start) >= 2:
        ax.plot([start[1]], [start[0]], marker="^", color="green", markersize=8, linestyle="", zorder=4)
    for goal in goals:
        g = _floats(goal)
        ax.plot([g[1]], [g[0]], marker="x", color="black", markersize=7, linestyle="", zorder=4)
        if len(g) >= 4 and math.isfinite(g[3]):
            yaw = math.radians(g[3])  # NED yaw: from north, clockwise -> east = sin, north = cos
            ax.annotate(
                "",
                xy=(g[1] + arrow * math.sin(yaw), g[0] + arrow * math.cos(yaw)),
                xytext=(g[1], g[0]),
                arrowprops={"arrowstyle": "->", "color": "black", "lw": 1.0},
                zorder=4,
            )
    ax.set_xlim(e_lo, e_hi)
    ax.set_ylim(n_lo, n_hi)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("east y (m)", fontsize=8)
    ax.set_ylabel("north x (m)", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(True, linewidth=0.3)
    if px or tx:
        ax.legend(fontsize=6, loc="best")
    return fig


# --------------------------------------------------------------------------------------------- report.html


def html_text(value: Any) -> str:
    """``value`` as escaped HTML text; ``None`` (and NaN) as a dash."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return _NONE_TEXT
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.3g}"
    return html.escape(str(value))


def _pct(rate: Any, runs: int = 1) -> str:
    number = _number(rate)
    if number is None or not runs:
        return _NONE_TEXT
    return f"{100.0 * number:.1f} %"


def html_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """An HTML table; the cells are already escaped."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in row) + "</tr>\n" for row in rows)
    return f"<table>\n<tr>{head}</tr>\n{body}</table>\n"


CSS = """
body { font-family: sans-serif; margin: 1.5em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 2px 8px; text-align: right; }
th { background: #eee; }
td:first-child { text-align: left; }
.figs img { margin: 4px; vertical-align: top; }
.run { border-top: 1px solid #ccc; padding: 0.5em 0; display: flex; gap: 1em; align-items: flex-start; }
pre { background: #f4f4f4; padding: 4px 8px; white-space: pre-wrap; word-break: break-all; }
"""


def write_report(
    out_dir: Path, runs: list[Run], summary: dict[str, Any], rerun_command: Callable[[str], str]
) -> Path:
    """Write ``out_dir/report.html`` (self-contained: inline PNG figures, no script, no external asset) and
    return its path.

    It shows the counts, a table of success per sweep axis value (every axis), bar charts of the success
    rate per axis with more than one value, the error statistics, histograms of the final position error,
    final course error and max cross-track, and the :data:`WORST_COUNT` worst runs of ``summary``, each
    with its track figure, its numbers and the command that re-flies it.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    by_id = {str(run.get("run_id")): run for run in runs}
    rows = [run["row"] for run in runs if isinstance(run.get("row"), dict)]
    name = str(summary.get("name", ""))
    parts: list[str] = [
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n',
        f"<title>Campaign {html.escape(name)}</title>\n<style>{CSS}</style>\n</head>\n<body>\n",
        f"<h1>Campaign {html.escape(name)}</h1>\n",
    ]

    n = int(summary.get("runs", 0))
    counts = [
        ("runs", html_text(n)),
        ("errors (exceptions)", html_text(summary.get("errors"))),
        ("planned", html_text(summary.get("planned"))),
        ("completed (the vehicle said COMPLETE)", html_text(summary.get("completed"))),
        ("arrived (the truth crossed the last goal's line)", html_text(summary.get("arrived"))),
        ("success", html_text(summary.get("success"))),
        ("false complete", html_text(summary.get("false_complete"))),
        ("time limit reached (still under way)", html_text(summary.get("time_limit_reached"))),
        ("inside an obstacle at some time", html_text(summary.get("penetrated"))),
        ("success rate", _pct(summary.get("success_rate"), n)),
    ]
    parts += ["<h2>Counts</h2>\n", html_table(("", "count"), counts)]

    per_axis: dict[str, dict[str, dict[str, Any]]] = summary.get("per_axis") or {}
    axis_rows = [
        (
            html.escape(axis),
            html.escape(label),
            html_text(s.get("runs")),
            html_text(s.get("success")),
            _pct(s.get("success_rate"), int(s.get("runs") or 0)),
            html_text(s.get("false_complete")),
            html_text(s.get("median_final_position_error_m")),
            html_text(s.get("median_max_cross_track_m")),
        )
        for axis, labels in per_axis.items()
        for label, s in labels.items()
    ]
    header = (
        "axis",
        "value",
        "runs",
        "success",
        "success rate",
        "false complete",
        "median final pos. error (m)",
        "median max cross-track (m)",
    )
    parts += ["<h2>Success per sweep value</h2>\n", html_table(header, axis_rows)]
    legend_rows = [
        (html.escape(axis), html.escape(label), html.escape(text))
        for axis, labels in (summary.get("legend") or {}).items()
        for label, text in labels.items()
        if len(labels) > 1 or text not in ("packaged onboard.toml", "packaged isimi100.toml")
    ]
    if legend_rows:
        legend_table = html_table(("axis", "label", "meaning"), legend_rows)
        parts += ["<h3>What the labels stand for</h3>\n", legend_table]
    bars = [_bar_img(axis, labels) for axis, labels in per_axis.items() if len(labels) > 1]
    if bars:
        parts += ['<div class="figs">\n', "\n".join(bars), "\n</div>\n"]

    metrics: dict[str, dict[str, Any]] = summary.get("metrics") or {}
    metric_rows = [
        (html.escape(column), html_text(s.get("median")), html_text(s.get("p90")), html_text(s.get("max")))
        for column, s in metrics.items()
    ]
    parts += ["<h2>Errors</h2>\n", html_table(("metric", "median", "p90", "max"), metric_rows)]
    hists = [_histogram_img(_values(rows, column), title, label) for column, title, label in HISTOGRAMS]
    parts += ['<div class="figs">\n', "\n".join(hists), "\n</div>\n"]

    worst: list[dict[str, Any]] = list(summary.get("worst") or [])[:WORST_COUNT]
    parts.append(f"<h2>The {len(worst)} worst runs (highest severity, uncapped)</h2>\n")
    for entry in worst:
        run_id = str(entry.get("run_id"))
        run = by_id.get(run_id)
        row: Row = run["row"] if run is not None else entry
        numbers = [
            ("severity", html_text(_number(entry.get("cost")))),
            ("success", html_text(bool(row.get("success")))),
            ("planned", html_text(row.get("planned"))),
            ("completed", html_text(row.get("completed"))),
            ("arrived", html_text(row.get("arrived"))),
            ("goals reached", f"{html_text(row.get('goals_reached'))} of {html_text(row.get('goals'))}"),
            ("false complete", html_text(row.get("false_complete"))),
            ("time limit reached", html_text(row.get("time_limit_reached"))),
            ("final state", html_text(row.get("final_state"))),
            ("final reason", html_text(row.get("final_reason"))),
            ("final position error (m)", html_text(_number(row.get("final_position_error_m")))),
            ("final course error (deg)", html_text(_number(row.get("final_course_error_deg")))),
            ("final heading error (deg)", html_text(_number(row.get("final_heading_error_deg")))),
            ("max cross-track (m)", html_text(_number(row.get("max_cross_track_m")))),
            ("min clearance (m)", html_text(_number(row.get("min_clearance_m")))),
            ("time to goal (s)", html_text(_number(row.get("time_to_goal_s")))),
            ("end state", html_text(row.get("end_state"))),
            ("glide after the end (m)", html_text(_number(row.get("glide_after_end_m")))),
            ("max depth after the end (m)", html_text(_number(row.get("max_depth_after_end_m")))),
        ]
        if row.get("error"):
            numbers.append(("error", html_text(row.get("error"))))
        parts += [
            f'<div class="run">\n{_track_img(run, run_id)}\n<div>\n<h3>{html.escape(run_id)}</h3>\n',
            html_table(("", ""), numbers),
            f"<pre><code>{html.escape(rerun_command(run_id))}</code></pre>\n</div>\n</div>\n",
        ]
    parts.append("</body>\n</html>\n")
    path = out_dir / "report.html"
    path.write_text("".join(parts), encoding="utf-8")
    return path


def write_all(
    out_dir: Path,
    runs: list[Run],
    axes: dict[str, list[str]],
    name: str,
    rerun_command: Callable[[str], str],
    legend: dict[str, dict[str, str]] | None = None,
) -> dict[str, Any]:
    """Write ``runs.csv``, ``summary.json`` and ``report.html`` into ``out_dir``; return the summary.

    ``legend``: axis -> label -> what it stands for (the onboard overrides and vehicle variants), kept in
    the summary and shown in the report."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = [run["row"] for run in runs if isinstance(run.get("row"), dict)]
    write_csv(rows, out_dir / "runs.csv")
    summary = summarize(rows, axes, name, rerun_command=rerun_command)
    summary["legend"] = {axis: dict(labels) for axis, labels in (legend or {}).items() if labels}
    (out_dir / "summary.json").write_text(
        json.dumps(summary, indent=2, allow_nan=False) + "\n", encoding="utf-8"
    )
    write_report(out_dir, runs, summary, rerun_command)
    return summary
