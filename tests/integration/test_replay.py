"""Record a run's frames with python-can's logger and replay them onto a bus."""

from __future__ import annotations

import threading
import time

import can
from can.interfaces.virtual import VirtualBus

from hil_sim.replay import replay
from onboard.protocol.messages import DepthMeas, FinCmd
from onboard.protocol.port import BusPort


def test_recorded_frames_replay_in_order_and_filtered(tmp_path) -> None:
    log_path = tmp_path / "run.asc"
    channel = f"replay-{time.monotonic_ns()}"
    rec = BusPort(VirtualBus(channel=channel), time.monotonic, record=log_path)
    sink = VirtualBus(channel=channel)
    for i in range(10):
        rec.send(FinCmd(0.01 * i, 0.0, 0.0))
        rec.send(DepthMeas(1.0 + 0.1 * i))
    rec.close()
    sink.shutdown()
    out_channel = f"replay-out-{time.monotonic_ns()}"
    tx, rx = VirtualBus(channel=out_channel), BusPort(VirtualBus(channel=out_channel), time.monotonic)
    try:
        sent = replay(str(log_path), tx, speed=100.0, ids=frozenset({0x42}), stop=threading.Event())
        got = rx.drain()
    finally:
        tx.shutdown()
        rx.close()
    # Only the depth frames, in order, each one passing the E2E checks of a fresh receiver.
    assert sent == 10
    assert [round(m.depth_m, 4) for m in got if isinstance(m, DepthMeas)] == [
        round(1.0 + 0.1 * i, 4) for i in range(10)
    ]
    assert rx.receiver.rejected_total == 0
    assert all(isinstance(m, DepthMeas) for m in got)
    assert len(list(can.LogReader(str(log_path)))) == 20
