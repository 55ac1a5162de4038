"""SYS_STATUS ``load`` of the real firmware (issue 22, item 2: it was always 0, ``loop_load`` was set only
in a test): ``auv-hil run`` (the bench, hosting the CAN hub) and ``auv-onboard run`` as processes, a ground
station reading SYS_STATUS over UDP as QGroundControl does. The load is the control loop's busy time per
period (``onboard.app.loop.LoopStats.load``), in MAVLink's per mille."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

from groundstation.mavclient import MavClient
from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import bench_cmd, onboard_cmd, processes, start_vehicle

pytestmark = pytest.mark.e2e

WAIT_S = 60.0  # generous: two processes start on a possibly loaded machine


def test_the_firmware_reports_its_loop_load_in_sys_status(tmp_path: Path) -> None:
    channel = f"ws://127.0.0.1:{free_port()}/"
    mav_port = free_udp_port()
    with processes() as procs, (tmp_path / "log.txt").open("w") as log:
        # GIVEN the bench and the firmware running (the loop ticks at 20 Hz in real time)
        start_vehicle(
            procs,
            log,
            bench_cmd(channel, "0,0,1.0,0", 120),
            onboard_cmd(channel, mav_port, tmp_path / "state"),
        )
        with MavClient(f"udpout:127.0.0.1:{mav_port}") as gcs:
            gcs.heartbeat()
            # WHEN a station reads SYS_STATUS
            deadline = time.monotonic() + WAIT_S
            seen: list[int] = []
            msg: Any = None
            while time.monotonic() < deadline and not (seen and seen[-1] > 0):
                msg = gcs.recv(0.25)
                if msg is not None and msg.get_type() == "SYS_STATUS" and gcs.from_vehicle(msg):
                    seen.append(int(msg.load))
            # THEN its load is the loop's busy share of the period: above 0 and at most 1000 per mille
            assert seen and 0 < seen[-1] <= 1000, f"SYS_STATUS loads seen: {seen[-10:]}"
