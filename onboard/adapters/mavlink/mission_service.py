"""The mission service: the pure protocol (:class:`MissionServer`), the validator, the core, the store.

A complete transfer (the last item of an upload, MISSION_COUNT 0, MISSION_CLEAR_ALL) goes through:

1. the candidate :class:`~onboard.core.mission.model.Mission`: the new items plus the stored plan of the
   OTHER type (goals and fence are one unit; a clear of MAV_MISSION_TYPE_ALL clears both, and a whole-plan
   upload of type ALL (:mod:`~onboard.adapters.mavlink.mission_protocol`) replaces both: one candidate, one
   verdict, so goals refused leave the fence that came with them out of force too);
2. the validator given to the link (``Callable[[Mission], MissionCheck]``, normally
   :func:`onboard.core.mission.validate.check_mission` bound to the configuration) in a worker thread,
   with the deadline ``validate_timeout_s``; a problem ends the transfer with the MAV_MISSION code of its
   field (:data:`FIELD_CODES`) and a STATUSTEXT naming the item and the reason;
3. the new plans are saved through the store (an acknowledgement means durable): a plan that cannot be
   saved is refused (MAV_MISSION_ERROR, a STATUSTEXT with the reason, e.g. "No space left on device") and
   never reaches the core;
4. ``ReplaceMission(mission, goals_changed)`` as a request to the loop: the core's verdict (the one judge);
5. accepted: the stored plans replaced and MISSION_ACK ACCEPTED sent; refused: the files are written back
   to the plans in force (MAV_MISSION_ERROR and a STATUSTEXT with the core's reason). Saving before the core
   judges keeps "nothing changes in force" without undoing anything in the core; a kill -9 between the save
   and the verdict may leave a checked but unacknowledged plan to be loaded at the next boot (it passes the
   same check there).

Mission seq vs goal index: the core counts goals 0..n-1. When the stored mission starts with an
ArduPilot-style home item (seq 0, see :mod:`onboard.adapters.mavlink.mission_protocol`), MAVLink seq = goal
index + 1 everywhere; :meth:`MissionService.shape` gives (home offset, number of goals).

Progress: the current goal of the snapshot is handed to the store (``Store.keep_progress``, the one rule of
when it is written: when it changes, retried with back-off after a failure) tied to the stored MISSION plan
(:func:`~onboard.adapters.mavlink.storage.mission_key`); :meth:`MissionService.progress` returns the
persisted one at boot. A save that fails is said once (STATUSTEXT, until a save works again).
"""

from __future__ import annotations

import concurrent.futures
import logging
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Protocol

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.commands import RequestQueue
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.mission_protocol import (
    TYPE_ALL,
    TYPE_FENCE,
    TYPE_MISSION,
    Candidate,
    MissionItem,
    MissionLimits,
    MissionServer,
    home_offset,
    items_from_mission,
)
from onboard.adapters.mavlink.peers import Sender
from onboard.adapters.mavlink.storage import PLAN_KINDS, Store, load_plan, mission_key
from onboard.adapters.mavlink.transport import Transport
from onboard.core import commands as core
from onboard.core.commands import Severity, Verdict
from onboard.core.mission.model import Mission

log = logging.getLogger(__name__)

#: The flat-earth projection of the global frames holds away from the poles only.
MAX_ORIGIN_LAT_DEG = 85.0


class ProblemLike(Protocol):
    """One problem of :class:`onboard.core.mission.validate.MissionCheck`."""

    @property
    def item(self) -> str: ...  # "goal" | "obstacle" | "mission"
    @property
    def index(self) -> int: ...
    @property
    def field(self) -> str: ...  # x, y, depth, yaw, radius, count, plan, format
    @property
    def reason(self) -> str: ...


class CheckLike(Protocol):
    @property
    def problems(self) -> Sequence[ProblemLike]: ...


Validator = Callable[[Mission], CheckLike]

#: The validator's field of the first problem -> the MAV_MISSION code of the final MISSION_ACK.
FIELD_CODES: dict[str, int] = {
    "x": mavlink.MAV_MISSION_INVALID_PARAM5_X,
    "y": mavlink.MAV_MISSION_INVALID_PARAM6_Y,
    "depth": mavlink.MAV_MISSION_INVALID_PARAM7,
    "yaw": mavlink.MAV_MISSION_INVALID_PARAM4,
    "radius": mavlink.MAV_MISSION_INVALID_PARAM1,
    "arrival_radius": mavlink.MAV_MISSION_INVALID_PARAM2,
    "count": mavlink.MAV_MISSION_NO_SPACE,
}
_TYPE_NAMES = {TYPE_MISSION: "mission", TYPE_FENCE: "fence", TYPE_ALL: "mission and fence"}


def problems_of(check: CheckLike, mission: Mission) -> list[ProblemLike]:
    """The problems that refuse ``mission`` (a mission without goals is "no mission": valid)."""
    return list(check.problems)


def describe(p: ProblemLike, offset: int = 0) -> str:
    """E.g. "goal 2 refused: inside obstacle 1 (inflated)" (with the seq when a home item shifts it)."""
    if p.item == "mission" or p.index < 0:
        return f"mission refused: {p.reason}"
    seq = f" (item {p.index + offset})" if p.item == "goal" and offset else ""
    return f"{p.item} {p.index}{seq} refused: {p.reason}"


@dataclass
class _Judge:
    candidate: Candidate
    mission: Mission
    future: concurrent.futures.Future[CheckLike]
    deadline_s: float
    with_core: bool = False  # the validator passed it; the core has it


class MissionService:
    """The mission micro-service on the I/O thread; :meth:`mission` and :meth:`shape` from any thread."""

    def __init__(
        self,
        config: MavlinkConfig,
        transport: Transport,
        requests: RequestQueue,
        store: Store,
        validator: Validator,
        initial_mission: Mission | None = None,
    ) -> None:
        self.config = config
        self.transport = transport
        self.requests = requests
        self.store = store
        self.validator = validator
        lat, lon, alt = store.load_origin() or (
            config.origin_lat_deg,
            config.origin_lon_deg,
            config.origin_alt_m,
        )
        self.limits = MissionLimits(  # the one owner of the geodetic origin (set_origin); telemetry asks it
            origin_lat_deg=lat,
            origin_lon_deg=lon,
            origin_alt_m=alt,
            item_timeout_s=config.item_timeout_s,
            upload_timeout_s=config.upload_timeout_s,
        )
        stored: dict[int, tuple[MissionItem, ...]] = {}
        for mt in (TYPE_MISSION, TYPE_FENCE):
            items = load_plan(store, mt)
            if items is not None:
                stored[mt] = items
        ids = (config.system_id, config.component_id)
        self.server = MissionServer(self.limits, ids, stored)
        if stored and initial_mission is None:
            # the persisted mission passes the same check as an upload, or it is set aside (goals and fence
            # are one unit: both) and the vehicle boots with no mission
            mission = self.server.mission()
            try:
                problems = problems_of(validator(mission), mission)
                why = describe(problems[0], self.server.home_offset()) if problems else ""
            except Exception as exc:  # a bug in the check must not brick the boot: boot safe, say why
                log.exception("the persisted mission could not be checked")
                why = f"it could not be checked: {type(exc).__name__}: {exc}"
            if why:
                for mt in sorted(stored):
                    store.quarantine_plan(PLAN_KINDS[mt], why)
                self.server = MissionServer(self.limits, ids, {})
        if initial_mission is not None:  # --mission: checked by the runtime; wins and is persisted
            goals, fences = items_from_mission(initial_mission)
            for mt, items in ((TYPE_MISSION, goals), (TYPE_FENCE, fences)):
                try:
                    store.save_plan(PLAN_KINDS[mt], items)
                except OSError as exc:  # the operator's command line: flown this run, said why not kept
                    log.error(
                        "--mission: the %s plan is not saved (%s): lost at a restart", _TYPE_NAMES[mt], exc
                    )
                self.server.replace(mt, items)
        self.server.take_changed()
        self._lock = threading.Lock()
        self._mission = self.server.mission()
        self._shape = (self.server.home_offset(), self.server.goal_count())
        self._key = mission_key(self.server.items(TYPE_MISSION))
        self._progress = store.load_progress(self._key)
        self._executor = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="mission-check")
        self._judge: _Judge | None = None

    # ---- any thread ------------------------------------------------------------------------------
    def mission(self) -> Mission:
        """The accepted mission (goals and fence obstacles)."""
        with self._lock:
            return self._mission

    def shape(self) -> tuple[int, int]:
        """(home offset, number of goals) of the accepted mission: MAVLink seq = goal index + offset."""
        with self._lock:
            return self._shape

    def progress(self) -> int | None:
        """The goal index persisted for the stored mission at boot (None: none, or another mission's)."""
        return self._progress

    def close(self) -> None:
        self._executor.shutdown(wait=False, cancel_futures=True)

    # ---- I/O thread ------------------------------------------------------------------------------
    def set_origin(self, lat_deg: float, lon_deg: float, alt_m: float) -> str:
        """SET_GPS_GLOBAL_ORIGIN: move the geodetic origin of the local frame (persisted); "" when done,
        else why not. Refused while a mission or a fence is stored (its global items would move: the
        goals are the items converted about the origin) or a transfer is going on."""
        if not (-MAX_ORIGIN_LAT_DEG <= lat_deg <= MAX_ORIGIN_LAT_DEG and -180.0 <= lon_deg <= 180.0):
            return f"origin out of range: lat {lat_deg:g} (|lat| <= {MAX_ORIGIN_LAT_DEG:g}), lon {lon_deg:g}"
        if not math.isfinite(alt_m):
            return f"origin out of range: alt {alt_m:g} m"
        if self.server.judging or self.server.transfer_sender is not None:
            return "origin not changed: a mission transfer is going on"
        if self.server.items(TYPE_MISSION) or self.server.items(TYPE_FENCE):
            return "origin not changed: a mission or fence is stored (clear it first; its items would move)"
        try:  # saved first: an origin in force that a reboot would forget is not set
            self.store.save_origin(lat_deg, lon_deg, alt_m)
        except OSError as exc:
            return f"origin not changed: it cannot be saved ({exc.strerror or exc})"
        self.limits = replace(self.limits, origin_lat_deg=lat_deg, origin_lon_deg=lon_deg, origin_alt_m=alt_m)
        self.server.limits = self.limits
        return ""

    def handle(self, msg: mavlink.MAVLink_message, sender: Sender, now_s: float) -> None:
        for m in self.server.handle(msg, sender, now_s):
            self.transport.reply(m, sender)  # every answer is to the sender (a request, an ACK, DENIED)
        for refused, why in self.server.take_refusals():
            log.warning("%s (%s)", why, refused)
            self.transport.statustext(Severity.WARNING, why, to=refused)
        candidate = self.server.take_candidate()
        if candidate is not None:
            self._check(candidate, now_s)

    def _check(self, candidate: Candidate, now_s: float) -> None:
        mission = self.server.candidate_mission(candidate)
        try:
            future = self._executor.submit(self.validator, mission)
        except RuntimeError as exc:  # shut down
            self._finish(mavlink.MAV_MISSION_ERROR, f"upload refused: {exc}")
            return
        future.add_done_callback(lambda _f: self.transport.wake())
        self._judge = _Judge(candidate, mission, future, now_s + self.config.validate_timeout_s)

    def poll(self, now_s: float, snapshot: VehicleSnapshot | None = None) -> None:
        peer = self.server.transfer_sender
        for m in self.server.poll(now_s):
            self._to_peer(m, peer)
        j = self._judge
        if j is not None and not j.with_core:
            if j.future.done():
                self._checked(j)
            elif now_s >= j.deadline_s:
                j.future.cancel()
                limit = self.config.validate_timeout_s
                self._finish(
                    mavlink.MAV_MISSION_ERROR,
                    f"upload refused: the mission check took longer than {limit:g} s",
                )
        if snapshot is not None:
            self._save_progress(snapshot, now_s)

    def next_deadline(self) -> float | None:
        ds = [d for d in (self.server.next_deadline(),) if d is not None]
        j = self._judge
        if j is not None and not j.with_core:
            ds.append(j.deadline_s)
        return min(ds) if ds else None

    def _checked(self, j: _Judge) -> None:
        try:
            check = j.future.result()
        except Exception as exc:
            log.error("mission check failed", exc_info=exc)
            self._finish(mavlink.MAV_MISSION_ERROR, f"upload refused: the mission check failed: {exc}")
            return
        problems = problems_of(check, j.mission)
        if problems:
            first = problems[0]
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            plans = j.candidate.plans
            offset = home_offset(plans[TYPE_MISSION]) if TYPE_MISSION in plans else self.server.home_offset()
            code = FIELD_CODES.get(first.field, mavlink.MAV_MISSION_ERROR)
            self._finish(code, describe(first, offset) + more)
            return
        c = j.candidate
        why = self._save_plans(c.plans)
        if why:
            self._finish(
                mavlink.MAV_MISSION_ERROR, f"{_TYPE_NAMES.get(c.mission_type, 'plan')} refused: {why}"
            )
            return
        j.with_core = True
        command = core.ReplaceMission(
            j.mission, goals_changed=TYPE_MISSION in c.plans, source=f"MAVLink {c.sender[0]}/{c.sender[1]}"
        )
        self.requests.submit(command, self._answered)

    def _answered(self, verdict: Verdict) -> None:
        j = self._judge
        if j is None:
            return
        c = j.candidate
        if not verdict.accepted:
            self._restore_plans(c.plans)
            self._finish(mavlink.MAV_MISSION_ERROR, f"upload refused: {verdict.reason}")
            return
        self._judge = None
        peer = self.server.transfer_sender
        acks = self.server.finish(mavlink.MAV_MISSION_ACCEPTED)
        with self._lock:  # the accepted mission is in force before the ground station hears ACCEPTED
            self._mission = self.server.mission()
            self._shape = (self.server.home_offset(), self.server.goal_count())
        self._key = mission_key(self.server.items(TYPE_MISSION))
        for m in acks:
            self._to_peer(m, peer)
        what = _TYPE_NAMES.get(c.mission_type, "plan")
        n_goals, n_obstacles = len(j.mission.goals), len(j.mission.obstacles)
        text = f"{what} accepted: {n_goals} goals, {n_obstacles} obstacles ({c.sender[0]}/{c.sender[1]})"
        log.info(text)
        self.transport.statustext(Severity.INFO, text)  # every station: another one's plan changed too

    def _finish(self, result: int, text: str = "") -> None:
        self._judge = None
        peer = self.server.transfer_sender
        for m in self.server.finish(result):
            self._to_peer(m, peer)
        if text:
            log.warning("%s", text)
            self.transport.statustext(Severity.WARNING, text, to=peer)

    def _save_plans(self, plans: dict[int, tuple[MissionItem, ...]]) -> str:
        """Save the new plans before they are in force; "" when done, else why not (the files are then
        the plans in force again)."""
        done: list[int] = []
        for mt, items in sorted(plans.items()):
            try:
                self.store.save_plan(PLAN_KINDS[mt], items)
            except OSError as exc:
                log.error("the %s plan cannot be saved: %s", _TYPE_NAMES[mt], exc)
                self._restore_plans(dict.fromkeys(done, ()))
                return f"it cannot be saved ({exc})"
            done.append(mt)
        return ""

    def _restore_plans(self, plans: dict[int, tuple[MissionItem, ...]]) -> None:
        """Write back the plans in force of the types in ``plans`` (a refused candidate was saved)."""
        for mt in sorted(plans):
            try:
                self.store.save_plan(PLAN_KINDS[mt], self.server.items(mt))
            except OSError as exc:
                text = (
                    f"the refused {_TYPE_NAMES[mt]} stays saved and is loaded at the next boot: it cannot "
                    f"be written back ({exc})"
                )
                log.critical("%s", text)
                self.transport.statustext(Severity.CRITICAL, text)

    def _to_peer(self, msg: mavlink.MAVLink_message, peer: Sender | None) -> None:
        """A message of the transfer of ``peer``: to its link alone (to every peer when unknown)."""
        if peer is None:
            self.transport.send(msg)
        else:
            self.transport.reply(msg, peer)

    def _save_progress(self, s: VehicleSnapshot, now_s: float) -> None:
        with self._lock:
            n = self._shape[1]
            goals = self._mission.goals
        if n == 0 or s.current_goal < 0 or s.mission_goals != goals:
            return  # (a snapshot of the mission before the one just accepted: its progress is not ours)
        news = self.store.keep_progress(s.current_goal, self._key, now_s)
        if news is not None:
            saved, text = news
            self.transport.statustext(Severity.NOTICE if saved else Severity.ERROR, text)
