"""A lossy, reordering UDP relay for tests and benchmarks (loopback only).

``LossyRelay(vehicle_addr, loss=0.2, reorder=0.1, seed=1)`` listens on 127.0.0.1 (a free port, read back
from ``port``); datagrams from the ground station go to the vehicle, datagrams from the vehicle go back to
the last ground-station address. Each direction independently drops ``loss`` of the datagrams and holds
back ``reorder`` of them for ``reorder_delay_s`` so they arrive after later ones.
"""

from __future__ import annotations

import heapq
import random
import selectors
import socket
import threading
import time


class LossyRelay:
    def __init__(
        self,
        vehicle_addr: tuple[str, int],
        *,
        loss: float = 0.2,
        reorder: float = 0.1,
        reorder_delay_s: float = 0.02,
        seed: int = 1,
    ) -> None:
        self.vehicle_addr = vehicle_addr
        self.loss = loss
        self.reorder = reorder
        self.reorder_delay_s = reorder_delay_s
        self._rng = random.Random(seed)
        self.gcs_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.gcs_side.bind(("127.0.0.1", 0))
        self.vehicle_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.vehicle_side.bind(("127.0.0.1", 0))
        self.port = self.gcs_side.getsockname()[1]
        self._gcs_addr: tuple[str, int] | None = None
        self._delayed: list[tuple[float, int, socket.socket, bytes, tuple[str, int]]] = []
        self._n = 0
        self.forwarded = {"up": 0, "down": 0}
        self.dropped = {"up": 0, "down": 0}
        self.reordered = {"up": 0, "down": 0}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="lossy-relay", daemon=True)

    def start(self) -> LossyRelay:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.gcs_side.close()
        self.vehicle_side.close()

    def __enter__(self) -> LossyRelay:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _forward(self, direction: str, out: socket.socket, data: bytes, addr: tuple[str, int]) -> None:
        r = self._rng.random()
        if r < self.loss:
            self.dropped[direction] += 1
            return
        self.forwarded[direction] += 1
        if r < self.loss + self.reorder:
            self.reordered[direction] += 1
            self._n += 1
            heapq.heappush(self._delayed, (time.monotonic() + self.reorder_delay_s, self._n, out, data, addr))
            return
        out.sendto(data, addr)

    def _run(self) -> None:
        sel = selectors.DefaultSelector()
        sel.register(self.gcs_side, selectors.EVENT_READ, "up")
        sel.register(self.vehicle_side, selectors.EVENT_READ, "down")
        while not self._stop.is_set():
            timeout = 0.05
            if self._delayed:
                timeout = max(0.0, min(timeout, self._delayed[0][0] - time.monotonic()))
            for key, _ in sel.select(timeout):
                try:
                    data, addr = key.fileobj.recvfrom(65535)  # type: ignore[union-attr]
                except OSError:
                    continue
                if key.data == "up":
                    self._gcs_addr = addr
                    self._forward("up", self.vehicle_side, data, self.vehicle_addr)
                elif self._gcs_addr is not None:
                    self._forward("down", self.gcs_side, data, self._gcs_addr)
            now = time.monotonic()
            while self._delayed and self._delayed[0][0] <= now:
                _, _, out, data, addr = heapq.heappop(self._delayed)
                try:
                    out.sendto(data, addr)
                except OSError:
                    pass
        sel.close()
