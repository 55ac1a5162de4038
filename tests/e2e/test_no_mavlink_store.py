"""The vehicle's state store without MAVLink (issue 22 item 4): ``auv-onboard run --no-mavlink`` keeps its
parameters, its mission progress and its flight logs in ``[store] dir`` (``--state-dir``) as a vehicle with
MAVLink does. Before: without MAVLink nothing was opened: a params.json edit was not in force, and a vehicle
killed mid-mission and started again flew its mission from goal 0."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from hil_sim.scenario import free_port
from tests.e2e.procs import bench_cmd, processes, stop
from tests.waiting import wait_until

pytestmark = pytest.mark.e2e

#: Three goals straight ahead of the bench's start (0, 0, 1 m, heading north): goal 0 is reached in about
#: 10 s of real time, the others are far enough that the vehicle is still flying when it is killed.
MISSION_YAML = (
    "goals:\n"
    "  - {x_m: 8.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"
    "  - {x_m: 60.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"
    "  - {x_m: 120.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"
)


def _run(channel: str, state: Path, *extra: str) -> list[str]:
    return [
        sys.executable, "-m", "onboard", "run", "--no-mavlink",
        "--set", f'bus.channel="{channel}"', "--state-dir", str(state), *extra,
    ]  # fmt: skip


def _saved_goal(state: Path) -> int:
    """The goal index in the store's progress.json (-1: none yet)."""
    try:
        return int(json.loads((state / "progress.json").read_text())["goal_index"])
    except (OSError, ValueError, KeyError):
        return -1


def _said(log: Path, text: str) -> bool:
    return log.exists() and text in log.read_text(errors="replace")


def test_killed_mid_mission_without_mavlink_it_resumes_from_the_saved_goal(tmp_path: Path) -> None:
    channel = f"ws://127.0.0.1:{free_port()}/"
    state = tmp_path / "state"
    mission = tmp_path / "mission.yaml"
    mission.write_text(MISSION_YAML)
    run = _run(channel, state, "--mission", str(mission), "--autostart")
    log1, log2 = tmp_path / "firmware1.log", tmp_path / "firmware2.log"
    with processes() as procs, open(tmp_path / "bench.log", "w") as bench_log:
        procs.append(
            subprocess.Popen(bench_cmd(channel, "0,0,1.0,0", 600), stdout=bench_log, stderr=subprocess.STDOUT)
        )
        # GIVEN a vehicle without MAVLink flying a three-goal mission from the command line
        with open(log1, "w") as out:
            first: subprocess.Popen[Any] = subprocess.Popen(run, stdout=out, stderr=subprocess.STDOUT)
        procs.append(first)
        # WHEN it has reached goal 0 (the store says goal 1 is current) and is killed mid-mission
        wait_until(lambda: _saved_goal(state) >= 1, 120.0, f"progress.json at goal 1 (see {log1})")
        first.kill()
        first.wait(10.0)
        assert _saved_goal(state) == 1
        # THEN a new start with the same command line resumes at the saved goal, not at goal 0
        with open(log2, "w") as out:
            second: subprocess.Popen[Any] = subprocess.Popen(run, stdout=out, stderr=subprocess.STDOUT)
        procs.append(second)
        wait_until(
            lambda: _said(log2, "mission progress restored: goal 1 is the current goal"),
            60.0,
            f"the restored progress in {log2}",
        )
        second.send_signal(signal.SIGINT)
        second.wait(20.0)
        stop(second)
    assert "Traceback" not in log2.read_text()
    # and the flight logs of both runs are in <store.dir>/logs
    assert len(list((state / "logs").glob("flight-*.mcap"))) == 2


def test_without_mavlink_a_persisted_parameter_edit_is_in_force(tmp_path: Path) -> None:
    # GIVEN a store whose params.json holds a ground-station edit (PD_KP5 -0.5; the file's value is -0.3)
    state = tmp_path / "state"
    state.mkdir()
    (state / "params.json").write_text(json.dumps({"version": 1, "params": {"PD_KP5": -0.5}}))
    channel = f"ws://127.0.0.1:{free_port()}/"  # a hub nobody hosts: the firmware boots and waits for it
    log = tmp_path / "firmware.log"
    with processes() as procs, open(log, "w") as out:
        # WHEN the vehicle starts without MAVLink
        procs.append(subprocess.Popen(_run(channel, state), stdout=out, stderr=subprocess.STDOUT))
        # THEN the edit is in force, said with its source
        wait_until(
            lambda: _said(log, "config control.improved.Kp5 = -0.5 (persisted, PD_KP5)"),
            30.0,
            f"the persisted edit in force (see {log})",
        )


def test_without_mavlink_a_store_that_cannot_be_written_is_reported_in_the_log(tmp_path: Path) -> None:
    # GIVEN a store directory that is a file (nothing can be saved there)
    blocker = tmp_path / "state"
    blocker.write_text("not a directory")
    channel = f"ws://127.0.0.1:{free_port()}/"
    log = tmp_path / "firmware.log"
    with processes() as procs, open(log, "w") as out:
        # WHEN the vehicle starts without MAVLink
        procs.append(subprocess.Popen(_run(channel, blocker), stdout=out, stderr=subprocess.STDOUT))
        # THEN it boots all the same and says in its log why nothing can be saved
        wait_until(
            lambda: (
                _said(log, f"state directory {blocker} is not a directory")
                and _said(log, "waiting for remote bus")
            ),
            30.0,
            f"the storage problem in the log (see {log})",
        )
    assert "Traceback" not in log.read_text()
