"""A state directory that cannot be written (a full disk): an acknowledgement still means durable.

Issue 21, rows 1, 2, 3 and 17. The state directory is a 1 MB tmpfs filled to the last byte (root only:
``mount -t tmpfs``; the test is skipped with the reason where mounting is not permitted). The vehicles are
real: the standalone process (``groundstation.bench_upload.start_vehicle``: the real link and core over a
simple plant), the in-process :class:`Vehicle` (the same on real sockets), and ``auv-onboard run``.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.bench_upload import start_vehicle, stop_vehicle
from groundstation.mavclient import MavClient
from groundstation.mission_files import goal_item
from tests.integration.mavlink.conftest import Vehicle

LOGGING = mavlink.MAV_SYS_STATUS_LOGGING
WAIT_S = 20.0  # generous: the machine may be loaded


class Disk:
    """A 1 MB tmpfs at ``path``; :meth:`fill` takes every free byte, :meth:`free` gives them back."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fill_file = path / "fill"

    def fill(self) -> None:
        with contextlib.suppress(OSError), self.fill_file.open("ab") as f:
            while True:
                f.write(b"\0" * 4096)
                f.flush()
        # a last try of small writes: tmpfs counts pages, every byte must be gone
        with contextlib.suppress(OSError), self.fill_file.open("ab", buffering=0) as f:
            while True:
                f.write(b"\0")

    def free(self) -> None:
        self.fill_file.unlink(missing_ok=True)


@pytest.fixture
def disk(tmp_path: Path) -> Iterator[Disk]:
    path = tmp_path / "state"
    path.mkdir()
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(path)], capture_output=True, text=True
    )
    if r.returncode != 0:
        pytest.skip(f"cannot mount a 1 MB tmpfs here: {r.stderr.strip() or r.returncode}")
    try:
        yield Disk(path)
    finally:
        subprocess.run(["umount", "-l", str(path)], capture_output=True)


def connect(port: int) -> MavClient:
    c = MavClient(f"udpout:127.0.0.1:{port}")
    c.heartbeat()
    c.wait_heartbeat(WAIT_S)
    return c


def goals(k: float, n: int = 3) -> list:  # type: ignore[type-arg]
    return [goal_item(k, float(i), 1.0, None) for i in range(n)]


def xy(items: list) -> list[tuple[float, float]]:  # type: ignore[type-arg]
    return [(i.x / 1e4, i.y / 1e4) for i in items]


def wait_text(
    c: MavClient, pred: Callable[[str], bool], since: float = 0.0, timeout_s: float = WAIT_S
) -> str:
    """The first (reassembled) STATUSTEXT since ``since`` for which ``pred`` holds."""
    t_end = time.monotonic() + timeout_s
    while True:
        for t in c.texts_since(since):
            if pred(t.text):
                return t.text
        if time.monotonic() > t_end:
            seen = [t.text for t in c.texts_since(since)]
            raise AssertionError(f"no such STATUSTEXT within {timeout_s} s; seen {seen}")
        c.recv(0.1)


def wait_msg(
    c: MavClient, kind: str, pred: Callable[[mavlink.MAVLink_message], bool], timeout_s: float = WAIT_S
) -> mavlink.MAVLink_message:
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        m = c.recv(0.1)
        if m is not None and m.get_type() == kind and c.from_vehicle(m) and pred(m):
            return m
    raise AssertionError(f"no such {kind} within {timeout_s} s")


def logging_bits(m: mavlink.MAVLink_message) -> tuple[bool, bool, bool]:
    """SYS_STATUS: the logging bit (present, enabled, healthy)."""
    return (
        bool(m.onboard_control_sensors_present & LOGGING),
        bool(m.onboard_control_sensors_enabled & LOGGING),
        bool(m.onboard_control_sensors_health & LOGGING),
    )


# ---- row 1: an upload or a PARAM_SET that cannot be saved is refused, nothing changes in force -----------
def test_an_upload_and_a_param_set_that_cannot_be_saved_are_refused_and_nothing_changes(disk: Disk) -> None:
    # GIVEN a vehicle with mission A and PD_KP5 -0.4 saved, then its disk full
    proc, port = start_vehicle(disk.path, timeout_s=WAIT_S)
    try:
        with connect(port) as c:
            assert c.upload(goals(5.0)).ok
            assert c.param_set("PD_KP5", -0.4) == (True, pytest.approx(-0.4))
            disk.fill()
            # WHEN mission B is uploaded and PD_KP5 set to -0.5
            t0 = time.monotonic()
            r = c.upload(goals(7.0))
            ok, value = c.param_set("PD_KP5", -0.5)
            # THEN both are refused on the wire with the reason, and the vehicle flies what it had
            assert (r.ok, r.result) == (False, mavlink.MAV_MISSION_ERROR), r
            assert "No space left on device" in r.reason, r.reason
            assert not ok and value == pytest.approx(-0.4)
            wait_text(c, lambda t: "PD_KP5" in t and "No space left on device" in t, since=t0)
            assert xy(c.download()) == [(5.0, 0.0), (5.0, 1.0), (5.0, 2.0)]
            assert c.param_get("PD_KP5") == pytest.approx(-0.4)
    finally:
        stop_vehicle(proc)
    # AND after a restart (the disk still full) the vehicle has the same mission and value
    proc, port = start_vehicle(disk.path, timeout_s=WAIT_S)
    try:
        with connect(port) as c:
            assert xy(c.download()) == [(5.0, 0.0), (5.0, 1.0), (5.0, 2.0)]
            assert c.param_get("PD_KP5") == pytest.approx(-0.4)
    finally:
        stop_vehicle(proc)


# ---- row 2: a vehicle that boots on a full disk runs, says so, refuses uploads, recovers -----------------
def test_a_vehicle_booting_on_a_full_disk_runs_says_so_and_recovers_when_space_returns(disk: Disk) -> None:
    # GIVEN a state directory with mission A saved, then the disk full
    proc, port = start_vehicle(disk.path, timeout_s=WAIT_S)
    try:
        with connect(port) as c:
            assert c.upload(goals(5.0)).ok
    finally:
        stop_vehicle(proc)
    disk.fill()
    # WHEN the vehicle boots
    proc, port = start_vehicle(disk.path, timeout_s=WAIT_S)
    try:
        with connect(port) as c:
            # THEN a station that connects hears why nothing can be saved, SYS_STATUS says it too,
            text = wait_text(c, lambda t: t.startswith("storage: nothing can be saved"))
            assert "No space left on device" in text, text
            sys_status = wait_msg(c, "SYS_STATUS", lambda m: True)
            assert logging_bits(sys_status) == (True, True, False)
            # the mission it could read is in force, and an upload is refused with the reason
            assert xy(c.download()) == [(5.0, 0.0), (5.0, 1.0), (5.0, 2.0)]
            r = c.upload(goals(7.0))
            assert (r.ok, r.result) == (False, mavlink.MAV_MISSION_ERROR)
            assert "No space left on device" in r.reason, r.reason
            # AND once space returns the vehicle is writable again without a reboot
            disk.free()
            wait_msg(c, "SYS_STATUS", lambda m: logging_bits(m) == (True, True, True))
            assert c.upload(goals(7.0)).ok
        # a second station that connects later hears nothing about storage any more
        with connect(port) as c2:
            t0 = time.monotonic()
            wait_msg(c2, "SYS_STATUS", lambda m: True)
            assert not [t for t in c2.texts_since(t0) if t.text.startswith("storage:")]
    finally:
        stop_vehicle(proc)
    assert json.loads((disk.path / "mission.json").read_text())["items"][0]["x"] == 70000


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_the_firmware_boots_on_a_full_disk_and_serves_mavlink(disk: Disk) -> None:
    # GIVEN a full state directory and a CAN hub nobody hosts (the firmware waits for its bus, MAVLink runs)
    disk.fill()
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        hub = s.getsockname()[1]
    port = _free_udp_port()
    proc = subprocess.Popen(
        [
            sys.executable, "-m", "onboard", "run", "--state-dir", str(disk.path),
            "--set", f'bus.channel="ws://127.0.0.1:{hub}/"',
            "--set", f'mavlink.endpoints=["udpin:127.0.0.1:{port}"]',
        ],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        # WHEN a station connects THEN it gets heartbeats and hears why nothing can be saved
        with connect(port) as c:
            text = wait_text(c, lambda t: t.startswith("storage: nothing can be saved"))
            assert "No space left on device" in text, text
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    assert "Traceback" not in err, err


# ---- row 3: progress that cannot be saved is reported and retried --------------------------------------
def test_progress_that_cannot_be_saved_is_reported_and_saved_once_space_returns(disk: Disk) -> None:
    v = Vehicle(disk.path).start()
    try:
        with v.client() as c:
            # GIVEN a mission with its progress (goal 0) saved, then the disk full
            assert c.upload(goals(5.0)).ok
            progress = disk.path / "progress.json"
            t_end = time.monotonic() + WAIT_S
            while not progress.exists() and time.monotonic() < t_end:
                time.sleep(0.05)
            assert json.loads(progress.read_text())["goal_index"] == 0
            disk.fill()
            # WHEN the current goal becomes goal 1
            t0 = time.monotonic()
            ts, tc = c.target
            c.send(mavlink.MAVLink_mission_set_current_message(ts, tc, 1))
            wait_msg(c, "MISSION_CURRENT", lambda m: m.seq == 1)
            # THEN the operator hears that it is not saved
            text = wait_text(c, lambda t: "progress" in t and "No space left on device" in t, since=t0)
            assert "goal 1" in text, text
            # AND once space returns it is saved without anything else happening
            disk.free()
            t_end = time.monotonic() + WAIT_S
            while json.loads(progress.read_text())["goal_index"] != 1:
                assert time.monotonic() < t_end, "progress never saved after the disk was freed"
                time.sleep(0.05)
    finally:
        v.stop()


# ---- row 17: temporary files left by a killed process are removed at boot -------------------------------
def test_temporary_files_left_by_a_killed_process_are_removed_at_boot(tmp_path: Path) -> None:
    # GIVEN the leftovers a kill -9 in write_json_atomic or the write probe leaves, and files of other names
    state = tmp_path / "state"
    state.mkdir()
    leftovers = [
        ".progress.json.4242.tmp",
        ".params.json.4243.tmp",
        ".mission.json.17.tmp",
        ".signing.json.99999.tmp",
        ".write-probe.4244",
    ]
    kept = ["notes.tmp", ".hidden", "mission.json.invalid-20300101T000000Z", ".params.json.x.tmp"]
    for name in (*leftovers, *kept):
        (state / name).write_text("{")
    # WHEN the vehicle boots
    proc, port = start_vehicle(state, timeout_s=WAIT_S)
    try:
        with connect(port):
            pass
        # THEN the leftovers are gone and nothing else was touched
        names = set(os.listdir(state))
        assert not names & set(leftovers), names & set(leftovers)
        assert set(kept) <= names
    finally:
        stop_vehicle(proc)
