"""Fixtures: an in-process vehicle endpoint (free port, temporary state dir) with a fake loop thread."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from groundstation.mavclient import MavClient
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink
from onboard.adapters.mavlink.standalone import FakeLoop


class Vehicle:
    def __init__(self, state_dir: Path, **cfg: object) -> None:
        table: dict[str, object] = {"endpoints": ("udpin:127.0.0.1:0",), "state_dir": str(state_dir)}
        table.update(cfg)
        self.config = MavlinkConfig(**table)  # type: ignore[arg-type]
        self.link = VehicleLink(self.config)
        self.loop = FakeLoop(self.link, speed_mps=20.0)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self.loop.run, args=(self._stop, 50.0), daemon=True)

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
