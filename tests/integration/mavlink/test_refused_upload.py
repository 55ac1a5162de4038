"""A refused upload changes nothing, also while RUNNING (issue 21, row 10).

The real firmware process (the standalone vehicle: the real core and link over a simple plant) flies a
mission; the operator's ``auv-gcs upload`` (the real process) of new goals and a new fence is refused for its
goals (goal 0 lies in the new fence's obstacle). The new fence alone is valid with the old goals but covers
the vehicle, so had it been in force for a moment the running vehicle would have re-planned into it and held.
The vehicle must stay RUNNING on its old goals and old fence throughout.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from groundstation.bench_upload import start_vehicle, stop_vehicle
from groundstation.mavclient import MavClient, state_from_heartbeat
from groundstation.mission_files import goal_item, obstacle_item
from hil_sim.scenario import gcs_command

OLD_GOALS = [goal_item(80.0, 0.0, 1.0, None), goal_item(80.0, 20.0, 1.0, None)]  # a long run
OLD_FENCE = [obstacle_item(-30.0, -30.0, 2.0)]
NEW_PLAN = """goals:
  - {x_m: 5.0, y_m: 0.0, depth_m: 1.0}
  - {x_m: 80.0, y_m: 20.0, depth_m: 1.0}
obstacles:
  - {x_m: 0.0, y_m: 0.0, radius_m: 15.0}
"""


def _wait_state(c: MavClient, state: str, timeout_s: float) -> None:
    t_end = time.monotonic() + timeout_s
    seen = ""
    while time.monotonic() < t_end:
        m = c.recv(0.2)
        if m is not None and m.get_type() == "HEARTBEAT" and c.from_vehicle(m):
            seen = state_from_heartbeat(m)
            if seen == state:
                return
    raise AssertionError(f"no {state} within {timeout_s:g} s (last {seen or 'nothing'})")


def _plan(c: MavClient, mission_type: int) -> list[tuple[float, float, float]]:
    return [(i.x / 1e4, i.y / 1e4, i.param1) for i in c.download(mission_type)]


def test_a_refused_goals_and_fence_upload_leaves_the_running_mission_as_it_was(tmp_path: Path) -> None:
    proc, port = start_vehicle(tmp_path / "state", timeout_s=30.0)
    url = f"udpout:127.0.0.1:{port}"
    try:
        with MavClient(url) as c:
            c.heartbeat()
            c.wait_heartbeat(10.0)
            # GIVEN a vehicle RUNNING a mission with a fence
            assert c.upload(OLD_FENCE, mavlink.MAV_MISSION_TYPE_FENCE).ok
            assert c.upload(OLD_GOALS).ok
            old_goals, old_fence = (
                _plan(c, mavlink.MAV_MISSION_TYPE_MISSION),
                _plan(c, mavlink.MAV_MISSION_TYPE_FENCE),
            )
            ready, _hb, why = c.wait_ready(30.0)
            assert ready, why
            assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == mavlink.MAV_RESULT_ACCEPTED
            assert c.command(mavlink.MAV_CMD_MISSION_START) == mavlink.MAV_RESULT_ACCEPTED
            _wait_state(c, "RUNNING", 30.0)
            # WHEN the operator uploads new goals and a new fence, and the goals are refused
            plan = tmp_path / "new.yaml"
            plan.write_text(NEW_PLAN)
            gcs = subprocess.Popen(
                gcs_command(url, tmp_path / "tlogs", "upload", str(plan), timeout_s=20.0),
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
            )
            states: list[str] = []
            t_end = time.monotonic() + 60.0
            while gcs.poll() is None and time.monotonic() < t_end:
                m = c.recv(0.1)
                if m is not None and m.get_type() == "HEARTBEAT" and c.from_vehicle(m):
                    states.append(state_from_heartbeat(m))
            out, _ = gcs.communicate(timeout=30.0)
            t_end = time.monotonic() + 3.0  # and a while after: a late re-plan would show now
            while time.monotonic() < t_end:
                m = c.recv(0.1)
                if m is not None and m.get_type() == "HEARTBEAT" and c.from_vehicle(m):
                    states.append(state_from_heartbeat(m))
            # THEN the upload is refused for its goals (exit 1, the vehicle's reason) ...
            assert gcs.returncode == 1, out
            assert "goal 0" in out, out
            # ... and the vehicle flew on RUNNING, on its old goals and its old fence
            assert states and set(states) == {"RUNNING"}, f"states {states}; gcs said {out}"
            assert _plan(c, mavlink.MAV_MISSION_TYPE_MISSION) == old_goals
            assert _plan(c, mavlink.MAV_MISSION_TYPE_FENCE) == old_fence
    finally:
        stop_vehicle(proc)
