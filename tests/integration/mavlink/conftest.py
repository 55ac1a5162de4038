"""Fixtures: an in-process vehicle (free port, temporary state dir): the real core and link over a simple
plant (``onboard.app.standalone``), simulated time 10 times faster than the wall clock."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from groundstation.mavclient import MavClient
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.app.standalone import build
from onboard.app.store import StateStore

TIME_SCALE = 10.0


WAIT_S = 30.0  # generous: the machine may be loaded (the vehicle's own time is simulated)


def wait_message(client: MavClient, what: str, pred: Callable[[Any], bool], timeout_s: float = WAIT_S) -> Any:
    """The first message ``client`` receives for which ``pred`` holds; an AssertionError naming ``what``
    after ``timeout_s`` (s, the monotonic clock)."""
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        msg = client.recv(0.1)
        if msg is not None and pred(msg):
            return msg
    raise AssertionError(f"no {what} within {timeout_s} s")


class Vehicle:
    def __init__(self, state_dir: Path, **cfg: object) -> None:
        table: dict[str, object] = {"endpoints": ("udpin:127.0.0.1:0",)}
        table.update(cfg)
        self.config = MavlinkConfig(**table)  # type: ignore[arg-type]
        self.state_dir = state_dir  # the vehicle's state store ([store] dir)
        self.loop = build(self.config, store=StateStore(state_dir))
        self.link = self.loop.link
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self.loop.run, args=(self._stop, TIME_SCALE), daemon=True)

    @property
    def port(self) -> int:
        return self.link.ports[0]

    def start(self, with_loop: bool = True) -> Vehicle:
        self.link.start()
        if with_loop:
            self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        self.link.stop()

    def client(self, port: int | None = None, **kw: object) -> MavClient:
        c = MavClient(f"udpout:127.0.0.1:{port or self.port}", **kw)  # type: ignore[arg-type]
        c.heartbeat()
        c.wait_heartbeat(3.0)
        return c


@pytest.fixture
def vehicle(tmp_path: Path) -> Iterator[Vehicle]:
    v = Vehicle(tmp_path / "state").start()
    yield v
    v.stop()
