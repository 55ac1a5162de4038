"""One record per tick, one set of names: the CSV row, the MAVLink snapshot and the MCAP log read the same."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from onboard.adapters.mavlink import bridge
from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.app.flight_log import TELEMETRY, FlightLog, LoggedLink
from onboard.core import commands as c
from onboard.core.mission.model import Goal
from onboard.core.mission.state import MissionState
from tests.unit.app.test_flight_log import read
from tests.unit.autopilot.test_autopilot import DT, sensors, started, tick


def _same(a: object, b: object) -> bool:
    """Equal, NaN and None (the log's null) counting as the same unknown."""
    unknown_a = a is None or (isinstance(a, float) and math.isnan(a))
    unknown_b = b is None or (isinstance(b, float) and math.isnan(b))
    return unknown_a == unknown_b and (unknown_a or a == b)


def test_the_row_the_snapshot_and_the_flight_log_carry_one_record_under_one_set_of_names(
    tmp_path: Path,
) -> None:
    # GIVEN the real core flying a goal, its ticks through the bridge to a flight log (no MAVLink link)
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    flight = FlightLog(open(tmp_path / "f.mcap", "xb"))
    link = LoggedLink(flight, None, lambda: ap.mission.obstacles)
    rows, snaps = [], []
    for k in range(1, 11):
        out = tick(ap, k * DT, x=0.5 * k * DT, y=0.2)
        rows.append(out.telemetry_row())
        snaps.append(bridge.snapshot(ap, out, k * DT))
        bridge.after_tick(ap, link, out, k * DT)
    # WHEN navigation goes stale (the same samples, 5 s old): the failsafe aborts
    out = ap.step(sensors(0.0), 5.0, DT)
    assert out.status.state is MissionState.ABORT
    rows.append(out.telemetry_row())
    snaps.append(bridge.snapshot(ap, out, 5.0))
    bridge.after_tick(ap, link, out, 5.0)
    flight.close()
    logged = read(tmp_path / "f.mcap")["topics"][TELEMETRY]
    # THEN every name the snapshot shares with the row carries the row's value, in the snapshot and the log
    shared = set(rows[0]) & {f.name for f in dataclasses.fields(VehicleSnapshot)} - {"state"}
    assert {"e_yaw_rad", "e_depth_m", "cross_track_m", "nav_conditions", "failsafe_flags"} <= shared
    for row, snap, msg in zip(rows, snaps, logged, strict=True):
        for name in shared:
            assert _same(getattr(snap, name), row[name]), name
            assert _same(msg[name], row[name]), name
    # AND the guidance errors of a flown tick are there (not NaN), and the log carries the nav conditions and
    # the failsafe bits of the abort
    assert math.isfinite(float(logged[5]["e_yaw_rad"])) and logged[5]["failsafe_flags"] == 0
    assert logged[-1]["failsafe_flags"] == int(out.failsafe_flags) != 0
    assert logged[-1]["nav_conditions"] == int(out.nav.conditions) != 0


def test_the_record_keeps_each_stages_debug() -> None:
    # GIVEN the real core flying a goal
    ap = started((Goal(20.0, 0.0, 1.0, 0.0),))
    for k in range(1, 5):
        out = tick(ap, k * DT, x=0.5 * k * DT, y=0.2)
    # THEN the tick's record carries the debug of navigation, guidance and the PD, and the row shows them
    assert out.nav_debug is not None and out.guidance_debug is not None and out.control_debug is not None
    row = out.telemetry_row()
    assert row["rps_ff"] == out.control_debug.rps_ff and row["crab_rad"] == out.guidance_debug.crab_rad
    # AND a tick that flies nothing has no guidance or PD debug (NaN in the row, the same columns)
    ap.handle(c.Hold())
    held = tick(ap, 1.0)
    assert held.guidance_debug is None and held.control_debug is None
    assert list(held.telemetry_row()) == list(row) and math.isnan(float(held.telemetry_row()["rps_ff"]))
