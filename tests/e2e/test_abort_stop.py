"""The last resort works when the onboard is what failed (issue 23, item 3: "the same for ABORT").

``auv-hil run`` (the bench and its actuator node) and ``auv-onboard run`` (the firmware) as processes on a
hub of their own, the mission uploaded and started with ``auv-gcs``; at cruise (1.2 m/s) the firmware is
killed (kill -9: the onboard computer failed). The actuator node's command watchdog fires and the node does
the bus contract's ABORT by itself: propeller off, rudder centred, stern planes nose up
(``messages.ABORT_STERN_DEG``). Before, it held the fins neutral: the vehicle glided 22 m on from 1.2 m/s
(still moving 40 s later) and sank 0.17 m below where it was. Judged on the simulator's truth.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, start_vehicle, upload_arm_start
from tests.waiting import wait_until

pytestmark = pytest.mark.e2e

MISSION_YAML = "goals:\n  - {x_m: 150.0, y_m: 0.0, depth_m: 3.0, yaw_deg: 0.0}\n"
#: Where the firmware is killed (m along the leg: at cruise) and how long the truth is watched after.
KILL_AT_X_M = 25.0
WATCH_S = 25.0


def _rows(truth: Path) -> list[dict[str, float]]:
    """The truth log's complete rows so far (the bench is still writing its last one)."""
    if not truth.exists():
        return []
    out = []
    with truth.open(newline="") as f:
        for r in csv.DictReader(f):
            try:
                out.append({k: float(r[k]) for k in ("t_s", "x_m", "y_m", "depth_m", "u_mps", "failsafe")})
            except (TypeError, ValueError):
                break
    return out


def test_the_actuator_node_stops_the_vehicle_when_the_firmware_dies_at_cruise(tmp_path: Path) -> None:
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    truth = tmp_path / "truth.csv"
    mission = tmp_path / "mission.yaml"
    mission.write_text(MISSION_YAML)
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        # GIVEN the vehicle flying a 150 m leg at 3 m, at cruise 25 m along
        start_vehicle(
            procs,
            log,
            bench_cmd(channel, "0,0,3.0,0", 600, f"--truth-log={truth}"),
            onboard_cmd(channel, mav_port, tmp_path / "state"),
        )
        firmware = procs[-1]
        upload_arm_start(f"udpout:127.0.0.1:{mav_port}", tmp_path / "tlogs", mission)
        along = f"the vehicle {KILL_AT_X_M} m along"
        wait_until(lambda: any(r["x_m"] > KILL_AT_X_M for r in _rows(truth)), 90.0, along)
        # WHEN the onboard computer fails (kill -9 of the firmware)
        firmware.kill()
        firmware.wait(10.0)

        # THEN the actuator node's watchdog fires, and the truth is watched for 25 s after
        def watched() -> list[dict[str, float]]:
            rows = _rows(truth)
            fired = next((r["t_s"] for r in rows if r["failsafe"]), None)
            return rows if fired is not None and rows[-1]["t_s"] >= fired + WATCH_S else []

        rows = wait_until(watched, 120.0, f"{WATCH_S} s of truth after the actuator failsafe")
    i = next(i for i, r in enumerate(rows) if r["failsafe"])
    at, after = rows[i], rows[i:]
    assert at["u_mps"] > 1.0, at  # it was at cruise
    ahead = max(math.hypot(r["x_m"] - at["x_m"], r["y_m"] - at["y_m"]) for r in after)
    deepest = max(r["depth_m"] for r in after)
    # the vehicle stops within 8 m ahead (before: 22 m, still gliding) and never goes deeper (before: +0.17 m)
    assert ahead <= 8.0, (ahead, at)
    assert deepest <= at["depth_m"] + 0.05, (deepest, at)
    assert abs(after[-1]["u_mps"]) < 0.5, after[-1]
