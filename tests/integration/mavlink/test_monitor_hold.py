"""A leg monitor's HOLD as the operator sees it over MAVLink, on a running vehicle (the in-process vehicle:
the real core and link over a simple plant, ``conftest.Vehicle``): the cross-track monitor has a time of its
own, ``MIS_XTRACK_S``, set over MAVLink like its bound ``MIS_XTRACK_M``; the HOLD comes with a STATUSTEXT
that names the figure (issue 23: swept off its path, a vehicle stayed RUNNING a whole 60 s window).
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import state_from_heartbeat
from groundstation.mission_files import goal_item
from onboard.protocol import messages as msgs
from tests.integration.mavlink.conftest import Vehicle, wait_message


def _swept_off_and_stuck(vehicle: Vehicle, sideways_mps: float, for_s: float) -> None:
    """The fault: the plant makes no more way ahead and is swept to starboard at ``sideways_mps`` for
    ``for_s`` (its DVL and position fixes say so), then stays where it is, whatever the vehicle commands."""
    plant = vehicle.loop.plant
    sensors = plant.sensors
    swept = {"s": 0.0}

    def advance(cmd: object, dt_s: float) -> tuple[float, float]:
        plant.u_mps = 0.0
        if swept["s"] < for_s:
            plant.x_m -= sideways_mps * math.sin(plant.yaw_rad) * dt_s
            plant.y_m += sideways_mps * math.cos(plant.yaw_rad) * dt_s
            swept["s"] += dt_s
        return 0.0, 0.0

    def dvl(t_s: float, r_radps: float, w_mps: float) -> dict[type, Any]:
        cache = sensors(t_s, r_radps, w_mps)
        lateral = sideways_mps if swept["s"] < for_s else 0.0
        cache[msgs.DvlVelocity] = msgs.DvlVelocity(0.0, lateral, 0.0, True, t_s)
        return cache

    plant.advance = advance  # type: ignore[method-assign]
    plant.sensors = dvl  # type: ignore[method-assign]


def test_off_the_path_for_mis_xtrack_s_set_over_mavlink_holds_with_the_figure(tmp_path: Path) -> None:
    vehicle = Vehicle(tmp_path / "state").start()
    try:
        with vehicle.client() as c:
            # GIVEN a vehicle whose operator set the cross-track bound to 2 m for 3 s over MAVLink, RUNNING a
            # leg to a goal 10 m ahead (near enough that no re-plan for the current follows)
            for name, value in (("MIS_XTRACK_M", 2.0), ("MIS_XTRACK_S", 3.0)):
                ok, got = c.param_set(name, value)
                assert ok and got == pytest.approx(value), name
            assert c.upload([goal_item(10.0, 0.0, 1.0, None)]).ok
            assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == mavlink.MAV_RESULT_ACCEPTED
            assert c.command(mavlink.MAV_CMD_MISSION_START) == mavlink.MAV_RESULT_ACCEPTED
            running = lambda m: m.get_type() == "HEARTBEAT" and state_from_heartbeat(m) == "RUNNING"  # noqa: E731
            wait_message(c, "RUNNING", running)
            # WHEN it is swept 5 m off its path and held there
            t0 = time.monotonic()
            _swept_off_and_stuck(vehicle, 1.0, 5.0)
            # THEN it holds (long before the progress window, 60 s), and the operator is told why: the
            # distance off the path, the time, and the bound
            texts = lambda: [t.text for t in c.texts_since(t0)]  # noqa: E731
            held = lambda m: m.get_type() == "HEARTBEAT" and state_from_heartbeat(m) == "HOLD"  # noqa: E731
            try:
                wait_message(c, "HOLD", held)
                wait_message(
                    c, "the monitor's text", lambda _m: any("off the path for 3 s" in t for t in texts())
                )
            except AssertionError as e:
                raise AssertionError(f"{e}; the vehicle said: {texts()}") from e
            text = next(t for t in texts() if "off the path for 3 s" in t)
            assert "goal 0: 5." in text or "goal 0: 4." in text, text  # about 5 m off the path
            assert "(MIS_XTRACK_S; MIS_XTRACK_M 2 m + 3 x the position's 1 sigma" in text, text
    finally:
        vehicle.stop()
