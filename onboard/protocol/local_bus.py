"""An in-process python-can bus that hands every receiver the frame that was sent, not a copy of it.

python-can's ``virtual`` bus deep-copies each frame for each receiver (and stamps the copy with the wall
clock), which cost a one-process lock-step run more than its onboard core (issue 22). Inside one process
the copy buys nothing when nobody changes a frame once sent, and no node of this stack does: a
:class:`onboard.protocol.port.BusPort` builds a new ``can.Message`` per frame and only reads the ones it
receives. :class:`LocalBus` keeps that contract (immutable use) and passes the object itself.

It stays a python-can bus (``can.BusABC``: ``send``, ``recv``, acceptance filters, ``shutdown``), selected
by configuration: ``[bus] interface = "local"`` (:func:`onboard.protocol.bus.open_bus`). Buses on one channel
(any hashable name) in one process hear each other, not themselves. The acceptance filters are applied
when a frame is sent, so a receiver's queue holds only the frames it listens to and a non-blocking
``recv`` never ends early on a filtered frame. A frame keeps the timestamp its sender gave it (a lock-step
receiver times frames by its own clock). The receive queues are unbounded, as the ``virtual`` bus's are by
default: a node on this bus reads every period.

Thread-safe for senders and receivers on different threads (a blocking ``recv`` waits on a condition); the
lock-step runs that use it send and receive on one thread, where a frame costs a deque append and pop.
"""

from __future__ import annotations

import threading
from collections import deque
from typing import Any

import can
from can.typechecking import CanFilters, Channel


class _Channel:
    """The buses on one channel name: a tuple replaced on each join and leave (a sender iterates the tuple
    it read, never a list another thread changes)."""

    __slots__ = ("members",)

    def __init__(self) -> None:
        self.members: tuple[LocalBus, ...] = ()


_channels: dict[Channel, _Channel] = {}
_channels_lock = threading.Lock()


class LocalBus(can.BusABC):
    """A python-can bus inside one process whose receivers get the sent ``can.Message`` itself (see the
    module docstring: receivers must not change a frame)."""

    def __init__(
        self,
        channel: Channel = "local-0",
        can_filters: CanFilters | None = None,
        **kwargs: Any,
    ) -> None:
        self._accepts: dict[tuple[int, bool], bool] = {}
        super().__init__(channel=channel, can_filters=can_filters, **kwargs)
        self.channel_id = channel
        self.channel_info = f"local bus channel {channel}"
        self._rx: deque[can.Message] = deque()
        self._wake = threading.Condition()
        self._waiting = 0  # receivers blocked in recv (a sender wakes them only then)
        self._open = True
        with _channels_lock:
            self._channel = _channels.setdefault(channel, _Channel())
            self._channel.members = (*self._channel.members, self)

    def _apply_filters(self, filters: CanFilters | None) -> None:
        """python-can's hook for new acceptance filters: forget the decisions taken under the old ones."""
        self._accepts = {}

    def _accepts_frame(self, msg: can.Message) -> bool:
        """Whether this bus's acceptance filters pass ``msg``: python-can's own rule, taken once per id
        (it depends on the id and its format only) and remembered until the filters change."""
        key = (msg.arbitration_id, msg.is_extended_id)
        accept = self._accepts.get(key)
        if accept is None:
            accept = self._accepts[key] = self._matches_filters(msg)
        return accept

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        """Queue ``msg`` itself for every other bus on the channel whose acceptance filters pass it."""
        if not self._open:
            raise can.CanOperationError("Cannot operate on a closed bus")
        for peer in self._channel.members:
            if peer is self or not peer._accepts_frame(msg):
                continue
            peer._rx.append(msg)
            if peer._waiting:
                with peer._wake:
                    peer._wake.notify()

    def recv(self, timeout: float | None = None) -> can.Message | None:
        """The next frame, waiting up to ``timeout`` s (None: for ever, 0: not at all). The frames were
        filtered when they were sent, so this is a queue pop (``BusABC.recv``'s filter loop, clock reads and
        log call per frame are not needed)."""
        if not self._open:
            raise can.CanOperationError("Cannot operate on a closed bus")
        try:
            return self._rx.popleft()
        except IndexError:
            if timeout is not None and timeout <= 0.0:
                return None
        return self._recv_internal(timeout)[0]

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        if not self._open:
            raise can.CanOperationError("Cannot operate on a closed bus")
        try:
            return self._rx.popleft(), True  # filtered when it was sent
        except IndexError:
            if timeout is not None and timeout <= 0.0:
                return None, True
        with self._wake:
            self._waiting += 1
            try:
                self._wake.wait_for(lambda: self._rx or not self._open, timeout)
            finally:
                self._waiting -= 1
        if not self._open:
            raise can.CanOperationError("Cannot operate on a closed bus")
        try:
            return self._rx.popleft(), True
        except IndexError:
            return None, True

    def shutdown(self) -> None:
        super().shutdown()
        if not self._open:
            return
        self._open = False
        with _channels_lock:
            self._channel.members = tuple(bus for bus in self._channel.members if bus is not self)
            if not self._channel.members and _channels.get(self.channel_id) is self._channel:
                del _channels[self.channel_id]
        with self._wake:
            self._wake.notify_all()
