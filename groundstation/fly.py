"""``auv-gcs fly FILE``: upload (fence and goals), wait until ready, arm, start, and watch to the end.

One command for what ``upload``, ``wait-ready``, ``arm`` and ``start`` do one by one, then a live progress
display (rich; ``--json``: one line a second): goal i of n, the distance to it and the time to get there at
the speed over ground now, the state, the cross-track and depth errors. It ends with the vehicle:

- COMPLETE: exit 0;
- any refusal on the way (the upload, arming, the start): exit 1 (3 when the vehicle says "not now", e.g.
  not ready within ``--ready-timeout``), with the vehicle's reason;
- the vehicle stops flying on its own: ABORT, HOLD (a goal missed after its tries, the link lost, a new
  mission from another station), or IDLE / ARMED: exit 1 with the vehicle's reason (its STATUSTEXT);
- no HEARTBEAT for :data:`LINK_LOST_S`: exit 2;
- Ctrl-C: from the START on, HOLD is sent and what the vehicle answered is said (before it nothing runs);
  exit 130.

The session sends GCS heartbeats all along (the vehicle's link watch is satisfied while it runs).
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import common as mavlink
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn

from groundstation.mavclient import MavClient, state_from_heartbeat
from groundstation.text import labelled, plain

EXIT_OK, EXIT_REFUSED, EXIT_ERROR, EXIT_NOT_NOW, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
LINK_LOST_S = 5.0
START_WAIT_S = 5.0  # after the START's ACK, how long the vehicle may take to report RUNNING
STALE_S = 1.5  # a heartbeat sent before the START took effect may still arrive this long after its ACK
REASON_WAIT_S = 0.5  # after the state changes, how long the vehicle's STATUSTEXT with the reason may take
FLYING = ("RUNNING",)


@dataclass
class FlightView:
    """What the display shows, from the vehicle's messages (pure: :meth:`feed`)."""

    goals: int
    state: str = "?"
    goal: int = 0  # the current goal, 0-based
    reached: int = 0
    distance_m: float = math.nan
    speed_mps: float = math.nan
    cross_track_m: float = math.nan
    depth_error_m: float = math.nan
    home_offset: int = 0  # MAVLink seq - goal index (1 when the mission holds a home item)
    goal_xy_m: list[tuple[float, float] | None] = field(default_factory=list)  # local goals (None: global)
    whole_metres: bool = True  # the distance is NAV_CONTROLLER_OUTPUT's wp_dist (whole metres)

    def feed(self, m: Any) -> None:
        kind = m.get_type()
        if kind == "HEARTBEAT":
            self.state = state_from_heartbeat(m)
        elif kind == "MISSION_CURRENT":
            self.goal = max(0, int(m.seq) - self.home_offset)
        elif kind == "MISSION_ITEM_REACHED":
            self.reached = max(self.reached, int(m.seq) - self.home_offset + 1)
        elif kind == "NAV_CONTROLLER_OUTPUT":
            if self._goal_xy() is None:
                self.distance_m, self.whole_metres = float(m.wp_dist), True
            self.cross_track_m = float(m.xtrack_error)
            self.depth_error_m = float(m.alt_error)
        elif kind == "LOCAL_POSITION_NED":
            self.speed_mps = math.hypot(float(m.vx), float(m.vy))
            goal = self._goal_xy()
            if goal is not None:  # to the decimetre, from where the vehicle says it is
                self.distance_m, self.whole_metres = math.hypot(goal[0] - m.x, goal[1] - m.y), False

    def _goal_xy(self) -> tuple[float, float] | None:
        return self.goal_xy_m[self.goal] if 0 <= self.goal < len(self.goal_xy_m) else None

    @property
    def eta_s(self) -> float:
        if not (math.isfinite(self.distance_m) and math.isfinite(self.speed_mps)) or self.speed_mps < 0.05:
            return math.nan
        return self.distance_m / self.speed_mps

    def line(self) -> str:
        def f(v: float, unit: str, digits: int = 1) -> str:
            return "-" if not math.isfinite(v) else f"{v:.{digits}f} {unit}"

        return (
            f"{self.state:8s} goal {min(self.goal + 1, self.goals)}/{self.goals}  "
            f"{f(self.distance_m, 'm', 0 if self.whole_metres else 1)} to go, ETA {f(self.eta_s, 's', 0)}  "
            f"cross-track {f(self.cross_track_m, 'm', 2)}  depth error {f(self.depth_error_m, 'm', 2)}"
        )

    def as_dict(self) -> dict[str, Any]:
        def num(v: float) -> float | None:
            return round(v, 3) if math.isfinite(v) else None

        return {
            "state": self.state,
            "goal": self.goal,
            "goals": self.goals,
            "reached": self.reached,
            "distance_m": num(self.distance_m),
            "eta_s": num(self.eta_s),
            "cross_track_m": num(self.cross_track_m),
            "depth_error_m": num(self.depth_error_m),
        }


def _reason(client: MavClient, since_s: float) -> str:
    """The vehicle's last text since ``since_s`` (the STATUSTEXT of the transition), waiting a little."""
    t_end = time.monotonic() + REASON_WAIT_S
    while True:
        texts = client.texts_since(since_s)
        if texts or time.monotonic() >= t_end:
            return texts[-1].text if texts else ""
        client.recv(0.05)


def watch(
    client: MavClient,
    goals: int,
    console: Console,
    *,
    home_offset: int = 0,
    goal_xy_m: list[tuple[float, float] | None] | None = None,
    as_json: bool = False,
    emit: Callable[[dict[str, Any]], None] | None = None,
) -> tuple[int, dict[str, Any]]:
    """Watch a started mission to its end (see the module docstring); (exit code, final data)."""
    p = FlightView(goals, home_offset=home_offset, goal_xy_m=goal_xy_m or [])
    emit = emit or (lambda d: sys.stdout.write(json.dumps(d) + "\n"))
    last_hb = time.monotonic()
    started = False
    t_watch = t_state = texts_from = time.monotonic()
    next_json = 0.0
    bar = None
    if not as_json:
        bar = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(),
            TextColumn("{task.fields[info]}", markup=False), console=console, transient=False,
        )  # fmt: skip
        bar.start()
        task = bar.add_task("flying", total=goals, info="")
    try:
        while True:
            m = client.recv(0.1)
            now = time.monotonic()
            if m is not None and client.from_vehicle(m):
                before = p.state
                p.feed(m)
                if m.get_type() == "HEARTBEAT":
                    last_hb = now
                    if p.state != before:
                        t_state = now
                if m.get_type() == "MISSION_ITEM_REACHED" and bar is not None:
                    index = int(m.seq) - home_offset  # the vehicle's own numbering (from 0)
                    bar.console.print(plain(f"goal {index} reached ({p.reached} of {goals})"))
            if p.state in FLYING:
                started = True
            if bar is not None:
                for text in client.texts_since(texts_from):  # each text of the vehicle once, whole
                    bar.console.print(labelled("vehicle:", "dim", text.text))  # text, never markup
                    texts_from = text.t_s + 1e-9
                bar.update(task, completed=p.reached, info=p.line())
            elif now >= next_json:
                next_json = now + 1.0
                emit({"event": "progress", **p.as_dict()})
            if now - last_hb > LINK_LOST_S:
                return EXIT_ERROR, {
                    **p.as_dict(),
                    "ok": False,
                    "reason": f"no heartbeat for {LINK_LOST_S:g} s",
                }
            if p.state == "COMPLETE":
                return EXIT_OK, {**p.as_dict(), "ok": True, "reason": ""}
            if started and p.state not in FLYING:
                why = _reason(client, t_state - 0.5)
                return EXIT_REFUSED, {**p.as_dict(), "ok": False, "reason": why}
            # not started yet: a heartbeat from before the START (sent between its ACK and the tick's
            # snapshot) may still say the state before it (ARMED, or HOLD for a resume) for STALE_S; then
            # any state but ARMED (HOLD: the first leg could not be planned; ABORT), or ARMED for long, is
            # the end, with the reason
            waiting = now - t_watch < STALE_S or (p.state in ("?", "ARMED") and now - t_watch < START_WAIT_S)
            if not started and not waiting:
                why = _reason(client, t_state - 0.5)
                why = why or "the mission did not start"
                return EXIT_REFUSED, {**p.as_dict(), "ok": False, "reason": why}
    finally:
        if bar is not None:
            bar.stop()


def hold(client: MavClient) -> tuple[bool, str]:
    """Ctrl-C: HOLD the vehicle (DO_PAUSE_CONTINUE 0); (accepted, the vehicle's answer in words)."""
    ack = client.command_ack(mavlink.MAV_CMD_DO_PAUSE_CONTINUE, 0.0, retries=3)
    return ack.ok, ack.result_name + (f": {ack.reason}" if ack.reason else "")
