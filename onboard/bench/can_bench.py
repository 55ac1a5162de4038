"""CAN benchmark: codec cost per frame and one-way latency between two processes through the bench hub."""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time

from onboard.protocol.bus import BenchHub
from onboard.protocol.codec import Codec, FrameSender
from onboard.protocol.messages import FinCmd, PositionFix, Sync
from onboard.protocol.port import BusPort


def _codec_cost_us(n: int) -> dict[str, float]:
    codec = Codec()
    sender = FrameSender(codec)
    msgs: list[FinCmd | PositionFix] = [FinCmd(0.1, -0.05, 0.05), PositionFix(12.345, -6.789)]
    out: dict[str, float] = {}
    for msg in msgs:
        name = type(msg).DBC_NAME.lower()
        t0 = time.perf_counter()
        for _ in range(n):
            frame_id, data = sender.encode(msg)
        out[f"encode_{name}_us"] = (time.perf_counter() - t0) / n * 1e6
        t0 = time.perf_counter()
        for _ in range(n):
            codec.decode(frame_id, data, 0.0)
        out[f"decode_{name}_us"] = (time.perf_counter() - t0) / n * 1e6
    # Reference in the same run: packing the same three int16 by hand with struct (no DBC, no checks).
    import struct

    t0 = time.perf_counter()
    for _ in range(n):
        struct.pack("<hhhBB", 1000, -500, 500, 0, 0)
    out["struct_pack_reference_us"] = (time.perf_counter() - t0) / n * 1e6
    out["encode_vs_struct_ratio"] = out["encode_fin_cmd_us"] / out["struct_pack_reference_us"]
    return out


def _latency(rate_hz: float, count: int) -> dict[str, float]:
    """One-way latency through the hub (its own process): this process (a client) -> a peer process."""
    hub = BenchHub("ws://127.0.0.1:0/", f"canbench-{time.monotonic_ns()}", listen_ids=())  # sends only
    url = f"ws://127.0.0.1:{hub.port}/"
    port = BusPort(hub.bus, time.monotonic)
    peer = subprocess.Popen(
        [sys.executable, "-m", "onboard.bench.busdemo", "record", "--channel", url, "--count", str(count)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert peer.stdout is not None
        if '"ready"' not in peer.stdout.readline():
            raise RuntimeError("CAN bench peer did not start")
        sent: dict[int, float] = {}
        period = 1.0 / rate_hz
        next_t = time.monotonic()
        for tick in range(count):
            # Sleep, never spin: a spinning thread holds the GIL and starves the hub's threads.
            now = time.monotonic()
            if next_t > now:
                time.sleep(next_t - now)
            next_t += period
            sent[tick] = time.monotonic()
            port.send(Sync(tick, 0.0))
        out, _ = peer.communicate(timeout=60)
        arrivals = {int(k): v for k, v in json.loads(out.strip().splitlines()[-1])["arrivals"].items()}
    finally:
        if peer.poll() is None:
            peer.kill()
        port.close()
        hub.close()
    lat = sorted((arrivals[t] - sent[t]) * 1e6 for t in arrivals if t in sent)
    name = f"{int(rate_hz)}_fps"
    return {
        f"latency_{name}_p50_us": statistics.median(lat) if lat else float("nan"),
        f"latency_{name}_p99_us": lat[min(len(lat) - 1, int(0.99 * len(lat)))] if lat else float("nan"),
        f"latency_{name}_lost_frames": float(count - len(lat)),
    }


def run(quick: bool = False) -> dict[str, float]:
    """The ``can`` section of ``auv-bench``."""
    out = _codec_cost_us(2000 if quick else 20000)
    out.update(_latency(100.0, 100 if quick else 1000))
    out.update(_latency(1000.0, 500 if quick else 5000))
    return out
