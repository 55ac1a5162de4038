"""MAVProxy, the real program, against the vehicle's link: what an operator types, what MAVProxy prints.

MAVProxy (a dev dependency) is started on a TCP endpoint of an in-process vehicle and typed at on its stdin,
one command at a time, the way an operator types. It must show the vehicle's mode by name (ArduSub's names:
HEARTBEAT custom_mode, :mod:`onboard.adapters.mavlink.modes`), set modes by name, and list a local-frame
mission in metres (``set wp_use_mission_int 0``: MAVProxy reads a local MISSION_ITEM_INT's x/y as degrees
* 1e7, so it asks with the legacy MISSION_REQUEST, answered with a float MISSION_ITEM).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from groundstation.mavclient import MavClient
from groundstation.mission_files import goal_item
from hil_sim.scenario import free_port
from tests.integration.mavlink.conftest import Vehicle

MAVPROXY = shutil.which("mavproxy.py", path=str(Path(sys.executable).parent))


class Operator:
    """MAVProxy on a pipe: ``type`` a command, ``wait_for`` a line it prints."""

    def __init__(self, master: str, cwd: Path) -> None:
        assert MAVPROXY, "MAVProxy is a dev dependency: pip install -e '.[dev]'"
        self.lines: list[str] = []
        self.proc = subprocess.Popen(
            [sys.executable, MAVPROXY, f"--master={master}", f"--logfile={cwd / 'mav.tlog'}"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=cwd,
        )  # fmt: skip
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))

    def type(self, command: str) -> int:
        """Send one command line; returns the index of the output from which its answer counts."""
        assert self.proc.stdin is not None
        mark = len(self.lines)
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()
        return mark

    def wait_for(self, pattern: str, since: int = 0, timeout_s: float = 8.0) -> re.Match[str]:
        t_end = time.monotonic() + timeout_s
        while time.monotonic() < t_end:
            for line in self.lines[since:]:
                if m := re.search(pattern, line):
                    return m
            time.sleep(0.05)
        tail = "\n".join(self.lines[-40:])
        raise AssertionError(f"MAVProxy never printed /{pattern}/; it printed:\n{tail}")

    def stop(self) -> None:
        self.proc.kill()
        self.proc.wait(timeout=5)


@pytest.fixture
def operator(tmp_path: Path) -> Iterator[tuple[Vehicle, Operator]]:
    port = free_port()
    v = Vehicle(tmp_path / "state", endpoints=(f"tcpin:127.0.0.1:{port}",)).start()
    with MavClient(f"tcp:127.0.0.1:{port}") as c:  # the mission, from our own ground station
        c.heartbeat()
        c.wait_heartbeat(3.0)
        assert c.upload([goal_item(300.0, 5.0, 2.0, 90.0), goal_item(300.0, 300.0, 3.0, None)]).ok
    op = Operator(f"tcp:127.0.0.1:{port}", tmp_path)
    try:
        op.wait_for(r"online system 1", timeout_s=15.0)
        yield v, op
    finally:
        op.stop()
        v.stop()


def test_mavproxy_shows_and_sets_the_modes_by_name_and_lists_the_mission_in_metres(
    operator: tuple[Vehicle, Operator],
) -> None:
    _, op = operator
    # GIVEN MAVProxy connected to the vehicle (idle, a mission of two goals uploaded)
    # THEN its prompt and its mode line name the mode: MANUAL (IDLE)
    op.wait_for(r"Mode MANUAL")
    # WHEN the operator lists the mission the legacy way
    op.type("set wp_use_mission_int 0")
    mark = op.type("wp list")
    # THEN each goal is listed in metres (x north, y east, z depth) with its yaw
    first = op.wait_for(r"^16 1 (\S+) (\S+) (\S+) .*p4=(\S+)", mark)
    assert [float(v) for v in first.groups()] == [300.0, 5.0, 2.0, 90.0]
    op.wait_for(r"^16 1 300\.0+ 300\.0+ 3\.0+ .*p4=nan", mark)
    # WHEN the operator arms and sets the modes by name
    mark = op.type("arm throttle")
    op.wait_for(r"COMPONENT_ARM_DISARM: ACCEPTED", mark)
    mark = op.type("mode AUTO")
    # THEN the vehicle starts and MAVProxy shows AUTO; POSHOLD holds; SURFACE aborts
    op.wait_for(r"DO_SET_MODE: ACCEPTED", mark)
    op.wait_for(r"ARMED -> RUNNING", mark)
    op.wait_for(r"Mode AUTO", mark)
    mark = op.type("mode POSHOLD")
    op.wait_for(r"RUNNING -> HOLD", mark)
    op.wait_for(r"Mode POSHOLD", mark)
    mark = op.type("mode SURFACE")
    op.wait_for(r"HOLD -> ABORT", mark)
    op.wait_for(r"Mode SURFACE", mark)
    # AND a mode the vehicle does not have is refused with the reason, printed by MAVProxy
    mark = op.type("mode GUIDED")
    op.wait_for(r"DO_SET_MODE: DENIED", mark)
    op.wait_for(r"GUIDED is not a mode of this vehicle \(modes: AUTO, POSHOLD, SURFACE, MANUAL\)", mark)
    # AND no mode was ever shown as a number
    assert not any(re.search(r"Mode\(\d+\)", line) for line in op.lines), op.lines


def test_mavproxy_reads_the_planned_path_over_mavlink_ftp(
    operator: tuple[Vehicle, Operator], tmp_path: Path
) -> None:
    _, op = operator
    # GIVEN MAVProxy connected to the vehicle, which flies the first goal of its mission
    op.wait_for(r"Mode MANUAL")
    mark = op.type("arm throttle")
    op.wait_for(r"COMPONENT_ARM_DISARM: ACCEPTED", mark)
    mark = op.type("mode AUTO")
    op.wait_for(r"Mode AUTO", mark)
    # WHEN the operator lists the vehicle's files and fetches the path with MAVProxy's ftp module
    mark = op.type("ftp list /")
    op.wait_for(r"@PATH", mark)
    target = tmp_path / "planned.json"
    mark = op.type(f"ftp get @PATH/planned.json {target}")
    op.wait_for(r"Wrote \d+ bytes|Got \d+ bytes", mark, timeout_s=15.0)
    # THEN the file is the path the vehicle flies: to goal 0 at (300, 5), depth 2
    t_end = time.monotonic() + 5.0
    while not target.exists() and time.monotonic() < t_end:
        time.sleep(0.1)
    doc = json.loads(target.read_text())
    assert doc["kind"] == "goal" and doc["goal_index"] == 0 and doc["frame"] == "local_ned"
    x_m, y_m, depth_m = doc["points_m"][-1]
    assert abs(x_m - 300.0) < 0.05 and abs(y_m - 5.0) < 0.05 and abs(depth_m - 2.0) < 1e-6
