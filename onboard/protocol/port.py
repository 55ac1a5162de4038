"""The thin CAN adapter: typed messages in and out of a python-can bus, with E2E checks and recording."""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from pathlib import Path

import can

from onboard.protocol.codec import Codec, EncodeError, FrameReceiver, FrameSender
from onboard.protocol.messages import BusMessage

log = logging.getLogger(__name__)

#: Frames one drain reads at most: a tick's receive budget. The bench's sensors send a few frames per 20 Hz
#: tick (AHRS, depth, DVL, fix, status, heartbeats); 256 leaves room for a burst after a stall and bounds
#: the time a flood of listened ids can take from one tick.
DRAIN_BUDGET_FRAMES = 256


class BusPort:
    """Send and receive :mod:`onboard.protocol.messages` over a python-can bus.

    ``clock`` gives the receive time stamped into ``t_sample_s`` (the monotonic clock in real time, the
    simulated time in lock-step). ``listen_ids`` limits the ids this node decodes (open the bus with the same
    ids as acceptance filters, :func:`onboard.protocol.bus.open_bus`, so the others never arrive). ``record``
    writes every frame sent and received to a ``.blf``/``.asc`` log with python-can's loggers.
    ``drain_budget_frames``: the most frames one :meth:`drain` reads (a tick's receive budget).
    """

    def __init__(
        self,
        bus: can.BusABC,
        clock: Callable[[], float],
        listen_ids: Iterable[int] | None = None,
        codec: Codec | None = None,
        record: str | Path | None = None,
        drain_budget_frames: int = DRAIN_BUDGET_FRAMES,
    ) -> None:
        if drain_budget_frames < 1:
            raise ValueError(f"drain_budget_frames must be >= 1, got {drain_budget_frames}")
        self.bus = bus
        self.drain_budget_frames = drain_budget_frames
        self.drain_capped = 0
        #: the receiver's rate check reads the bus's arrival times (python-can's timestamps, the wall
        #: clock) instead of ``clock``: for real time, where a stall of this process must not bunch frames
        self.rates_on_bus_time = False
        self.codec = codec or Codec()
        self.clock = clock
        self.sender = FrameSender(self.codec)
        self.receiver = FrameReceiver(self.codec, frozenset(listen_ids) if listen_ids is not None else None)
        self.recorder: can.Listener | None = can.Logger(str(record)) if record else None
        self.sent = 0

    def send(self, msg: BusMessage) -> None:
        """Encode (E2E counter + CRC) and send one message.

        Raises :class:`EncodeError` for NaN / out of range, and python-can's error if the bus refuses the
        frame; in both cases no alive-counter value is used up (the next frame continues the sequence).
        """
        frame_id, data = self.sender.encode(msg, commit=False)
        frame = can.Message(arbitration_id=frame_id, data=data, is_extended_id=False)
        self.bus.send(frame)
        self.sender.commit(frame_id)
        self.sent += 1
        if self.recorder is not None:
            self.recorder.on_message_received(frame)

    def send_all(self, msgs: Iterable[BusMessage]) -> None:
        for msg in msgs:
            self.send(msg)

    def recv(self, timeout_s: float | None) -> BusMessage | None:
        """Wait up to ``timeout_s`` for one frame; its message, or None (timeout, ignored or rejected)."""
        frame = self.bus.recv(timeout_s)
        if frame is None:
            return None
        return self._accept(frame)

    def drain(self, budget_frames: int | None = None) -> list[BusMessage]:
        """The messages already waiting, without blocking: at most ``budget_frames`` frames read
        (default :attr:`drain_budget_frames`), so a flood cannot hold the caller's tick; the rest wait for
        the next call (:attr:`drain_capped` counts the calls that stopped at the budget)."""
        out: list[BusMessage] = []
        budget = self.drain_budget_frames if budget_frames is None else budget_frames
        for _ in range(budget):
            frame = self.bus.recv(0.0)
            if frame is None:
                return out
            msg = self._accept(frame)
            if msg is not None:
                out.append(msg)
        self.drain_capped += 1
        return out

    def _accept(self, frame: can.Message) -> BusMessage | None:
        if self.recorder is not None:
            self.recorder.on_message_received(frame)
        if frame.is_error_frame or frame.is_remote_frame or frame.is_extended_id:
            return None
        t_bus_s = frame.timestamp if self.rates_on_bus_time and frame.timestamp else None  # 0: not stamped
        return self.receiver.receive(frame.arbitration_id, bytes(frame.data), self.clock(), t_bus_s)

    def close(self) -> None:
        if self.recorder is not None:
            self.recorder.stop()
            self.recorder = None
        try:
            self.bus.shutdown()
        except OSError as exc:  # the other end already went away (e.g. the bench hub stopped)
            log.debug("bus shutdown: %s", exc)
            self.bus._is_shutdown = True  # python-can would otherwise retry (and fail again) in __del__


__all__ = ["BusPort", "EncodeError"]
