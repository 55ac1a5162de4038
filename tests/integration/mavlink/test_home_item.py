"""A QGC WPL 110 mission with a home line, uploaded as MAVProxy ``wp load`` sends it, over real UDP.

MAVProxy sends every line of the file as MISSION_ITEM_INT with the file's frame and ``current`` flag: the home
line becomes seq 0 in MAV_FRAME_GLOBAL (lat/lon 0/0 here), the goals seq 1.. in GLOBAL_RELATIVE_ALT. The
vehicle stores the home item, flies the goals, and reports MAVLink seqs (goal index + 1).
"""

from __future__ import annotations

import math
import time

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from tests.integration.mavlink.conftest import Vehicle

EARTH_RADIUS_M = 6_378_137.0
FIELDS = ("frame", "command", "param1", "param2", "param3", "param4", "x", "y", "z", "autocontinue")


def wpl_lines(vehicle: Vehicle, goals: list[tuple[float, float, float]]) -> list[tuple]:
    """The lines of a WPL file: INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 LAT LON ALT AUTOCONTINUE."""
    lat0, lon0 = vehicle.config.origin_lat_deg, vehicle.config.origin_lon_deg
    lines = [(0, 1, mavlink.MAV_FRAME_GLOBAL, 16, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1)]  # home: 0/0
    for i, (north_m, east_m, depth_m) in enumerate(goals, start=1):
        lat = lat0 + math.degrees(north_m / EARTH_RADIUS_M)
        lon = lon0 + math.degrees(east_m / (EARTH_RADIUS_M * math.cos(math.radians(lat0))))
        rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
        lines.append((i, 0, rel, 16, 0.0, 0.0, 0.0, 0.0, lat, lon, -depth_m, 1))
    return lines


def item_int(line: tuple, ts: int = 1, tc: int = 1) -> mavlink.MAVLink_mission_item_int_message:
    """MAVProxy's wp_to_mission_item_int: x, y = int(deg * 1e7), everything else as in the file."""
    seq, cur, frame, cmd, p1, p2, p3, p4, lat, lon, alt, auto = line
    return mavlink.MAVLink_mission_item_int_message(
        ts, tc, seq, frame, cmd, cur, auto, p1, p2, p3, p4, int(lat * 1e7), int(lon * 1e7), alt, 0
    )


def recv(conn: mavutil.mavfile, kinds: set[str], timeout_s: float = 3.0, pred=lambda m: True):
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        m = conn.recv_match(type=list(kinds), blocking=True, timeout=0.1)
        if m is not None and pred(m):
            return m
    raise AssertionError(f"none of {kinds} within {timeout_s} s")


def command(conn: mavutil.mavfile, cmd: int, *p: float) -> int:
    ps = [*map(float, p), *([0.0] * (7 - len(p)))]
    conn.mav.command_long_send(1, 1, cmd, 0, *ps)
    return int(recv(conn, {"COMMAND_ACK"}, pred=lambda m: m.command == cmd).result)


def test_mavproxy_style_wpl_upload_with_home(vehicle: Vehicle) -> None:
    conn = mavutil.mavlink_connection(
        f"udpout:127.0.0.1:{vehicle.port}", source_system=255, source_component=230, dialect="common"
    )
    try:
        conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        recv(conn, {"HEARTBEAT"}, pred=lambda m: m.get_srcSystem() == 1)
        lines = wpl_lines(vehicle, [(10.0, 0.0, 1.0), (10.0, 10.0, 2.0)])
        # WHEN the file is uploaded as MAVProxy does: MISSION_COUNT n+1, items on request
        conn.mav.mission_count_send(1, 1, len(lines), 0)
        while True:
            m = recv(conn, {"MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"})
            if m.get_type() == "MISSION_ACK":
                break
            assert m.get_type() == "MISSION_REQUEST_INT"
            conn.mav.send(item_int(lines[m.seq]))
        # THEN it is accepted; the goals are the lines after home, the home item is stored as sent
        assert m.type == mavlink.MAV_MISSION_ACCEPTED
        goals = vehicle.link.mission().goals
        assert [(round(g.x_m, 1), round(g.y_m, 1), g.depth_m, g.yaw_rad) for g in goals] == [
            (10.0, 0.0, 1.0, 0.0),  # WPL param4 = 0: arrival yaw 0 deg
            (10.0, 10.0, 2.0, 0.0),
        ]
        # AND the download returns exactly what was uploaded (count n+1, home first)
        conn.mav.mission_request_list_send(1, 1, 0)
        assert recv(conn, {"MISSION_COUNT"}).count == len(lines)
        for line in lines:
            conn.mav.mission_request_int_send(1, 1, line[0], 0)
            got = recv(conn, {"MISSION_ITEM_INT"}, pred=lambda m, s=line[0]: m.seq == s)
            sent = item_int(line)
            assert [getattr(got, f) for f in FIELDS] == [getattr(sent, f) for f in FIELDS]
        conn.mav.mission_ack_send(1, 1, mavlink.MAV_MISSION_ACCEPTED, 0)
        # WHEN started at first_item 1 (the first goal) THEN MISSION_CURRENT / ITEM_REACHED carry seqs 1, 2
        iv = mavlink.MAVLINK_MSG_ID_MISSION_CURRENT
        assert command(conn, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, iv, 50_000) == 0
        assert command(conn, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
        assert command(conn, mavlink.MAV_CMD_MISSION_START, 1, 2) == 0
        active = mavlink.MISSION_STATE_ACTIVE
        cur = recv(conn, {"MISSION_CURRENT"}, pred=lambda m: m.mission_state == active)
        assert (cur.seq, cur.total) == (1, 2)
        reached: list[int] = []
        seqs: set[int] = set()
        t_end = time.monotonic() + 60.0  # a deadline, not a timing: the run-in slows the end (issue 23)
        while time.monotonic() < t_end and reached != [1, 2]:
            m = conn.recv_match(type=["MISSION_ITEM_REACHED", "MISSION_CURRENT"], blocking=True, timeout=0.1)
            if m is not None and m.get_type() == "MISSION_ITEM_REACHED":
                reached.append(m.seq)
            elif m is not None and m.mission_state == active:
                seqs.add(m.seq)
        assert reached == [1, 2] and seqs <= {1, 2} and 2 in seqs
        complete = mavlink.MISSION_STATE_COMPLETE
        done = recv(conn, {"MISSION_CURRENT"}, pred=lambda m: m.mission_state == complete)
        assert done.total == 2
    finally:
        conn.close()
