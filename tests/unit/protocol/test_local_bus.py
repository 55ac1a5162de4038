"""The ``local`` bus: a python-can bus in one process passing each frame itself, filtered as it is sent."""

from __future__ import annotations

import itertools
import threading

import can
import pytest

from auv_common.config import from_table
from onboard.protocol.bus import BusConfig, open_bus
from onboard.protocol.local_bus import LocalBus
from onboard.protocol.messages import AhrsAttitude, DepthMeas, FinCmd
from onboard.protocol.port import BusPort

_names = itertools.count()


def _channel() -> str:
    return f"test-local-{next(_names)}"


def _frame(arbitration_id: int) -> can.Message:
    return can.Message(arbitration_id=arbitration_id, data=bytes(8), is_extended_id=False)


def test_the_local_bus_by_configuration_round_trips_a_frame_through_ports() -> None:
    # GIVEN two ports on a local bus chosen by the [bus] table WHEN one sends THEN the other decodes it
    cfg = from_table(BusConfig, {"interface": "local", "channel": _channel()}, "test.toml [bus]")
    a, b = BusPort(open_bus(cfg), lambda: 0.0), BusPort(open_bus(cfg), lambda: 0.0)
    try:
        assert isinstance(a.bus, LocalBus) and isinstance(a.bus, can.BusABC)
        a.send(FinCmd(0.1, 0.0, 0.0))
        msg = b.recv(0.0)
        assert isinstance(msg, FinCmd) and abs(msg.rudder_rad - 0.1) < 1e-4
        assert a.recv(0.0) is None  # not heard by its sender
    finally:
        a.close()
        b.close()


def test_every_receiver_gets_the_sent_frame_itself_in_order_and_the_sender_none() -> None:
    channel = _channel()
    tx, rx1, rx2 = LocalBus(channel), LocalBus(channel), LocalBus(channel)
    other = LocalBus(_channel())
    try:
        frames = [_frame(0x40 + i) for i in range(5)]
        for frame in frames:
            tx.send(frame)
        for rx in (rx1, rx2):
            got = [rx.recv(0.0) for _ in frames]
            # the objects themselves, in order: no copy per frame and receiver
            assert all(g is sent for g, sent in zip(got, frames, strict=True))
            assert rx.recv(0.0) is None
        assert tx.recv(0.0) is None and other.recv(0.0) is None
    finally:
        for bus in (tx, rx1, rx2, other):
            bus.shutdown()


def test_acceptance_filters_apply_as_a_frame_is_sent_so_a_drain_is_never_cut_short() -> None:
    # GIVEN a port listening to AHRS_ATTITUDE and DEPTH only, with the same ids as acceptance filters
    channel = _channel()
    cfg = BusConfig(interface="local", channel=channel)
    tx = BusPort(open_bus(cfg), lambda: 0.0)
    listen = [tx.codec.frame_id(AhrsAttitude), tx.codec.frame_id(DepthMeas)]
    rx = BusPort(open_bus(cfg, listen_ids=listen), lambda: 0.0, listen)
    try:
        # WHEN frames it does not listen to come between the ones it does
        for i in range(3):
            tx.send(FinCmd(0.0, 0.0, 0.0))
            tx.send(AhrsAttitude(0.0, 0.0, 0.1 * i))
            tx.send(FinCmd(0.0, 0.0, 0.0))
            tx.send(DepthMeas(1.0 + i))
        # THEN they were never queued, and one non-blocking drain reads every listened frame
        assert isinstance(rx.bus, LocalBus) and len(rx.bus._rx) == 6
        got = rx.drain()
        assert [type(m) for m in got] == [AhrsAttitude, DepthMeas] * 3
    finally:
        tx.close()
        rx.close()


def test_a_blocking_receive_wakes_for_a_frame_sent_from_another_thread() -> None:
    channel = _channel()
    tx, rx = LocalBus(channel), LocalBus(channel)
    got: list[can.Message | None] = []
    reader = threading.Thread(target=lambda: got.append(rx.recv(30.0)))
    try:
        reader.start()
        frame = _frame(0x42)
        tx.send(frame)
        reader.join(30.0)
        assert not reader.is_alive() and got == [frame] and got[0] is frame
    finally:
        tx.shutdown()
        rx.shutdown()


def test_a_closed_bus_refuses_to_send_and_leaves_its_channel() -> None:
    channel = _channel()
    tx, rx = LocalBus(channel), LocalBus(channel)
    rx.shutdown()
    tx.send(_frame(0x10))  # nobody left to hear it: nothing queued anywhere
    assert len(rx._rx) == 0
    tx.shutdown()
    with pytest.raises(can.CanOperationError):
        tx.send(_frame(0x10))
    with pytest.raises(can.CanOperationError):
        rx.recv(0.0)
    again = LocalBus(channel)  # the name is free again
    try:
        assert again.recv(0.0) is None
    finally:
        again.shutdown()


def test_a_receiver_blocked_in_recv_is_woken_by_its_shutdown() -> None:
    rx = LocalBus(_channel())
    errors: list[BaseException] = []

    def wait() -> None:
        try:
            rx.recv(30.0)
        except can.CanOperationError as exc:
            errors.append(exc)

    reader = threading.Thread(target=wait)
    reader.start()
    rx.shutdown()
    reader.join(30.0)
    # woken by the shutdown (or closed before it began to wait): recv says the bus is closed
    assert not reader.is_alive() and len(errors) == 1


def test_new_acceptance_filters_apply_to_the_next_frame() -> None:
    # GIVEN a receiver that accepted id 0x40 WHEN its filters change to 0x41 only THEN 0x40 is not queued
    channel = _channel()
    tx = LocalBus(channel)
    rx = LocalBus(channel, can_filters=[{"can_id": 0x40, "can_mask": 0x7FF, "extended": False}])
    try:
        tx.send(_frame(0x40))
        tx.send(_frame(0x41))
        assert [f.arbitration_id for f in iter(lambda: rx.recv(0.0), None)] == [0x40]
        rx.set_filters([{"can_id": 0x41, "can_mask": 0x7FF, "extended": False}])
        tx.send(_frame(0x40))
        tx.send(_frame(0x41))
        assert [f.arbitration_id for f in iter(lambda: rx.recv(0.0), None)] == [0x41]
        extended = can.Message(arbitration_id=0x41, data=bytes(8), is_extended_id=True)
        tx.send(extended)  # the same number as an extended id: another frame, refused
        assert rx.recv(0.0) is None
    finally:
        tx.shutdown()
        rx.shutdown()
