"""A bus is a link that can come back (issue 21, row 5): the port outlives its bus."""

from __future__ import annotations

import itertools
import time

import can
import pytest
from can.interfaces.virtual import VirtualBus

from onboard.protocol import messages as m
from onboard.protocol.bus import bus_lost, loss_reason
from onboard.protocol.port import BusPort

_channels = itertools.count()


class _Gone(can.BusABC):
    """A bus whose transport went away: every send and receive fails as python-can's would."""

    def __init__(self, exc: Exception) -> None:
        self.exc = exc
        self.shut = False
        super().__init__(channel="gone")

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        raise self.exc

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        raise self.exc

    def shutdown(self) -> None:
        self.shut = True
        super().shutdown()


def _wait(cond: object, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():  # type: ignore[operator]
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def test_what_counts_as_a_lost_bus() -> None:
    assert bus_lost(ConnectionResetError(104, "Connection reset by peer"))
    assert bus_lost(can.CanOperationError("Failed to transmit: [Errno 100] Network is down"))
    assert not bus_lost(ValueError("out of range"))  # an encoding error: the frame, not the bus
    assert loss_reason(OSError(100, "Network is down")) == "OSError: [Errno 100] Network is down"


def test_a_port_without_reopen_raises_as_python_can_does() -> None:
    port = BusPort(_Gone(OSError("down")), time.monotonic)
    with pytest.raises(OSError):
        port.send(m.SensorsHeartbeat(m.NodeHealth.OK, 1.0, 1.0))


def test_a_lost_bus_is_reopened_with_back_off_and_taken_in_by_the_user() -> None:
    channel = f"reconnect-{next(_channels)}"
    gone = _Gone(can.CanOperationError("Network is down"))
    attempts: list[float] = []

    def reopen() -> can.BusABC:
        attempts.append(time.monotonic())
        if len(attempts) < 3:
            raise OSError(111, "Connection refused")
        return VirtualBus(channel=channel)

    port = BusPort(gone, time.monotonic, reopen=reopen, reconnect_max_s=1.0)
    peer = VirtualBus(channel=channel)
    try:
        # WHEN the bus fails under a send: nothing raises, the port says why, the old bus is shut down
        port.send(m.SensorsHeartbeat(m.NodeHealth.OK, 1.0, 1.0))
        assert port.lost == "CanOperationError: Network is down" and port.losses == 1 and gone.shut
        assert port.drain() == [] and port.recv(0.01) is None
        # THEN it is reopened after failed attempts, each wait longer than the one before
        _wait(lambda: len(attempts) >= 3)
        gaps = [b - a for a, b in itertools.pairwise(attempts)]
        assert gaps[1] > gaps[0], gaps
        # and taken in at the user's next receive: frames flow both ways again
        _wait(lambda: port.recv(0.05) is None and not port.lost)
        assert port.restored == 1
        port.send(m.SensorsHeartbeat(m.NodeHealth.OK, 2.0, 2.0))
        assert peer.recv(1.0) is not None
    finally:
        port.close()
        peer.shutdown()
