"""The mission/fence and parameter services against plain-Python models (hypothesis stateful testing).

Issue 12, item 5. Each machine drives a real :class:`VehicleLink` in-process (no sockets: every message it
sends is captured with the link it goes to, every message it receives goes through a MAVLink 2 encode and
decode, the clock is injected) and compares everything the vehicle says and holds with a model of what it
must say and hold.

- :class:`MissionMachine`: two ground stations (same ids on another link, other ids on another link, or
  other ids behind the same link) upload MISSION and FENCE plans (in order, out of order, duplicated, with
  items lost, abandoned part way, restarted), clear them (MISSION_CLEAR_ALL and MISSION_COUNT 0), download
  them, let the clock run past the item and transfer timeouts, play the loop (the core's verdict on the
  ReplaceMission request, or a loop that does not take it) and reboot the vehicle. The validator is a test
  double that runs in the mission service's worker thread as the real one does: it refuses marked goals and
  fence circles and too many items in total (goals + fence: the check sees the new plan with the stored plan
  of the other type), raises for another marker and blocks (until released, or past the check's deadline)
  for a third. The model: the stored plans are always exactly the last fully accepted transfer (never a mix,
  never a partial one), also as persisted and as reloaded at boot; every reply goes to the sender's link and
  ids; only the owner of a transfer ever gets its ACCEPTED; another sender during a transfer is DENIED.
- :class:`ParamMachine`: PARAM_SET (in range, out of range, at and beyond the float32 bounds, not a number,
  unknown names, a 16-character name, another param_type, another target system), resends while pending,
  PARAM_REQUEST_READ by name and index, PARAM_REQUEST_LIST, a loop that judges with a real
  :class:`~onboard.core.autopilot.Autopilot`, a loop that does not run, and a reboot (the persisted edits
  go to the core again). The model is the table of values.

What the model found (fixed; a deterministic test below keeps it): a MISSION_CLEAR_ALL of another type,
from a second ground station during an upload, was judged and ended the upload without a word to its
owner. A clear during an upload is now the uploader's alone, and only of the type it uploads.
"""

from __future__ import annotations

import concurrent.futures
import math
import shutil
import struct
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hypothesis import HealthCheck, event, note, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule
from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink import bridge
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink
from onboard.adapters.mavlink.mission_protocol import (
    GLOBAL_SCALE,
    LOCAL_SCALE,
    TYPE_ALL,
    TYPE_FENCE,
    TYPE_MISSION,
    TYPE_RALLY,
    MissionItem,
)
from onboard.adapters.mavlink.peers import Sender
from onboard.adapters.mavlink.storage import load_plan
from onboard.app.store import StateStore
from onboard.core import commands as core
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.validate import MissionCheck, Problem
from onboard.core.params import BusLimits, param_table, param_value
from onboard.protocol.codec import command_ranges

from .test_mission_protocol import wp

C = mavlink
ACCEPTED = C.MAV_MISSION_ACCEPTED
DENIED = C.MAV_MISSION_DENIED
#: Each machine: this many runs of up to this many steps (about 3 s each on a slow core when they pass).
SETTINGS = settings(
    max_examples=100, stateful_step_count=30, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
T0 = 100.0

# ---- the vehicle, captured -------------------------------------------------------------------------
#: What the machines look at (telemetry streams, HEARTBEAT, MISSION_CURRENT are not theirs).
WATCHED = frozenset(
    {
        "MISSION_ACK",
        "MISSION_REQUEST_INT",
        "MISSION_COUNT",
        "MISSION_ITEM_INT",
        "MISSION_ITEM",
        "STATUSTEXT",
        "PARAM_VALUE",
    }
)


class Vehicle:
    """A VehicleLink without sockets: every message it sends captured with its destination link (None =
    every peer), the messages it sends and receives encoded and decoded as on the wire, its clock ``t``."""

    def __init__(self, state_dir: Path, t: float, **kw: Any) -> None:
        self.t = t
        self.link = VehicleLink(MavlinkConfig(), clock=lambda: self.t, store=StateStore(state_dir), **kw)
        self.out: list[tuple[mavlink.MAVLink_message, Any]] = []
        self.link.transport.send = self._capture  # type: ignore[method-assign]
        self._mav = mavlink.MAVLink(None, 1, 1)

    def _capture(self, msg: mavlink.MAVLink_message, link: Any = None) -> None:
        if msg.get_type() in WATCHED:  # as the ground station reads it (float32, char arrays)
            msg = self._mav.decode(bytearray(msg.pack(self._mav)))
        self.out.append((msg, link))

    def rx(self, msg: mavlink.MAVLink_message, sender: Sender) -> None:
        mav = mavlink.MAVLink(None, sender.system_id, sender.component_id)
        self.link.dispatch(mav.decode(bytearray(msg.pack(mav))), sender, self.t)

    def poll(self, dt: float = 0.0) -> None:
        self.t += dt
        self.link.poll(self.t)

    def take(self) -> list[tuple[mavlink.MAVLink_message, Any]]:
        got = [(m, link) for m, link in self.out if m.get_type() in WATCHED]
        self.out.clear()
        return got

    def close(self) -> None:
        self.link.missions.close()


def texts_of(out: list[tuple[mavlink.MAVLink_message, Any]]) -> list[tuple[Any, str]]:
    """(link, text) of each STATUSTEXT, chunked ones reassembled."""
    texts: list[tuple[Any, str]] = []
    open_id = None
    for m, link in out:
        if m.get_type() != "STATUSTEXT":
            continue
        if m.id and m.id == open_id and texts and texts[-1][0] == link:
            texts[-1] = (link, texts[-1][1] + m.text)
        else:
            texts.append((link, m.text))
        open_id = m.id if m.id and len(m.text) == 50 else None
    return texts


# ---- mission items ---------------------------------------------------------------------------------
#: Markers the validator double reacts to (goal depth, fence radius; all exact in float32).
REFUSED = 77.0  # a goal at this depth / a circle of this radius is refused by the validator
EXPLODES = 66.0  # a goal at this depth makes the validator raise
SLOW = 55.0  # a goal at this depth makes the validator wait to be released
MAX_ITEMS = 8  # the validator refuses more goals + circles than this ("count")
FIELD_CODE = {"depth": C.MAV_MISSION_INVALID_PARAM7, "radius": C.MAV_MISSION_INVALID_PARAM1,
              "count": C.MAV_MISSION_NO_SPACE}  # fmt: skip
FENCE_CMD = C.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
HOME = wp(frame=C.MAV_FRAME_GLOBAL_INT, x=0, y=0, z=0.0)  # ArduPilot's home placeholder (seq 0 only)


def fence(x_m: int, y_m: int, radius: float, **kw: Any) -> MissionItem:
    return wp(x_m, y_m, 0.0, **{"command": FENCE_CMD, "param1": radius, **kw})


BAD_GOAL = wp(4, 4, 1.0, yaw_deg=math.inf)  # format: yaw not a number -> INVALID_PARAM4
BAD_CIRCLE = fence(4, 4, 2.0, command=C.MAV_CMD_NAV_WAYPOINT)  # format: not a circle -> UNSUPPORTED


def format_code(item: MissionItem, mt: int) -> int:
    """The model's per-item format check: only the two malformed items above fail it."""
    if item.key() == BAD_GOAL.key():
        return C.MAV_MISSION_INVALID_PARAM4
    if mt == TYPE_FENCE and item.command != FENCE_CMD:
        return C.MAV_MISSION_UNSUPPORTED
    return ACCEPTED


def sometimes(specials: list[MissionItem], usual: st.SearchStrategy[MissionItem]) -> st.SearchStrategy[Any]:
    """``usual``, or one of ``specials`` about once in eight draws."""
    pick = st.sampled_from(specials)
    return st.integers(0, 7).flatmap(lambda n: pick if n == 7 else usual)


xy = st.integers(-40, 40)
goals = sometimes(
    [wp(7, 7, REFUSED), wp(8, 8, EXPLODES), wp(9, 9, SLOW), BAD_GOAL],
    st.builds(wp, xy, xy, st.sampled_from([1.0, 2.0, 3.5])),
)
circles = sometimes([fence(6, 6, REFUSED), BAD_CIRCLE], st.builds(fence, xy, xy, st.sampled_from([1.0, 3.0])))
mission_plans = st.tuples(st.booleans(), st.lists(goals, max_size=5)).map(
    lambda hp: tuple([HOME, *hp[1]] if hp[0] and hp[1] else hp[1])
)
plans = st.one_of(
    st.tuples(st.just(TYPE_MISSION), mission_plans),
    st.tuples(st.just(TYPE_MISSION), mission_plans),
    st.tuples(st.just(TYPE_FENCE), st.lists(circles, max_size=4).map(tuple)),
)


def goal_items(items: tuple[MissionItem, ...]) -> tuple[MissionItem, ...]:
    return items[1:] if items and items[0].key() == HOME.key() else items


def model_mission(plans: dict[int, tuple[MissionItem, ...]]) -> Mission:
    """The Mission the vehicle must hold for ``plans`` (local items: x, y in 1e-4 m; yaw NaN = free)."""
    gs = tuple(Goal(i.x / 1e4, i.y / 1e4, i.z, None) for i in goal_items(plans[TYPE_MISSION]))
    obs = tuple(Obstacle(i.x / 1e4, i.y / 1e4, i.param1) for i in plans[TYPE_FENCE])
    return Mission(gs, obs)


def problems(m: Mission) -> list[Problem]:
    """The validator double's problems (in this order; the first one gives the MAV_MISSION code)."""
    out = [Problem("goal", i, "depth", "marked") for i, g in enumerate(m.goals) if g.depth_m == REFUSED]
    out += [
        Problem("obstacle", i, "radius", "marked") for i, o in enumerate(m.obstacles) if o.radius_m == REFUSED
    ]
    if len(m.goals) + len(m.obstacles) > MAX_ITEMS:
        out.append(Problem("mission", -1, "count", f"more than {MAX_ITEMS} goals and circles"))
    return out


def msg_key(m: mavlink.MAVLink_message) -> tuple[str, ...]:
    """The MissionItem key of a downloaded MISSION_ITEM_INT."""
    return MissionItem(m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z,
                       m.autocontinue).key()  # fmt: skip


def _scale(frame: int) -> float:
    return LOCAL_SCALE if frame == mavlink.MAV_FRAME_LOCAL_NED else GLOBAL_SCALE


def legacy_msg_key(m: mavlink.MAVLink_message) -> tuple[str, ...]:
    """The MissionItem key of a downloaded legacy MISSION_ITEM (float x/y in metres or degrees)."""
    k = _scale(m.frame)
    return MissionItem(m.frame, m.command, m.param1, m.param2, m.param3, m.param4, round(m.x * k),
                       round(m.y * k), m.z, m.autocontinue).key()  # fmt: skip


def legacy_key(it: MissionItem) -> tuple[str, ...]:
    """What ``legacy_msg_key`` gives for a stored item: x/y through the float32 of MISSION_ITEM, and the
    frame in its legacy name (GLOBAL_INT -> GLOBAL, GLOBAL_RELATIVE_ALT_INT -> GLOBAL_RELATIVE_ALT)."""
    k = _scale(it.frame)
    f32 = [struct.unpack("<f", struct.pack("<f", v / k))[0] for v in (it.x, it.y)]
    legacy = {mavlink.MAV_FRAME_GLOBAL_INT: mavlink.MAV_FRAME_GLOBAL,
              mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT}  # fmt: skip
    frame = legacy.get(it.frame, it.frame)
    return MissionItem(frame, it.command, it.param1, it.param2, it.param3, it.param4, round(f32[0] * k),
                       round(f32[1] * k), it.z, it.autocontinue).key()  # fmt: skip


def item_msg(seq: int, it: MissionItem, mt: int) -> mavlink.MAVLink_message:
    return C.MAVLink_mission_item_int_message(
        1, 1, seq, it.frame, it.command, 0, it.autocontinue, it.param1, it.param2, it.param3, it.param4,
        it.x, it.y, it.z, mt,
    )  # fmt: skip


# ---- the mission model -----------------------------------------------------------------------------
@dataclass
class Upload:
    """An upload in progress, as the vehicle must see it."""

    owner: str
    mt: int
    count: int
    got: list[MissionItem]
    last_rx: float
    last_req: float


@dataclass
class Judging:
    """A complete transfer being judged. ``phase``: "slow" (the check is blocked), "check" (its result is
    ready for the next poll), "core" (a ReplaceMission request not taken yet), "taken" (the loop has it),
    "answered" (the loop's verdict ``accept`` is delivered at the next poll)."""

    owner: str
    mt: int
    plans: dict[int, tuple[MissionItem, ...]]
    final: tuple[int, MissionItem] | None
    phase: str
    check_deadline: float
    core_deadline: float = math.inf
    accept: bool = False


A = Sender(255, 190, (1, ("10.0.0.1", 14550)))
B_VARIANTS = {
    "same ids, another link": Sender(255, 190, (1, ("10.0.0.2", 14550))),
    "other ids, another link": Sender(254, 190, (2, None)),  # a TCP connection
    "other ids, the same link": Sender(254, 190, (1, ("10.0.0.1", 14550))),  # two GCSs behind one router
}
PEERS = st.sampled_from(["A", "B"])
THEN = st.sampled_from(["", "accept", "accept", "refuse"])  # after a transfer: the judgement at once?


class _VehicleMachine(RuleBasedStateMachine):
    """What both machines share: a state directory of their own and the vehicle under test."""

    def __init__(self, prefix: str) -> None:
        super().__init__()
        self.dir = Path(tempfile.mkdtemp(prefix=prefix))
        self.v: Vehicle | None = None

    def teardown(self) -> None:
        if self.v is not None:
            self.v.close()
        shutil.rmtree(self.dir, ignore_errors=True)

    @property
    def vehicle(self) -> Vehicle:
        assert self.v is not None
        return self.v


class MissionMachine(_VehicleMachine):
    def __init__(self) -> None:
        super().__init__("stateful-mission-")
        self.gate = threading.Semaphore(0)
        self.booting = False
        self.slow_future: concurrent.futures.Future[Any] | None = None
        self.stored: dict[int, tuple[MissionItem, ...]] = {TYPE_MISSION: (), TYPE_FENCE: ()}
        self.up: Upload | None = None
        self.judging: Judging | None = None
        self.last_done: tuple[str, int, int, tuple[str, ...]] | None = None
        self.plan: dict[str, tuple[int, tuple[MissionItem, ...]]] = {}
        self.peers: dict[str, Sender] = {"A": A}
        self.requests: list[int] = []  # ids the loop took and did not answer yet

    # ---- the harness -------------------------------------------------------------------------------
    def validator(self, m: Mission) -> MissionCheck:
        if any(g.depth_m == EXPLODES for g in m.goals):
            raise RuntimeError("validator exploded")
        if not self.booting and any(g.depth_m == SLOW for g in m.goals):  # released by the machine
            self.gate.acquire(timeout=10.0)
        return MissionCheck(tuple(problems(m)))

    def boot(self) -> None:
        t = self.v.t if self.v is not None else T0
        self.booting = True
        try:
            self.v = Vehicle(self.dir, t, validator=self.validator)
        finally:
            self.booting = False
        self.requests = []

    def teardown(self) -> None:
        self.release_slow()
        super().teardown()

    def release_slow(self) -> None:
        if self.slow_future is not None:
            self.gate.release()
            concurrent.futures.wait([self.slow_future], timeout=10.0)
            assert self.slow_future.done()
            self.slow_future = None

    def after_rx(self) -> None:
        """A transfer that became complete: wait for its check (unless the model's check is slow)."""
        j = self.vehicle.link.missions._judge
        if j is None or j.with_core or j.future is self.slow_future:
            return
        if self.judging is not None and self.judging.phase == "slow":
            self.slow_future = j.future
            return
        concurrent.futures.wait([j.future], timeout=10.0)
        assert j.future.done()

    def dest(self, who: str) -> tuple[Any, int, int]:
        s = self.peers[who]
        return (s.link, s.system_id, s.component_id)

    def check_out(self, expected: list[tuple[Any, ...]], texts: list[tuple[str | None, str]]) -> None:
        """What the vehicle sent since the last look is exactly ``expected`` (in order) and one STATUSTEXT
        per (peer, words) of ``texts`` to that peer's link (peer None: to every one) containing the words."""
        out = self.vehicle.take()
        got: list[tuple[Any, ...]] = []
        for m, link in out:
            k = m.get_type()
            if k == "STATUSTEXT":
                continue
            d = (link, m.target_system, m.target_component)
            if k == "MISSION_ACK":
                got.append(("ACK", d, m.type, m.mission_type))
                if m.type == ACCEPTED:  # to one peer, never to every one (to the owner: ``expected``)
                    assert any(d == self.dest(p) for p in self.peers), (d, self.peers)
            elif k == "MISSION_REQUEST_INT":
                got.append(("REQ", d, m.seq, m.mission_type))
            elif k == "MISSION_COUNT":
                got.append(("COUNT", d, m.count, m.mission_type))
            elif k == "MISSION_ITEM_INT":
                got.append(("ITEM", d, m.seq, msg_key(m), m.mission_type))
            elif k == "MISSION_ITEM":
                got.append(("LEGACY_ITEM", d, m.seq, legacy_msg_key(m), m.mission_type))
            else:
                got.append((k, d))
        assert got == expected
        sent = texts_of(out)
        assert len(sent) == len(texts), (sent, texts)
        for (link, text), (who, words) in zip(sent, texts, strict=True):
            to = None if who is None else self.peers[who].link  # None: to every station
            assert link == to and words in text, (link, text, who, words)

    # ---- the model's transitions -------------------------------------------------------------------
    def ack(self, who: str, result: int, mt: int) -> tuple[Any, ...]:
        return ("ACK", self.dest(who), result, mt)

    def req(self, who: str, seq: int, mt: int) -> tuple[Any, ...]:
        return ("REQ", self.dest(who), seq, mt)

    def busy(self, who: str, mt: int, exp: list, texts: list) -> None:
        event("mission: another sender DENIED")
        exp.append(self.ack(who, DENIED, mt))
        texts.append((who, "mission transfer refused"))

    def judge(self, who: str, mt: int, plans: dict, final: tuple[int, MissionItem] | None) -> None:
        self.up = None
        self.last_done = None
        candidate = model_mission({**self.stored, **plans})
        depths = {g.depth_m for g in candidate.goals}
        slow = SLOW in depths and EXPLODES not in depths  # (the validator raises before it waits)
        self.judging = Judging(who, mt, plans, final, "slow" if slow else "check", self.vehicle.t + 3.0)

    def finish(self, result: int, words: str, exp: list, texts: list) -> None:
        j = self.judging
        assert j is not None
        self.judging = None
        event(f"mission: transfer judged {'ACCEPTED' if result == ACCEPTED else 'refused'} ({words or 'ok'})")
        if result == ACCEPTED:
            self.stored.update(j.plans)
            self.last_done = None if j.final is None else (j.owner, j.mt, j.final[0], j.final[1].key())
            texts.append((None, " accepted: "))  # to every station: the plan changed
        else:
            texts.append((j.owner, words))
        exp.append(self.ack(j.owner, result, j.mt))

    def model_poll(self, now: float) -> tuple[list, list]:
        exp: list[tuple[Any, ...]] = []
        texts: list[tuple[str, str]] = []
        j = self.judging
        # 1. the request queue: the loop's answer, or a request the loop did not take in time
        if j is not None and j.phase == "answered":
            if j.accept:
                self.finish(ACCEPTED, "", exp, texts)
            else:
                self.finish(C.MAV_MISSION_ERROR, "upload refused: not now", exp, texts)
        elif j is not None and j.phase == "core" and now >= j.core_deadline:
            self.finish(C.MAV_MISSION_ERROR, "the control loop is not running", exp, texts)
        # 2. the transfer timers
        up = self.up
        if up is not None:
            if now - up.last_rx >= 5.0:
                event("mission: upload cancelled (timeout)")
                self.up = None
                exp.append(self.ack(up.owner, C.MAV_MISSION_OPERATION_CANCELLED, up.mt))
            elif now - up.last_req >= 0.25:
                up.last_req = now
                event("mission: item re-requested (timer)")
                exp.append(self.req(up.owner, len(up.got), up.mt))
        # 3. the check's result, or its deadline
        j = self.judging
        if j is not None and j.phase == "check":
            candidate = model_mission({**self.stored, **j.plans})
            if any(g.depth_m == EXPLODES for g in candidate.goals):
                self.finish(C.MAV_MISSION_ERROR, "the mission check failed", exp, texts)
            elif ps := problems(candidate):
                self.finish(FIELD_CODE[ps[0].field], "refused", exp, texts)
            else:
                j.phase, j.core_deadline = "core", now + 1.0
        elif j is not None and j.phase == "slow" and now >= j.check_deadline:
            self.finish(C.MAV_MISSION_ERROR, "the mission check took longer than 3 s", exp, texts)
        return exp, texts

    def on_item(self, who: str, mt: int, seq: int, item: MissionItem, exp: list, texts: list) -> None:
        j, up = self.judging, self.up
        if j is not None:
            final_again = j.owner == who and j.mt == mt and j.final is not None and seq == j.final[0] - 1
            if not final_again and j.owner != who:
                self.busy(who, mt, exp, texts)
            return  # the final item again (its ACK comes with the judgement), or a stray one
        if up is None:
            if self.last_done == (who, mt, seq + 1, item.key()):  # our final ACK was lost: again
                event("mission: final ACK sent again")
                exp.append(self.ack(who, ACCEPTED, mt))
            return
        if up.owner != who:
            self.busy(who, mt, exp, texts)
            return
        if mt != up.mt or seq != len(up.got):
            if seq >= up.count and mt == up.mt:
                event("mission: INVALID_SEQUENCE")
                self.up = None
                exp.append(self.ack(who, C.MAV_MISSION_INVALID_SEQUENCE, mt))
            else:
                event("mission: out-of-sequence item re-requested")
                up.last_req = self.vehicle.t
                exp.append(self.req(who, len(up.got), up.mt))
            return
        code = format_code(item, mt)
        if code != ACCEPTED:
            event("mission: item format refused")
            self.up = None
            exp.append(self.ack(who, code, mt))
            if code == C.MAV_MISSION_INVALID_PARAM4:  # a goal's yaw: the reason names the goal (issue 21)
                texts.append((who, "mission upload refused: goal "))
            return
        up.got.append(item)
        up.last_rx = up.last_req = self.vehicle.t
        if len(up.got) < up.count:
            exp.append(self.req(who, len(up.got), mt))
        else:
            self.judge(who, mt, {mt: tuple(up.got)}, (up.count, item))

    def send_item(self, who: str, seq: int) -> None:
        mt, items = self.plan.get(who, (TYPE_MISSION, (wp(),)))
        item = items[min(seq, len(items) - 1)] if items else wp()
        note(f"{who} sends item {seq} of type {mt}")
        exp: list[tuple[Any, ...]] = []
        texts: list[tuple[str, str]] = []
        self.on_item(who, mt, seq, item, exp, texts)
        self.vehicle.rx(item_msg(seq, item, mt), self.peers[who])
        self.after_rx()
        self.check_out(exp, texts)

    # ---- rules ------------------------------------------------------------------------------------
    @initialize(b=st.sampled_from(sorted(B_VARIANTS)), stored=mission_plans)
    def start(self, b: str, stored: tuple[MissionItem, ...]) -> None:
        self.peers["B"] = B_VARIANTS[b]
        keep = stored if not problems(model_mission({TYPE_MISSION: stored, TYPE_FENCE: ()})) else ()
        keep = () if any(format_code(i, TYPE_MISSION) != ACCEPTED or i.z == EXPLODES for i in keep) else keep
        if keep:  # a mission persisted by an earlier run: checked at boot, in force
            StateStore(self.dir).save_plan("mission", keep)
            self.stored[TYPE_MISSION] = keep
        note(f"peer B: {b}; stored at boot: {len(keep)} items")
        self.boot()

    @rule(who=PEERS, plan=st.one_of(plans, st.just((TYPE_RALLY, (wp(),)))))
    def count(self, who: str, plan: tuple[int, tuple[MissionItem, ...]]) -> None:
        """MISSION_COUNT: start (or restart) an upload of ``plan``."""
        mt, items = plan
        n = len(items)
        exp: list[tuple[Any, ...]] = []
        texts: list[tuple[str, str]] = []
        j, up, t = self.judging, self.up, self.vehicle.t
        if j is not None or (up is not None and up.owner != who):
            self.busy(who, mt, exp, texts)
        elif mt == TYPE_RALLY:
            exp.append(self.ack(who, C.MAV_MISSION_UNSUPPORTED, mt))
        elif up is not None and up.mt == mt and up.count == n and not up.got:
            up.last_req = t  # a repeated COUNT (our request was lost): asked again, no progress
            exp.append(self.req(who, 0, mt))
        else:
            self.up = None
            if n == 0:
                self.judge(who, mt, {mt: ()}, None)
            else:
                self.up = Upload(who, mt, n, [], t, t)
                exp.append(self.req(who, 0, mt))
        if mt != TYPE_RALLY:
            self.plan[who] = (mt, items)
        note(f"{who} MISSION_COUNT {n} of type {mt}")
        self.vehicle.rx(C.MAVLink_mission_count_message(1, 1, n, mt), self.peers[who])
        self.after_rx()
        self.check_out(exp, texts)

    @rule(who=PEERS)
    def next_item(self, who: str) -> None:
        """The item the vehicle asks for (or item 0 from a peer that owns no upload)."""
        up = self.up
        self.send_item(who, len(up.got) if up is not None and up.owner == who else 0)

    @rule(who=PEERS, lost=st.integers(-1, 5), dup=st.booleans())
    def rest(self, who: str, lost: int, dup: bool) -> None:
        """The rest of the plan in order, one item lost (never sent; -1: none), each maybe sent twice."""
        up = self.up
        start = len(up.got) if up is not None and up.owner == who else 0
        _, items = self.plan.get(who, (TYPE_MISSION, ()))
        for seq in range(start, len(items)):
            if seq == start + lost:
                continue
            self.send_item(who, seq)
            if dup:
                self.send_item(who, seq)

    @rule(who=PEERS, data=st.data())
    def any_item(self, who: str, data: st.DataObject) -> None:
        """Any item of the plan, or one beyond its count: out of order, duplicated, stray."""
        _, items = self.plan.get(who, (TYPE_MISSION, ()))
        self.send_item(who, data.draw(st.integers(0, len(items)), label="seq"))

    @rule(who=PEERS)
    def final_again(self, who: str) -> None:
        """The last item again (the GCS did not hear the final ACK)."""
        _, items = self.plan.get(who, (TYPE_MISSION, ()))
        if items:
            self.send_item(who, len(items) - 1)

    @rule(who=PEERS, plan=plans, lost=st.sampled_from([-1, -1, -1, 0, 1, 2]), dup=st.booleans(), then=THEN)
    def upload(
        self, who: str, plan: tuple[int, tuple[MissionItem, ...]], lost: int, dup: bool, then: str
    ) -> None:
        """A whole upload: MISSION_COUNT, then every item in order (maybe one lost, maybe each twice), then
        maybe the judgement (``then``: the loop's verdict)."""
        self.count(who, plan)
        self.rest(who, lost, dup)
        if then and self.judging is not None:
            self.settle(then == "accept", release=True)

    @precondition(lambda self: self.judging is not None)
    @rule(accept=st.sampled_from([True, True, False]), release=st.booleans())
    def settle(self, accept: bool, release: bool) -> None:
        """The I/O thread and the loop run: the check's result (a slow one maybe released first), the
        loop's verdict ``accept``, its delivery."""
        if release and self.slow_future is not None:
            self.release()
        self.advance(0.0)
        if self.judging is not None and self.judging.phase in ("core", "taken"):
            self.loop_answers(accept)
        self.advance(0.0)

    @rule(who=PEERS, mt=st.sampled_from([TYPE_MISSION, TYPE_FENCE, TYPE_ALL]), then=THEN)
    def clear(self, who: str, mt: int, then: str = "") -> None:
        """MISSION_CLEAR_ALL of one type or of both (one candidate for both: goals and fence are a unit)."""
        types = (TYPE_MISSION, TYPE_FENCE) if mt == TYPE_ALL else (mt,)
        up = self.up
        something = any(self.stored[t] for t in types)
        exp: list[tuple[Any, ...]] = []
        texts: list[tuple[str, str]] = []
        if self.judging is not None or (up is not None and (up.owner != who or up.mt not in types)):
            self.busy(who, mt, exp, texts)  # one transfer at a time; the uploader may clear only its own type
        else:
            if up is not None:
                event("mission: the uploader clears what it uploads")
                self.up = None  # its own upload ends
            if not something:
                exp.append(self.ack(who, ACCEPTED, mt))  # nothing to clear
            else:
                self.judge(who, mt, {t: () for t in types}, None)
        note(f"{who} MISSION_CLEAR_ALL of type {mt}")
        self.vehicle.rx(C.MAVLink_mission_clear_all_message(1, 1, mt), self.peers[who])
        self.after_rx()
        self.check_out(exp, texts)
        if then and self.judging is not None:
            self.settle(then == "accept", release=True)

    @rule(who=PEERS, mt=st.sampled_from([TYPE_MISSION, TYPE_FENCE]), legacy=st.booleans())
    def download(self, who: str, mt: int, legacy: bool) -> None:
        """MISSION_REQUEST_LIST, then every item and one beyond: always the stored plan."""
        s, d = self.peers[who], self.dest(who)
        items = self.stored[mt]
        if items:
            event("mission: download of a stored plan")
        self.vehicle.rx(C.MAVLink_mission_request_list_message(1, 1, mt), s)
        self.check_out([("COUNT", d, len(items), mt)], [])
        request = C.MAVLink_mission_request_message if legacy else C.MAVLink_mission_request_int_message
        for seq in range(len(items) + 1):
            self.vehicle.rx(request(1, 1, seq, mt), s)
            if seq < len(items):
                if legacy:
                    self.check_out([("LEGACY_ITEM", d, seq, legacy_key(items[seq]), mt)], [])
                else:
                    self.check_out([("ITEM", d, seq, items[seq].key(), mt)], [])
            else:
                self.check_out([("ACK", d, C.MAV_MISSION_INVALID_SEQUENCE, mt)], [])

    @rule(dt=st.sampled_from([0.0, 0.1, 0.25, 0.5, 1.0, 2.0, 3.0, 5.0, 6.0]))
    def advance(self, dt: float) -> None:
        """The clock runs on and the link's timers run (one poll)."""
        exp, texts = self.model_poll(self.vehicle.t + dt)
        self.vehicle.poll(dt)
        if self.slow_future is not None and self.judging is None:  # timed out: let the worker go
            self.release_slow()
        self.check_out(exp, texts)

    @precondition(lambda self: self.slow_future is not None)
    @rule()
    def release(self) -> None:
        """The slow check finishes (before its deadline, unless a poll saw it pass)."""
        if self.slow_future is not None:
            event("mission: slow check released in time")
            self.release_slow()
            assert self.judging is not None and self.judging.phase == "slow"
            self.judging.phase = "check"

    @precondition(lambda self: self.judging is not None and self.judging.phase == "core")
    @rule()
    def loop_takes(self) -> None:
        """The loop takes the requests (the core's verdict comes later, however late)."""
        reqs = self.vehicle.link.take_requests()
        j = self.judging
        if j is None or j.phase != "core":
            assert reqs == []  # none but the mission service's
            return
        (r,) = reqs
        assert isinstance(r.command, core.ReplaceMission)
        assert r.command.mission == model_mission({**self.stored, **j.plans})
        assert r.command.goals_changed == (TYPE_MISSION in j.plans)
        self.requests.append(r.id)
        j.phase = "taken"

    @precondition(lambda self: self.judging is not None and self.judging.phase in ("core", "taken"))
    @rule(accept=st.booleans())
    def loop_answers(self, accept: bool) -> None:
        """The loop takes what is there and answers everything it took (delivered at the next poll)."""
        self.loop_takes()
        for rid in self.requests:
            verdict = core.accepted("mission replaced") if accept else core.denied("not now")
            self.vehicle.link.answer(rid, verdict)
        if self.requests:
            assert self.judging is not None
            self.judging.phase, self.judging.accept = "answered", accept
        self.requests = []

    @rule()
    def reboot(self) -> None:
        """The vehicle restarts: what was accepted (and persisted) is in force, every transfer is gone."""
        if self.stored[TYPE_MISSION] or self.stored[TYPE_FENCE]:
            event("mission: reboot with stored plans")
        self.release_slow()
        j = self.vehicle.link.missions._judge
        if j is not None and j.with_core:  # saved before the core judges: a restart now boots with it
            event("mission: reboot while the core judges")
            self.stored.update(j.candidate.plans)
        self.vehicle.close()
        self.up = self.judging = self.last_done = None
        self.boot()
        self.check_out([], [])

    # ---- invariants -------------------------------------------------------------------------------
    @invariant()
    def holds_the_last_accepted(self) -> None:
        if self.v is None:
            return
        link = self.v.link
        srv = link.missions.server
        j = link.missions._judge
        with_core = j.candidate.plans if j is not None and j.with_core else {}
        for mt in (TYPE_MISSION, TYPE_FENCE):
            want = [i.key() for i in self.stored[mt]]
            assert [i.key() for i in srv.items(mt)] == want
            # as persisted; a candidate with the core was saved before it judges (issue 21: durable ACK)
            saved = [i.key() for i in with_core[mt]] if mt in with_core else want
            assert [i.key() for i in load_plan(StateStore(self.dir), mt) or ()] == saved
        assert link.mission() == model_mission(self.stored)
        owner = self.judging.owner if self.judging else self.up.owner if self.up else None
        assert srv.transfer_sender == (None if owner is None else self.peers[owner])
        assert srv.judging == (self.judging is not None)
        assert self.v.out == [] or all(m.get_type() not in WATCHED for m, _ in self.v.out)


MissionMachine.TestCase.settings = SETTINGS
test_mission_and_fence_services = MissionMachine.TestCase


# ---- the parameter model ---------------------------------------------------------------------------
BUS = BusLimits.from_ranges(command_ranges())
SPECS = param_table(CoreConfig(), BUS)
SPEC = {s.name: s for s in SPECS}
INDEX = {s.name: i for i, s in enumerate(SPECS)}
#: The parameters the machine sets, with what the model knows of each beyond [min, max]: "open" (min itself
#: is refused by the configuration's own rule), "count" (a whole number). Their bounds span no other value.
SETTABLE = {"PD_KP1": "", "PD_KD5": "", "PD_DTAU_S": "", "GDE_ILOS_GAIN": "", "PLN_W_PSI": "",
            "LIM_FIN_RATE_DPS": "", "LIM_RUDDER_DEG": "", "MIS_MAX_TRIES": "count",
            "FS_ABORT_STN_DEG": ""}  # fmt: skip
#: PARAM_SET's param_type: the vehicle's own REAL32 mostly, sometimes another (the service ignores it).
REAL32, INT32, UINT8 = C.MAV_PARAM_TYPE_REAL32, C.MAV_PARAM_TYPE_INT32, C.MAV_PARAM_TYPE_UINT8
PARAM_TYPES = [REAL32, REAL32, INT32, UINT8]
UNKNOWN = ["NOPE", "pd_kp1", "PD_KP1 ", "PD_KP99", "ABCDEFGHIJKLMNOP", ""]


def f32(x: float) -> float:
    try:
        return float(struct.unpack("<f", struct.pack("<f", x))[0])
    except OverflowError:
        return math.copysign(math.inf, x)


def f32_step(x: float, up: bool) -> float:
    """The float32 neighbour of the float32 ``x``."""
    if x == 0.0:
        return f32(1e-45) if up else -f32(1e-45)
    bits = struct.unpack("<I", struct.pack("<f", x))[0]
    bits += 1 if (x > 0.0) == up else -1
    return float(struct.unpack("<f", struct.pack("<I", bits))[0])


def values_for(name: str) -> st.SearchStrategy[float]:
    s = SPEC.get(name)
    if s is None:
        return st.sampled_from([0.0, 1.0])
    lo, hi = f32(s.min), f32(s.max)
    edges = [lo, hi, f32(s.default), lo - 1.0, hi + 1.0, 0.0, -0.3, 2.5, math.nan, math.inf, -math.inf]
    edges += [f32_step(b, up) for b in (lo, hi) for up in (False, True)]  # just inside and outside
    return st.one_of(
        st.sampled_from(edges),
        st.floats(lo, hi, width=32),
        st.floats(lo, hi, width=32),
        st.integers(int(lo) - 2, int(hi) + 2).map(float),
        st.floats(width=32),
    )


def param_msg(m: mavlink.MAVLink_message) -> tuple[str, float, int, int, int]:
    return (m.param_id, m.param_value, m.param_type, m.param_count, m.param_index)


class ParamMachine(_VehicleMachine):
    def __init__(self) -> None:
        super().__init__("stateful-param-")
        self.values = {s.name: float(s.default) for s in SPECS}
        self.pending: list[tuple[str, float, float]] = []  # (name, value as received, deadline), in order
        self.file: dict[str, float] = {}  # params.json: an edit is saved before the core judges it
        self.gcs = Sender(255, 190, (1, ("10.0.0.1", 14550)))
        self.ap: Autopilot | None = None

    def boot(self) -> None:
        t = self.v.t if self.v is not None else T0
        if self.v is not None:
            self.v.close()
        self.ap = Autopilot(CoreConfig(), bus_limits=BUS)
        self.v = Vehicle(self.dir, t, validator=lambda _m: MissionCheck(), params=SPECS)
        self.pending = []

    def pv(self, name: str) -> tuple[str, float, int, int, int]:
        return (name, f32(self.values[name]), C.MAV_PARAM_TYPE_REAL32, len(SPECS), INDEX[name])

    def check_out(
        self, expected: list[tuple[tuple[str, float, int, int, int], Any]], texts: list[str]
    ) -> None:
        """``expected``: (PARAM_VALUE, link: None to every peer) in order; every STATUSTEXT is an answer, to
        the asker's link only (issue 21: a refusal or a list costs no other station anything)."""
        out = self.vehicle.take()
        got = [(param_msg(m), link) for m, link in out if m.get_type() == "PARAM_VALUE"]
        assert [m.get_type() for m, _ in out if m.get_type() not in ("PARAM_VALUE", "STATUSTEXT")] == []
        assert got == expected
        assert all(link == self.gcs.link for link, _ in texts_of(out))
        sent = [text for _, text in texts_of(out)]
        assert len(sent) == len(texts), (sent, texts)
        for text, words in zip(sent, texts, strict=True):
            assert words in text, (text, words)

    def judged(self, name: str, value: float) -> tuple[bool, float]:
        """(accepted, value in force after) of the core's judgement of ``name`` = ``value`` (float32)."""
        s, now, kind = SPEC[name], self.values[name], SETTABLE[name]
        for exact in (now, s.min, s.max):  # the float32 of the value in force or a bound means it exactly
            if f32(value) == f32(exact):
                value = exact
                break
        ok = s.min <= value <= s.max and not (kind == "open" and value == s.min)
        ok = ok and not (kind == "count" and value != math.floor(value))
        return ok, (value if ok else now)

    @initialize()
    def start(self) -> None:
        self.boot()

    @rule(
        name=st.one_of(st.sampled_from(sorted(SETTABLE)), st.sampled_from(UNKNOWN)),
        ptype=st.sampled_from(PARAM_TYPES),
        data=st.data(),
    )
    def param_set(self, name: str, ptype: int, data: st.DataObject) -> None:
        value = f32(data.draw(values_for(name), label="value"))
        note(f"PARAM_SET {name!r} = {value!r} (type {ptype})")
        exp: list[tuple[tuple[str, float, int, int, int], Any]] = []
        texts: list[str] = []
        if name not in SPEC:
            texts.append(f"unknown parameter {name}")
        elif not math.isfinite(value):
            event("param: not a number")
            texts.append("the value is not a number")
            exp.append((self.pv(name), self.gcs.link))
        elif any(n == name and f32(v) == value for n, v, _ in self.pending):
            event("param: resend while pending")
        else:
            self.pending.append((name, value, self.vehicle.t + 1.0))
            self.save(name, value)
        self.vehicle.rx(C.MAVLink_param_set_message(1, 1, name.encode(), value, ptype), self.gcs)
        self.check_out(exp, texts)

    @rule(name=st.sampled_from(sorted(SETTABLE)), data=st.data())
    def set_and_serve(self, name: str, data: st.DataObject) -> None:
        """A PARAM_SET the loop judges at once."""
        self.param_set(name, C.MAV_PARAM_TYPE_REAL32, data)
        self.serve()

    @rule(name=st.sampled_from(sorted(SETTABLE)), value=st.sampled_from([1.0, 5.0]))
    def param_set_elsewhere(self, name: str, value: float) -> None:
        """A PARAM_SET for another system: ignored."""
        self.vehicle.rx(C.MAVLink_param_set_message(7, 1, name.encode(), value, 9), self.gcs)
        self.check_out([], [])

    @rule()
    def serve(self) -> None:
        """One loop tick: the core judges every request; the link answers at its next poll."""
        assert self.ap is not None
        exp: list[tuple[tuple[str, float, int, int, int], Any]] = []
        texts: list[str] = []
        for name, value, _ in self.pending:
            ok, self.values[name] = self.judged(name, value)
            event(f"param: set {'accepted' if ok else 'refused by the core'}")
            if not ok:
                texts.append(name)  # the core's reason names the parameter
            exp.append((self.pv(name), None if ok else self.gcs.link))  # a change: to every peer
        answered = {n for n, _, _ in self.pending}
        self.pending = []
        self.settle(answered)
        bridge.before_tick(self.ap, self.vehicle.link)
        self.vehicle.poll()
        self.check_out(exp, texts)

    @rule(dt=st.sampled_from([0.3, 1.0, 2.0]))
    def stall(self, dt: float) -> None:
        """The loop does not run: a request not taken in time is refused with the value in force."""
        now = self.vehicle.t + dt
        exp = [(self.pv(n), self.gcs.link) for n, _, deadline in self.pending if now >= deadline]
        if exp:
            event("param: loop not running")
        answered = {n for n, _, deadline in self.pending if now >= deadline}
        self.pending = [p for p in self.pending if now < p[2]]
        self.settle(answered)
        self.vehicle.poll(dt)
        self.check_out(exp, ["the control loop is not running"] * len(exp))

    @rule(name=st.one_of(st.sampled_from(sorted(SPEC)), st.sampled_from(UNKNOWN)))
    def read_by_name(self, name: str) -> None:
        self.vehicle.rx(C.MAVLink_param_request_read_message(1, 1, name.encode(), -1), self.gcs)
        self.check_out([(self.pv(name), self.gcs.link)] if name in SPEC else [], [])

    @rule(index=st.integers(0, len(SPECS) + 2), name=st.sampled_from(["", "PD_KP1", "NOPE"]))
    def read_by_index(self, index: int, name: str) -> None:
        """By index (the name is ignored when the index is given); beyond the table: no answer."""
        self.vehicle.rx(C.MAVLink_param_request_read_message(1, 1, name.encode(), index), self.gcs)
        self.check_out([(self.pv(SPECS[index].name), self.gcs.link)] if index < len(SPECS) else [], [])

    @rule()
    def read_all(self) -> None:
        self.vehicle.rx(C.MAVLink_param_request_list_message(1, 1), self.gcs)
        self.check_out([(self.pv(s.name), self.gcs.link) for s in SPECS], [])

    @rule()
    def reboot(self) -> None:
        """A restart: the persisted edits go to a fresh core, then one tick. An edit saved but not yet
        judged (pending at the restart) is judged at boot like the others; a refused one stays in the file."""
        self.values = {s.name: float(s.default) for s in SPECS}
        for name, value in self.file.items():
            self.values[name] = self.judged(name, value)[1]
        self.boot()
        assert self.ap is not None
        bridge.before_tick(self.ap, self.vehicle.link)
        self.vehicle.poll()
        self.check_out([], [])

    def edits(self) -> dict[str, float]:
        return {n: v for n, v in self.values.items() if f32(v) != f32(SPEC[n].default)}

    @invariant()
    def values_are_the_model(self) -> None:
        if self.v is None or self.ap is None:
            return
        assert self.v.link.params.values() == self.values
        assert {n: param_value(self.ap.config, n) for n in SPEC} == self.values  # the core agrees
        assert StateStore(self.dir).load_params() == self.file

    def save(self, name: str, value: float) -> None:
        """The link saves ``name`` = ``value`` as an edit (none when it is the default, in float32)."""
        if f32(value) == f32(SPEC[name].default):
            self.file.pop(name, None)
        else:
            self.file[name] = value

    def settle(self, names: set[str]) -> None:
        """The last answer for a name: the file holds the value in force (saved before, issue 21)."""
        for name in names - {n for n, _, _ in self.pending}:
            self.save(name, self.values[name])


ParamMachine.TestCase.settings = SETTINGS
test_parameter_service = ParamMachine.TestCase


# ---- what the model found ----------------------------------------------------------------------------
def test_a_clear_by_another_peer_during_an_upload_is_denied_and_the_upload_goes_on(tmp_path: Path) -> None:
    b = B_VARIANTS["same ids, another link"]
    StateStore(tmp_path).save_plan("mission", (wp(1, 1, 1.0),))
    v = Vehicle(tmp_path, T0, validator=lambda _m: MissionCheck())
    circles = (fence(5, 5, 1.0), fence(6, 6, 1.0))
    v.rx(C.MAVLink_mission_count_message(1, 1, 2, TYPE_FENCE), A)  # A uploads a fence
    v.rx(item_msg(0, circles[0], TYPE_FENCE), A)
    v.take()
    v.rx(C.MAVLink_mission_clear_all_message(1, 1, TYPE_MISSION), b)  # B clears the goals meanwhile
    acks = [(m.type, link) for m, link in v.take() if m.get_type() == "MISSION_ACK"]
    v.rx(item_msg(1, circles[1], TYPE_FENCE), A)  # A's upload carries on...
    j = v.link.missions._judge
    if j is not None:
        concurrent.futures.wait([j.future], timeout=5.0)
    v.poll()
    for r in v.link.take_requests():
        v.link.answer(r.id, core.accepted("ok"))
    v.poll()
    finals = [(m.type, link) for m, link in v.take() if m.get_type() == "MISSION_ACK"]
    v.close()
    assert acks == [(DENIED, b.link)]  # ... B was refused
    assert finals == [(ACCEPTED, A.link)]  # ... and A's fence was accepted, the goals kept
    assert [i.key() for i in v.link.missions.server.items(TYPE_FENCE)] == [c.key() for c in circles]
    assert len(v.link.mission().goals) == 1
