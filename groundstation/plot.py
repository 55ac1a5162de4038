"""Track and error plots from a .tlog or an onboard flight log (.mcap) (matplotlib, Agg: no display needed).

``auv-gcs plot FILE`` takes either; the file's first bytes say which (an MCAP file begins with
``\\x89MCAP0\\r\\n``; a tlog with an 8-byte time stamp and a MAVLink packet), never its name:

- a flight log (``onboard.app.flight_log``: /telemetry, /path, /mission, /events, JSON): the track (east
  vs north) with the planned paths (thin, dashed), the goals (an arrow for an arrival heading), the fence
  circles at scale, the start and the end; depth, cross-track, yaw error and propeller over time, with the
  mission-state changes as vertical lines named by the new state. A log cut short (no footer: the vehicle
  stopped without closing it) is drawn as far as it goes.
- a tlog: the track with the uploaded goals; depth, cross-track and depth error, yaw error over time, with
  the state changes of the vehicle's HEARTBEAT.

Anything else raises ``ValueError`` with the reason (the CLI prints it on one line, exit 2): no empty picture.
A flight log of another program or a damaged one: a message that is no JSON object is skipped (counted); a
/mission or /path message that is an object but not of that shape (a key missing, a goal that is no object,
a position that is no number) is a ``ValueError`` naming the message and what is wrong.
"""

from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auv_common.mission_items import FRAME_LOCAL, LOCAL_SCALE
from groundstation.mavclient import state_from_heartbeat
from groundstation.tlog import read_tlog

MCAP_MAGIC = b"\x89MCAP0\r\n"
FLIGHT_LOG_TOPICS = ("/telemetry", "/path", "/mission", "/events")


def is_mcap(path: str | Path) -> bool:
    """True if the file begins with the MCAP magic bytes."""
    with open(path, "rb") as f:
        return f.read(len(MCAP_MAGIC)) == MCAP_MAGIC


def plot_tlog(tlog: str | Path, out: str | Path, vehicle_system: int = 1) -> dict[str, int]:
    """``auv-gcs plot``: draw a tlog or an onboard flight log (told apart by the magic bytes) into ``out``
    (PNG/SVG/PDF); return what was drawn, counted (see :func:`plot_flight_log`, :func:`plot_mavlink_log`).

    Raises ValueError (with the reason) for a file that is neither, or holds nothing to plot."""
    if is_mcap(tlog):
        return plot_flight_log(tlog, out)
    return plot_mavlink_log(tlog, out, vehicle_system)


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _state_lines(axes: Any, changes: list[tuple[float, str]], label_axis: Any, span_s: float) -> None:
    """A vertical line on each time plot at each state change, the new state named on ``label_axis``
    (changes closer than 2 % of ``span_s`` share one label: "ARMED > RUNNING")."""
    labels: list[tuple[float, list[str]]] = []
    for t, state in changes:
        for a in axes:
            a.axvline(t, color="0.45", lw=0.7, ls=":", zorder=1)
        if labels and t - labels[-1][0] < 0.02 * span_s:
            labels[-1][1].append(state)
        else:
            labels.append((t, [state]))
    for t, states in labels:
        label_axis.annotate(
            " > ".join(states),
            xy=(t, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(2, -2),
            textcoords="offset points",
            rotation=90,
            va="top",
            ha="left",
            fontsize=7,
            color="0.3",
        )


# --- tlog ------------------------------------------------------------------------------------------------
def plot_mavlink_log(tlog: str | Path, out: str | Path, vehicle_system: int = 1) -> dict[str, int]:
    """Draw track (east vs north), depth, cross-track and yaw error over time of a tlog into ``out``, with the
    state changes of the vehicle's HEARTBEAT.

    Returns counts: positions, nav_samples, goals (uploaded), state_changes. Raises ValueError (with the
    reason) for a file that holds no MAVLink packet or no position of the vehicle: no empty picture."""
    pos_t, xs, ys, zs = [], [], [], []
    nav_t, xtrack, depth_err, yaw_err = [], [], [], []
    goals_x, goals_y = [], []
    states: list[tuple[float, str]] = []
    t0: float | None = None
    packets = 0
    for t, m in read_tlog(tlog):
        packets += 1
        if m.get_srcSystem() != vehicle_system:
            if m.get_type() == "MISSION_ITEM_INT" and m.frame == FRAME_LOCAL and m.mission_type == 0:
                goals_x.append(m.x / LOCAL_SCALE)
                goals_y.append(m.y / LOCAL_SCALE)
            continue
        t0 = t if t0 is None else t0
        kind = m.get_type()
        if kind == "LOCAL_POSITION_NED" and math.isfinite(m.x):
            pos_t.append(t - t0)
            xs.append(m.x)
            ys.append(m.y)
            zs.append(m.z)
        elif kind == "NAV_CONTROLLER_OUTPUT":
            nav_t.append(t - t0)
            xtrack.append(m.xtrack_error)
            depth_err.append(m.alt_error)
            yaw_err.append(((m.target_bearing - m.nav_bearing + 180) % 360) - 180)
        elif kind == "HEARTBEAT" and m.get_srcComponent() == 1:
            state = state_from_heartbeat(m)
            if not states or states[-1][1] != state:
                states.append((t - t0, state))
    if not packets:
        raise ValueError(f"{tlog}: not a tlog (no MAVLink packet in it) nor an MCAP flight log")
    if not xs:
        raise ValueError(f"{tlog}: no position of vehicle {vehicle_system} in it: nothing to plot")
    plt = _pyplot()
    fig, ax = plt.subplots(2, 2, figsize=(11, 8))
    ax[0][0].plot(ys, xs, "-", label="track")
    if goals_x:
        ax[0][0].plot(goals_y, goals_x, "x", label="goals (uploaded)")
    ax[0][0].set_xlabel("east y (m)")
    ax[0][0].set_ylabel("north x (m)")
    ax[0][0].set_aspect("equal", adjustable="datalim")
    ax[0][0].legend()
    ax[0][0].set_title("track")
    ax[0][1].plot(pos_t, zs)
    ax[0][1].invert_yaxis()
    ax[0][1].set_xlabel("t (s)")
    ax[0][1].set_ylabel("depth (m)")
    ax[1][0].plot(nav_t, xtrack, label="cross-track (m)")
    ax[1][0].plot(nav_t, depth_err, label="depth error (m)")
    ax[1][0].set_xlabel("t (s)")
    ax[1][0].legend()
    ax[1][1].plot(nav_t, yaw_err)
    ax[1][1].set_xlabel("t (s)")
    ax[1][1].set_ylabel("yaw error (deg)")
    changes = states[1:]  # the first is where the log begins, not a change
    _state_lines([ax[0][1], ax[1][0], ax[1][1]], changes, ax[0][1], max(pos_t + nav_t) - min(pos_t + nav_t))
    for a in ax.flat:
        a.grid(True)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return {
        "positions": len(xs),
        "nav_samples": len(nav_t),
        "goals": len(goals_x),
        "state_changes": len(changes),
    }


# --- flight log ------------------------------------------------------------------------------------------
@dataclass
class FlightLogData:
    """What an onboard flight log holds, decoded (JSON messages by topic, with ``log_time`` in ns)."""

    telemetry: list[dict[str, Any]] = field(default_factory=list)
    paths: list[dict[str, Any]] = field(default_factory=list)
    missions: list[dict[str, Any]] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = False  # the footer was read: the log was closed
    skipped: int = 0  # messages of these topics that are no JSON object (another program's, or damaged)


def read_flight_log(path: str | Path) -> FlightLogData:
    """Read an MCAP flight log in one pass (no index needed: a log cut short reads as far as it goes).

    Raises ValueError: an MCAP file without a /telemetry channel (not an onboard flight log), or one whose
    records cannot be read from the start."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Footer, Message, Metadata
    from mcap.stream_reader import StreamReader

    data = FlightLogData()
    topics: dict[int, str] = {}
    by_topic = {
        "/telemetry": data.telemetry,
        "/path": data.paths,
        "/mission": data.missions,
        "/events": data.events,
    }
    cut: str | None = None
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f).records:
                if isinstance(record, Channel):
                    if record.message_encoding == "json":
                        topics[record.id] = record.topic
                elif isinstance(record, Message):
                    target = by_topic.get(topics.get(record.channel_id, ""))
                    if target is not None:
                        message = _json_object(record.data)
                        if message is None:
                            data.skipped += 1
                        else:
                            target.append({"log_time": record.log_time, **message})
                elif isinstance(record, Metadata):
                    data.metadata[record.name] = dict(record.metadata)
                elif isinstance(record, Footer):
                    data.complete = True
        except (McapError, EOFError, ValueError, struct.error) as exc:
            # cut short (the vehicle stopped without closing it): what was read is drawn
            cut = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    if "/telemetry" not in topics.values():
        if cut is not None:
            raise ValueError(f"{path}: an MCAP file cut short before its first tick was written ({cut})")
        raise ValueError(f"{path}: an MCAP file but not an onboard flight log (no JSON /telemetry channel)")
    return data


def _json_object(raw: bytes) -> dict[str, Any] | None:
    """A message's JSON object; None for one that is not (no JSON, another type, nested too deep)."""
    try:
        message = json.loads(raw)
    except (ValueError, RecursionError):  # (UnicodeDecodeError is a ValueError)
        return None
    return message if isinstance(message, dict) else None


def _num(value: Any) -> float:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else math.nan


def _short(value: Any) -> str:
    try:
        text = json.dumps(value)
    except (TypeError, ValueError, RecursionError):
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _finite(d: dict[str, Any], key: str, what: str) -> float:
    """``d[key]``, a finite number (``what`` names ``d`` in the message: a KeyError when it is missing, a
    ValueError when it is something else)."""
    if key not in d:
        raise KeyError(f"{what}.{key}")
    value = d[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{what}.{key} must be a number, got {_short(value)}")
    return float(value)


def _array(d: dict[str, Any], key: str) -> list[Any]:
    """``d[key]``, a JSON array (absent or null: empty)."""
    value = d.get(key)
    if value is None:
        return []
    if not isinstance(value, list):
        raise TypeError(f"{key} must be an array, got {_short(value)}")
    return value


def _object(value: Any, what: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise TypeError(f"{what} must be an object, got {_short(value)}")
    return value


@dataclass(frozen=True)
class _Plan:
    """A /mission message, decoded for drawing: goals (x_m, y_m, arrival yaw_rad or None: free) and
    obstacles (x_m, y_m, radius_m), local NED metres."""

    goals: list[tuple[float, float, float | None]]
    obstacles: list[tuple[float, float, float]]


def _decode_mission(m: dict[str, Any]) -> _Plan:
    goals = []
    for i, raw in enumerate(_array(m, "goals")):
        where = f"goals[{i}]"
        g = _object(raw, where)
        yaw_rad = _num(g.get("yaw_rad"))  # null / absent: free (no arrow)
        x_m, y_m = _finite(g, "x_m", where), _finite(g, "y_m", where)
        goals.append((x_m, y_m, yaw_rad if math.isfinite(yaw_rad) else None))
    obstacles = []
    for i, raw in enumerate(_array(m, "obstacles")):
        where = f"obstacles[{i}]"
        o = _object(raw, where)
        x, y, radius = (_finite(o, k, where) for k in ("x_m", "y_m", "radius_m"))
        obstacles.append((x, y, radius))
    return _Plan(goals, obstacles)


def _decode_path(p: dict[str, Any]) -> tuple[list[float], list[float]]:
    """A /path message's points (x_m north, y_m east), null (a NaN) a gap."""
    xs, ys = _array(p, "x_m"), _array(p, "y_m")
    if len(xs) != len(ys):
        raise ValueError(f"x_m has {len(xs)} points, y_m {len(ys)}")
    return [_num(v) for v in xs], [_num(v) for v in ys]


def _decoded(path: str | Path, topic: str, messages: list[dict[str, Any]], decode: Any) -> list[Any]:
    """``decode`` of every message of ``topic``; a message it cannot decode (KeyError, TypeError,
    ValueError) is a ValueError naming the file, the message and the reason."""
    out = []
    for i, m in enumerate(messages):
        try:
            out.append(decode(m))
        except KeyError as exc:
            raise ValueError(f"{path}: {topic} message {i}: missing {exc.args[0]}") from None
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{path}: {topic} message {i}: {exc}") from None
    return out


def plot_flight_log(path: str | Path, out: str | Path) -> dict[str, int]:
    """Draw an onboard flight log into ``out``: the track (east vs north) with the planned paths (thin,
    dashed), the goals (with arrival-heading arrows), the fence circles at scale, the start and end marks;
    depth, cross-track, yaw error and propeller over time with the state changes as vertical lines.

    Returns counts: ticks, positions, paths, path_points, goals, obstacles (of the last mission), missions,
    state_changes, notes, truncated (1: the log has no footer), skipped (messages that are no JSON object).
    Raises ValueError for a log with no position in it, or a /mission or /path message it cannot decode (the
    message and the reason): no empty picture."""
    log = read_flight_log(path)
    tel = log.telemetry
    if not tel:
        raise ValueError(f"{path}: a flight log without a tick in it: nothing to plot")
    t0 = _num(tel[0].get("t_s"))
    t = [_num(m.get("t_s")) - t0 for m in tel]
    xs = [_num(m.get("x_m")) for m in tel]
    ys = [_num(m.get("y_m")) for m in tel]
    fixes = [(x, y) for x, y in zip(xs, ys, strict=True) if math.isfinite(x) and math.isfinite(y)]
    if not fixes:
        raise ValueError(f"{path}: no position of the vehicle in the flight log: nothing to plot")
    changes = [
        (_num(e.get("t_s")) - t0, str(e.get("to_state", "")))
        for e in log.events
        if e.get("kind") == "state" and e.get("from_state")
    ]
    notes = [e for e in log.events if e.get("kind") == "note"]
    paths: list[tuple[list[float], list[float]]] = _decoded(path, "/path", log.paths, _decode_path)
    plans: list[_Plan] = _decoded(path, "/mission", log.missions, _decode_mission)
    missions = [m for m in plans if m.goals or m.obstacles]

    plt = _pyplot()
    from matplotlib.patches import Circle

    fig = plt.figure(figsize=(15, 9))
    grid = fig.add_gridspec(4, 2, width_ratios=(1.15, 1.0))
    track = fig.add_subplot(grid[:, 0])
    series = [fig.add_subplot(grid[0, 1])]
    series += [fig.add_subplot(grid[i, 1], sharex=series[0]) for i in range(1, 4)]

    # the track, the planned paths, the mission
    path_points = 0
    drawn_paths = [xy for xy in paths if xy[0]]
    for i, (px, py) in enumerate(drawn_paths):
        track.plot(
            py,
            px,
            "--",
            lw=0.8,
            color="k",
            alpha=0.6,
            label="planned path" if i == 0 else None,
            zorder=4,  # over the track: where the vehicle left it shows
        )
        path_points += len(px)
    track.plot(ys, xs, "-", lw=1.4, color="tab:blue", label="track", zorder=3)
    track.plot(*reversed(fixes[0]), "o", ms=8, mfc="none", mec="tab:green", mew=2, label="start", zorder=5)
    track.plot(*reversed(fixes[-1]), "s", ms=7, color="tab:red", label="end", zorder=5)
    last = missions[-1] if missions else _Plan([], [])
    for m in missions[:-1]:  # earlier missions, faint
        for gx, gy, _ in m.goals:
            track.plot(gy, gx, "x", color="0.7", zorder=3)
    goals = last.goals
    for k, (gx, gy, yaw) in enumerate(goals):
        track.plot(gy, gx, "x", ms=9, mew=2, color="tab:orange", label="goals" if k == 0 else None)
        track.annotate(str(k), (gy, gx), xytext=(5, 5), textcoords="offset points", fontsize=8)
        if yaw is not None:
            length = 2.0  # m on the map
            track.annotate(
                "",
                xy=(gy + length * math.sin(yaw), gx + length * math.cos(yaw)),
                xytext=(gy, gx),
                arrowprops={"arrowstyle": "->", "color": "tab:orange", "lw": 1.5},
            )
    obstacles = last.obstacles
    for k, (ox, oy, radius) in enumerate(obstacles):
        track.add_patch(
            Circle(
                (oy, ox),
                radius,
                facecolor="tab:red",
                edgecolor="tab:red",
                alpha=0.25,
                label="obstacles" if k == 0 else None,
            )
        )
    track.set_xlabel("east y (m)")
    track.set_ylabel("north x (m)")
    track.set_aspect("equal", adjustable="datalim")
    track.grid(True)
    track.legend(loc="best", fontsize=8)
    meta = log.metadata.get("flight_log", {})
    title = f"{Path(path).name}"
    if meta.get("start_utc"):
        title += f"  (start {meta['start_utc']})"
    if not log.complete:
        title += "  [cut short: no footer]"
    track.set_title(title, fontsize=9)

    # the time plots
    depth = [_num(m.get("depth_m")) for m in tel]
    xtrack = [_num(m.get("cross_track_m")) for m in tel]
    yaw_err = [math.degrees(_num(m.get("e_yaw_rad", m.get("yaw_error_rad")))) for m in tel]  # (older logs)
    prop = [_num(m.get("propeller_rps")) for m in tel]
    series[0].plot(t, depth)
    series[0].invert_yaxis()
    series[0].set_ylabel("depth (m)")
    series[1].plot(t, xtrack)
    series[1].set_ylabel("cross-track (m)")
    series[2].plot(t, yaw_err)
    series[2].set_ylabel("yaw error (deg)")
    series[3].plot(t, prop)
    series[3].set_ylabel("propeller (rps)")
    series[3].set_xlabel("t (s) from the first tick")
    _state_lines(series, changes, series[0], max(t) - min(t))
    for a in series:
        a.grid(True)
    for a in series[:-1]:
        a.tick_params(labelbottom=False)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return {
        "ticks": len(tel),
        "positions": len(fixes),
        "paths": len(drawn_paths),
        "path_points": path_points,
        "goals": len(goals),
        "obstacles": len(obstacles),
        "missions": len(missions),
        "state_changes": len(changes),
        "notes": len(notes),
        "truncated": 0 if log.complete else 1,
        "skipped": log.skipped,
    }
