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

:func:`run` is the whole command (``__main__`` only parses its arguments); :func:`upload_plans`, its first
step, is also the ``upload`` and ``fence`` sub-commands.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import common as mavlink
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn
from rich.text import Text

from groundstation import mission_files
from groundstation.command_client import CommandClient
from groundstation.link import Link, LinkError
from groundstation.mavclient import MavClient
from groundstation.messages import Msg, state_from_heartbeat
from groundstation.mission_client import Item, MissionClient, TransferResult
from groundstation.output import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_NOT_NOW,
    EXIT_OK,
    EXIT_REFUSED,
    Out,
    exit_code_of_command,
)
from groundstation.text import labelled, lines, plain

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

    def feed(self, m: Msg) -> None:
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


def _reason(link: Link, since_s: float) -> str:
    """The vehicle's last text since ``since_s`` (the STATUSTEXT of the transition), waiting a little."""
    t_end = time.monotonic() + REASON_WAIT_S
    while True:
        texts = link.texts_since(since_s)
        if texts or time.monotonic() >= t_end:
            return texts[-1].text if texts else ""
        link.recv(0.05)


def watch(
    link: Link,
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

    def print_line(d: dict[str, Any]) -> None:
        sys.stdout.write(json.dumps(d) + "\n")

    emit = emit or print_line
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
            m = link.recv(0.1)
            now = time.monotonic()
            if m is not None and link.from_vehicle(m):
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
                for text in link.texts_since(texts_from):  # each text of the vehicle once, whole
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
                why = _reason(link, t_state - 0.5)
                return EXIT_REFUSED, {**p.as_dict(), "ok": False, "reason": why}
            # not started yet: a heartbeat from before the START (sent between its ACK and the tick's
            # snapshot) may still say the state before it (ARMED, or HOLD for a resume) for STALE_S; then
            # any state but ARMED (HOLD: the first leg could not be planned; ABORT), or ARMED for long, is
            # the end, with the reason
            waiting = now - t_watch < STALE_S or (p.state in ("?", "ARMED") and now - t_watch < START_WAIT_S)
            if not started and not waiting:
                why = _reason(link, t_state - 0.5)
                why = why or "the mission did not start"
                return EXIT_REFUSED, {**p.as_dict(), "ok": False, "reason": why}
    finally:
        if bar is not None:
            bar.stop()


def hold(commands: CommandClient) -> tuple[bool, str]:
    """Ctrl-C: HOLD the vehicle (DO_PAUSE_CONTINUE 0); (accepted, the vehicle's answer in words)."""
    ack = commands.command_ack(mavlink.MAV_CMD_DO_PAUSE_CONTINUE, 0.0, retries=3)
    return ack.ok, ack.result_name + (f": {ack.reason}" if ack.reason else "")


# ---- the command: upload, ready, arm, start, watch ----------------------------------------------------
def _upload(
    missions: MissionClient, out: Out, items: list[Item], mission_type: int, label: str
) -> dict[str, Any]:
    r: TransferResult
    if out.as_json or not items:
        r = missions.upload(items, mission_type)
    else:
        with out.progress() as prog:
            task = prog.add_task(f"upload {label}", total=len(items))
            r = missions.upload(
                items, mission_type, progress=lambda done, n: prog.update(task, completed=done)
            )
    return {
        "type": label,
        "items": len(items),
        "ok": r.ok,
        "result": r.result_name,
        "reason": r.reason,
        "elapsed_s": r.elapsed_s,
        "timeout": r.result < 0,
    }


def upload_text(r: dict[str, Any]) -> str:
    """One line for one result of :func:`upload_plans`."""
    verdict = "accepted" if r["ok"] else "REFUSED"
    why = f": {r['reason']}" if r["reason"] else ""
    return f"{r['type']}: {r['items']} items {verdict} ({r['result']}{why}, {r['elapsed_s']:.3f} s)"


def upload_plans(
    missions: MissionClient,
    out: Out,
    goals: list[Item],
    fences: list[Item],
    with_goals: bool,
    with_fence: bool,
) -> tuple[list[dict[str, Any]], str]:
    """Upload the goals, the fence, or both; returns the results (mission first) and, when any was not
    accepted, a note on what is in force on the vehicle now (read back from it).

    Both go in ONE transfer of type MAV_MISSION_TYPE_ALL (the goals, then the fence circles; the vehicle's
    MAVLink profile, :mod:`onboard.adapters.mavlink.mission_protocol`): the vehicle judges them as one unit
    and puts both in force or, refused, neither, so a refused upload changes nothing, also while the vehicle
    runs (two transfers would put the first in force before the second is judged). The one verdict is
    reported for each part.
    """
    results: list[dict[str, Any]]
    if with_goals and with_fence:
        r = _upload(missions, out, goals + fences, mavlink.MAV_MISSION_TYPE_ALL, "mission and fence")
        results = [dict(r, type="mission", items=len(goals)), dict(r, type="fence", items=len(fences))]
    elif with_fence:
        results = [_upload(missions, out, fences, mavlink.MAV_MISSION_TYPE_FENCE, "fence")]
    elif with_goals:
        results = [_upload(missions, out, goals, mavlink.MAV_MISSION_TYPE_MISSION, "mission")]
    else:
        return [], ""
    if all(r["ok"] for r in results):
        return results, ""
    try:
        n_goals = len(missions.download(mavlink.MAV_MISSION_TYPE_MISSION))
        n_fence = len(missions.download(mavlink.MAV_MISSION_TYPE_FENCE))
    except LinkError as exc:
        return results, f"what is in force on the vehicle could not be read back: {exc}"
    return results, f"in force on the vehicle: {n_goals} mission items, {n_fence} fence circles"


def run(
    client: MavClient, out: Out, goals: list[Item], fences: list[Item], *, ready_timeout_s: float, tlog: Path
) -> int:
    """``fly``: the file as the whole plan (an empty fence clears the old one), then ready, arm, start and
    the watch; the exit code (see the module docstring). Every end is one ``out.done`` with ``event: end``.
    """

    def stop(code: int, data: dict[str, Any], text: str | Text) -> int:
        out.done({"event": "end", "tlog": str(tlog), **data}, text)
        return code

    results, note = upload_plans(client.mission, out, goals, fences, True, True)
    refused = next((r for r in results if not r["ok"]), None)
    if refused is not None:
        why = f"upload {refused['type']}: {refused['result']}" + (
            f": {refused['reason']}" if refused["reason"] else ""
        )
        code = EXIT_ERROR if refused["timeout"] else EXIT_REFUSED
        text = why + (f" ({note})" if note else "")  # what is in force after the refusal, read back
        return stop(
            code, {"ok": False, "step": "upload", "reason": why, "in_force": note}, plain(text, "red")
        )
    if not out.as_json:
        out.show(lines(map(upload_text, results)))
    ready, _hb, why = client.wait_ready(ready_timeout_s)
    if not ready:
        text = f"not ready after {ready_timeout_s:g} s" + (f": {why}" if why else "")
        return stop(EXIT_NOT_NOW, {"ok": False, "step": "ready", "reason": text}, plain(text, "red"))
    offset = 1 if mission_files.is_home_placeholder(goals) else 0
    n_goals = len(goals) - offset
    # the local goals' (x, y), for the distance to go (a global goal's origin is the vehicle's: None)
    xy = [None if (ned := mission_files.local_ned(g, None)) is None else ned[:2] for g in goals[offset:]]
    start_sent = False
    try:
        for step, (cmd, params) in (
            ("arm", (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))),
            ("start", (mavlink.MAV_CMD_MISSION_START, (0.0, 0.0))),
        ):
            start_sent = step == "start"
            ack = client.commands.command_ack(cmd, *params)
            if not ack.ok:
                text = f"{step}: {ack.result_name}" + (f": {ack.reason}" if ack.reason else "")
                data = {"ok": False, "step": step, "result": ack.result_name, "reason": ack.reason}
                return stop(exit_code_of_command(ack.result), data, plain(text, "red"))
            if not out.as_json:
                out.show(f"{step}: {ack.result_name}")
        code, data = watch(
            client, n_goals, out.console, home_offset=offset, goal_xy_m=xy, as_json=out.as_json
        )
    except KeyboardInterrupt:
        if not start_sent:  # nothing runs: the vehicle is at most armed, its propeller off
            data = {"ok": False, "step": "interrupted", "hold": False, "reason": "before the start"}
            return stop(EXIT_INTERRUPTED, data, "interrupted before the start: nothing sent after it")
        try:
            ok, answer = hold(client.commands)
        except LinkError as exc:
            ok, answer = False, str(exc)
        text = f"interrupted: HOLD sent, the vehicle answered {answer}"
        return stop(
            EXIT_INTERRUPTED, {"ok": False, "step": "interrupted", "hold": ok, "reason": answer}, text
        )
    if code == EXIT_OK:
        done = f"{n_goals} of {n_goals} goals reached"
        return stop(code, {**data, "step": "done"}, labelled("COMPLETE:", "green", done))
    text = f"{data['state']}: {data['reason'] or 'the vehicle stopped the mission'}"
    return stop(code, {**data, "step": "watch"}, plain(text, "red"))
