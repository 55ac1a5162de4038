"""The onboard flight log: every control tick of one run in an MCAP file (Foxglove and PlotJuggler open it).

``<state_dir>/logs/flight-<seq>-YYYYmmdd-HHMMSS.mcap`` (``[log] dir`` puts it elsewhere), one file per run
of ``auv-onboard run``; the names, their order and what is kept are :mod:`onboard.adapters.log_files`'s
rule. The directory is kept within ``[log] max_total_mb`` and ``keep_files`` (:func:`rotate`) at the
start, after every flush and at the end: boot-only logs go first, then the oldest flights, never the file
being written; the writer marks its log as a flight at the first RUNNING tick. Messages
are JSON (``message_encoding="json"``) with one JSON Schema per channel (``encoding="jsonschema"``), in SI
units and radians as in :class:`~onboard.adapters.mavlink.api.VehicleSnapshot` (NED world, FRD body):

- ``/telemetry``, every tick: every number, flag and string of the snapshot (state name, armed, position,
  attitude, velocities, guidance errors, actuator commands, saturation flags, the nav conditions, actuator
  and failsafe bits, failsafe, overruns, loop load, ...), under the tick record's names
  (:class:`onboard.core.record.TickRecord`, as the telemetry CSV); an unknown value (NaN) is ``null``, no
  failsafe is ``""``.
- ``/path``, whenever the path the autopilot flies is a new object: its kind, goal index, length, Dubins
  word and the path sampled every ~0.5 m (``x_m``, ``y_m``, ``depth_m``); empty arrays when it flies none.
- ``/mission``, whenever the mission's goals or fence change: goals (``yaw_rad`` null = free arrival
  heading) and obstacle circles.
- ``/events``: each mission-state change (``kind`` "state": from, to, reason) and each note the core gives
  the operator (``kind`` "note": severity, text; each is one STATUSTEXT on MAVLink).

``log_time`` = ``publish_time`` = the tick's loop time (``t_s``) in ns: the monotonic clock in real time,
the simulated time in lock-step. The metadata record ``flight_log`` holds the UTC wall time of the start,
the vehicle, the software version and the configuration file; ``config`` every configuration value in
force; ``flight_log_end`` (written at close) the message counts and the ticks dropped.

Writing never stops the loop. The loop thread only hands the tick's immutable snapshot (with the notes of
that tick) to a bounded queue; a writer thread encodes and writes, and ends the chunk every
``[log] flush_period_s`` (written and fsynced: a crash loses at most that much). A full queue drops the
tick (counted, logged once per burst). An ``OSError`` (disk full, the directory gone) logs one warning and
turns the log off; the loop goes on. :meth:`FlightLog.close` (every stop of ``auv-onboard run`` passes
through it) writes the summary and the footer.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import importlib.metadata
import json
import logging
import math
import os
import platform
import queue
import threading
import time
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from mcap.writer import CompressionType, Writer

from auv_common.config import check_declared, param
from onboard.adapters.log_files import (
    log_files,
    log_name,
    marker,
    next_sequence,
    orphan_markers,
    scan,
    to_remove,
)
from onboard.adapters.mavlink.api import MISSION_STATES, Request, VehicleSnapshot
from onboard.core.commands import Note, Verdict
from onboard.core.mission.model import Goal, Obstacle
from onboard.core.mission.state import MissionState
from onboard.core.planner.path import POINT_STEP_M, sample_evenly
from onboard.core.planner.path import Path as PlannedPath

log = logging.getLogger(__name__)

#: The spacing of the path samples in /path (m of arc length; the last gap may be shorter: both ends kept).
PATH_STEP_M = POINT_STEP_M
#: Ticks the writer may lag behind before the loop drops them (about 100 s at 20 Hz).
QUEUE_TICKS = 2048
#: A chunk also ends at this many bytes (lock-step runs faster than the wall clock).
CHUNK_BYTES = 256 * 1024

TELEMETRY, PATH, MISSION, EVENTS = "/telemetry", "/path", "/mission", "/events"


@dataclass(frozen=True)
class LogConfig:
    """The ``[log]`` table: the flight log of ``auv-onboard run`` (:mod:`onboard.app.flight_log`).

    Beyond ``max_total_mb`` or ``keep_files``, logs are removed (:func:`onboard.adapters.log_files.to_remove`:
    boot-only ones first, then the oldest flights, never the one being written).
    """

    enabled: bool = param(True, desc="write one file per run")
    max_total_mb: float = param(
        500.0, unit="MB", min=0.01, max=1e6,
        desc="the bytes all logs may take together, the one being written included (1 MB = 1e6 bytes)",
    )  # fmt: skip
    keep_files: int = param(200, min=1, max=1000, desc="the most log files kept")
    flush_period_s: float = param(
        1.0, unit="s", min=0.1, max=10.0,
        desc="the writer ends a chunk, writes and fsyncs it this often: what a crash may lose",
    )  # fmt: skip
    dir: str = param("", desc='the directory ("" = logs in the state directory)')

    def __post_init__(self) -> None:
        check_declared(self)

    def directory(self, state_dir: Path) -> Path:
        """Where the files go: ``dir``, or ``logs`` in the state directory."""
        return Path(self.dir) if self.dir else Path(state_dir) / "logs"

    @property
    def max_total_bytes(self) -> int:
        return round(self.max_total_mb * 1e6)


# --- the messages --------------------------------------------------------------------------------------
def _telemetry_fields() -> tuple[tuple[str, str], ...]:
    """(name, JSON Schema type) of every snapshot field that is a number, a flag, a string or the state,
    in the snapshot's order (a field added to the snapshot is logged without a change here)."""
    kinds: dict[Any, str] = {
        float: "number",
        int: "integer",
        bool: "boolean",
        str: "string",
        str | None: "string",
        MissionState: "string",
    }
    hints = typing.get_type_hints(VehicleSnapshot)
    return tuple(
        (f.name, kinds[hints[f.name]]) for f in dataclasses.fields(VehicleSnapshot) if hints[f.name] in kinds
    )


TELEMETRY_FIELDS = _telemetry_fields()


def _number(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def telemetry_message(snapshot: VehicleSnapshot) -> dict[str, Any]:
    """The /telemetry message of one snapshot: NaN -> null, the state by name, no failsafe -> ""."""
    out: dict[str, Any] = {}
    for name, kind in TELEMETRY_FIELDS:
        value = getattr(snapshot, name)
        if kind == "number":
            out[name] = _number(value)
        elif isinstance(value, MissionState):
            out[name] = value.name
        elif value is None:
            out[name] = ""
        else:
            out[name] = value
    return out


def sample_path(
    path: PlannedPath, step_m: float = PATH_STEP_M
) -> tuple[list[float], list[float], list[float]]:
    """(x_m, y_m, depth_m) of ``path`` every ``step_m`` of arc length or closer (``sample_evenly``)."""
    points = sample_evenly(path, step_m)
    return [p.x_m for p in points], [p.y_m for p in points], [p.depth_m for p in points]


def path_message(t_s: float, snapshot: VehicleSnapshot) -> dict[str, Any]:
    """The /path message of the path ``snapshot`` flies (empty arrays when it flies none)."""
    path = snapshot.path
    xs, ys, ds = sample_path(path) if path is not None else ([], [], [])
    return {
        "t_s": t_s,
        "kind": snapshot.path_kind if path is not None else "",
        "goal_index": snapshot.path_goal_index if path is not None else -1,
        "length_m": path.length_m if path is not None else 0.0,
        "word": path.word if path is not None else "",
        "note": path.note if path is not None else "",
        "x_m": xs,
        "y_m": ys,
        "depth_m": ds,
    }


def mission_message(
    t_s: float, goals: Sequence[Goal], obstacles: Sequence[Obstacle] | None
) -> dict[str, Any]:
    """The /mission message: the goals (yaw null = free) and the fence (empty when not known)."""
    return {
        "t_s": t_s,
        "goals": [
            {
                "x_m": g.x_m,
                "y_m": g.y_m,
                "depth_m": g.depth_m,
                "yaw_rad": None if g.yaw_rad is None else _number(g.yaw_rad),
            }
            for g in goals
        ],
        "obstacles": [{"x_m": o.x_m, "y_m": o.y_m, "radius_m": o.radius_m} for o in obstacles or ()],
    }


def event_message(t_s: float, kind: str, **fields: str) -> dict[str, Any]:
    """An /events message: ``kind`` "state" (from_state, to_state, reason) or "note" (severity, text)."""
    out = {
        "t_s": t_s,
        "kind": kind,
        "from_state": "",
        "to_state": "",
        "reason": "",
        "severity": "",
        "text": "",
    }
    out.update(fields)
    return out


# JSON Schemas: one type per property (Foxglove takes no type lists); null where the description says so.
def _prop(kind: str, description: str = "") -> dict[str, Any]:
    return {"type": kind, **({"description": description} if description else {})}


def _array(kind: str, description: str) -> dict[str, Any]:
    return {"type": "array", "items": {"type": kind}, "description": description}


def _object(title: str, description: str, properties: dict[str, Any]) -> dict[str, Any]:
    return {"type": "object", "title": title, "description": description, "properties": properties}


def _telemetry_schema() -> dict[str, Any]:
    props: dict[str, Any] = {}
    for name, kind in TELEMETRY_FIELDS:
        if name == "state":
            props[name] = {"type": "string", "enum": list(MISSION_STATES), "description": "mission state"}
        elif kind == "number":
            props[name] = _prop(kind, "SI units / rad as the name says; null = unknown (NaN)")
        else:
            props[name] = _prop(kind)
    return _object(
        "isimi100.Telemetry", "One control tick (onboard.adapters.mavlink.api.VehicleSnapshot)", props
    )


_POINT = {"x_m": _prop("number"), "y_m": _prop("number")}
SCHEMAS: dict[str, dict[str, Any]] = {
    TELEMETRY: _telemetry_schema(),
    PATH: _object(
        "isimi100.Path",
        "The planned path flown from t_s on, sampled every ~0.5 m of arc length (NED, m)",
        {
            "t_s": _prop("number", "loop time (s)"),
            "kind": _prop("string", '"goal", "loiter" or "" (no path)'),
            "goal_index": _prop("integer", "the goal it leads to, -1 for none"),
            "length_m": _prop("number"),
            "word": _prop("string", "Dubins word of the path"),
            "note": _prop("string", "how it was planned, for the operator"),
            "x_m": _array("number", "north (m)"),
            "y_m": _array("number", "east (m)"),
            "depth_m": _array("number", "depth (m, positive down)"),
        },
    ),
    MISSION: _object(
        "isimi100.Mission",
        "The mission in force from t_s on (NED, m, rad)",
        {
            "t_s": _prop("number", "loop time (s)"),
            "goals": {
                "type": "array",
                "items": _object(
                    "isimi100.Goal",
                    "A goal pose",
                    {
                        **_POINT,
                        "depth_m": _prop("number"),
                        "yaw_rad": _prop("number", "arrival yaw from north to east; null = free"),
                    },
                ),
            },
            "obstacles": {
                "type": "array",
                "items": _object(
                    "isimi100.Obstacle", "A fence circle", {**_POINT, "radius_m": _prop("number")}
                ),
            },
        },
    ),
    EVENTS: _object(
        "isimi100.Event",
        'A mission-state change (kind "state") or a note for the operator (kind "note", one STATUSTEXT)',
        {
            "t_s": _prop("number", "loop time (s)"),
            "kind": {"type": "string", "enum": ["state", "note"]},
            "from_state": _prop("string", '"" for the first state of the log'),
            "to_state": _prop("string"),
            "reason": _prop("string"),
            "severity": _prop("string"),
            "text": _prop("string"),
        },
    ),
}


def _ns(t_s: float) -> int:
    return max(0, round(t_s * 1e9)) if math.isfinite(t_s) else 0


def _same(a: Any, b: Any) -> bool:
    return a is b or a == b


_NO_PATH = object()  # nothing logged yet (None is "flies no path")


class _Recorder:
    """Snapshots into MCAP records (the writer thread's; no lock: one thread uses it)."""

    def __init__(self, stream: BinaryIO, metadata: Mapping[str, Mapping[str, str]]) -> None:
        self.stream = stream
        self.writer = Writer(stream, chunk_size=CHUNK_BYTES, compression=CompressionType.ZSTD)
        self.writer.start(profile="", library="isimi100 flight log (mcap-python)")
        for name, data in metadata.items():
            self.writer.add_metadata(name, {k: str(v) for k, v in data.items()})
        self.channels: dict[str, int] = {}
        for topic, schema in SCHEMAS.items():
            schema_id = self.writer.register_schema(
                name=str(schema["title"]), encoding="jsonschema", data=json.dumps(schema).encode()
            )
            self.channels[topic] = self.writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_id
            )
        self.counts = dict.fromkeys(SCHEMAS, 0)
        self._state: MissionState | None = None
        self._path: object = _NO_PATH
        self._goals: tuple[Goal, ...] | None = None
        self._obstacles: tuple[Obstacle, ...] | None = None

    def _write(self, topic: str, t_ns: int, message: dict[str, Any]) -> None:
        data = json.dumps(message, separators=(",", ":"), allow_nan=False).encode()
        self.counts[topic] += 1
        self.writer.add_message(self.channels[topic], t_ns, data, t_ns, sequence=self.counts[topic])

    def record(
        self, snapshot: VehicleSnapshot, notes: Sequence[Note], obstacles: tuple[Obstacle, ...] | None
    ) -> None:
        """One tick: what changed (/mission, /path, /events), its notes, then /telemetry."""
        t_s, t_ns = snapshot.t_s, _ns(snapshot.t_s)
        goals = snapshot.mission_goals
        if self._goals is None or not _same(goals, self._goals) or not _same(obstacles, self._obstacles):
            self._goals, self._obstacles = goals, obstacles
            self._write(MISSION, t_ns, mission_message(t_s, goals, obstacles))
        if snapshot.path is not self._path:
            if not (snapshot.path is None and self._path is _NO_PATH):
                self._write(PATH, t_ns, path_message(t_s, snapshot))
            self._path = snapshot.path
        if snapshot.state is not self._state:
            before = self._state.name if self._state is not None else ""
            self._write(
                EVENTS,
                t_ns,
                event_message(
                    t_s, "state", from_state=before, to_state=snapshot.state.name, reason=snapshot.reason
                ),
            )
            self._state = snapshot.state
        for note in notes:
            self._write(EVENTS, t_ns, event_message(t_s, "note", severity=note.severity.name, text=note.text))
        self._write(TELEMETRY, t_ns, telemetry_message(snapshot))

    def flush(self) -> None:
        """End the chunk, write it and get it to the disk."""
        self.writer.flush()
        _fsync(self.stream)

    def finish(self, end: Mapping[str, str]) -> None:
        """The end record, the summary and the footer; the file closed."""
        self.writer.add_metadata("flight_log_end", dict(end))
        self.writer.finish()
        self.stream.flush()
        _fsync(self.stream)
        self.stream.close()


def _fsync(stream: BinaryIO) -> None:
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (a test's buffer)
        return
    os.fsync(fd)


_STOP = object()


class FlightLog:
    """The flight log of one run, written by its own thread into ``stream`` (see the module docstring).

    The loop thread calls :meth:`notify` with the notes of a tick and :meth:`publish` with its snapshot
    (both O(1), never blocking, never raising), then :meth:`close` once at the end. ``path`` names the file
    in messages; ``metadata``: MCAP metadata records (name -> string map) written after the header.
    The writer thread calls ``on_flight`` once, at the first RUNNING tick (the log marks itself a flight),
    and ``after_flush`` after every flush and after the footer (the rotation: the directory stays within
    its budget while the log grows); an error in either is one warning (once per hook), the log goes on.
    """

    def __init__(
        self,
        stream: BinaryIO,
        *,
        path: Path | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
        flush_period_s: float = 1.0,
        queue_ticks: int = QUEUE_TICKS,
        clock: Callable[[], float] = time.monotonic,
        on_flight: Callable[[], None] | None = None,
        after_flush: Callable[[], object] | None = None,
    ) -> None:
        self.path = path
        self.flew = False  # a tick RUNNING was logged
        self._on_flight = on_flight
        self._after_flush = after_flush
        self._hook_failed: set[str] = set()  # hooks that failed (warned once each)
        self.flush_period_s = flush_period_s
        self.dropped = 0  # ticks not logged: the writer was behind
        self.failed = False  # an error turned the log off
        self._recorder = _Recorder(stream, metadata or {})  # the header: an OSError here is the caller's
        self._stream = stream
        self._clock = clock
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=queue_ticks)
        self._notes: list[Note] = []
        self._dropping = False
        self._closed = False
        self._finished = False
        self._thread = threading.Thread(target=self._run, name="flight-log", daemon=True)
        self._thread.start()

    @property
    def name(self) -> str:
        return str(self.path) if self.path is not None else "the flight log"

    @property
    def counts(self) -> dict[str, int]:
        """Messages written so far, by channel (final once :meth:`close` returned)."""
        return dict(self._recorder.counts)

    @property
    def finished(self) -> bool:
        """True once the file has its summary and footer."""
        return self._finished

    # --- the loop's side ----------------------------------------------------------------------------
    def notify(self, notes: list[Note]) -> None:
        """The core's notes of this tick (logged with the tick's snapshot, in :meth:`publish`)."""
        if notes and not (self._closed or self.failed):
            self._notes.extend(notes)

    def publish(self, snapshot: VehicleSnapshot, obstacles: tuple[Obstacle, ...] | None = None) -> None:
        """Log one tick: ``snapshot`` and the notes given since the last call; ``obstacles``: the fence in
        force (for /mission; None = not known)."""
        if self._closed or self.failed:
            return
        notes, self._notes = self._notes, []
        try:
            self._queue.put_nowait((snapshot, notes, obstacles))
        except queue.Full:
            self.dropped += 1
            if not self._dropping:
                log.warning("flight log: the writer is behind, ticks are dropped (%s)", self.name)
                self._dropping = True
            return
        if self._dropping:
            log.info("flight log: writing again (%d ticks dropped so far)", self.dropped)
            self._dropping = False

    def close(self, timeout_s: float = 5.0) -> None:
        """Write what is queued, the summary and the footer; wait up to ``timeout_s`` for it. Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            self._queue.put(_STOP, timeout=timeout_s)
        except queue.Full:
            pass
        self._thread.join(timeout_s)
        if self._thread.is_alive():
            log.warning(
                "flight log: not finished within %.1f s: %s may lack its footer", timeout_s, self.name
            )
        elif self._finished:
            counts = self._recorder.counts
            log.info(
                "flight log: %s closed (%d ticks, %d events, %d paths, %d dropped)",
                self.name,
                counts[TELEMETRY],
                counts[EVENTS],
                counts[PATH],
                self.dropped,
            )

    # --- the writer thread --------------------------------------------------------------------------
    def _run(self) -> None:
        next_flush_s = self._clock() + self.flush_period_s
        while True:
            timeout = None if self.failed else max(0.0, next_flush_s - self._clock())
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:
                item = None
            if item is _STOP:
                break
            if self.failed:
                continue  # drain: the loop stops queueing once it sees the flag
            try:
                if item is not None:
                    self._recorder.record(*item)
                    if not self.flew and item[0].state is MissionState.RUNNING:
                        self.flew = True
                        self._hook("cannot mark it as a flight", self._on_flight)
                if self._clock() >= next_flush_s:
                    self._recorder.flush()
                    next_flush_s = self._clock() + self.flush_period_s
                    self._hook("cannot keep the directory within its budget", self._after_flush)
            except Exception as exc:  # the log never stops the vehicle
                self._fail(exc)
        if self.failed:
            return
        try:
            self._recorder.finish(
                {
                    "end_utc": _utc_iso(dt.datetime.now(dt.UTC)),
                    "dropped_ticks": str(self.dropped),
                    **{
                        f"messages{topic.replace('/', '_')}": str(n)
                        for topic, n in self._recorder.counts.items()
                    },
                }
            )
            self._finished = True
        except Exception as exc:
            self._fail(exc)
            return
        self._hook("cannot keep the directory within its budget", self._after_flush)

    def _hook(self, what: str, hook: Callable[[], object] | None) -> None:
        """Run a writer-side hook; an error is one warning (the log goes on)."""
        if hook is None:
            return
        try:
            hook()
        except Exception as exc:
            if what not in self._hook_failed:
                self._hook_failed.add(what)
                log.warning("flight log: %s: %s: %s: %s", self.name, what, type(exc).__name__, exc)

    def _fail(self, exc: BaseException) -> None:
        """One warning; the log is off from here on (the loop goes on)."""
        self.failed = True
        if isinstance(exc, OSError):
            log.warning("flight log off: %s: %s (the vehicle goes on without it)", self.name, exc)
        else:
            log.error("flight log off: %s: %s: %s", self.name, type(exc).__name__, exc, exc_info=exc)
        try:
            self._stream.close()
        except Exception:  # the buffer may still hold what did not fit on the disk
            pass


class LoggedLink:
    """The bridge's link (:class:`onboard.adapters.mavlink.bridge.Link`) with the flight log beside it.

    Requests and answers go to ``link`` (none without a link); the core's notes and the tick's snapshot go
    to ``link`` and to the log. ``obstacles`` gives the fence in force (e.g. ``autopilot.mission.obstacles``)
    for /mission; without it /mission has the goals only.
    """

    def __init__(
        self,
        flight_log: FlightLog,
        link: Any = None,
        obstacles: Callable[[], tuple[Obstacle, ...]] | None = None,
    ) -> None:
        self.flight_log = flight_log
        self.link = link
        self.obstacles = obstacles

    def take_requests(self) -> list[Request]:
        return self.link.take_requests() if self.link is not None else []

    def answer(self, request_id: int, verdict: Verdict) -> None:
        if self.link is not None:
            self.link.answer(request_id, verdict)

    def notify(self, notes: list[Note]) -> None:
        if self.link is not None:
            self.link.notify(notes)
        self.flight_log.notify(notes)

    def publish(self, snapshot: VehicleSnapshot) -> None:
        if self.link is not None:
            self.link.publish(snapshot)
        self.flight_log.publish(snapshot, self.obstacles() if self.obstacles is not None else None)


# --- files ----------------------------------------------------------------------------------------------
def _utc_iso(t: dt.datetime) -> str:
    return t.astimezone(dt.UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def rotate(
    directory: Path, config: LogConfig, current: Path | None = None, warned: set[str] | None = None
) -> list[Path]:
    """Remove flight logs until ``directory`` is within ``config``'s bytes and files
    (:func:`~onboard.adapters.log_files.to_remove`: never ``current``, boot-only logs first, then the oldest
    flights), with their markers, and markers whose log is gone; return the logs removed. A file that cannot
    be removed is one warning (once per name in ``warned``: the writer rotates after every flush)."""
    warned = set() if warned is None else warned
    removed = []
    for name in to_remove(scan(directory, current), config.max_total_bytes, config.keep_files):
        p = directory / name
        try:
            p.unlink()
            removed.append(p)
            log.info(
                "flight log: removed the old %s (max_total_mb = %g, keep_files = %d)",
                name,
                config.max_total_mb,
                config.keep_files,
            )
        except FileNotFoundError:
            pass
        except OSError as exc:
            _warn_once(warned, p, exc)
            continue
        _remove(marker(p), warned)
    for p in orphan_markers(directory):
        _remove(p, warned)
    return removed


def _remove(p: Path, warned: set[str]) -> None:
    try:
        p.unlink(missing_ok=True)
    except OSError as exc:
        _warn_once(warned, p, exc)


def _warn_once(warned: set[str], p: Path, exc: OSError) -> None:
    if p.name not in warned:
        warned.add(p.name)
        log.warning("flight log: cannot remove the old %s: %s (the directory may go over its budget)", p, exc)


def mark_flight(path: Path) -> None:
    """Mark ``path`` as a log that saw the vehicle RUNNING (the empty marker beside it, made durable)."""
    flag = marker(path)
    flag.touch()
    fd = os.open(flag.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    log.info("flight log: %s holds a flight (RUNNING): kept before boot-only logs", path.name)


def _create(directory: Path, start: dt.datetime) -> tuple[Path, BinaryIO]:
    """The next log file, created (never one that exists: another run may have taken the number)."""
    seq = next_sequence(directory)
    for n in range(seq, seq + 100):
        path = directory / log_name(n, start)
        try:
            return path, open(path, "xb")  # the writer thread closes it
        except FileExistsError:
            continue
    raise FileExistsError(f"{directory}: logs {seq}..{seq + 99} all exist")


def _leaves(node: Any, prefix: str = "") -> dict[str, str]:
    out: dict[str, str] = {}
    for f in dataclasses.fields(node):
        if not f.init:
            continue
        value = getattr(node, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out.update(_leaves(value, f"{prefix}{f.name}."))
        else:
            out[f"{prefix}{f.name}"] = repr(value)
    return out


def run_metadata(config: Any, config_name: str, start: dt.datetime) -> dict[str, dict[str, str]]:
    """The metadata records of a run: ``flight_log`` (UTC start, vehicle, software, configuration file, time
    base) and ``config`` (every value of the ``OnboardConfig`` in force, ``repr`` by dotted key)."""
    try:
        version = importlib.metadata.version("isimi100-autonomy")
    except importlib.metadata.PackageNotFoundError:
        version = "unknown"
    return {
        "flight_log": {
            "vehicle": "ISiMI100",
            "software": f"isimi100-autonomy {version}",
            "config": config_name,
            "start_utc": _utc_iso(start),
            "time_source": str(config.loop.time_source),
            "rate_hz": f"{config.loop.rate_hz:g}",
            "system_id": str(config.mavlink.system_id),
            "host": platform.node(),
            "log_time": "the loop's t_s in ns (the monotonic clock in real time, simulated in lock-step)",
        },
        "config": _leaves(config),
    }


def open_flight_log(
    config: LogConfig,
    state_dir: Path,
    metadata: Mapping[str, Mapping[str, str]] | None = None,
    start: dt.datetime | None = None,
) -> FlightLog | None:
    """Start the flight log of a run in ``config.directory(state_dir)`` (the directory kept within the
    budget: :func:`rotate`, now and as the log grows), or None: off by configuration, or the file cannot be
    created (one warning: the vehicle flies without it). ``start``: the UTC start time (in the name; default
    now)."""
    if not config.enabled:
        return None
    directory = config.directory(state_dir)
    when = start if start is not None else dt.datetime.now(dt.UTC)
    stream = None
    warned: set[str] = set()
    try:
        directory.mkdir(parents=True, exist_ok=True)
        path, stream = _create(directory, when)
        flight = FlightLog(
            stream,
            path=path,
            metadata=metadata,
            flush_period_s=config.flush_period_s,
            on_flight=lambda: mark_flight(path),
            after_flush=lambda: rotate(directory, config, path, warned),
        )
    except OSError as exc:
        log.warning("flight log off: cannot write in %s: %s (the vehicle goes on without it)", directory, exc)
        if stream is not None:
            try:
                stream.close()
            except OSError:
                pass
        return None
    rotate(directory, config, path, warned)
    log.info("flight log: %s", path)
    return flight


__all__ = [
    "EVENTS",
    "MISSION",
    "PATH",
    "TELEMETRY",
    "FlightLog",
    "LogConfig",
    "LoggedLink",
    "log_files",
    "mark_flight",
    "open_flight_log",
    "rotate",
    "run_metadata",
    "sample_path",
]
