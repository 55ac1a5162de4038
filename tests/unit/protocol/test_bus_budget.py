"""Acceptance filters, the hub's per-client bus and the drain budget (issue 12, item 4)."""

from __future__ import annotations

import itertools
import time

import can
import pytest
from can.interfaces.virtual import VirtualBus

from onboard.protocol import hub
from onboard.protocol import messages as m
from onboard.protocol.bus import BusConfig, acceptance_filters, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.hub import AcceptanceVirtualBus
from onboard.protocol.port import BusPort

_channels = itertools.count()


def _frame(frame_id: int) -> can.Message:
    return can.Message(arbitration_id=frame_id, data=bytes(8), is_extended_id=False)


def test_acceptance_filters_pass_exactly_the_ids_listened_to() -> None:
    assert acceptance_filters(None) is None
    channel = f"filters-{next(_channels)}"
    sender = AcceptanceVirtualBus(channel)
    listener = AcceptanceVirtualBus(channel, can_filters=acceptance_filters([0x101, 0x100]))
    deaf = AcceptanceVirtualBus(channel, can_filters=acceptance_filters(()))
    try:
        for frame_id in (0x000, 0x7F0, 0x100, 0x200, 0x101, 0x7FF):
            sender.send(_frame(frame_id))
        assert [f.arbitration_id for f in iter(lambda: listener.recv(0.0), None)] == [0x100, 0x101]
        assert deaf.queue.qsize() == 0
    finally:
        for bus in (sender, listener, deaf):
            bus.shutdown()


def test_an_in_process_bus_leaves_the_filtering_to_the_port() -> None:
    # python-can's software filter would end a non-blocking recv at the first frame it drops
    channel = f"filters-{next(_channels)}"
    listener = open_bus(BusConfig(interface="virtual", channel=channel), listen_ids=[0x100])
    sender = VirtualBus(channel=channel)
    try:
        for frame_id in (0x7F0, 0x100):
            sender.send(_frame(frame_id))
        assert [f.arbitration_id for f in iter(lambda: listener.recv(0.0), None)] == [0x7F0, 0x100]
    finally:
        listener.shutdown()
        sender.shutdown()


def test_the_hub_queues_a_frame_only_for_clients_that_accept_it_and_never_without_bound(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(hub, "CLIENT_QUEUE_FRAMES", 10)
    channel = f"hub-{next(_channels)}"
    flooder = AcceptanceVirtualBus(channel)
    listener = AcceptanceVirtualBus(channel, can_filters=acceptance_filters([0x100]))
    slow = AcceptanceVirtualBus(channel, rx_queue_size=0)  # asks for no bound, hears everything, never reads
    try:
        dropped_before = AcceptanceVirtualBus.dropped
        for _ in range(50):
            flooder.send(_frame(0x7F0))
        flooder.send(_frame(0x100))
        assert listener.queue.qsize() == 1 and listener.recv(0.0).arbitration_id == 0x100
        assert slow.queue.qsize() == 10 and AcceptanceVirtualBus.dropped - dropped_before == 41
    finally:
        for bus in (flooder, listener, slow):
            bus.shutdown()


def test_a_drain_reads_at_most_its_budget_and_the_rest_waits_for_the_next() -> None:
    channel = f"budget-{next(_channels)}"
    codec = Codec()
    sender = BusPort(VirtualBus(channel=channel), time.monotonic, (), codec)
    receiver = BusPort(VirtualBus(channel=channel), time.monotonic, None, codec, drain_budget_frames=64)
    try:
        for k in range(100):
            sender.send(m.DepthMeas(1.0 + k * 0.01, 0.0))
        first = receiver.drain()
        assert len(first) == 64 and receiver.drain_capped == 1
        second = receiver.drain()
        assert len(second) == 36 and receiver.drain_capped == 1
        assert receiver.drain() == []
    finally:
        sender.close()
        receiver.close()
