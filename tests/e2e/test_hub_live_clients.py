"""The hub serves only live clients (issue 21, row 12), on the real hub process and real sockets.

Before: one python-can-remote ``periodic_start`` at 0.1 ms, then the client's socket closes (a crash, a
kill: no websocket close), and the hub went on sending ~10 k frames/s for ever: python-can-remote's thread
that forwards the bus to the client died on the broken socket before it shut the client's in-hub bus down,
and the periodic task belonged to that bus. Now the hub refuses periodic sends with a reason the client
reads, and a client's in-hub bus is shut down however its connection ends.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator

import can
import pytest
from can_remote.protocol import RemoteError

from hil_sim.scenario import free_port
from onboard.protocol.bus import BenchHub, BusConfig, open_bus

pytestmark = pytest.mark.e2e

ATTACK_ID = 0x7F0


@contextlib.contextmanager
def _hub() -> Iterator[BenchHub]:
    hub = BenchHub(f"ws://127.0.0.1:{free_port()}/", "row12", listen_ids=())
    try:
        yield hub
    finally:
        hub.bus.shutdown()
        hub.close()


def _traffic(bus: can.BusABC, done: threading.Event) -> None:
    frame = can.Message(arbitration_id=0x100, data=bytes(8), is_extended_id=False)
    while not done.wait(0.005):
        bus.send(frame)


def _count(bus: can.BusABC, window_s: float) -> int:
    """Frames of the attack id received over ``window_s``."""
    n = 0
    t_end = time.monotonic() + window_s
    while (left := t_end - time.monotonic()) > 0:
        frame = bus.recv(min(left, 0.1))
        if frame is not None and frame.arbitration_id == ATTACK_ID:
            n += 1
    return n


def _crash(bus: can.BusABC) -> None:
    """The client's process dies: its socket closes with unread frames (a reset), no websocket close."""
    bus.socket.close()  # type: ignore[attr-defined]
    bus._is_shutdown = True


def test_a_periodic_send_is_refused_with_the_reason() -> None:
    with _hub() as hub:
        # GIVEN a client of the real hub; WHEN it asks for a 0.1 ms periodic send
        client = can.Bus(interface="remote", channel=hub.url)
        frame = can.Message(arbitration_id=ATTACK_ID, data=bytes(8), is_extended_id=False)
        refusal = ""
        try:
            client.send_periodic(frame, 0.0001)
            t_end = time.monotonic() + 5.0
            while time.monotonic() < t_end and not refusal:
                try:
                    client.recv(0.2)
                except RemoteError as exc:
                    refusal = str(exc)
        finally:
            with contextlib.suppress(Exception):
                client.shutdown()
        # THEN the hub's answer on the client's connection says why
        assert "periodic" in refusal, f"no refusal within 5 s ({refusal!r})"


def test_nothing_a_client_started_outlives_its_connection() -> None:
    with _hub() as hub:
        # GIVEN a listener on the real hub, traffic on the bus (the host sends 200 frames/s, as a bench
        # does), and a client that asks the hub for a 0.1 ms periodic send and reads nothing
        listener = open_bus(BusConfig(interface="remote", channel=hub.url), timeout_s=10.0)
        done = threading.Event()
        traffic = threading.Thread(target=_traffic, args=(hub.bus, done), daemon=True)
        traffic.start()
        try:
            attacker = can.Bus(interface="remote", channel=hub.url)
            frame = can.Message(arbitration_id=ATTACK_ID, data=bytes(8), is_extended_id=False)
            attacker.send_periodic(frame, 0.0001)
            during = _count(listener, 1.0)
            # WHEN the client's process dies (its socket closes, no websocket close)
            _crash(attacker)
            # THEN within a few seconds the hub sends nothing of it any more: a whole second without a frame
            t_end = time.monotonic() + 10.0
            counts = [during]
            while time.monotonic() < t_end:
                counts.append(_count(listener, 1.0))
                if counts[-1] == 0:
                    break
            assert counts[-1] == 0, f"the hub still sends the gone client's frames: {counts} frames/s"
        finally:
            done.set()
            traffic.join(5.0)
            listener.shutdown()
