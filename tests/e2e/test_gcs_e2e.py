"""End to end with the ground station: `auv-hil` + `auv-onboard` + `auv-gcs` as real processes on 127.0.0.1.

- the scenario runner waits for the vehicle to be ready (`auv-gcs wait-ready`), uploads the mission through
  `auv-gcs upload`, then `arm` and `start` over MAVLink (UDP), once each, and the vehicle flies it to the
  goal (pass/fail from the scenario's metrics of the simulator's truth);
- `auv-gcs monitor --json` shows the real loop's telemetry (state, LOCAL_POSITION_NED) during a real-time run;
- kill -9 of the firmware after the upload's ACK loses nothing: after a restart on the same state directory
  `auv-gcs download` gives the mission back.

Every process is started by the test (or the runner) and stopped in a ``finally``; every wait has a timeout.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil

from hil_sim.scenario import free_port, free_udp_port, mission_yaml, run_gcs
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, start_vehicle, upload_arm_start

pytestmark = pytest.mark.e2e

START = (-13.0, 0.0, 0.0)  # paper-straight
GOAL = (15.0, 0.0, 0.0)


def _tlog_messages(tlog_dir: Path, kinds: list[str]) -> list[Any]:
    out = []
    for path in sorted(tlog_dir.glob("*.tlog")):
        log = mavutil.mavlink_connection(str(path))
        while (msg := log.recv_match(type=kinds)) is not None:
            out.append(msg)
        log.close()
    return out


def test_scenario_uploads_through_gcs_and_reaches_the_goal(tmp_path: Path) -> None:
    # GIVEN the bench and the firmware as real processes, the firmware with MAVLink and no start-up mission
    # WHEN the runner uploads the mission with auv-gcs, arms and starts it over MAVLink
    out = subprocess.run(
        [sys.executable, "-m", "hil_sim", "scenario", "paper-straight", "--upload", "gcs", "--json",
         "--workdir", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads(out.stdout)
    # THEN the vehicle reaches the goal as with the start-up file
    assert result["upload"] == "gcs"
    assert result["completed"] is True and result["final_state"] == "COMPLETE"
    assert result["final_position_error_m"] < 0.05
    assert result["overruns"] == 0 and result["frames_rejected"] == 0
    assert result["gcs_start_attempts"] == 1  # no retries: the vehicle's answers are the truth
    # AND the ground station's own recordings show the accepted upload and the accepted start
    acks = _tlog_messages(Path(result["gcs_tlogs"]), ["MISSION_ACK", "COMMAND_ACK"])
    assert any(m.get_type() == "MISSION_ACK" and m.type == 0 and m.get_srcSystem() == 1 for m in acks)
    starts = [m for m in acks if m.get_type() == "COMMAND_ACK" and m.command == 300]  # MAV_CMD_MISSION_START
    assert starts and starts[-1].result == 0
    # AND no process is left behind (the runner stopped the bench and the firmware)
    onboard_log = (tmp_path / "onboard.log").read_text()
    assert "onboard stopped" in onboard_log and "Traceback" not in onboard_log


def test_monitor_shows_the_real_loop_telemetry(tmp_path: Path) -> None:
    # GIVEN the bench and the firmware in real time, the mission uploaded, armed and started by auv-gcs
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    url = f"udpout:127.0.0.1:{mav_port}"
    mission = tmp_path / "mission.yaml"
    mission.write_text(mission_yaml(GOAL))
    tlogs = tmp_path / "tlogs"
    hil_cmd = bench_cmd(channel, f"{START[0]},{START[1]},1.0,{START[2]}", 60)
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        start_vehicle(procs, log, hil_cmd, onboard_cmd(channel, mav_port, tmp_path / "state"))
        # WHEN the operator uploads, waits for the vehicle to be ready (its HEARTBEAT leaves BOOT), arms and
        # starts it once each, and watches the live telemetry for 2 s
        upload_arm_start(url, tlogs, mission)
        mon = subprocess.run(
            [sys.executable, "-m", "groundstation", "--connect", url, "--json", "--tlog-dir", str(tlogs),
             "monitor", "--duration", "2"],
            capture_output=True, text=True, timeout=30, check=False,
        )  # fmt: skip
        assert mon.returncode == 0, mon.stderr[-1000:]
        lines = [json.loads(x) for x in mon.stdout.splitlines() if x.startswith("{")]
        # THEN it shows the vehicle running, at the bench's start pose and depth, moving towards the goal
        running = [x for x in lines if x.get("state") == "RUNNING" and "x north (m)" in x]
        assert running, lines
        assert -14.0 < running[0]["x north (m)"] < 0.0
        assert abs(running[-1]["y east (m)"]) < 1.0 and 0.5 < running[-1]["depth (m)"] < 1.5
        assert running[-1]["x north (m)"] > running[0]["x north (m)"]
    # AND the monitor's tlog holds the vehicle's LOCAL_POSITION_NED stream
    positions = _tlog_messages(tlogs, ["LOCAL_POSITION_NED"])
    assert len(positions) >= 5 and all(m.get_srcSystem() == 1 for m in positions)


def test_mission_survives_kill_9_after_the_upload_ack(tmp_path: Path) -> None:
    # GIVEN the bench and the firmware with MAVLink and a state directory (an upload is handed to the
    # vehicle's control loop, so the loop must run: the bench is there)
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    url = f"udpout:127.0.0.1:{mav_port}"
    state = tmp_path / "state"
    mission = tmp_path / "mission.yaml"
    mission.write_text(
        "goals:\n  - {x_m: 12.5, y_m: -3.25, depth_m: 2.0, yaw_deg: 90.0}\n"
        "  - {x_m: 30.0, y_m: 20.0, depth_m: 1.0}\n"
        "obstacles:\n  - {x_m: 20.0, y_m: 5.0, radius_m: 1.5}\n"
    )
    hil_cmd = [
        sys.executable,
        "-m",
        "hil_sim",
        "run",
        "--mode=realtime",
        f"--channel={channel}",
        "--duration=60",
    ]
    with processes() as procs, open(tmp_path / "onboard.log", "w") as log:
        procs.append(subprocess.Popen(hil_cmd, stdout=log, stderr=subprocess.STDOUT))
        first = subprocess.Popen(onboard_cmd(channel, mav_port, state), stdout=log, stderr=subprocess.STDOUT)
        procs.append(first)
        code, data = run_gcs(url, tmp_path, "wait-ready", "--timeout", "20", timeout_s=20.0)
        assert code == 0, data
        code, data = run_gcs(url, tmp_path, "upload", str(mission), timeout_s=20.0)
        assert code == 0 and data["ok"] and len(data["results"]) == 2, data
        # WHEN the firmware is killed with SIGKILL right after the ACK and restarted on the same state dir
        first.kill()
        first.wait(5)
        procs.append(
            subprocess.Popen(onboard_cmd(channel, mav_port, state), stdout=log, stderr=subprocess.STDOUT)
        )
        code, data = run_gcs(url, tmp_path, "download", timeout_s=20.0)
    # THEN the mission and the fence are there
    assert code == 0, data
    assert data["goals"] == 2 and data["obstacles"] == 1
    goals = data["mission"]["goals"]
    assert goals[0] == {"x_m": 12.5, "y_m": -3.25, "depth_m": 2.0, "yaw_deg": 90.0}
    assert goals[1]["x_m"] == 30.0 and goals[1]["y_m"] == 20.0 and goals[1]["yaw_deg"] is None
    assert data["mission"]["obstacles"] == [{"x_m": 20.0, "y_m": 5.0, "radius_m": 1.5}]
