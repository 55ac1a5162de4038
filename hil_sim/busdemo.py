"""The bus demo: the bench hosts the CAN hub, a second real process answers SYNCs with protected frames.

The bench (this process) sends SYNC frames at ``rate_hz``; the peer (``python -m onboard.bench.busdemo
echo``, a separate process connected through the python-can-remote hub on 127.0.0.1) answers each with
FIN_CMD, PROP_CMD and SYNC_ACK, as the onboard does in lock-step. The bench checks every answer (E2E counter
and CRC, tick echo) and reports the round-trip times.
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
import time
from dataclasses import dataclass, field

from onboard.protocol.bus import BenchHub
from onboard.protocol.codec import Codec
from onboard.protocol.messages import FinCmd, PropCmd, Sync, SyncAck
from onboard.protocol.port import BusPort

log = logging.getLogger(__name__)


@dataclass
class BusDemoResult:
    syncs_sent: int = 0
    answers_complete: int = 0
    rtt_s: list[float] = field(default_factory=list)
    rejected: dict[str, int] = field(default_factory=dict)
    peer: dict[str, object] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.syncs_sent > 0 and self.answers_complete == self.syncs_sent and not self.rejected


def run_bus_demo(count: int = 200, rate_hz: float = 100.0, timeout_s: float = 30.0) -> BusDemoResult:
    """Run the two-process exchange; returns what the bench saw. Uses a free port and its own hub channel."""
    codec = Codec()
    listen = [codec.frame_id(m) for m in (FinCmd, PropCmd, SyncAck)]
    hub = BenchHub("ws://127.0.0.1:0/", f"busdemo-{time.monotonic_ns()}", listen)
    url = f"ws://127.0.0.1:{hub.port}/"
    port = BusPort(hub.bus, time.monotonic, listen, codec)
    peer = subprocess.Popen(
        [sys.executable, "-m", "onboard.bench.busdemo", "echo", "--channel", url, "--count", str(count)],
        stdout=subprocess.PIPE,
        text=True,
    )
    result = BusDemoResult()
    try:
        assert peer.stdout is not None
        ready = peer.stdout.readline()
        if '"ready"' not in ready:
            raise RuntimeError(f"bus demo peer did not start: {ready!r}")
        period = 1.0 / rate_hz
        next_t = time.monotonic()
        deadline = next_t + timeout_s
        for tick in range(count):
            now = time.monotonic()
            if now > deadline:
                break
            if next_t > now:
                time.sleep(next_t - now)
            next_t += period
            t0 = time.monotonic()
            port.send(Sync(tick, tick * period, t_sample_s=t0))
            result.syncs_sent += 1
            got: set[type] = set()
            while SyncAck not in got and time.monotonic() < t0 + 1.0:
                msg = port.recv(0.5)
                if msg is None:
                    continue
                if isinstance(msg, SyncAck) and msg.tick != tick:
                    continue
                got.add(type(msg))
            if got == {FinCmd, PropCmd, SyncAck}:
                result.answers_complete += 1
                result.rtt_s.append(time.monotonic() - t0)
        out, _ = peer.communicate(timeout=15)
        result.peer = json.loads(out.strip().splitlines()[-1]) if out.strip() else {}
    finally:
        if peer.poll() is None:
            peer.terminate()
            peer.wait(5)
        port.close()
        hub.close()
    result.rejected = dict(port.receiver.rejected)
    return result


def print_bus_demo(result: BusDemoResult) -> None:
    """A rich table of the demo's figures."""
    from rich.console import Console
    from rich.table import Table

    rtt = sorted(result.rtt_s) or [float("nan")]
    table = Table(title="Bus demo: bench <-> peer process through the python-can-remote hub")
    table.add_column("figure")
    table.add_column("value", justify="right")
    table.add_row("SYNC frames sent", str(result.syncs_sent))
    table.add_row("complete answers (FIN_CMD, PROP_CMD, SYNC_ACK)", str(result.answers_complete))
    table.add_row("frames rejected by the bench", str(sum(result.rejected.values())))
    table.add_row("frames rejected by the peer", str(sum(dict(result.peer.get("rejected", {})).values())))  # type: ignore[call-overload]
    table.add_row("round trip p50 (ms)", f"{rtt[len(rtt) // 2] * 1e3:.3f}")
    table.add_row("round trip p99 (ms)", f"{rtt[min(len(rtt) - 1, int(0.99 * len(rtt)))] * 1e3:.3f}")
    table.add_row("result", "OK" if result.ok else "FAILED")
    Console().print(table)
