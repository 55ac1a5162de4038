"""The onboard flight log: ticks in, an MCAP file out (read back with mcap's reader), rotation, disk full."""

from __future__ import annotations

import datetime as dt
import io
import json
import logging
import math
import os
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from auv_common.config import ConfigError
from onboard.adapters.log_files import LogFile, marker, scan, to_remove
from onboard.adapters.mavlink import bridge
from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.app.config import config_from_dict, load_config
from onboard.app.flight_log import (
    EVENTS,
    MISSION,
    PATH,
    TELEMETRY,
    TELEMETRY_FIELDS,
    FlightLog,
    LogConfig,
    LoggedLink,
    log_files,
    open_flight_log,
    rotate,
    run_metadata,
    sample_path,
)
from onboard.core.autopilot import Autopilot
from onboard.core.commands import Note, Severity
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.state import MissionState
from onboard.core.planner.path import ArcSegment, StraightSegment
from onboard.core.planner.path import Path as PlannedPath
from onboard.core.planner.planner import plan
from tests.unit.autopilot.test_autopilot import DT, core, started, tick

S = MissionState
GOALS = (Goal(10.0, 0.0, 2.0, 0.5), Goal(20.0, 5.0, 1.0, None))
FENCE = (Obstacle(5.0, 3.0, 1.5),)
# one straight segment north, 10 m long, diving 1 -> 2 m
STRAIGHT = PlannedPath((StraightSegment(0.0, 0.0, 0.0, 10.0),), start_depth_m=1.0, end_depth_m=2.0, word="S")


def read(path: Path) -> dict[str, Any]:
    """Everything in a log: messages by topic (decoded JSON with log_time), schemas, metadata, summary."""
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        by_topic: dict[str, list[dict[str, Any]]] = {}
        schemas: dict[str, tuple[str, str, dict[str, Any]]] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            assert schema is not None
            schemas[channel.topic] = (schema.encoding, channel.message_encoding, json.loads(schema.data))
            by_topic.setdefault(channel.topic, []).append(
                {"log_time": message.log_time, "sequence": message.sequence, **json.loads(message.data)}
            )
        f.seek(0)
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    return {"topics": by_topic, "schemas": schemas, "metadata": metadata, "summary": summary}


def snap(t_s: float, state: S = S.IDLE, **fields: Any) -> VehicleSnapshot:
    base: dict[str, Any] = {"x_m": 1.0 + t_s, "y_m": -2.0, "depth_m": 1.5, "propeller_rps": 0.0}
    return VehicleSnapshot(t_s=t_s, state=state, **{**base, **fields})


def flight_ticks() -> list[tuple[VehicleSnapshot, list[Note], tuple[Obstacle, ...]]]:
    """Eight ticks: idle without a mission, a mission arrives, armed, running on a path (a new path at
    t = 0.6), then the path is gone and the vehicle holds; notes on two of them."""
    other = PlannedPath((ArcSegment(0.0, 3.0, 3.0, -1, 0.0, math.pi / 2),), word="L")
    run = {"mission_goals": GOALS, "path_kind": "goal", "path_goal_index": 0}
    return [
        (snap(0.0), [], ()),
        (snap(0.1), [], ()),
        (snap(0.2, mission_goals=GOALS), [], FENCE),
        (
            snap(0.3, S.ARMED, mission_goals=GOALS, armed=True, reason="armed"),
            [Note(Severity.INFO, "armed")],
            FENCE,
        ),
        (snap(0.4, S.RUNNING, armed=True, reason="started", path=STRAIGHT, **run), [], FENCE),
        (snap(0.5, S.RUNNING, armed=True, path=STRAIGHT, rudder_saturated=True, **run), [], FENCE),
        (snap(0.6, S.RUNNING, armed=True, path=other, **run), [Note(Severity.WARNING, "re-planned")], FENCE),
        (
            snap(
                0.7,
                S.HOLD,
                mission_goals=GOALS,
                reason="operator hold",
                failsafe="none really",
                loop_load=0.25,
            ),
            [],
            FENCE,
        ),
    ]


def write(path: Path, ticks: Any, **kw: Any) -> FlightLog:
    flight = FlightLog(open(path, "xb"), path=path, metadata={"flight_log": {"vehicle": "test"}}, **kw)
    for snapshot, notes, obstacles in ticks:
        flight.notify(notes)
        flight.publish(snapshot, obstacles)
    flight.close()
    return flight


def test_a_log_of_synthetic_ticks_reads_back_channel_by_channel(tmp_path: Path) -> None:
    # GIVEN eight ticks (mission, states, two paths and the end of a path, notes) WHEN they are logged
    path = tmp_path / "flight.mcap"
    flight = write(path, flight_ticks())
    assert flight.finished and not flight.failed and flight.dropped == 0
    log = read(path)
    topics = log["topics"]
    # THEN the four channels are JSON with JSON Schemas, and the summary (footer) counts every message
    assert set(log["schemas"]) == {TELEMETRY, PATH, MISSION, EVENTS}
    assert all((enc, menc) == ("jsonschema", "json") for enc, menc, _ in log["schemas"].values())
    assert {t: len(v) for t, v in topics.items()} == {TELEMETRY: 8, PATH: 3, MISSION: 2, EVENTS: 6}
    assert flight.counts == {TELEMETRY: 8, PATH: 3, MISSION: 2, EVENTS: 6}
    summary = log["summary"]
    assert summary is not None and summary.statistics.message_count == 19
    # AND /telemetry: every tick at its loop time (ns), every plain field of the snapshot, NaN as null
    tel = topics[TELEMETRY]
    assert [m["log_time"] for m in tel] == [k * 100_000_000 for k in range(8)]
    assert [m["state"] for m in tel] == ["IDLE"] * 3 + ["ARMED"] + ["RUNNING"] * 3 + ["HOLD"]
    assert set(tel[0]) - {"log_time", "sequence"} == {name for name, _ in TELEMETRY_FIELDS}
    assert {"x_m", "yaw_rad", "rudder_rad", "rudder_saturated", "failsafe", "overruns", "loop_load"} <= set(
        tel[0]
    )
    assert tel[2]["x_m"] == pytest.approx(1.2) and tel[0]["yaw_rad"] is None and tel[0]["failsafe"] == ""
    assert tel[5]["rudder_saturated"] is True and tel[4]["rudder_saturated"] is False
    assert tel[7]["failsafe"] == "none really" and tel[7]["loop_load"] == 0.25 and tel[7]["armed"] is False
    assert tel[4]["path_kind"] == "goal" and tel[4]["path_goal_index"] == 0
    # AND /path when the path is a new object: 10 m sampled every 0.5 m, then the arc, then none
    paths = topics[PATH]
    assert [p["t_s"] for p in paths] == [0.4, 0.6, 0.7]
    first = paths[0]
    assert first["kind"] == "goal" and first["goal_index"] == 0 and first["length_m"] == 10.0
    assert first["x_m"] == pytest.approx([0.5 * i for i in range(21)]) and set(first["y_m"]) == {0.0}
    assert first["depth_m"] == pytest.approx([1.0 + 0.05 * i for i in range(21)])
    assert len(paths[1]["x_m"]) == math.ceil(3.0 * math.pi / 2 / 0.5) + 1 and paths[1]["word"] == "L"
    assert paths[2]["kind"] == "" and paths[2]["x_m"] == [] and paths[2]["goal_index"] == -1
    # AND /mission when the goals or the fence change: none at first, then the goals with the fence
    missions = topics[MISSION]
    assert missions[0]["goals"] == [] and missions[0]["obstacles"] == []
    assert missions[1]["t_s"] == 0.2 and missions[1]["obstacles"] == [
        {"x_m": 5.0, "y_m": 3.0, "radius_m": 1.5}
    ]
    assert missions[1]["goals"] == [
        {"x_m": 10.0, "y_m": 0.0, "depth_m": 2.0, "yaw_rad": 0.5},
        {"x_m": 20.0, "y_m": 5.0, "depth_m": 1.0, "yaw_rad": None},
    ]
    # AND /events: each state change with its reason, each note with its severity, in order
    events = [
        (e["t_s"], e["kind"], e["from_state"], e["to_state"], e["reason"], e["severity"], e["text"])
        for e in topics[EVENTS]
    ]
    assert events == [
        (0.0, "state", "", "IDLE", "", "", ""),
        (0.3, "state", "IDLE", "ARMED", "armed", "", ""),
        (0.3, "note", "", "", "", "INFO", "armed"),
        (0.4, "state", "ARMED", "RUNNING", "started", "", ""),
        (0.6, "note", "", "", "", "WARNING", "re-planned"),
        (0.7, "state", "RUNNING", "HOLD", "operator hold", "", ""),
    ]
    # AND the metadata: the caller's records and the end record with the counts
    assert log["metadata"]["flight_log"] == {"vehicle": "test"}
    end = log["metadata"]["flight_log_end"]
    assert end["messages_telemetry"] == "8" and end["dropped_ticks"] == "0" and end["end_utc"].endswith("Z")


def test_schemas_are_what_foxglove_parses_one_type_per_field(tmp_path: Path) -> None:
    # Foxglove's JSON Schema reader takes an object with properties, one string "type" each (no type lists)
    path = tmp_path / "f.mcap"
    write(path, flight_ticks()[:1])

    def check(schema: dict[str, Any]) -> None:
        assert schema["type"] == "object"
        for prop in schema["properties"].values():
            assert isinstance(prop["type"], str) and prop["type"] != "null"
            if prop["type"] == "object":
                check(prop)
            if prop["type"] == "array":
                assert isinstance(prop["items"]["type"], str)
                if prop["items"]["type"] == "object":
                    check(prop["items"])

    for _enc, _menc, schema in read(path)["schemas"].values():
        check(schema)


@pytest.mark.parametrize(
    ("length_m", "points"),
    [(0.0, 1), (0.3, 2), (0.5, 2), (1.0, 3), (10.0, 21), (10.2, 22)],
)
def test_a_path_is_sampled_every_half_metre_both_ends_kept(length_m: float, points: int) -> None:
    path = PlannedPath(
        (StraightSegment(1.0, 2.0, math.pi / 2, length_m),), start_pose=(1.0, 2.0, math.pi / 2)
    )
    xs, ys, ds = sample_path(path)
    assert len(xs) == len(ys) == len(ds) == points
    assert xs[0] == pytest.approx(1.0) and ys[0] == pytest.approx(2.0)
    assert ys[-1] == pytest.approx(2.0 + length_m)  # east along yaw = pi/2
    gaps = [math.hypot(xs[i + 1] - xs[i], ys[i + 1] - ys[i]) for i in range(points - 1)]
    assert all(g <= 0.5 + 1e-9 for g in gaps)


def test_a_planned_path_sampled_lies_on_the_path() -> None:
    # GIVEN a real plan from the planner (turns, a straight, a dive) WHEN sampled
    path = plan((0.0, 0.0, 0.0), (15.0, 12.0, math.pi), obstacles=[(8.0, 5.0, 1.0)], goal_depth_m=3.0)
    xs, ys, ds = sample_path(path)
    # THEN evenly spaced at most 0.5 m of arc apart, from the start to the goal, each point on the path
    n = len(xs) - 1
    assert n == math.ceil(path.length_m / 0.5 - 1e-9)
    for i in range(n + 1):
        ref = path.sample(path.length_m * i / n)
        assert (xs[i], ys[i], ds[i]) == pytest.approx((ref.x_m, ref.y_m, ref.depth_m))
    assert (xs[-1], ys[-1], ds[-1]) == pytest.approx((15.0, 12.0, 3.0), abs=1e-6)


def test_the_real_core_through_the_bridge_logs_transitions_paths_and_notes(tmp_path: Path) -> None:
    # GIVEN the real autopilot started on a mission with a fence, its ticks through the bridge's exchange
    # with the flight log beside the link (no MAVLink link: the log alone)
    goals, fence = (Goal(20.0, 0.0, 1.0, 0.0),), (Obstacle(10.0, 6.0, 1.0),)
    ap = started(goals, fence)
    flight = FlightLog(open(tmp_path / "f.mcap", "xb"))
    link = LoggedLink(flight, None, lambda: ap.mission.obstacles)
    for k in range(1, 41):
        t = k * DT
        bridge.before_tick(ap, link)
        out = tick(ap, t, x=0.5 * t)
        bridge.after_tick(ap, link, out, t, overruns=0)
    flight.close()
    topics = read(tmp_path / "f.mcap")["topics"]
    # THEN every tick, the transition to RUNNING with the core's reason, the planned path and the mission
    assert len(topics[TELEMETRY]) == 40
    states = [(e["from_state"], e["to_state"]) for e in topics[EVENTS] if e["kind"] == "state"]
    assert states == [("", "RUNNING")]  # ARMED -> RUNNING happened at the start, before the log
    paths = topics[PATH]
    assert paths and paths[0]["kind"] == "goal" and paths[0]["x_m"][-1] == pytest.approx(20.0, abs=1e-6)
    assert topics[MISSION][0]["obstacles"] == [{"x_m": 10.0, "y_m": 6.0, "radius_m": 1.0}]
    assert all(m["t_s"] > 0.0 for m in topics[TELEMETRY]) and topics[TELEMETRY][-1]["propeller_rps"] > 0.0


# --- files: names, rotation ----------------------------------------------------------------------------
def boot_only(seq: int, size: int, **kw: Any) -> LogFile:
    return LogFile(f"b{seq}", size, (seq, 0, f"b{seq}"), has_flight=False, **kw)


def flown(seq: int, size: int, **kw: Any) -> LogFile:
    return LogFile(f"f{seq}", size, (seq, 0, f"f{seq}"), has_flight=True, **kw)


def test_rotation_removes_boot_only_logs_before_flights_oldest_first_never_the_current() -> None:
    logs = [
        flown(1, 100),
        boot_only(2, 100),
        flown(3, 100),
        boot_only(4, 100),
        boot_only(5, 50, is_current=True),
    ]
    # within both limits: nothing
    assert to_remove(logs, max_total_bytes=450, max_files=5) == []
    # over the bytes: the boot-only logs first (oldest first), then the oldest flight
    assert to_remove(logs, max_total_bytes=300, max_files=5) == ["b2", "b4"]
    assert to_remove(logs, max_total_bytes=200, max_files=5) == ["b2", "b4", "f1"]
    # over the files: the same order
    assert to_remove(logs, max_total_bytes=10_000, max_files=4) == ["b2"]
    # the current log alone over the budget: it stays, all the others go
    assert to_remove(logs, max_total_bytes=10, max_files=1) == ["b2", "b4", "f1", "f3"]
    # a crash loop of 31 boot-only logs after 3 flights, 20 files kept: every flight stays
    loop = [flown(i, 1000) for i in range(1, 4)] + [boot_only(i, 10) for i in range(4, 35)]
    loop[-1] = boot_only(34, 10, is_current=True)
    gone = to_remove(loop, max_total_bytes=10**9, max_files=20)
    assert len(gone) == 14 and all(n.startswith("b") for n in gone) and "b34" not in gone


@settings(max_examples=300, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 1000), st.booleans()), min_size=1, max_size=30),
    st.integers(0, 5000),
    st.integers(1, 30),
    st.data(),
)
def test_rotation_choice_properties(
    files: list[tuple[int, bool]], budget: int, max_files: int, data: st.DataObject
) -> None:
    current = data.draw(st.integers(0, len(files) - 1))
    logs = [
        LogFile(f"n{i}", size, (i, 0, f"n{i}"), flew, is_current=i == current)
        for i, (size, flew) in enumerate(files)
    ]
    gone = to_remove(logs, budget, max_files)
    kept = [f for f in logs if f.name not in gone]
    by_name = {f.name: f for f in logs}
    # never the current one; the rest within the limits when the current one allows it
    assert f"n{current}" not in gone
    if logs[current].size_bytes <= budget:
        assert sum(f.size_bytes for f in kept) <= budget and len(kept) <= max_files
    # boot-only before flights, oldest first within each; no log removed that need not be
    assert [by_name[n] for n in gone] == sorted(
        (by_name[n] for n in gone), key=lambda f: (f.has_flight, f.order)
    )
    candidates = sorted((f for f in logs if not f.is_current), key=lambda f: (f.has_flight, f.order))
    assert gone == [f.name for f in candidates[: len(gone)]]
    if gone:
        before_last = [f for f in logs if f.name not in gone[:-1]]
        assert sum(f.size_bytes for f in before_last) > budget or len(before_last) > max_files


def test_names_carry_a_sequence_and_the_order_is_creation_not_the_date_in_a_name(tmp_path: Path) -> None:
    logs = tmp_path / "state" / "logs"
    logs.mkdir(parents=True)
    # GIVEN logs of the older firmware named by a clock that ran ahead (2030), written in this order
    for i, day in enumerate((3, 1, 2)):
        (logs / f"flight-203001{day:02d}-120000.mcap").write_bytes(b"old")
        os.utime(logs / f"flight-203001{day:02d}-120000.mcap", ns=(10**18 + i, 10**18 + i))
    (logs / "notes.txt").write_text("kept")
    start = dt.datetime(2024, 3, 1, 8, 30, 5, tzinfo=dt.UTC)
    # WHEN two runs start in the same second
    first = open_flight_log(LogConfig(), tmp_path / "state", {}, start)
    second = open_flight_log(LogConfig(), tmp_path / "state", {}, start)
    assert first is not None and second is not None
    first.close()
    second.close()
    # THEN each has the next sequence number and the UTC start; the order is creation, old names first
    assert [p.name for p in log_files(logs)] == [
        "flight-20300103-120000.mcap",
        "flight-20300101-120000.mcap",
        "flight-20300102-120000.mcap",
        "flight-000001-20240301-083005.mcap",
        "flight-000002-20240301-083005.mcap",
    ]
    assert (logs / "notes.txt").exists()
    # AND a clock that runs ahead later changes nothing: the sequence goes on
    ahead = open_flight_log(LogConfig(), tmp_path / "state", {}, dt.datetime(2031, 1, 1, tzinfo=dt.UTC))
    behind = open_flight_log(LogConfig(), tmp_path / "state", {}, dt.datetime(2001, 1, 1, tzinfo=dt.UTC))
    assert ahead is not None and behind is not None
    ahead.close()
    behind.close()
    assert [p.name for p in log_files(logs)][-2:] == [
        "flight-000003-20310101-000000.mcap",
        "flight-000004-20010101-000000.mcap",
    ]


def test_a_run_keeps_its_own_log_among_logs_named_ahead_and_marks_a_flight(tmp_path: Path) -> None:
    logs = tmp_path / "state" / "logs"
    logs.mkdir(parents=True)
    for day in range(1, 21):  # 20 logs named 2030 by a clock that ran ahead
        (logs / f"flight-203001{day:02d}-120000.mcap").write_bytes(b"x" * 1000)
    # WHEN a run starts with room for 20 files
    flight = open_flight_log(LogConfig(keep_files=20), tmp_path / "state", {})
    # THEN its own new log is there, the oldest 2030 log made room
    assert flight is not None and flight.path is not None and flight.path.exists()
    assert not (logs / "flight-20300101-120000.mcap").exists() and len(log_files(logs)) == 20
    # WHEN it logs a tick RUNNING
    flight.publish(snap(0.0, S.ARMED))
    flight.publish(snap(0.1, S.RUNNING))
    # THEN the writer marks it a flight at once (before any close: a crash keeps the mark)
    deadline = time.monotonic() + 30.0
    while not marker(flight.path).exists():
        assert time.monotonic() < deadline, "no mark within 30 s"
        time.sleep(0.01)
    flight.close()
    assert [f.has_flight for f in scan(logs) if f.name == flight.path.name] == [True]
    # AND a run that never flies leaves no mark; rotating its log out removes its mark too
    boot = open_flight_log(LogConfig(keep_files=20), tmp_path / "state", {})
    assert boot is not None and boot.path is not None
    boot.publish(snap(0.0, S.IDLE))
    boot.close()
    assert not marker(boot.path).exists() and boot.path.exists()
    # AND a boot-only log goes before any flight (the 2030 ones count as flights: nothing cheap tells)
    assert rotate(logs, LogConfig(keep_files=19)) == [boot.path]
    assert rotate(logs, LogConfig(keep_files=1)) == [
        logs / f"flight-203001{d:02d}-120000.mcap" for d in range(3, 21)
    ]
    assert log_files(logs) == [flight.path]
    # AND a flight rotated out takes its mark with it (a later run, one file kept)
    last = open_flight_log(LogConfig(keep_files=1), tmp_path / "state", {})
    assert last is not None
    last.close()
    assert log_files(logs) == [last.path] and sorted(p.name for p in logs.iterdir()) == [last.path.name]


def test_the_directory_stays_within_its_bytes_as_the_log_grows(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    for seq in range(1, 6):  # five older boot-only logs of 4 kB
        (logs / f"flight-{seq:06d}-20240101-000000.mcap").write_bytes(b"x" * 4000)
    # WHEN a run with a 20 kB budget logs ticks, a chunk flushed every 0.1 s
    config = LogConfig(dir=str(logs), max_total_mb=0.02, flush_period_s=0.1)
    flight = open_flight_log(config, tmp_path, {})
    assert flight is not None and flight.path is not None
    current = flight.path

    def within() -> bool:
        return sum(p.stat().st_size for p in logs.iterdir()) <= 20_000 or log_files(logs) == [current]

    for i in range(2000):
        flight.publish(snap(i * 0.05, S.RUNNING, x_m=i * 0.1234567))
        if i % 200 == 199:
            # THEN after the next flush the older logs have made room for it (while there are older ones)
            deadline = time.monotonic() + 30.0
            while not within():
                assert time.monotonic() < deadline, sorted((p.name, p.stat().st_size) for p in logs.iterdir())
                time.sleep(0.02)
    flight.close()  # it writes what the writer thread still holds (on a loaded machine, all of it)
    grown = current.stat().st_size
    # AND at the end only the run's own log is left, it alone over the budget
    assert log_files(logs) == [current] and grown > 20_000


def test_the_configured_directory_and_off(tmp_path: Path) -> None:
    assert (
        open_flight_log(LogConfig(enabled=False), tmp_path, {}) is None and not (tmp_path / "logs").exists()
    )
    flight = open_flight_log(LogConfig(dir=str(tmp_path / "elsewhere")), tmp_path, {})
    assert flight is not None and flight.path is not None and flight.path.parent == tmp_path / "elsewhere"
    flight.close()
    assert read(flight.path)["summary"] is not None


def test_the_log_table_is_validated_like_the_others() -> None:
    assert load_config().log == LogConfig()  # the packaged onboard.toml says the defaults
    assert config_from_dict({"log": {"keep_files": 5, "flush_period_s": 0.5}}, "x").log.keep_files == 5
    assert config_from_dict({"log": {"max_total_mb": 0.5}}, "x").log.max_total_bytes == 500_000
    with pytest.raises(ConfigError, match=r"max_total_mb must be in \[0\.01, 1e\+06\] MB, got 0"):
        config_from_dict({"log": {"max_total_mb": 0.0}}, "onboard.toml")
    with pytest.raises(ConfigError, match=r"keep_files must be in \[1, 1000\], got 0"):
        config_from_dict({"log": {"keep_files": 0}}, "onboard.toml")
    with pytest.raises(ConfigError, match=r"flush_period_s must be in \[0\.1, 10\] s, got 60"):
        config_from_dict({"log": {"flush_period_s": 60.0}}, "onboard.toml")
    with pytest.raises(ConfigError, match=r"unknown key rate"):
        config_from_dict({"log": {"rate": 1}}, "onboard.toml")
    with pytest.raises(ConfigError, match=r"expected true or false"):
        config_from_dict({"log": {"enabled": "yes"}}, "onboard.toml")


def test_run_metadata_names_the_vehicle_the_start_and_every_config_value() -> None:
    cfg = load_config()
    meta = run_metadata(cfg, "onboard.toml", dt.datetime(2024, 3, 1, 8, 30, 5, 250000, tzinfo=dt.UTC))
    assert meta["flight_log"]["start_utc"] == "2024-03-01T08:30:05.250Z"
    assert meta["flight_log"]["vehicle"] == "ISiMI100" and meta["flight_log"]["config"] == "onboard.toml"
    assert meta["flight_log"]["software"].startswith("isimi100-autonomy ")
    assert meta["config"]["loop.rate_hz"] == "20.0" and meta["config"]["log.keep_files"] == str(
        LogConfig().keep_files
    )
    assert all(isinstance(v, str) for rec in meta.values() for v in rec.values())


# --- the loop goes on ------------------------------------------------------------------------------------
class MemoryFile(io.RawIOBase):
    """A write-only file in memory (the MCAP writer asks where it is: ``tell``)."""

    def __init__(self) -> None:
        self.data = bytearray()

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        assert (offset, whence) in ((0, io.SEEK_CUR), (len(self.data), io.SEEK_SET)), "append only"
        return len(self.data)


class FullDisk(MemoryFile):
    """A file on a disk with room for ``room`` bytes: beyond, every write is ENOSPC."""

    def __init__(self, room: int) -> None:
        super().__init__()
        self.room = room

    def write(self, b: Any) -> int:
        if len(self.data) + len(b) > self.room:
            raise OSError(28, "No space left on device")
        self.data.extend(b)
        return len(b)


def test_a_directory_that_cannot_be_written_is_one_warning_and_no_log(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    (tmp_path / "state").write_text("a file where the state directory should be")
    with caplog.at_level(logging.WARNING, logger="onboard.app.flight_log"):
        assert open_flight_log(LogConfig(), tmp_path / "state", {}) is None
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "flight log off" in warnings[0].getMessage()


def test_a_full_disk_turns_the_log_off_with_one_warning_and_the_loop_goes_on(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # GIVEN the real core through the bridge, logging onto a disk that fills up after the header
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    disk = FullDisk(room=2000)
    flight = FlightLog(io.BufferedWriter(disk), flush_period_s=0.0)  # a chunk every tick
    link = LoggedLink(flight, None)
    ticks = 0
    with caplog.at_level(logging.WARNING, logger="onboard.app.flight_log"):
        # WHEN the loop ticks on (the writer hits the full disk on its first chunks)
        for k in range(1, 101):
            t = k * DT
            out = tick(ap, t, x=0.5 * t)
            bridge.after_tick(ap, link, out, t)
            ticks += 1
        flight.close()
    # THEN every tick ran, the log is off, one warning said why, and close neither raised nor hung
    assert ticks == 100 and ap.status.state is S.RUNNING
    assert flight.failed and not flight.finished
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "No space left on device" in warnings[0], warnings
    flight.publish(VehicleSnapshot(t_s=99.0))  # after the failure and the close: nothing, no error


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full")
def test_dev_full_is_a_disk_full_too(caplog: pytest.LogCaptureFixture) -> None:
    flight = FlightLog(open("/dev/full", "wb"), path=Path("/dev/full"), flush_period_s=0.0)
    with caplog.at_level(logging.WARNING, logger="onboard.app.flight_log"):
        for k in range(20):
            flight.publish(snap(k * 0.05))
        flight.close()
    assert flight.failed and [r.levelno for r in caplog.records] == [logging.WARNING]


class GatedFile(MemoryFile):
    """A file whose writes wait for ``gate`` (a slow disk); ``waiting`` is set when one waits."""

    def __init__(self) -> None:
        super().__init__()
        self.gate = threading.Event()
        self.gate.set()
        self.waiting = threading.Event()

    def write(self, b: Any) -> int:
        if not self.gate.is_set():
            self.waiting.set()
            self.gate.wait(10.0)
        self.data.extend(b)
        return len(b)


def test_a_writer_behind_drops_ticks_counted_and_never_blocks_the_loop(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # GIVEN a log whose disk stalls (the writer thread waits in a write) and room for 4 ticks in the queue
    f = GatedFile()
    flight = FlightLog(io.BufferedWriter(f, buffer_size=1), queue_ticks=4, flush_period_s=0.0)
    f.gate.clear()
    flight.publish(snap(0.0))
    assert f.waiting.wait(5.0)
    # WHEN the loop publishes 20 more ticks meanwhile
    with caplog.at_level(logging.WARNING, logger="onboard.app.flight_log"):
        for k in range(1, 21):
            flight.publish(snap(k * 0.05))
    # THEN it was never blocked: 4 queued, 16 dropped and counted, one warning
    assert flight.dropped == 16
    assert [r.getMessage() for r in caplog.records if "behind" in r.getMessage()] != []
    assert len(caplog.records) == 1
    # AND once the disk is back the rest is written, the file is whole and says what was dropped
    f.gate.set()
    flight.close()
    assert flight.finished and flight.counts[TELEMETRY] == 5
    buf = io.BytesIO(bytes(f.data))
    reader = make_reader(buf)
    summary = reader.get_summary()
    assert summary is not None and summary.statistics.message_count >= 5
    meta = {m.name: m.metadata for m in reader.iter_metadata()}
    assert meta["flight_log_end"]["dropped_ticks"] == "16"


def test_the_bridge_exchange_with_a_link_and_the_log_reaches_both() -> None:
    # GIVEN a link (the MAVLink side's protocol) and the log beside it
    class Link:
        def __init__(self) -> None:
            self.calls: list[str] = []

        def take_requests(self) -> list[Any]:
            self.calls.append("take")
            return []

        def answer(self, request_id: int, verdict: Any) -> None:
            self.calls.append("answer")

        def notify(self, notes: list[Note]) -> None:
            self.calls.append(f"notify {len(notes)}")

        def publish(self, snapshot: VehicleSnapshot) -> None:
            self.calls.append(f"publish {snapshot.t_s}")

    inner = Link()
    buf = io.BytesIO()
    flight = FlightLog(buf)
    link = LoggedLink(flight, inner)
    ap = Autopilot(core())
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),)))
    bridge.before_tick(ap, link)
    out = tick(ap, 0.05)
    bridge.after_tick(ap, link, out, 0.05)
    flight.close()
    # THEN the link got what it always got, and the log the same tick
    assert inner.calls == ["take", "notify 1", "publish 0.05"]
    assert flight.counts[TELEMETRY] == 1 and flight.counts[EVENTS] == 2  # the first state and the note


# --- `auv-gcs plot` of a flight log ----------------------------------------------------------------------
def test_plot_draws_a_flight_log_with_paths_goals_fence_and_states(tmp_path: Path) -> None:
    from groundstation.plot import plot_tlog

    path = tmp_path / "flight.bin"  # the magic bytes say MCAP, not the name
    write(path, flight_ticks())
    drawn = plot_tlog(path, tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 10_000
    assert drawn == {
        "ticks": 8,
        "positions": 8,
        "paths": 2,  # the straight and the arc; the empty one draws nothing
        "path_points": 21 + 11,
        "goals": 2,
        "obstacles": 1,
        "missions": 1,  # the empty first one is no mission
        "state_changes": 3,  # IDLE -> ARMED -> RUNNING -> HOLD (the first state is no change)
        "notes": 2,
        "truncated": 0,
        "skipped": 0,
    }


def test_plot_draws_a_log_cut_short_as_far_as_it_goes(tmp_path: Path) -> None:
    from groundstation.plot import plot_tlog

    # GIVEN a log written a chunk per tick and cut at 60 % (the vehicle lost power: no footer)
    path = tmp_path / "flight.mcap"
    write(
        path,
        [(snap(0.05 * k, S.RUNNING if k > 10 else S.ARMED), [], ()) for k in range(40)],
        flush_period_s=0.0,
    )
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 6 // 10])
    drawn = plot_tlog(path, tmp_path / "f.png")
    assert drawn["truncated"] == 1 and 10 < drawn["ticks"] < 40 and drawn["state_changes"] == 1


@pytest.mark.parametrize(
    ("content", "reason"),
    [
        (b"not a telemetry log\n", "not a tlog"),
        (b"\x89MCAP0\r\n" + b"\x00" * 40, "MCAP file cut short before its first tick"),
    ],
)
def test_plot_refuses_what_is_neither_with_the_reason(tmp_path: Path, content: bytes, reason: str) -> None:
    from groundstation.plot import plot_tlog

    f = tmp_path / "x.mcap"
    f.write_bytes(content)
    with pytest.raises(ValueError, match=reason):
        plot_tlog(f, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_plot_refuses_an_mcap_that_is_no_flight_log(tmp_path: Path) -> None:
    from mcap.writer import Writer

    from groundstation.plot import plot_tlog

    f = tmp_path / "other.mcap"
    with open(f, "wb") as out:
        w = Writer(out)
        w.start()
        schema = w.register_schema("x", "jsonschema", b'{"type": "object", "properties": {}}')
        channel = w.register_channel("/camera", "json", schema)
        w.add_message(channel, 1, b"{}", 1)
        w.finish()
    with pytest.raises(ValueError, match="not an onboard flight log"):
        plot_tlog(f, tmp_path / "x.png")


def _foreign_log(path: Path, messages: list[tuple[str, bytes]]) -> Path:
    """An MCAP file of another program (or a damaged one) with the flight log's JSON topics: ``messages``
    as (topic, raw data), a footer at the end."""
    from mcap.writer import Writer

    with open(path, "wb") as out:
        w = Writer(out)
        w.start()
        schema = w.register_schema("x", "jsonschema", b'{"type": "object"}')
        channels = {t: w.register_channel(t, "json", schema) for t in ("/telemetry", "/path", "/mission")}
        for k, (topic, data) in enumerate(messages):
            w.add_message(channels[topic], k, data, k)
        w.finish()
    return path


def _tick(k: int) -> tuple[str, bytes]:
    return "/telemetry", json.dumps({"t_s": 0.1 * k, "x_m": 0.5 * k, "y_m": 0.0, "depth_m": 1.0}).encode()


def test_plot_skips_flight_log_messages_that_are_no_json_object(tmp_path: Path) -> None:
    from groundstation.plot import plot_tlog

    # GIVEN a log whose /telemetry holds a JSON list, a string, no JSON and 100000 nested lists among ticks
    deep = b"[" * 100_000 + b"]" * 100_000
    junk = [("/telemetry", b"[1, 2]"), ("/telemetry", b'"tick"'), ("/telemetry", b"{not json"),
            ("/telemetry", deep), ("/mission", b"[]"), ("/path", b"7")]  # fmt: skip
    f = _foreign_log(tmp_path / "f.mcap", [_tick(0), *junk, _tick(1), _tick(2)])
    # WHEN plotted
    drawn = plot_tlog(f, tmp_path / "f.png")
    # THEN the ticks are drawn, the rest skipped and counted (no TypeError: a list is no message)
    assert (drawn["ticks"], drawn["skipped"], drawn["truncated"]) == (3, len(junk), 0)
    assert (tmp_path / "f.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    ("message", "reason"),
    [
        (("/mission", b'{"goals": [{"x_m": 1.0}]}'), "/mission message 0: missing goals[0].y_m"),
        (("/mission", b'{"goals": [[1.0, 2.0]]}'), "/mission message 0: goals[0] must be an object"),
        (("/mission", b'{"goals": 5}'), "/mission message 0: goals must be an array, got 5"),
        (("/mission", b'{"goals": [{"x_m": "1", "y_m": 2}]}'), 'goals[0].x_m must be a number, got "1"'),
        (("/mission", b'{"obstacles": [{"x_m": 1, "y_m": 2}]}'), "missing obstacles[0].radius_m"),
        (("/path", b'{"x_m": [1.0, 2.0]}'), "/path message 0: x_m has 2 points, y_m 0"),
        (("/path", b'{"x_m": 3, "y_m": 4}'), "/path message 0: x_m must be an array, got 3"),
    ],
)
def test_plot_refuses_a_mission_or_path_message_it_cannot_decode_with_the_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], message: tuple[str, bytes], reason: str
) -> None:
    from groundstation import __main__ as gcs
    from groundstation.plot import plot_tlog

    # GIVEN a foreign log: good ticks, and a /mission or /path object that is not of the flight log's shape
    f = _foreign_log(tmp_path / "f.mcap", [_tick(0), message, _tick(1)])
    # THEN plotting it is a ValueError that names the file, the message and the reason; no picture
    with pytest.raises(ValueError) as err:
        plot_tlog(f, tmp_path / "f.png")
    assert str(err.value).startswith(f"{f}: ") and reason in str(err.value), err.value
    assert not (tmp_path / "f.png").exists()
    # AND the command line says so in one line, exit 2
    assert gcs.main(["--json", "plot", str(f)]) == 2
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 and reason in json.loads(lines[0])["error"]


def test_plot_of_a_tlog_marks_the_state_changes_of_the_heartbeat(tmp_path: Path) -> None:
    import struct

    from pymavlink.dialects.v20 import common as mavlink

    from groundstation.plot import plot_tlog

    # GIVEN a tlog of the vehicle (system 1): IDLE (MANUAL), RUNNING (AUTO), HOLD (POSHOLD), positions
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    records = []
    for k in range(30):
        mode = 19 if k < 10 else 3 if k < 20 else 16
        msgs = [
            mav.heartbeat_encode(mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_GENERIC, 0, mode, 4, 3),
            mav.local_position_ned_encode(k * 100, 0.5 * k, 0.0, 1.0, 0.5, 0.0, 0.0),
        ]
        records += [struct.pack(">Q", 1_700_000_000_000_000 + k * 100_000) + bytes(m.pack(mav)) for m in msgs]
    tlog = tmp_path / "gcs.tlog"
    tlog.write_bytes(b"".join(records))
    drawn = plot_tlog(tlog, tmp_path / "t.png")
    assert drawn["positions"] == 30 and drawn["state_changes"] == 2
