"""The values served are the values in force, from the first packet (issue 21, row 4).

A ground station (QGroundControl) reads the parameter list once, at connect, and caches it: a firmware that
answers PARAM_* with the table's defaults before its persisted edits are in force shows the operator values
the vehicle does not fly with. The real firmware process is killed (SIGKILL) and restarted five times beside
two CPU hogs; each time the whole list is read at the first heartbeat and every edited value is the
persisted one.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from groundstation.bench_upload import start_vehicle, stop_vehicle
from groundstation.mavclient import MavClient
from onboard.core.params import float32

#: Edits away from the defaults, applied in any order (no rule spans two of them).
EDITS = {"LIM_RPS_MAX": 12.5, "PD_KP5": -0.5, "GDE_LOOKAHD_M": 3.5, "FS_NAV_TMO_S": 2.5, "MIS_MAX_TRIES": 5.0}
RESTARTS = 5


@contextlib.contextmanager
def cpu_hogs(n: int) -> Iterator[None]:
    """``n`` busy processes (``while 1: pass``) for the duration: the machine is loaded."""
    hogs = [subprocess.Popen([sys.executable, "-c", "while 1: pass"]) for _ in range(n)]
    try:
        yield
    finally:
        for p in hogs:
            p.kill()
            p.wait(timeout=10.0)


def test_every_value_served_at_the_first_heartbeat_is_the_persisted_one(tmp_path: Path) -> None:
    state = tmp_path / "state"
    proc, port = start_vehicle(state)
    try:
        with MavClient(f"udpout:127.0.0.1:{port}") as c:
            c.heartbeat()
            c.wait_heartbeat(10.0)
            for name, value in EDITS.items():
                ok, got = c.param_set(name, value)
                assert ok and got == pytest.approx(value), name
        with cpu_hogs(2):
            for k in range(RESTARTS):
                # GIVEN a firmware killed without warning after its edits were acknowledged
                os.kill(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10.0)
                # WHEN it restarts on a loaded machine and the list is read at the first heartbeat
                proc, port = start_vehicle(state, timeout_s=60.0)
                with MavClient(f"udpout:127.0.0.1:{port}") as c:
                    c.heartbeat()
                    c.wait_heartbeat(30.0)
                    got = c.param_list(timeout_s=60.0)
                # THEN every edited value is the persisted one (float32 on the wire)
                wrong = {n: got.get(n) for n, v in EDITS.items() if got.get(n) != float32(v)}
                assert not wrong, f"restart {k}: served {wrong}, persisted {EDITS}"
    finally:
        if proc.poll() is None:
            stop_vehicle(proc)
