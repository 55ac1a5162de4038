"""A bus is a link that can come back (issue 21, row 5), with real processes on 127.0.0.1.

``auv-hil run`` (the bench, hosting the CAN hub), ``auv-onboard run`` (the firmware, MAVLink on UDP) and a
ground station. Before: kill -9 of the bench mid-mission ended the firmware ("bus lost:
ConnectionResetError", exit 1) with its MAVLink link and every failsafe, and it stayed dead when the hub was
back. Now the firmware aborts (propeller 0), keeps MAVLink, says "CAN bus lost (reason)" (STATUSTEXT, and
SYS_STATUS MOTOR_OUTPUTS present, enabled, unhealthy), reconnects with back-off, and once the sensors are
back it is ready again, disarmed, its mission kept: a new START flies it.

The bench does the same for its side: when the firmware goes (kill -9) it runs on (the actuator node's
watchdog holds the actuators), and a new firmware on the same hub is ready and flies.
"""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import MavClient
from hil_sim.scenario import free_port, free_udp_port, run_gcs
from onboard.adapters.mavlink.modes import AUTO, SURFACE
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, stop, upload_arm_start
from tests.waiting import wait_until

pytestmark = pytest.mark.e2e

MISSION_YAML = "goals:\n  - {x_m: 80.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"
MOTOR = mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS


def _wait(gcs: MavClient, what: str, ok: Callable[[Any], bool], timeout_s: float) -> Any:
    """The first message of the vehicle for which ``ok`` holds within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        m = gcs.recv(0.25)
        if m is not None and gcs.from_vehicle(m) and ok(m):
            return m
    raise AssertionError(f"no {what} within {timeout_s:g} s; the vehicle's texts: {list(gcs.texts)[-8:]}")


def _is(kind: str, **fields: Any) -> Callable[[Any], bool]:
    return lambda m: m.get_type() == kind and all(getattr(m, k) == v for k, v in fields.items())


def _motor_outputs(healthy: bool) -> Callable[[Any], bool]:
    def ok(m: Any) -> bool:
        if m.get_type() != "SYS_STATUS":
            return False
        on = m.onboard_control_sensors_present & m.onboard_control_sensors_enabled & MOTOR
        return bool(on) and bool(m.onboard_control_sensors_health & MOTOR) is healthy

    return ok


def _x_max(truth: Path) -> float:
    if not truth.exists():
        return float("-inf")
    xs = [float(r["x_m"]) for r in csv.DictReader(truth.open()) if r.get("x_m")]
    return max(xs, default=float("-inf"))


def _flies(truth: Path, metres: float, timeout_s: float) -> bool:
    """The bench's truth shows the vehicle ``metres`` ahead of its start within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if _x_max(truth) > metres:
            return True
        time.sleep(0.3)
    return False


class Flight:
    """The bench and the firmware as processes on a hub of their own, the vehicle flying an 80 m mission."""

    def __init__(self, tmp_path: Path, procs: list[subprocess.Popen[Any]], log: Any, truth: Path) -> None:
        self.channel = f"ws://127.0.0.1:{free_port()}/"
        self.mav_port = free_udp_port()
        self.url = f"udpout:127.0.0.1:{self.mav_port}"
        self.tlogs = tmp_path / "tlogs"
        self.state = tmp_path / "state"
        self.procs, self.log = procs, log
        mission = tmp_path / "mission.yaml"
        mission.write_text(MISSION_YAML)
        self.bench = self.start_bench(truth)
        # a short back-off cap: the test waits less for the reconnection (the default is 5 s)
        self.firmware = self._start(
            onboard_cmd(self.channel, self.mav_port, self.state, "--set", "bus.reconnect_max_s=1.0")
        )
        upload_arm_start(self.url, self.tlogs, mission)
        assert _flies(truth, 2.0, 30.0), "the mission did not fly"

    def _start(self, cmd: list[str]) -> subprocess.Popen[Any]:
        proc = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT)
        self.procs.append(proc)
        return proc

    def start_bench(self, truth: Path) -> subprocess.Popen[Any]:
        return self._start(bench_cmd(self.channel, "0,0,1.0,0", 600, f"--truth-log={truth}"))

    def start_firmware(self) -> subprocess.Popen[Any]:
        return self._start(onboard_cmd(self.channel, self.mav_port, self.state))

    def arm_start_flies(self, truth: Path, x_before_m: float, what: str) -> None:
        """ARM and START accepted, and the truth shows the vehicle 2 m further than ``x_before_m``."""
        code, data = run_gcs(self.url, self.tlogs, "arm")
        assert code == 0, data
        code, data = run_gcs(self.url, self.tlogs, "start")
        assert code == 0 and data["result"] == "MAV_RESULT_ACCEPTED", data
        assert _flies(truth, x_before_m + 2.0, 30.0), what


def test_the_firmware_outlives_its_bus_and_flies_again_when_it_is_back(tmp_path: Path) -> None:
    truth1, truth2 = tmp_path / "truth1.csv", tmp_path / "truth2.csv"
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        # GIVEN the vehicle flying an 80 m mission
        flight = Flight(tmp_path, procs, log, truth1)
        bench, firmware = flight.bench, flight.firmware
        with MavClient(flight.url, system_id=203) as gcs:
            gcs.wait_heartbeat(10.0)
            _wait(gcs, "HEARTBEAT in AUTO", _is("HEARTBEAT", custom_mode=AUTO), 10.0)
            # WHEN the bench, which hosts the CAN hub, is killed mid-mission
            bench.kill()
            bench.wait(10.0)
            t_kill = time.monotonic()
            # THEN the firmware keeps its MAVLink link and says why: ABORT (SURFACE, CRITICAL), the bus lost
            hb = _wait(
                gcs,
                "HEARTBEAT in ABORT",
                _is("HEARTBEAT", custom_mode=SURFACE, system_status=mavlink.MAV_STATE_CRITICAL),
                20.0,
            )
            assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            _wait(gcs, "SYS_STATUS with MOTOR_OUTPUTS unhealthy", _motor_outputs(healthy=False), 10.0)
            lost = [t.text for t in gcs.texts_since(t_kill) if "CAN bus lost" in t.text]
            assert lost, [t.text for t in gcs.texts]
            assert firmware.poll() is None, f"the firmware ended (exit {firmware.returncode})"
            # ... and still answers requests while it tries to reconnect (its log: a second attempt failed)
            wait_until(
                lambda: (
                    "reconnect attempt 2 failed" in (tmp_path / "procs.log").read_text()
                    or firmware.poll() is not None
                ),
                30.0,
                "a second reconnect attempt",
            )
            assert firmware.poll() is None, f"the firmware ended (exit {firmware.returncode})"
            assert gcs.param_get("LIM_RPS_MAX") > 0.0
            # WHEN the bench (and its hub) is back on the same port
            flight.start_bench(truth2)
            # THEN the vehicle is ready again, disarmed, the bus healthy, and the mission kept
            _wait(gcs, "SYS_STATUS with MOTOR_OUTPUTS healthy", _motor_outputs(healthy=True), 40.0)
            hb = _wait(
                gcs,
                "HEARTBEAT ready (STANDBY)",
                _is("HEARTBEAT", system_status=mavlink.MAV_STATE_STANDBY),
                30.0,
            )
            assert not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            items = gcs.download()
            assert len(items) == 1 and items[0].x != 0, items
        # AND a new START flies it
        flight.arm_start_flies(truth2, 0.0, "the restarted mission did not fly")
        stop(firmware)
        assert firmware.returncode == 0, firmware.returncode


def test_the_bench_outlives_its_firmware_and_serves_the_next_one(tmp_path: Path) -> None:
    truth = tmp_path / "truth.csv"
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        # GIVEN the vehicle flying an 80 m mission
        flight = Flight(tmp_path, procs, log, truth)
        bench, firmware = flight.bench, flight.firmware
        # WHEN the firmware is killed mid-mission
        firmware.kill()
        firmware.wait(10.0)
        # THEN the bench runs on, its actuator node in failsafe (no command comes), propeller 0
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline:
            rows = list(csv.DictReader(truth.open()))
            if rows and rows[-1]["failsafe"] == "1":
                break
            time.sleep(0.3)
        assert rows[-1]["failsafe"] == "1" and float(rows[-1]["propeller_cmd_rps"]) == 0.0, rows[-1]
        assert bench.poll() is None, f"the bench ended (exit {bench.returncode})"
        # WHEN a new firmware joins the same hub, THEN it is ready (the failsafe cleared) and flies
        x_before = _x_max(truth)
        flight.start_firmware()
        code, data = run_gcs(flight.url, flight.tlogs, "wait-ready", "--timeout", "30", timeout_s=30.0)
        assert code == 0 and data["ready"], data
        flight.arm_start_flies(truth, x_before, "the new firmware did not fly")
        assert bench.poll() is None, f"the bench ended (exit {bench.returncode})"


def _children(pid: int) -> list[int]:
    out: list[int] = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        out += [int(c) for c in (task / "children").read_text().split()]
    return out


def test_the_bench_hosts_a_new_hub_when_its_hub_dies_and_both_sides_fly_again(tmp_path: Path) -> None:
    truth = tmp_path / "truth.csv"
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        # GIVEN the vehicle flying an 80 m mission
        flight = Flight(tmp_path, procs, log, truth)
        bench, firmware = flight.bench, flight.firmware
        # WHEN the bench's CAN hub (a process of its own) is killed: both programs lose their bus
        (hub_pid,) = _children(bench.pid)
        os.kill(hub_pid, signal.SIGKILL)
        with MavClient(flight.url, system_id=204) as gcs:
            gcs.wait_heartbeat(10.0)
            # THEN the bench runs on and hosts a new hub on the same port; the firmware reconnects to it
            # and is ready again, disarmed
            _wait(gcs, "SYS_STATUS with MOTOR_OUTPUTS healthy", _motor_outputs(healthy=True), 40.0)
            _wait(
                gcs,
                "HEARTBEAT ready (STANDBY)",
                _is("HEARTBEAT", system_status=mavlink.MAV_STATE_STANDBY),
                30.0,
            )
        assert bench.poll() is None, f"the bench ended (exit {bench.returncode})"
        assert firmware.poll() is None, f"the firmware ended (exit {firmware.returncode})"
        # AND a new START flies
        x_before = _x_max(truth)
        flight.arm_start_flies(truth, x_before, "the vehicle did not fly again")
