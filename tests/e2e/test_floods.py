"""Floods starve no one (issue 12, item 4), with real processes: the bench and its hub, the firmware flying a
mission, and a flooder of its own.

- CAN: unknown-id frames through the hub at 50 k frames/s. The hub runs in a process of its own and applies
  each node's acceptance filters, and every drain has a frame budget: the control tick keeps its deadline
  and the actuator watchdog never fires. Before: the hub inside the bench starved the simulation and the
  actuator watchdog aborted the mission.
- MAVLink: 50 k datagrams/s of garbage and corrupt heartbeats from 64 other ports at the firmware's UDP port.
  Each known peer has a receive share of its own and strangers share one, so the genuine ground station
  keeps its answers and the heartbeats keep coming.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from groundstation.mavclient import LinkError, MavClient
from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import processes, stop

pytestmark = pytest.mark.e2e

FLOOD_RATE = 50_000.0


def _flooder(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "tests.e2e.flood", *args], stdout=subprocess.PIPE, text=True
    )


def _rate(flooder: subprocess.Popen[str]) -> float:
    out, _ = flooder.communicate(timeout=60)
    return float(json.loads(out.strip().splitlines()[-1])["rate"])


def test_a_can_flood_of_unknown_ids_starves_neither_the_tick_nor_the_actuators(tmp_path: Path) -> None:
    # GIVEN the bench and the firmware flying a 40 m mission on the real hub
    channel = f"ws://127.0.0.1:{free_port()}/"
    mission = tmp_path / "mission.yaml"
    mission.write_text("goals:\n  - {x_m: 40.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n")
    truth, bench_summary = tmp_path / "truth.csv", tmp_path / "bench.json"
    onboard_summary = tmp_path / "onboard.json"
    with processes() as procs:
        bench_cmd = [sys.executable, "-m", "hil_sim", "run", "--channel", channel, "--duration", "22",
                     "--truth-log", str(truth), "--summary-json", str(bench_summary)]  # fmt: skip
        bench = subprocess.Popen(bench_cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(bench)
        onboard_cmd = [sys.executable, "-m", "onboard", "run", "--no-mavlink",
                       "--set", f'bus.channel="{channel}"', "--state-dir", str(tmp_path / "state"),
                       "--mission", str(mission), "--autostart",
                       "--summary-json", str(onboard_summary)]  # fmt: skip
        onboard = subprocess.Popen(onboard_cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        procs.append(onboard)
        _wait_running(truth)
        # WHEN a third process floods the hub with an id nobody listens to, for 12 s
        flooder = _flooder("can", channel, "12", str(FLOOD_RATE))
        procs.append(flooder)
        rate = _rate(flooder)
        bench.wait(timeout=60)
        stop(onboard)
        _, err = onboard.communicate(timeout=10)
    rows = list(csv.DictReader(truth.open()))
    b: dict[str, Any] = json.loads(bench_summary.read_text())
    o: dict[str, Any] = json.loads(onboard_summary.read_text())
    # THEN the flood was real (at least 60 % of the aim reached the hub on this machine) ...
    assert rate > 0.6 * FLOOD_RATE, rate
    # ... the actuators never went to failsafe, the tick kept its deadlines, and the mission flew on
    assert b["failsafe_timeouts"] == 0 and not any(r["failsafe"] == "1" for r in rows), b
    _kept_deadlines(o)
    # the onboard's state as the bench heard it, tick by tick while it ran (the onboard's own final state
    # comes after the bench has stopped, when the sensors going stale abort it: that is no flood effect)
    states = [r["onboard_state"] for r in rows if r["onboard_state"]]
    assert "ABORT" not in states and states[-1] in ("RUNNING", "COMPLETE"), (states[-5:], o, err[-2000:])
    assert max(float(r["x_m"]) for r in rows) > 15.0
    # and not one flood frame reached the firmware's process: the hub filtered them
    assert o["frames_rejected"] == {} and o["drains_at_budget"] == 0, o


def _wait_running(truth: Path, timeout_s: float = 30.0) -> None:
    """Until the truth log shows the firmware RUNNING (the flood then hits a mission under way)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if truth.exists() and "RUNNING" in truth.read_text()[-4000:]:
            return
        time.sleep(0.2)
    raise AssertionError(f"the firmware did not start the mission within {timeout_s} s")


def test_a_mavlink_flood_from_other_ports_leaves_the_genuine_ground_station_its_answers(
    tmp_path: Path,
) -> None:
    # GIVEN the bench, the firmware on its own UDP port (the control loop running) and a ground station
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    onboard_summary = tmp_path / "onboard.json"
    with processes() as procs:
        bench_cmd = [sys.executable, "-m", "hil_sim", "run", "--channel", channel, "--duration", "60"]
        procs.append(subprocess.Popen(bench_cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        onboard_cmd = [sys.executable, "-m", "onboard", "run", "--set", f'bus.channel="{channel}"',
                       "--set", f'mavlink.endpoints=["udpin:127.0.0.1:{mav_port}"]',
                       "--state-dir", str(tmp_path / "state"),
                       "--summary-json", str(onboard_summary)]  # fmt: skip
        onboard = subprocess.Popen(onboard_cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        procs.append(onboard)
        with MavClient(f"udpout:127.0.0.1:{mav_port}", system_id=201) as gcs:
            gcs.wait_heartbeat(30.0)
            names = sorted(gcs.param_list())
            heartbeats: list[float] = []
            gcs.on_message = lambda msg: (
                heartbeats.append(time.monotonic()) if msg.get_type() == "HEARTBEAT" else None
            )
            # WHEN another process floods the firmware's port from 64 other ports: garbage and heartbeats
            # with one bit flipped, 50 k datagrams/s for 12 s
            flooder = _flooder("mavlink", "127.0.0.1", str(mav_port), "12", str(FLOOD_RATE))
            procs.append(flooder)
            time.sleep(1.0)
            t0 = time.monotonic()
            answered, latencies = 0, []
            for k in range(40):  # the genuine ground station asks for one parameter at a time
                t_ask = time.monotonic()
                try:
                    gcs.param_get(names[k % len(names)], resend_s=1.0, retries=1)
                except LinkError:
                    continue
                answered += 1
                latencies.append(time.monotonic() - t_ask)
            while time.monotonic() < t0 + 9.0:
                gcs.recv(0.1)
            t1 = time.monotonic()
            rate = _rate(flooder)
        stop(onboard)
        _, err = onboard.communicate(timeout=10)
    o: dict[str, Any] = json.loads(onboard_summary.read_text())
    in_flood = [t for t in heartbeats if t0 <= t <= t1]
    # THEN the flood was real, and the ground station got >= 90 % of its answers within 1 s, heartbeats
    # kept coming at >= 0.8 Hz, and the control tick kept its deadlines
    assert rate > 0.6 * FLOOD_RATE, rate
    assert answered >= 36, (answered, latencies)
    assert len(in_flood) / (t1 - t0) >= 0.8, (len(in_flood), t1 - t0)
    _kept_deadlines(o, err)


def _kept_deadlines(summary: dict[str, Any], err: str = "") -> None:
    """The control tick kept its deadlines through the flood: at most 2 % of the ticks late and never more
    than 2 in a row. Not 0: the suite runs 4 workers on 2 cores beside the flooder, the bench and the
    firmware, and the OS stalls a process now and then (once 2 in a row, 0.12 s late, 3 of 459 ticks). The
    starvation these tests guard against looked otherwise: before the hub's filters a CAN flood gave 12
    overruns, 61 missed deadlines and an actuator failsafe."""
    ticks = max(int(summary["ticks"]), 1)
    assert summary["overruns"] <= 0.02 * ticks, (summary, err[-2000:])
    assert summary["max_consecutive_overruns"] <= 2, (summary, err[-2000:])
