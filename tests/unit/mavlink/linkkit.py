"""A VehicleLink without sockets: its output captured, a fake clock, the loop played by the test."""

from __future__ import annotations

import concurrent.futures
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink import bridge
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink
from onboard.app.store import StateStore
from onboard.core import commands as core
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.mission.validate import MissionCheck, Problem
from onboard.core.nav.types import nav_state_at

GCS = (255, 190)


def ok(_mission: Any) -> MissionCheck:
    return MissionCheck()


def refuse(item: str, index: int, field: str, reason: str) -> Callable[[Any], MissionCheck]:
    def check(_mission: Any) -> MissionCheck:
        return MissionCheck((Problem(item, index, field, reason),))  # type: ignore[arg-type]

    return check


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def ready_autopilot() -> Autopilot:
    """A real autopilot whose navigation is valid (so START can be accepted)."""
    ap = Autopilot(CoreConfig())
    ap.last_nav = nav_state_at()
    return ap


class Captured:
    """The link with every message it would send appended to ``out``."""

    def __init__(
        self, state_dir: Path, validator: Callable[[Any], Any] = ok, items: tuple = (), **kw: Any
    ) -> None:
        if items:
            StateStore(state_dir).save_plan("mission", items)
        self.clock = Clock()
        cfg = kw.pop("config", None) or MavlinkConfig()
        self.link = VehicleLink(cfg, validator=validator, clock=self.clock, store=StateStore(state_dir), **kw)
        self.out: list[mavlink.MAVLink_message] = []
        self.link.transport.send = self.out.append  # type: ignore[method-assign]
        self._mav = mavlink.MAVLink(None, *GCS)

    def rx(self, msg: mavlink.MAVLink_message, sender: tuple[int, int] = GCS) -> None:
        """``msg`` as received from ``sender`` (encoded and decoded, as on the wire)."""
        mav = mavlink.MAVLink(None, *sender)
        self.link.dispatch(mav.decode(bytearray(msg.pack(mav))), sender, self.clock())

    def command(self, cmd: int, *p: float, nan_fill: bool = False) -> None:
        fill = math.nan if nan_fill else 0.0
        ps = [*map(float, p), *([fill] * (7 - len(p)))]
        self.rx(mavlink.MAVLink_command_long_message(1, 1, cmd, 0, *ps))

    def poll(self, dt: float = 0.0) -> None:
        self.clock.t += dt
        self.link.poll(self.clock())

    def serve(self, judge: Callable[[core.Command], core.Verdict] | Autopilot) -> None:
        """One loop tick: every request judged and answered, then the link's timers."""
        if isinstance(judge, Autopilot):
            bridge.before_tick(judge, self.link)
            self.link.notify(judge.take_notes())
        else:
            for req in self.link.take_requests():
                self.link.answer(req.id, judge(req.command))
        self.poll()

    def settle(self, judge: Callable[[core.Command], core.Verdict] | Autopilot | None = None) -> None:
        """Wait for a running mission check, then serve (if a judge is given) until nothing is pending."""
        for _ in range(20):
            j = self.link.missions._judge
            if j is not None and not j.with_core:
                concurrent.futures.wait([j.future], timeout=5.0)
            self.poll()
            if judge is not None:
                self.serve(judge)
            if self.link.missions._judge is None:
                return

    def sent(self, kind: str) -> list[mavlink.MAVLink_message]:
        got = [m for m in self.out if m.get_type() == kind]
        self.out[:] = [m for m in self.out if m.get_type() != kind]
        return got

    def texts(self) -> list[str]:
        """The STATUSTEXTs sent, chunked ones reassembled."""
        out: list[str] = []
        open_id = None
        for m in self.sent("STATUSTEXT"):
            if m.id and m.id == open_id:
                out[-1] += m.text
            else:
                out.append(m.text)
            open_id = m.id if m.id and len(m.text) == 50 else None
        return out

    def ack(self) -> int:
        (a,) = self.sent("COMMAND_ACK")
        return int(a.result)

    def upload(self, items: list, mt: int = mavlink.MAV_MISSION_TYPE_MISSION) -> None:
        from .test_mission_protocol import count_msg, item_msg

        self.rx(count_msg(len(items), mt))
        for i, it in enumerate(items):
            self.rx(item_msg(i, it, mt))

    def mission_ack(self) -> int:
        (a,) = self.sent("MISSION_ACK")
        return int(a.type)
