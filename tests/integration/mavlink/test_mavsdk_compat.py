"""What MAVSDK (and MAVProxy) send, emulated with pymavlink byte for byte (no mavsdk needed).

The commands are the ones captured from MAVSDK 4.1.0 (native binding) against the standalone vehicle:
MissionRaw.start_mission / pause_mission and Action.return_to_launch send MAV_CMD_DO_SET_MODE with a PX4
custom mode (param1 = base mode, param2 = main mode AUTO, param3 = sub mode, unused params NaN) from
system 245 / component 190; on connect it sends REQUEST_MESSAGE(AUTOPILOT_VERSION, HOME_POSITION) and
SET_MESSAGE_INTERVAL(EXTENDED_SYS_STATE, 1 s). MAVProxy asks for the home with the deprecated
MAV_CMD_GET_HOME_POSITION.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink
from pymavlink.mavutil import mode_string_v10

from groundstation.mavclient import MavClient, state_from_heartbeat
from groundstation.mission_files import goal_item
from onboard.adapters.mavlink.mission_protocol import (
    MissionItem,
    MissionLimits,
    item_position,
    local_to_global,
)
from tests.integration.mavlink.conftest import Vehicle

NAN = math.nan
MAVSDK_IDS = {"system_id": 245, "component_id": 190}
AUTO, READY, LOITER, MISSION, RTL = 4, 1, 3, 4, 5
CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
ARMED_CUSTOM = CUSTOM | mavlink.MAV_MODE_FLAG_SAFETY_ARMED  # 129, what MAVSDK sends once armed
FAR_GOALS = [goal_item(300.0, 0.0, 2.0, None), goal_item(300.0, 300.0, 2.0, None)]  # ~15 s at 20 m/s


@pytest.fixture
def vehicle(tmp_path: Path) -> Iterator[Vehicle]:
    v = Vehicle(tmp_path / "state", position_rate_hz=20.0, heartbeat_rate_hz=10.0).start()
    yield v
    v.stop()


def wait_for(
    c: MavClient, kind: str, pred: Callable[[mavlink.MAVLink_message], bool] = lambda m: True, t: float = 3.0
) -> mavlink.MAVLink_message:
    t_end = time.monotonic() + t
    while time.monotonic() < t_end:
        m = c.recv(0.1)
        if m is not None and m.get_type() == kind and pred(m):
            return m
    raise AssertionError(f"no {kind} within {t} s")


def command_as_mavsdk(c: MavClient, command: int, *params: float) -> mavlink.MAVLink_message:
    """COMMAND_LONG as MAVSDK sends it (unused params NaN, confirmation 0); returns the COMMAND_ACK."""
    p = [*params, *([NAN] * (7 - len(params)))]
    c.send(mavlink.MAVLink_command_long_message(1, 1, command, 0, *p))
    return wait_for(c, "COMMAND_ACK", lambda m: m.command == command)


def set_mode(c: MavClient, base: int, sub: int) -> int:
    ack = command_as_mavsdk(c, mavlink.MAV_CMD_DO_SET_MODE, float(base), float(AUTO), float(sub))
    assert (ack.target_system, ack.target_component) == (245, 190)  # addressed to the sender
    return int(ack.result)


def heartbeat_state(c: MavClient, state: str) -> mavlink.MAVLink_message:
    return wait_for(c, "HEARTBEAT", lambda m: m.get_srcSystem() == 1 and state_from_heartbeat(m) == state)


def test_mavsdk_flight_mode_changes(vehicle: Vehicle) -> None:
    with vehicle.client(**MAVSDK_IDS) as c:
        assert set_mode(c, CUSTOM, MISSION) == mavlink.MAV_RESULT_DENIED  # not armed, no mission
        assert set_mode(c, CUSTOM, READY) == mavlink.MAV_RESULT_ACCEPTED  # already AUTO / READY
        assert c.upload(FAR_GOALS).ok
        ack = command_as_mavsdk(c, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        heartbeat_state(c, "ARMED")
        # MissionRaw.start_mission before the armed flag reached MAVSDK: base mode 1
        assert set_mode(c, CUSTOM, MISSION) == mavlink.MAV_RESULT_ACCEPTED
        hb = heartbeat_state(c, "RUNNING")
        assert mode_string_v10(hb) == "AUTO"  # the HEARTBEAT speaks ArduSub's modes (MAVProxy's names)
        assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        # MissionRaw.pause_mission / Action.hold
        assert set_mode(c, ARMED_CUSTOM, LOITER) == mavlink.MAV_RESULT_ACCEPTED
        assert mode_string_v10(heartbeat_state(c, "HOLD")) == "POSHOLD"
        assert set_mode(c, ARMED_CUSTOM, READY) == mavlink.MAV_RESULT_DENIED  # not a no-op while holding
        # MissionRaw.start_mission again resumes
        assert set_mode(c, ARMED_CUSTOM, MISSION) == mavlink.MAV_RESULT_ACCEPTED
        heartbeat_state(c, "RUNNING")
        assert set_mode(c, 0, LOITER) == mavlink.MAV_RESULT_DENIED  # no custom-mode flag
        # Action.return_to_launch: AUTO / RTL = abort (return to the surface)
        assert set_mode(c, ARMED_CUSTOM, RTL) == mavlink.MAV_RESULT_ACCEPTED
        assert mode_string_v10(heartbeat_state(c, "ABORT")) == "SURFACE"


def test_mavsdk_and_mavproxy_requests(vehicle: Vehicle) -> None:
    cfg = vehicle.config
    with vehicle.client(**MAVSDK_IDS) as c:
        # MAVProxy: MAV_CMD_GET_HOME_POSITION -> ACCEPTED, then HOME_POSITION
        ack = command_as_mavsdk(c, mavlink.MAV_CMD_GET_HOME_POSITION)
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        home = wait_for(c, "HOME_POSITION", t=1.0)  # well before the 5 s stream period
        assert home.latitude == round(cfg.origin_lat_deg * 1e7)
        assert home.longitude == round(cfg.origin_lon_deg * 1e7)
        # MAVSDK on connect
        for msg_id, kind in (
            (mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION"),
            (mavlink.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION"),
        ):
            ack = command_as_mavsdk(c, mavlink.MAV_CMD_REQUEST_MESSAGE, float(msg_id))
            assert ack.result == mavlink.MAV_RESULT_ACCEPTED
            wait_for(c, kind, t=1.0)
        ack = command_as_mavsdk(
            c,
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
            float(mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE),
            100_000.0,
        )
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        ess = wait_for(c, "EXTENDED_SYS_STATE", t=1.0)
        assert ess.landed_state == mavlink.MAV_LANDED_STATE_UNDEFINED
        # Telemetry.position maps GLOBAL_POSITION_INT: the local position about the origin
        gp = wait_for(c, "GLOBAL_POSITION_INT", t=1.0)
        assert gp.lat == round(cfg.origin_lat_deg * 1e7) and gp.lon == round(cfg.origin_lon_deg * 1e7)
        assert gp.relative_alt == 0 and gp.alt == round(cfg.origin_alt_m * 1000)


def test_local_to_global_inverts_item_position() -> None:
    limits = MissionLimits(origin_lat_deg=35.1, origin_lon_deg=129.04)
    for x_m, y_m in ((0.0, 0.0), (123.4, -456.7), (-500.0, 500.0)):
        lat, lon = local_to_global(x_m, y_m, limits)
        frame, cmd = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT
        item = MissionItem(frame, cmd, 0.0, 0.0, 0.0, NAN, round(lat * 1e7), round(lon * 1e7), -1.0)
        x2, y2, _ = item_position(item, limits)
        assert abs(x2 - x_m) < 0.02 and abs(y2 - y_m) < 0.02  # 1e-7 deg is ~1 cm
