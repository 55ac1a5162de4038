"""The thin CAN adapter: typed messages in and out of a python-can bus, with E2E checks and recording.

A bus is a link that can come back: a port given ``reopen`` outlives its bus. When a send or a receive says
the transport is gone (:func:`onboard.protocol.bus.bus_lost`: the remote hub closed or reset, a socketcan
interface went down, a python-can error), the port shuts that bus down, says why in :attr:`BusPort.lost`,
and a thread of its own calls ``reopen`` after 0.2 s, then after a wait doubling up to
``reconnect_max_s`` (attempts 1, 2, 4, 8, ... logged). Meanwhile the port sends nothing and receives
nothing, without raising: its user runs on (the onboard loop aborts the mission and keeps MAVLink; the bench
simulates on, its actuator node held by its watchdog). The new bus is taken in on the user's thread, at its
next send or receive, with a fresh receiver state (a restarted peer starts its alive counters anew).
"""

from __future__ import annotations

import contextlib
import logging
import threading
from collections.abc import Callable, Iterable
from pathlib import Path

import can

from onboard.protocol.bus import bus_lost, loss_reason
from onboard.protocol.codec import Codec, EncodeError, FrameReceiver, FrameSender
from onboard.protocol.messages import BusMessage

log = logging.getLogger(__name__)

#: Frames one drain reads at most: a tick's receive budget. The bench's sensors send a few frames per 20 Hz
#: tick (AHRS, depth, DVL, fix, status, heartbeats); 256 leaves room for a burst after a stall and bounds
#: the time a flood of listened ids can take from one tick.
DRAIN_BUDGET_FRAMES = 256
#: The first wait before reopening a lost bus (s); it doubles after each failed attempt.
RECONNECT_FIRST_S = 0.2


class BusPort:
    """Send and receive :mod:`onboard.protocol.messages` over a python-can bus.

    ``clock`` gives the receive time stamped into ``t_sample_s`` (the monotonic clock in real time, the
    simulated time in lock-step). ``listen_ids`` limits the ids this node decodes (open the bus with the same
    ids as acceptance filters, :func:`onboard.protocol.bus.open_bus`, so the others never arrive). ``record``
    writes every frame sent and received to a ``.blf``/``.asc`` log with python-can's loggers.
    ``drain_budget_frames``: the most frames one :meth:`drain` reads (a tick's receive budget).
    ``reopen``: opens the bus again after it was lost (see the module docstring; None: a lost bus raises,
    as python-can does), retried with back-off up to ``reconnect_max_s``.
    """

    def __init__(
        self,
        bus: can.BusABC,
        clock: Callable[[], float],
        listen_ids: Iterable[int] | None = None,
        codec: Codec | None = None,
        record: str | Path | None = None,
        drain_budget_frames: int = DRAIN_BUDGET_FRAMES,
        reopen: Callable[[], can.BusABC] | None = None,
        reconnect_max_s: float = 5.0,
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
        self.reopen = reopen
        self.reconnect_max_s = max(reconnect_max_s, RECONNECT_FIRST_S)
        #: why the bus is lost ("" while it is up)
        self.lost = ""
        self.losses = 0  # times the bus was lost
        self.restored = 0  # times a lost bus came back
        self._fresh: can.BusABC | None = None  # reopened by the reconnect thread, not yet taken in
        self._fresh_lock = threading.Lock()
        self._back = threading.Event()  # set when a reopened bus waits to be taken in
        self._closed = threading.Event()
        self._reconnector: threading.Thread | None = None

    def send(self, msg: BusMessage) -> None:
        """Encode (E2E counter + CRC) and send one message.

        Raises :class:`EncodeError` for NaN / out of range, and python-can's error if the bus refuses the
        frame; in both cases no alive-counter value is used up (the next frame continues the sequence).
        """
        frame_id, data = self.sender.encode(msg, commit=False)
        if self.lost and not self._up():
            return  # nobody to send to: nothing is sent, no counter value used
        frame = can.Message(arbitration_id=frame_id, data=data, is_extended_id=False)
        try:
            self.bus.send(frame)
        except Exception as exc:
            self._lose(exc)
            return
        self.sender.commit(frame_id)
        self.sent += 1
        if self.recorder is not None:
            self.recorder.on_message_received(frame)

    def send_all(self, msgs: Iterable[BusMessage]) -> None:
        for msg in msgs:
            self.send(msg)

    def recv(self, timeout_s: float | None) -> BusMessage | None:
        """Wait up to ``timeout_s`` for one frame; its message, or None (timeout, ignored or rejected, or the
        bus lost: then it waits up to ``timeout_s`` for the bus to come back)."""
        if not self._up():
            self._back.wait(timeout_s)
            return None
        try:
            frame = self.bus.recv(timeout_s)
        except Exception as exc:
            self._lose(exc)
            return None
        if frame is None:
            return None
        return self._accept(frame)

    def drain(self, budget_frames: int | None = None) -> list[BusMessage]:
        """The messages already waiting, without blocking: at most ``budget_frames`` frames read
        (default :attr:`drain_budget_frames`), so a flood cannot hold the caller's tick; the rest wait for
        the next call (:attr:`drain_capped` counts the calls that stopped at the budget)."""
        out: list[BusMessage] = []
        if self.lost and not self._up():
            return out
        budget = self.drain_budget_frames if budget_frames is None else budget_frames
        for _ in range(budget):
            try:
                frame = self.bus.recv(0.0)
            except Exception as exc:
                self._lose(exc)
                return out
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
        return self.receiver.receive(frame.arbitration_id, frame.data, self.clock(), t_bus_s)

    # --- a bus that can come back --------------------------------------------------------------
    def _up(self) -> bool:
        """True when the bus is up (a bus reopened since it was lost is taken in here, on this thread)."""
        if not self.lost:
            return True
        with self._fresh_lock:
            bus, self._fresh = self._fresh, None
            self._back.clear()
        if bus is None:
            return False
        self.bus = bus
        # a new session: a restarted peer's alive counters start anew, its rates are measured afresh
        self.receiver.new_session()
        log.warning("CAN bus back (lost %d time(s): %s)", self.losses, self.lost)
        self.lost = ""
        self.restored += 1
        return True

    def _lose(self, exc: Exception) -> None:
        """The bus failed in a send or a receive: lost (reopened in the background), or re-raised when this
        port has no ``reopen`` or ``exc`` is no transport failure."""
        if self.reopen is None or not bus_lost(exc):
            raise exc
        self.lost = loss_reason(exc)
        self.losses += 1
        log.error("CAN bus lost (%s): reconnecting", self.lost)
        _shutdown_quietly(self.bus)
        self._reconnector = threading.Thread(target=self._reconnect, name="can-reconnect", daemon=True)
        self._reconnector.start()

    def _reconnect(self) -> None:
        """Call ``reopen`` with back-off until it gives a bus or the port is closed."""
        assert self.reopen is not None
        wait_s, attempt = RECONNECT_FIRST_S, 0
        while not self._closed.wait(wait_s):
            attempt += 1
            try:
                bus = self.reopen()
            except Exception as exc:
                if attempt & (attempt - 1) == 0:  # 1, 2, 4, 8, ...: a line now and then, not one a second
                    log.warning(
                        "CAN bus: reconnect attempt %d failed (%s); next in %.1f s",
                        attempt,
                        loss_reason(exc),
                        min(2.0 * wait_s, self.reconnect_max_s),
                    )
                wait_s = min(2.0 * wait_s, self.reconnect_max_s)
                continue
            with self._fresh_lock:
                if self._closed.is_set():
                    _shutdown_quietly(bus)
                    return
                self._fresh = bus
                self._back.set()
            log.info("CAN bus reopened at attempt %d", attempt)
            return

    def close(self) -> None:
        self._closed.set()
        if self.recorder is not None:
            self.recorder.stop()
            self.recorder = None
        with self._fresh_lock:
            fresh, self._fresh = self._fresh, None
        if fresh is not None:
            _shutdown_quietly(fresh)
        if not self.lost:
            _shutdown_quietly(self.bus)


def _shutdown_quietly(bus: can.BusABC) -> None:
    """Shut ``bus`` down; the other end may be gone already (e.g. the bench hub stopped)."""
    try:
        bus.shutdown()
    except Exception as exc:
        log.debug("bus shutdown: %s", exc)
        with contextlib.suppress(Exception):
            bus._is_shutdown = True  # python-can would otherwise retry (and fail again) in __del__


__all__ = ["BusPort", "EncodeError"]
