"""The vehicle names a fault the bench injects (issue 24 item 5), with real processes on 127.0.0.1.

``auv-hil run --fault kind=fin_stuck,fin=rudder,...`` (the bench drives the rudder to 6 deg and holds it
there; FIN_STATUS says so), ``auv-onboard run`` over the bus, a ground station on MAVLink: the firmware names
the stuck rudder (a STATUSTEXT "fault fin_stuck: ..."), HOLDs (a stuck rudder would circle), and SYS_STATUS
shows MOTOR_OUTPUTS present, enabled and unhealthy. Before: the vehicle circled until its progress monitor
held it 60 s later, "no progress", no fault named.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import MavClient
from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, start_vehicle, upload_arm_start

pytestmark = pytest.mark.e2e

MISSION_YAML = "goals:\n  - {x_m: 80.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"
MOTOR = mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS


def test_a_stuck_rudder_is_named_held_and_its_health_bit_unhealthy(tmp_path: Path) -> None:
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    url = f"udpout:127.0.0.1:{mav_port}"
    mission = tmp_path / "mission.yaml"
    mission.write_text(MISSION_YAML)
    fault = "--fault=kind=fin_stuck,fin=rudder,start_s=3,angle_deg=6"
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        start_vehicle(
            procs,
            log,
            bench_cmd(channel, "0,0,1.0,0", 600, fault),
            onboard_cmd(channel, mav_port, tmp_path / "state"),
        )
        upload_arm_start(url, tmp_path / "tlogs", mission)
        with MavClient(url, system_id=204) as gcs:
            gcs.wait_heartbeat(10.0)
            named = unhealthy = False
            deadline = time.monotonic() + 90.0
            while time.monotonic() < deadline and not (named and unhealthy):
                m: Any = gcs.recv(0.25)
                if m is None or not gcs.from_vehicle(m):
                    continue
                named = any("fault fin_stuck" in t.text for t in gcs.texts)  # assembled from chunks
                if m.get_type() == "SYS_STATUS":
                    on = m.onboard_control_sensors_present & m.onboard_control_sensors_enabled & MOTOR
                    unhealthy = unhealthy or (bool(on) and not m.onboard_control_sensors_health & MOTOR)
            texts = [t.text for t in gcs.texts]
    assert named, f"no STATUSTEXT names the fault: {texts[-8:]}"
    assert unhealthy, "SYS_STATUS MOTOR_OUTPUTS never unhealthy"
    assert any("HOLD" in t and "fin_stuck" in t for t in texts), texts[-8:]
