"""Operator thresholds that do what they say, driven the way a user does, over MAVLink on a running vehicle
(the in-process vehicle: the real core and link over a simple plant, ``conftest.Vehicle``).

- FS_NAV_TMO_S: set over MAVLink, then the attitude frames stop; the vehicle aborts once the attitude is
  older than FS_NAV_TMO_S, not before (issue 22, item 2: it aborted at 0.55 s whether 1 or 5).
- SYS_STATUS ``load``: the loop's busy time per period, per mille (issue 22, item 2: it was always 0).
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import state_from_heartbeat
from groundstation.mission_files import goal_item
from onboard.protocol import messages as m
from tests.integration.mavlink.conftest import Vehicle, wait_message


def _stop_attitude_frames(vehicle: Vehicle) -> None:
    """The fault: from the next tick on the AHRS sends nothing (its latest attitude and rates stay the ones
    already received), every other sensor goes on."""
    plant = vehicle.loop.plant
    sensors = plant.sensors
    last: dict[type, object] = {}

    def without_attitude(t_s: float, r_radps: float, w_mps: float) -> dict[type, Any]:
        cache = sensors(t_s, r_radps, w_mps)
        for kind in (m.AhrsAttitude, m.AhrsRates):
            cache[kind] = last.setdefault(kind, cache[kind])
        return cache

    plant.sensors = without_attitude  # type: ignore[method-assign]


@pytest.mark.parametrize("fs_nav_tmo_s", [1.0, 5.0])
def test_fs_nav_tmo_s_set_over_mavlink_decides_when_stopped_attitude_frames_abort(
    tmp_path: Path, fs_nav_tmo_s: float
) -> None:
    vehicle = Vehicle(tmp_path / "state").start()
    try:
        with vehicle.client() as c:
            # GIVEN a vehicle RUNNING a long leg, FS_NAV_TMO_S set over MAVLink
            ok, value = c.param_set("FS_NAV_TMO_S", fs_nav_tmo_s)
            assert ok and value == pytest.approx(fs_nav_tmo_s)
            assert c.upload([goal_item(300.0, 0.0, 1.0, None)]).ok
            assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == mavlink.MAV_RESULT_ACCEPTED
            assert c.command(mavlink.MAV_CMD_MISSION_START) == mavlink.MAV_RESULT_ACCEPTED
            wait_message(
                c,
                "RUNNING",
                lambda msg: msg.get_type() == "HEARTBEAT" and state_from_heartbeat(msg) == "RUNNING",
            )
            t0 = time.monotonic()
            # WHEN the attitude frames stop
            _stop_attitude_frames(vehicle)
            # THEN it aborts, and the reason it gives the operator says how old the attitude was: just over
            # FS_NAV_TMO_S (one 50 ms tick), so with 5 s it was still running at 2 s
            wait_message(
                c, "ABORT", lambda msg: msg.get_type() == "HEARTBEAT" and state_from_heartbeat(msg) == "ABORT"
            )
            wait_message(
                c,
                "the failsafe's text",
                lambda _msg: any("navigation stale" in t.text for t in c.texts_since(t0)),
            )
            text = next(t.text for t in c.texts_since(t0) if "navigation stale" in t.text)
            found = re.search(r"attitude age ([0-9.]+) s", text)
            assert found is not None, text
            assert fs_nav_tmo_s <= float(found.group(1)) <= fs_nav_tmo_s + 0.1, (
                text
            )  # the text rounds to 10 ms
    finally:
        vehicle.stop()


def test_sys_status_load_is_the_loops_busy_share_of_its_period(vehicle: Vehicle) -> None:
    # GIVEN a running vehicle  WHEN a station reads SYS_STATUS
    with vehicle.client() as c:
        sys_status = wait_message(
            c, "SYS_STATUS with a load", lambda msg: msg.get_type() == "SYS_STATUS" and msg.load > 0
        )
        # THEN load is the loop's measured busy time per period, per mille (MAVLink's unit): above 0, and
        # what the loop itself measured
        assert 0 < sys_status.load <= 1000
        assert vehicle.loop.stats.load > 0.0
