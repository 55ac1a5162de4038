"""Peers cannot hurt each other (issue 21, rows 7-9): the real link on real sockets, an operator, a stranger.

- Row 7: a stranger's SET_MESSAGE_INTERVAL (1 us for every stream) changes what the stranger gets (its link),
  bounded by ``[mavlink] max_stream_rate_hz``; the operator's LOCAL_POSITION_NED and ATTITUDE keep their rate,
  during and after. Before: every station's streams went to 100 Hz and stayed there.
- Row 8: a stranger's PARAM_REQUEST_LIST, unknown PARAM_SET names and refused commands at 200/s each are
  answered to the stranger alone, within its output budget (``tx_peer_per_s``); the operator hears none of it
  and its telemetry keeps its rate. Before: 8,600 PARAM_VALUE/s and hundreds of STATUSTEXT/s to every station.
- Row 9: 20 TCP connections that never send nor read do not lock a new TCP station out: a silent connection
  gives way to a newcomer and is closed after ``tcp_idle_timeout_s``. Before: no heartbeat, for ever.

Rates are measured over windows of seconds with generous bounds (the machine may be loaded); every wait is on
a condition with a deadline.
"""

from __future__ import annotations

import collections
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import LinkError, MavClient
from tests.integration.mavlink.conftest import Vehicle

WINDOW_S = 3.0
#: every stream the vehicle has, and a few it has not (18 ids, as in the issue's attack)
ATTACKED_IDS = (
    mavlink.MAVLINK_MSG_ID_HEARTBEAT,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
    mavlink.MAVLINK_MSG_ID_ATTITUDE,
    mavlink.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT,
    mavlink.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION,
    mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
    mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION,
    mavlink.MAVLINK_MSG_ID_VFR_HUD,
    mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE,
    mavlink.MAVLINK_MSG_ID_RAW_IMU,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
    mavlink.MAVLINK_MSG_ID_SYSTEM_TIME,
    mavlink.MAVLINK_MSG_ID_ALTITUDE,
)


def _rates(client: MavClient, seconds: float) -> dict[str, float]:
    """Messages per second ``client`` received, by type, over ``seconds`` (it keeps its heartbeat going)."""
    counts: collections.Counter[str] = collections.Counter()
    deadline = time.monotonic() + seconds
    while (left := deadline - time.monotonic()) > 0:
        m = client.recv(min(left, 0.2))
        if m is not None:
            counts[m.get_type()] += 1
    return {k: n / seconds for k, n in counts.items()}


def _drain(client: MavClient, seconds: float = 0.3) -> None:
    _rates(client, seconds)


def _command(client: MavClient, cmd: int, *p: float) -> None:
    ps = [*map(float, p), *([0.0] * (7 - len(p)))]
    client.send(mavlink.MAVLink_command_long_message(1, 1, cmd, 0, *ps))


@pytest.fixture
def udp_vehicle(tmp_path: Path) -> Iterator[Vehicle]:
    v = Vehicle(tmp_path / "state", max_stream_rate_hz=20.0).start()
    yield v
    v.stop()


def test_a_strangers_message_intervals_change_only_what_the_stranger_gets(udp_vehicle: Vehicle) -> None:
    # GIVEN a vehicle whose streams go at most 20 Hz, an operator and a stranger (the same ids, as every
    # stock ground station: the link tells them apart), the operator's rates measured
    operator = udp_vehicle.client()
    stranger = udp_vehicle.client(gcs_session=False)
    try:
        _drain(operator)
        before = _rates(operator, WINDOW_S)
        pos0, att0 = before.get("LOCAL_POSITION_NED", 0.0), before.get("ATTITUDE", 0.0)
        assert pos0 > 1.0 and att0 > 2.0, before
        # WHEN the stranger asks for every stream at 1 us, once (18 packets)
        for msg_id in ATTACKED_IDS:
            _command(stranger, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1.0)
        _drain(stranger)  # what waited in its socket while the operator was measured
        got: dict[str, float] = {}
        t = threading.Thread(target=lambda: got.update(_rates(stranger, WINDOW_S)))
        t.start()
        during = _rates(operator, WINDOW_S)
        t.join(timeout=WINDOW_S + 10.0)
        # THEN the operator's streams keep their rate (generous bounds: a loaded machine)
        assert during.get("LOCAL_POSITION_NED", 0.0) <= max(2.0 * pos0, pos0 + 4.0), (before, during)
        assert during.get("ATTITUDE", 0.0) <= max(2.0 * att0, att0 + 6.0), (before, during)
        assert during.get("LOCAL_POSITION_NED", 0.0) >= 0.3 * pos0, (before, during)
        # ... and the stranger got more, but no more than the configured maximum rate
        assert got.get("LOCAL_POSITION_NED", 0.0) > 1.5 * pos0, got
        bound = udp_vehicle.config.max_stream_rate_hz * 1.5
        assert got.get("LOCAL_POSITION_NED", 0.0) <= bound and got.get("ATTITUDE", 0.0) <= bound, got
        # WHEN the stranger leaves THEN the operator's rates stay as they were
        stranger.close()
        after = _rates(operator, WINDOW_S)
        print(f"\nrow 7 operator LOCAL_POSITION_NED / ATTITUDE Hz: before {pos0:.1f} / {att0:.1f}, during "
              f"{during.get('LOCAL_POSITION_NED', 0):.1f} / {during.get('ATTITUDE', 0):.1f}, after "
              f"{after.get('LOCAL_POSITION_NED', 0):.1f} / {after.get('ATTITUDE', 0):.1f}; stranger "
              f"{got.get('LOCAL_POSITION_NED', 0):.1f} / {got.get('ATTITUDE', 0):.1f}")  # fmt: skip
        assert after.get("LOCAL_POSITION_NED", 0.0) <= max(2.0 * pos0, pos0 + 4.0), (before, after)
        assert after.get("ATTITUDE", 0.0) <= max(2.0 * att0, att0 + 6.0), (before, after)
        # and the operator's own request still changes its own rate (its link)
        _command(
            operator, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 1e5
        )
        _drain(operator)
        mine = _rates(operator, WINDOW_S)
        assert mine.get("LOCAL_POSITION_NED", 0.0) > 1.5 * pos0, (before, mine)
    finally:
        operator.close()
        stranger.close()


def _flood(client: MavClient, seconds: float, per_s: float) -> int:
    """PARAM_REQUEST_LIST, an unknown PARAM_SET name and a refused command, each ``per_s`` a second."""
    sent = 0
    t0 = time.monotonic()
    while (now := time.monotonic()) - t0 < seconds:
        client.send(mavlink.MAVLink_param_request_list_message(1, 1))
        client.send(mavlink.MAVLink_param_set_message(1, 1, f"NOPE_{sent % 1000}".encode(), 1.0, 9))
        _command(client, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 5.0)  # DENIED "param1 must be 0 or 1"
        sent += 1
        time.sleep(max(0.0, t0 + sent / per_s - now))
    return sent


def test_answers_go_to_the_asker_within_its_budget(tmp_path: Path) -> None:
    # GIVEN a vehicle whose peers may be sent 300 messages a second each, an operator (its rates measured)
    # and a stranger on another socket
    udp_vehicle = Vehicle(tmp_path / "state", tx_peer_per_s=300).start()
    operator = udp_vehicle.client()
    stranger = udp_vehicle.client(gcs_session=False)
    try:
        _drain(operator)
        before = _rates(operator, WINDOW_S)
        pos0 = before.get("LOCAL_POSITION_NED", 0.0)
        assert pos0 > 1.0, before
        # WHEN the stranger floods parameter lists, unknown names and refused commands at 200/s each, and
        # reads what comes back
        got: dict[str, float] = {}
        reader = threading.Thread(target=lambda: got.update(_rates(stranger, WINDOW_S + 1.0)))
        reader.start()
        flooder = threading.Thread(target=_flood, args=(stranger, WINDOW_S, 200.0))
        flooder.start()
        during = _rates(operator, WINDOW_S)
        flooder.join(timeout=60.0)
        reader.join(timeout=60.0)
        print(f"\nrow 8 operator/s: {during}\nstranger/s: {got}\nstats: {udp_vehicle.link.stats()}")
        # THEN the operator hears none of the answers ...
        assert during.get("PARAM_VALUE", 0.0) * WINDOW_S <= 2, during
        assert during.get("STATUSTEXT", 0.0) * WINDOW_S <= 3, during
        # ... and its telemetry keeps its rate
        assert during.get("LOCAL_POSITION_NED", 0.0) >= 0.5 * pos0, (before, during)
        # and the stranger, the asker, was answered, within its output budget (the rest dropped, counted)
        assert got.get("PARAM_VALUE", 0.0) > 0 and got.get("STATUSTEXT", 0.0) > 0, got
        assert sum(got.values()) <= 1.5 * udp_vehicle.config.tx_peer_per_s + 50, got
        assert udp_vehicle.link.stats()["tx_shed"] > 0
    finally:
        operator.close()
        stranger.close()
        udp_vehicle.stop()


def _connect_until_heard(port: int, timeout_s: float) -> MavClient:
    """A new TCP station, as a ground station does it: connect, wait for a heartbeat, reconnect if refused."""
    deadline = time.monotonic() + timeout_s
    while True:
        c = MavClient(f"tcp:127.0.0.1:{port}")
        try:
            c.wait_heartbeat(min(2.0, max(0.1, deadline - time.monotonic())))
            return c
        except LinkError:
            c.close()
            if time.monotonic() >= deadline:
                raise


def _closed_by_peer(s: socket.socket) -> bool:
    """Whether the vehicle has closed ``s`` (EOF or a reset); what it sent is read and dropped."""
    s.setblocking(False)
    try:
        while s.recv(65536):
            pass
        return True
    except BlockingIOError:
        return False
    except OSError:
        return True


def _all_closed(socks: list[socket.socket], talker: MavClient, timeout_s: float) -> bool:
    """Wait until the vehicle has closed every one of ``socks``, ``talker`` speaking all the while."""
    deadline = time.monotonic() + timeout_s
    open_ = list(socks)
    while open_ and time.monotonic() < deadline:
        talker.recv(0.2)  # sends its heartbeat when due
        open_ = [s for s in open_ if not _closed_by_peer(s)]
    return not open_


def test_silent_tcp_connections_never_lock_a_new_station_out(tmp_path: Path) -> None:
    # GIVEN a vehicle on TCP whose silent connections give way after 1 s and are closed after 4 s
    v = Vehicle(
        tmp_path / "state", endpoints=("tcpin:127.0.0.1:0",), tcp_evict_idle_s=1.0, tcp_idle_timeout_s=4.0
    ).start()
    silent: list[socket.socket] = []
    try:
        # WHEN 20 connections are opened that never send nor read
        for _ in range(20):
            silent.append(socket.create_connection(("127.0.0.1", v.port), timeout=5.0))
        deadline = time.monotonic() + 10.0
        while v.link.stats()["peers_refused"] < 4 and time.monotonic() < deadline:
            time.sleep(0.05)  # the vehicle has taken all it takes
        # THEN a new TCP station gets the vehicle's heartbeat within a bounded time
        newcomer = _connect_until_heard(v.port, 15.0)
        try:
            # ... the silent connections are closed by the vehicle ...
            assert _all_closed(silent, newcomer, 15.0)
            assert v.link.stats()["tcp_closed_idle"] >= 16
            # ... and the newcomer, which speaks (a heartbeat a second), keeps its connection
            for _ in range(3):
                newcomer.wait_heartbeat(5.0)
        finally:
            newcomer.close()
    finally:
        for s in silent:
            s.close()
        v.stop()
