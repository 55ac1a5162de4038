"""Benchmark: mission upload time of 10 and 100 goals over loopback, clean and through a 20 % loss relay.

The vehicle side runs as a real process (``python -m onboard.app.standalone``: the endpoint
with a fake
loop); this module only talks MAVLink to it. ``run()`` returns seconds per upload (median) and counts;
it measures and prints, it asserts nothing. ``python -m groundstation.bench_upload [--quick] [--json]``.
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from auv_common.cli import run_one_section
from auv_common.process import stop_process
from groundstation.mavclient import MavClient
from groundstation.mission_client import Item
from groundstation.mission_files import goal_item
from groundstation.relay import LossyRelay


def start_vehicle(
    state_dir: Path,
    timeout_s: float = 10.0,
    *,
    endpoint: str = "udpin:127.0.0.1:0",
    time_scale: float = 1.0,
) -> tuple[subprocess.Popen[str], int]:
    """Start the standalone vehicle endpoint (``endpoint``: ``udpout:HOST:PORT`` sends to a ground station
    listening there); returns the process and its UDP port (the ``udpout`` socket's own port for that)."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "onboard.app.standalone",
            "--endpoint",
            endpoint,
            "--state-dir",
            str(state_dir),
            "--time-scale",
            f"{time_scale:g}",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    assert proc.stdout is not None
    t_end = time.monotonic() + timeout_s
    line = proc.stdout.readline()
    if not line or time.monotonic() > t_end:
        stop_vehicle(proc)
        raise RuntimeError("the standalone vehicle did not start")
    return proc, int(json.loads(line)["ports"][0])


def stop_vehicle(proc: subprocess.Popen[str]) -> None:
    """Stop the standalone vehicle (:func:`auv_common.process.stop_process`)."""
    stop_process(proc)


def _goals(n: int, k: int) -> list[Item]:
    # goals 1 rad apart on a 10 m circle, depth alternating 1 / 1.5 m: every leg is flyable (the vehicle
    # checks the whole mission, planning each leg, before it accepts it)
    return [
        goal_item(10.0 * math.cos(i + k), 10.0 * math.sin(i + k), 1.0 + 0.5 * (i % 2), None) for i in range(n)
    ]


def _measure(port: int, n: int, reps: int, loss: float) -> tuple[list[float], int, int]:
    relay = LossyRelay(("127.0.0.1", port), loss=loss, reorder=0.1, seed=n).start() if loss > 0 else None
    target = relay.port if relay is not None else port
    times, ok, resends = [], 0, 0
    try:
        with MavClient(f"udpout:127.0.0.1:{target}", system_id=250) as c:
            for _ in range(5):
                c.heartbeat()
                try:
                    c.wait_heartbeat(1.0)
                    break
                except Exception:
                    continue
            for k in range(reps):
                r = c.upload(_goals(n, k), timeout_s=8.0)
                resends += r.resends
                if r.ok:
                    ok += 1
                    times.append(r.elapsed_s)
    finally:
        if relay is not None:
            relay.stop()
    return times, ok, resends


def run(quick: bool = False) -> dict[str, float]:
    """Upload timings (median s) and success counts, clean and at 20 % loss each way with reordering."""
    reps = 3 if quick else 10
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as d:
        proc, port = start_vehicle(Path(d))
        try:
            for loss in (0.0, 0.2):
                tag = "clean" if loss == 0 else "loss20"
                for n in (10, 100):
                    times, ok, resends = _measure(port, n, reps, loss)
                    out[f"upload_{n}_{tag}_median_s"] = statistics.median(times) if times else math.nan
                    out[f"upload_{n}_{tag}_max_s"] = max(times) if times else math.nan
                    out[f"upload_{n}_{tag}_ok"] = float(ok)
                    out[f"upload_{n}_{tag}_tries"] = float(reps)
                    out[f"upload_{n}_{tag}_gcs_resends"] = float(resends)
        finally:
            stop_vehicle(proc)
    return out


def main(argv: list[str] | None = None) -> int:
    return run_one_section("python -m groundstation.bench_upload", run, argv)


if __name__ == "__main__":
    raise SystemExit(main())
