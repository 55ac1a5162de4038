"""A command that does not encode is a fault: not sent, not replaced, counted, and the autopilot is told."""

from __future__ import annotations

import itertools
import logging
import math
from collections.abc import Iterator
from dataclasses import dataclass

import can
import pytest

from onboard.app.loop import ControlLoop, LoopConfig
from onboard.protocol.codec import Codec, FrameReceiver
from onboard.protocol.messages import ActuatorMode, BusMessage, FinCmd, MissionStateCode, PropCmd
from onboard.protocol.port import BusPort

CODEC = Codec()
FIN_ID = CODEC.frame_id(FinCmd)
PROP_ID = CODEC.frame_id(PropCmd)
_channels = itertools.count()


@dataclass(frozen=True)
class Out:
    rudder_rad: float = 0.0
    stern_port_rad: float = 0.0
    stern_starboard_rad: float = 0.0
    propeller_rps: float = 10.0
    mode: ActuatorMode = ActuatorMode.ARMED
    mission_state: MissionStateCode = MissionStateCode.RUNNING

    def telemetry_row(self) -> dict[str, float | int | str]:
        return {"rudder_rad": self.rudder_rad}


ABORT = Out(0.0, -0.26, -0.26, 0.0, ActuatorMode.ABORT, MissionStateCode.ABORT)


class StubAutopilot:
    """Flies the rudders it is given; after an encode fault it aborts at the next step (as the core does)."""

    def __init__(self, rudders_deg: list[float]) -> None:
        self.rudders_deg = list(rudders_deg)
        self.faults: list[tuple[str, str]] = []
        self._abort = False

    def step(self, cache: dict[type, BusMessage], now_s: float, dt_s: float) -> Out:
        rudder = self.rudders_deg.pop(0) if self.rudders_deg else 0.0
        if self._abort:
            return ABORT
        return Out(rudder_rad=math.radians(rudder))

    def note_loop_late(self, late_s: float) -> None:
        pass

    def before_step(self) -> None:
        pass

    def note_encode_fault(self, message_name: str, reason: str) -> None:
        self.faults.append((message_name, reason))
        self._abort = True


@pytest.fixture
def buses() -> Iterator[tuple[can.BusABC, can.BusABC]]:
    channel = f"loop-encode-{next(_channels)}"
    vehicle = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    actuators = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    yield vehicle, actuators
    vehicle.shutdown()
    actuators.shutdown()


def received(bus: can.BusABC, rx: FrameReceiver) -> list[BusMessage]:
    out = []
    while (frame := bus.recv(0.0)) is not None:
        msg = rx.receive(frame.arbitration_id, bytes(frame.data), 0.0)
        if msg is not None:
            out.append(msg)
    return out


def test_an_unencodable_rudder_is_not_sent_counted_and_reported(
    buses: tuple[can.BusABC, can.BusABC], caplog: pytest.LogCaptureFixture
) -> None:
    vehicle, actuators = buses
    autopilot = StubAutopilot([5.0, 45.0])  # tick 0 good, tick 1 a 45 deg rudder (the DBC stops at 30 deg)
    loop = ControlLoop(BusPort(vehicle, clock=lambda: 0.0, codec=CODEC), autopilot, LoopConfig())
    rx = FrameReceiver(CODEC, accept_ids=frozenset({FIN_ID, PROP_ID}))

    loop.tick(0.0)
    assert [type(m) for m in received(actuators, rx)] == [FinCmd, PropCmd]

    with caplog.at_level(logging.ERROR, logger="onboard.app.loop"):
        loop.tick(0.05)
    this_tick = received(actuators, rx)
    assert not any(isinstance(m, FinCmd) for m in this_tick)  # not sent, and no made-up SAFE frame
    assert [type(m) for m in this_tick] == [PropCmd]  # what encodes goes out
    assert loop.stats.encode_errors == 1 and loop.stats.encode_errors_by_message == {"FIN_CMD": 1}
    ((name, reason),) = autopilot.faults
    assert name == "FIN_CMD" and "rudder_rad" in reason
    assert len([r for r in caplog.records if r.levelno >= logging.ERROR]) == 1

    for k in range(2, 22):  # the abort command, across the counter wrap
        loop.tick(0.05 * k)
    after = received(actuators, rx)
    fins = [m for m in after if isinstance(m, FinCmd)]
    assert len(fins) == 20 and fins[0].stern_port_rad == pytest.approx(-0.26, abs=1e-4)
    assert rx.rejected_total == 0, rx.rejected
    assert loop.stats.encode_errors == 1


def test_a_burst_of_encode_errors_is_logged_once(
    buses: tuple[can.BusABC, can.BusABC], caplog: pytest.LogCaptureFixture
) -> None:
    vehicle, actuators = buses

    class Stubborn(StubAutopilot):
        def note_encode_fault(self, message_name: str, reason: str) -> None:
            self.faults.append((message_name, reason))  # (does not abort: only the logging is tested)

    autopilot = Stubborn([45.0, 45.0, 45.0, 0.0, 45.0])
    loop = ControlLoop(BusPort(vehicle, clock=lambda: 0.0, codec=CODEC), autopilot, LoopConfig())
    with caplog.at_level(logging.WARNING, logger="onboard.app.loop"):
        for k in range(5):
            loop.tick(0.05 * k)
    levels = [r.levelno for r in caplog.records]
    assert levels == [logging.ERROR, logging.WARNING, logging.ERROR]
    assert "3 frame(s)" in caplog.records[1].getMessage()
    assert loop.stats.encode_errors == 4 and len(autopilot.faults) == 4
    rx = FrameReceiver(CODEC, accept_ids=frozenset({FIN_ID, PROP_ID}))
    got = received(actuators, rx)
    assert sum(isinstance(m, FinCmd) for m in got) == 1 and sum(isinstance(m, PropCmd) for m in got) == 5
    assert rx.rejected_total == 0
