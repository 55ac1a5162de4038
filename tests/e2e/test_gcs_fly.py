"""``auv-gcs fly`` end to end: a QGroundControl .plan flown against the bench, and Ctrl-C holding the vehicle.

Real processes on 127.0.0.1: ``auv-hil run`` (real time, the CAN hub, the 6-DOF model), ``auv-onboard run``
(MAVLink on UDP) and ``auv-gcs fly``. The plan is QGroundControl's layout (``tests/data/qgc_example.plan``:
its keys, a waypoint in QGC's default frame, a circle exclusion fence), its waypoints replaced by one goal
12 m ahead of the start, in lat/lon about the vehicle's configured origin, altitude -1 m (1 m deep).
"""

from __future__ import annotations

import csv
import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, start_vehicle

pytestmark = pytest.mark.e2e

EXAMPLE = Path(__file__).parents[1] / "data" / "qgc_example.plan"
ORIGIN = (35.1, 129.04)  # the onboard's default [mavlink] origin_lat_deg / origin_lon_deg
EARTH_M = 6378137.0


def lat_lon(north_m: float, east_m: float) -> tuple[float, float]:
    lat = ORIGIN[0] + math.degrees(north_m / EARTH_M)
    lon = ORIGIN[1] + math.degrees(east_m / (EARTH_M * math.cos(math.radians(ORIGIN[0]))))
    return round(lat, 7), round(lon, 7)


def plan_file(path: Path, goal_ne: tuple[float, float], fence_ne: tuple[float, float]) -> Path:
    """The example .plan with one waypoint at ``goal_ne`` (1 m deep) and its fence circle at ``fence_ne``."""
    plan = json.loads(EXAMPLE.read_text())
    item = dict(plan["mission"]["items"][0])
    lat, lon = lat_lon(*goal_ne)
    item["params"] = [0, 0, 0, None, lat, lon, -1.0]
    item["Altitude"] = -1.0
    plan["mission"]["items"] = [item]
    plan["mission"]["plannedHomePosition"] = [*lat_lon(0.0, 0.0), 0]
    plan["geoFence"]["circles"] = [plan["geoFence"]["circles"][0]]
    plan["geoFence"]["circles"][0]["circle"]["center"] = list(lat_lon(*fence_ne))
    plan["geoFence"]["circles"][0]["circle"]["radius"] = 2.0
    path.write_text(json.dumps(plan, indent=4))
    return path


def fly_cmd(url: str, tlogs: Path, plan: Path) -> list[str]:
    return [
        sys.executable, "-m", "groundstation", "--connect", url, "--json", "--tlog-dir", str(tlogs),
        "fly", str(plan), "--ready-timeout", "20",
    ]  # fmt: skip


def lines(text: str) -> list[dict[str, Any]]:
    return [json.loads(x) for x in text.splitlines() if x.startswith("{")]


def test_fly_a_qgc_plan_to_complete_then_ctrl_c_holds(tmp_path: Path) -> None:
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    url = f"udpout:127.0.0.1:{mav_port}"
    tlogs = tmp_path / "tlogs"
    truth = tmp_path / "truth.csv"
    hil_cmd = bench_cmd(channel, "0,0,1.0,0", 120, f"--truth-log={truth}")
    onboard = onboard_cmd(channel, mav_port, tmp_path / "state")
    with processes() as procs, open(tmp_path / "procs.log", "w") as log:
        start_vehicle(procs, log, hil_cmd, onboard)
        # GIVEN the bench and the firmware; WHEN the operator flies a QGroundControl plan with one command
        plan = plan_file(tmp_path / "short.plan", (12.0, 0.0), (6.0, 8.0))
        done = subprocess.run(
            fly_cmd(url, tlogs, plan), capture_output=True, text=True, timeout=90, check=False
        )
        out = lines(done.stdout)
        # THEN it uploads, arms, starts, shows the progress, and ends with COMPLETE, exit 0
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
        end = out[-1]
        assert end["event"] == "end" and end["ok"] and end["state"] == "COMPLETE" and end["reached"] == 1
        progress = [x for x in out if x.get("event") == "progress"]
        running = [x for x in progress if x["state"] == "RUNNING"]
        assert running, out
        dists = [x["distance_m"] for x in running if x["distance_m"] is not None]
        assert dists and dists[0] > dists[-1]  # the distance to go comes down
        assert any(x["eta_s"] is not None for x in running)
        # AND the simulator's truth shows the vehicle at the goal when it said COMPLETE
        # (the bench writes its truth as it runs: give its last rows a moment to reach the file)
        t_end = time.monotonic() + 20.0
        while True:
            rows = list(csv.DictReader(truth.open()))
            done_rows = [r for r in rows if r["onboard_state"] == "COMPLETE"]
            if done_rows or time.monotonic() > t_end:
                break
            time.sleep(0.2)
        assert done_rows, rows[-3:]
        at = done_rows[0]  # the vehicle when it said COMPLETE: at the 12 m goal (0.5 m arrival radius)
        assert float(at["x_m"]) > 11.5 and abs(float(at["y_m"])) < 0.5, at

        # WHEN the operator flies a far goal and presses Ctrl-C while it runs
        far = plan_file(tmp_path / "far.plan", (200.0, 0.0), (6.0, 20.0))
        p = subprocess.Popen(
            fly_cmd(url, tlogs, far), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        seen: list[dict[str, Any]] = []
        assert p.stdout is not None
        for line in p.stdout:
            if line.startswith("{"):
                seen.append(json.loads(line))
                if seen[-1].get("state") == "RUNNING":
                    break
        p.send_signal(signal.SIGINT)
        rest, err = p.communicate(timeout=60)  # a deadline for a loaded machine, not a timing
        # THEN it sends HOLD, says what the vehicle answered, and exits 130
        assert p.returncode == 130, rest + err
        end = lines(rest)[-1]
        assert end["step"] == "interrupted" and end["hold"] is True, end
        assert "ACCEPTED" in end["reason"]
        hb = subprocess.run(
            [sys.executable, "-m", "groundstation", "--connect", url, "--json", "--tlog-dir", str(tlogs),
             "wait-ready", "--timeout", "5"],
            capture_output=True, text=True, timeout=30, check=False,
        )  # fmt: skip
        assert lines(hb.stdout)[-1]["state"] == "HOLD"
