"""The geodetic origin of the local frame: configured, set by SET_GPS_GLOBAL_ORIGIN, told by
GPS_GLOBAL_ORIGIN.

A ground station that plans on a map (QGroundControl) sets the origin, uploads lat/lon goals and sees the
vehicle where it is; local NED missions are taken as before. An origin change that would move a stored
mission's items is refused with the reason; an accepted one is persisted (a reboot keeps it).
"""

from __future__ import annotations

import time
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import Item, MavClient
from tests.integration.mavlink.conftest import Vehicle


def origin_of(c: MavClient) -> tuple[float, float, float]:
    origin_id = mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN
    c.send(
        mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, origin_id, *[0] * 6)
    )
    return wait_origin(c)


def wait_origin(c: MavClient, t: float = 3.0) -> tuple[float, float, float]:
    t_end = time.monotonic() + t
    while time.monotonic() < t_end:
        m = c.recv(0.1)
        if m is not None and m.get_type() == "GPS_GLOBAL_ORIGIN":
            return m.latitude / 1e7, m.longitude / 1e7, m.altitude / 1000.0
    raise AssertionError("no GPS_GLOBAL_ORIGIN")


def drain(c: MavClient, t: float = 0.6) -> None:
    """Read for ``t`` s (the vehicle's texts are assembled as they are read)."""
    t_end = time.monotonic() + t
    while time.monotonic() < t_end:
        c.recv(0.05)


def set_origin(c: MavClient, lat: float, lon: float, alt_m: float) -> None:
    c.send(
        mavlink.MAVLink_set_gps_global_origin_message(
            1, round(lat * 1e7), round(lon * 1e7), round(alt_m * 1e3), 0
        )
    )


def test_set_gps_global_origin_moves_the_frame_and_is_kept(tmp_path: Path) -> None:
    v = Vehicle(tmp_path / "state").start()
    try:
        with v.client() as c:
            # GIVEN the configured origin
            assert origin_of(c) == (35.1, 129.04, 0.0)
            # WHEN a ground station sets another one (no mission stored)
            t = time.monotonic()
            set_origin(c, 36.5, 127.25, 12.5)
            # THEN the vehicle tells every station the new origin, and says so in words
            assert wait_origin(c) == (36.5, 127.25, 12.5)
            drain(c)
            assert any("origin set to 36.5000000, 127.2500000" in x.text for x in c.texts_since(t))
            # AND a lat/lon goal 10 m north of it is 10 m north in the local frame, 2 m deep
            lat = 36.5 + 10.0 / 6378137.0 * 180.0 / 3.141592653589793
            nan = float("nan")
            frame, wp = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT
            goal = Item(frame, wp, 0.0, nan, 0.0, nan, round(lat * 1e7), round(127.25 * 1e7), -2.0)
            assert c.upload([goal]).ok
            (g,) = v.link.mission().goals
            assert abs(g.x_m - 10.0) < 0.02 and abs(g.y_m) < 0.02 and g.depth_m == 2.0
            # WHEN another origin is asked for while that mission is stored
            t = time.monotonic()
            set_origin(c, 10.0, 10.0, 0.0)
            drain(c)
            # THEN it is refused with the reason, and the origin stays
            assert any("origin not changed: a mission or fence is stored" in x.text for x in c.texts_since(t))
            assert origin_of(c) == (36.5, 127.25, 12.5)
            # AND an origin out of range is refused too (after the clear)
            assert c.clear(mavlink.MAV_MISSION_TYPE_ALL).ok
            t = time.monotonic()
            set_origin(c, 95.0, 0.0, 0.0)
            set_origin(c, 89.0, 0.0, 0.0)  # valid, but the flat-earth projection does not hold there
            drain(c)
            refused = [x.text for x in c.texts_since(t) if "origin out of range" in x.text]
            assert len(refused) == 2 and "|lat| <= 85" in refused[1], refused
    finally:
        v.stop()
    # AND after a reboot on the same state directory the origin set is the one in force
    v = Vehicle(tmp_path / "state").start()
    try:
        with v.client() as c:
            assert origin_of(c) == (36.5, 127.25, 12.5)
    finally:
        v.stop()
