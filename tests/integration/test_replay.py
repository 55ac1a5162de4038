"""Record a run's frames with python-can's logger and replay them onto a bus."""

from __future__ import annotations

import threading
import time

import can
import pytest
from can.interfaces.virtual import VirtualBus

import hil_sim.replay as replay_module
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


def test_a_candump_log_is_recorded_cantools_decodes_it_and_replay_keeps_the_spacing_over_speed(
    tmp_path, monkeypatch
) -> None:
    import subprocess
    import sys

    from onboard.protocol.codec import DBC_PATH

    # GIVEN 20 depth frames 0.1 s apart (2 s) recorded as a candump -l log
    log_path = tmp_path / "run.log"
    channel = f"replay-{time.monotonic_ns()}"
    rec = BusPort(VirtualBus(channel=channel), time.monotonic, record=log_path)
    for i in range(20):
        rec.send(DepthMeas(1.0 + 0.1 * i))
    rec.close()
    lines = log_path.read_text().splitlines()
    stamped = [f"({100.0 + 0.1 * i:.6f}) {line.split(' ', 1)[1]}" for i, line in enumerate(lines)]
    log_path.write_text("\n".join(stamped) + "\n")
    # THEN cantools decodes it with the DBC (candump's own format)
    out = subprocess.run(
        [sys.executable, "-m", "cantools", "decode", str(DBC_PATH)],
        input=log_path.read_text(), capture_output=True, text=True, timeout=60, check=True,
    ).stdout  # fmt: skip
    assert out.count("DEPTH(") == 20 and "depth_m: 1.0 m" in out, out[:500]
    # AND replayed at x20 each frame goes out at its recorded time / 20: 0.1 s apart in the log, 5 ms on the
    # replay's clock (a simulated one here, advanced by each wait, so the test does not depend on the load)
    out_channel = f"replay-out-{time.monotonic_ns()}"
    tx = VirtualBus(channel=out_channel)
    clock = _SimulatedClock()
    monkeypatch.setattr(replay_module, "time", clock)
    try:
        sent_at: list[float] = []
        progress: list[tuple[int, int]] = []

        def on_frame(done: int, total: int) -> None:
            progress.append((done, total))
            sent_at.append(clock.now_s)

        sent = replay(str(log_path), tx, 20.0, None, clock.stop, on_frame)
    finally:
        tx.shutdown()
    assert sent == 20 and progress[-1] == (20, 20)
    assert sent_at == pytest.approx([0.1 * i / 20.0 for i in range(20)], abs=1e-9)


class _SimulatedClock:
    """The replay's ``time`` module and its stop event on one simulated clock: waiting advances it."""

    def __init__(self) -> None:
        self.now_s = 0.0
        clock = self

        class _Stop(threading.Event):
            def wait(self, timeout: float | None = None) -> bool:
                clock.now_s += timeout or 0.0
                return False

        self.stop = _Stop()

    def monotonic(self) -> float:
        return self.now_s
