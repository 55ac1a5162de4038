"""Flight logs that keep what matters (issue 21, row 11), with the real firmware and bench as processes.

The state directory's ``logs/`` holds 20 logs of an older firmware named by a clock that once ran ahead
(2030). A real flight (``auv-onboard run --autostart`` beside ``auv-hil run``) keeps its own log while it
is written and after, ``auv-gcs logs`` lists it last (creation order, not the date in a name); then a crash
loop (six boots with no mission, each killed with SIGKILL once its log is on the disk) does not push the
flight out, and the directory stays within a small configured budget (bytes and files).
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from groundstation.plot import read_flight_log
from hil_sim.scenario import free_port, free_udp_port, run_gcs
from tests.e2e.procs import bench_cmd, onboard_cmd, processes

pytestmark = pytest.mark.e2e

START = "-13,0,1.0,0"  # x, y, depth (m), yaw (deg): paper-straight
MISSION = """goals:
  - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}
"""
BUDGET_BYTES = 200_000
KEEP_FILES = 3
LOG_SETTINGS = ("--set", f"log.max_total_mb={BUDGET_BYTES / 1e6:g}", "--set", f"log.keep_files={KEEP_FILES}")
AHEAD = [f"flight-203001{day:02d}-120000.mcap" for day in range(1, 21)]  # an older firmware's names, 2030
CRASH_BOOTS = 6


def _mcaps(logs: Path) -> set[str]:
    return {p.name for p in logs.glob("*.mcap")}


def _total_bytes(logs: Path) -> int:
    return sum(p.stat().st_size for p in logs.iterdir() if p.is_file())


def _wait_new_log(
    logs: Path,
    before: set[str],
    proc: subprocess.Popen[bytes],
    ready: Callable[[Path], bool],
    tail: Callable[[], str],
) -> str:
    """The one log ``proc`` made in ``logs`` (not in ``before``), once ``ready`` says so (60 s at most)."""
    deadline = time.monotonic() + 60.0
    while True:
        assert proc.poll() is None, f"the firmware exited {proc.returncode}\n{tail()}"
        new = sorted(_mcaps(logs) - before)
        if len(new) == 1 and ready(logs / new[0]):
            return new[0]
        assert time.monotonic() < deadline, f"no new log of the firmware ({new}) within 60 s\n{tail()}"
        time.sleep(0.2)


def _on_disk(path: Path) -> bool:
    try:
        return path.stat().st_size > 0
    except OSError:
        return False


def _flew(path: Path) -> bool:
    """The log shows the vehicle RUNNING (it is flushed every second as it flies)."""
    try:
        return any(e["to_state"] == "RUNNING" for e in read_flight_log(path).events)
    except (OSError, ValueError):  # gone, or not a tick written yet
        return False


def test_a_clock_that_ran_ahead_and_a_crash_loop_lose_no_real_flight(tmp_path: Path) -> None:
    # GIVEN 20 logs of 25 kB (500 kB) named 2030 by an older firmware, in the state directory's logs/
    state = tmp_path / "state"
    logs = state / "logs"
    logs.mkdir(parents=True)
    for name in AHEAD:
        (logs / name).write_bytes(os.urandom(25_000))
    mission = tmp_path / "mission.yaml"
    mission.write_text(MISSION)
    channel = f"ws://127.0.0.1:{free_port()}/"
    out_path = tmp_path / "procs.log"
    tail = lambda: out_path.read_text()[-3000:]  # noqa: E731
    with processes() as procs, open(out_path, "w") as out, open(tmp_path / "bench.log", "w") as bench:
        # (the bench apart: its hub's threads print what a client killed with SIGKILL left them)
        procs.append(subprocess.Popen(bench_cmd(channel, START, 240), stdout=bench, stderr=subprocess.STDOUT))
        # WHEN the firmware flies a mission (--autostart), a budget of 200 kB and 3 files configured
        mav_port = free_udp_port()
        cmd = onboard_cmd(channel, mav_port, state, "--mission", str(mission), "--autostart", *LOG_SETTINGS)
        onboard = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)
        procs.append(onboard)
        # THEN its own new log exists while it is written, and shows the flight
        flight = _wait_new_log(logs, set(AHEAD), onboard, _flew, tail)
        # AND `auv-gcs logs` (MAVLink FTP) lists it last: creation order, not the date in a name
        code, data = run_gcs(f"udpout:127.0.0.1:{mav_port}", tmp_path / "tlogs", "logs", timeout_s=20.0)
        assert code == 0 and data["ok"], data
        listed = [e["name"] for e in data["logs"]]
        assert listed[-1] == flight and set(listed) == _mcaps(logs), listed
        onboard.send_signal(signal.SIGINT)
        assert onboard.wait(20.0) == 0, tail()
        # AND it is still there once closed; the oldest 2030 logs made room (3 files at most)
        assert flight in _mcaps(logs) and len(_mcaps(logs)) <= KEEP_FILES, sorted(_mcaps(logs))
        assert _total_bytes(logs) <= BUDGET_BYTES, sorted(_mcaps(logs))

        # WHEN the firmware then crash-loops: six boots without a mission, each killed once its log is on disk
        boot_logs: list[str] = []
        for boot in range(CRASH_BOOTS):
            before = _mcaps(logs)
            p = subprocess.Popen(
                onboard_cmd(channel, free_udp_port(), state, *LOG_SETTINGS),
                stdout=out,
                stderr=subprocess.STDOUT,
            )
            procs.append(p)
            mine = _wait_new_log(logs, before, p, _on_disk, tail)
            p.kill()
            p.wait(10.0)
            boot_logs.append(mine)
            # THEN each crashed boot's log is there after the crash, and the flight's too
            assert mine in _mcaps(logs) and flight in _mcaps(logs), (boot, sorted(_mcaps(logs)))
    # AND after the loop: the real flight kept, the last boot's log kept, the earlier boot-only logs removed
    # before even a 2030 log older than all of them (logs of the older firmware count as flights)
    left = _mcaps(logs)
    assert flight in left and boot_logs[-1] in left and set(AHEAD) & left, sorted(left)
    assert not set(boot_logs[:-1]) & left, sorted(left)
    # AND within 3 files and 200 kB
    assert len(left) <= KEEP_FILES and _total_bytes(logs) <= BUDGET_BYTES, (sorted(left), _total_bytes(logs))
    firmware = out_path.read_text()
    assert "Traceback" not in firmware and "flight log off" not in firmware and "cannot" not in firmware
