"""Processes of an end-to-end test: whatever happens, each is stopped (terminate, then kill)."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from auv_common.process import stop_process

#: The e2e tests' name for it.
stop = stop_process


@contextlib.contextmanager
def processes() -> Iterator[list[subprocess.Popen[Any]]]:
    """Processes appended to the yielded list are stopped on exit, the last started first."""
    procs: list[subprocess.Popen[Any]] = []
    try:
        yield procs
    finally:
        for p in reversed(procs):
            stop(p)


def bench_cmd(channel: str, start: str, duration_s: float, *extra: str) -> list[str]:
    """``auv-hil run`` in real time on ``channel`` from ``start`` ("X,Y,DEPTH,YAW_DEG"), basin sensors."""
    return [
        sys.executable, "-m", "hil_sim", "run", "--mode=realtime", f"--channel={channel}",
        f"--start={start}", f"--duration={duration_s:g}", "--profile=basin", *extra,
    ]  # fmt: skip


def onboard_cmd(channel: str, mav_port: int, state_dir: Path, *extra: str) -> list[str]:
    """``auv-onboard run`` on ``channel``, MAVLink on ``udpin:127.0.0.1:mav_port``, its own state dir."""
    return [
        sys.executable, "-m", "onboard", "run",
        "--set", f'bus.channel="{channel}"',
        "--set", f'mavlink.endpoints=["udpin:127.0.0.1:{mav_port}"]',
        "--state-dir", str(state_dir),
        *extra,
    ]  # fmt: skip


def start_vehicle(procs: list[subprocess.Popen[Any]], log: Any, bench: list[str], onboard: list[str]) -> None:
    """The bench and the firmware as processes (stopped with ``procs``), both writing to ``log``."""
    procs.append(subprocess.Popen(bench, stdout=log, stderr=subprocess.STDOUT))
    procs.append(subprocess.Popen(onboard, stdout=log, stderr=subprocess.STDOUT))


def upload_arm_start(url: str, tlogs: Path, mission: Path, boot_timeout_s: float = 60.0) -> None:
    """What an operator does step by step with ``auv-gcs``: upload, wait-ready, arm, start; each accepted.
    The upload is asked again while the vehicle says its control loop is not running yet (it boots: on a
    loaded machine that takes a while), until ``boot_timeout_s``."""
    import time

    from hil_sim.scenario import run_gcs

    deadline = time.monotonic() + boot_timeout_s
    while True:
        code, data = run_gcs(url, tlogs, "upload", str(mission), timeout_s=20.0)
        booting = code != 0 and "control loop is not running" in str(data.get("reason", ""))
        if not booting or time.monotonic() > deadline:
            break
        time.sleep(0.5)
    assert code == 0 and data["ok"], data
    code, data = run_gcs(url, tlogs, "wait-ready", "--timeout", "20", timeout_s=20.0)
    assert code == 0 and data["ready"], data
    code, data = run_gcs(url, tlogs, "arm")
    assert code == 0, data
    code, data = run_gcs(url, tlogs, "start")
    assert code == 0 and data["result"] == "MAV_RESULT_ACCEPTED", data
