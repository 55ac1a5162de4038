"""The MAVLink mission micro-service, vehicle side, as a pure state machine (no sockets, no clock).

Spec: https://mavlink.io/en/services/mission.html. Upload is MISSION_COUNT -> MISSION_REQUEST_INT per item ->
MISSION_ITEM_INT -> MISSION_ACK; the vehicle never sends the deprecated MISSION_REQUEST, but understands a
legacy MISSION_ITEM and answers a legacy MISSION_REQUEST with a float MISSION_ITEM, local x/y in metres and
global in degrees, as the message's definition and ArduPilot do (mavlink/mavlink#1389 would answer
MISSION_ITEM_INT; MAVProxy reads a local MISSION_ITEM_INT's x/y as degrees * 1e7, so with
``set wp_use_mission_int 0`` it lists a local mission in metres only this way).

- A missing item is re-requested every ``item_timeout_s`` (0.25 s); after ``upload_timeout_s`` (5 s) without
  progress the upload is cancelled (MISSION_ACK OPERATION_CANCELLED) and the stored plan is unchanged.
- Out-of-sequence items are dropped and the expected item re-requested (not an error).
- One uploader at a time: another sender gets MAV_MISSION_DENIED; every reply is addressed to the sender.
- Each item is checked on its own for its format only (command, frame, numbers NaN or finite, lat/lon
  ranges); the first failing check ends the upload with its MAV_MISSION code and the stored plan is
  unchanged. The limits (operating area, depth, counts, feasibility) are the mission validator's
  (:func:`onboard.core.mission.validate.check_mission`), run by the mission service.
- A complete upload (the last item, a MISSION_COUNT 0 or a MISSION_CLEAR_ALL) is not stored at once: the
  transfer enters the *judging* state and :meth:`MissionServer.take_candidate` hands the new plan(s) to the
  caller, who checks them and asks the core; :meth:`MissionServer.finish` ends the transfer with the result
  (the final MISSION_ACK), and only MAV_MISSION_ACCEPTED replaces the stored plan. While judging, the
  re-sent final item is ignored (it is answered by the final ACK) and any other upload is DENIED.
- A re-sent last item after the final ACK is answered with the same ACK again, without side effects.
- Download is stateless: MISSION_REQUEST_LIST -> MISSION_COUNT; each MISSION_REQUEST_INT is answered with
  MISSION_ITEM_INT, each MISSION_REQUEST with MISSION_ITEM (or MISSION_ACK INVALID_SEQUENCE).

The whole plan in one transfer (MAV_MISSION_TYPE_ALL): goals and fence are one unit, judged together, but
MAVLink carries them in two transfers, each acknowledged on its own, and an ACCEPTED one is in force at its
ACK: a fence that goes first is in force (a running vehicle re-plans round it) before the goals that come
with it are judged. So an upload may carry both: MISSION_COUNT with ``mission_type`` MAV_MISSION_TYPE_ALL
(MAVLink names it for MISSION_CLEAR_ALL only; stock ground stations never upload it), then the items, each
MAV_CMD_NAV_WAYPOINT a goal and each MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION a fence circle (:func:`plan_of_item`;
our ground station sends the goals first, then the fence), every request, item and the one final MISSION_ACK
of type ALL. The goals and the fence it carries replace the stored MISSION and FENCE plans together, or,
refused, neither (an empty fence in it clears the stored fence; a count of 0 clears both). Each plan is
downloaded by its own type, as ever. A MISSION or FENCE transfer still replaces its own plan alone.

Positions, frames, scales, the projection about the configured origin and the home placeholder are the
shared mission item encoding, :mod:`auv_common.mission_items` (the ground station uses the same): local NED
x, y = metres * 1e4 and z = depth; the global frames lat/lon * 1e7, depth = -altitude. Yaw (param4) is in
degrees, NaN = the planner's choice.

Home item (ArduPilot's convention, as MAVProxy ``wp load`` and Mission Planner send a QGC WPL 110 file): a
MISSION-type item at **seq 0** that is the encoding's home placeholder
(:func:`auv_common.mission_items.is_home_placeholder`), see :func:`is_home_item`.
It is not flown, so it is not a goal and never reaches the validator (MAVProxy sends lat/lon 0/0); only
validity is checked (lat within +-90 deg -> else INVALID_PARAM5_X, lon within +-180 deg -> else
INVALID_PARAM6_Y, param1..4 NaN or finite -> else INVALID_PARAMn, altitude finite -> else INVALID_PARAM7).
It is stored as sent (download returns it unchanged, persistence keeps it) but is not a goal: the goals are
the items after it. Every other item, including a seq-0 item in a relative-altitude or local frame, is a
goal. With a home item, MAVLink seq = goal index + 1 (:func:`home_offset`, :func:`seq_of_goal`,
:func:`goal_of_seq`); without one they are equal. A seq that names the home item maps to goal 0 (the first
item that is flown, as ArduPilot starts a mission at its first command after home). Our own ground station
never sends a home item.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as mavlink

from auv_common import mission_items as enc
from auv_common.mission_items import (  # re-exported: the adapter's callers and tests name them here
    FRAME_LOCAL,
    GLOBAL_SCALE,
    INT_FRAME_TO_LEGACY,
    LEGACY_FRAME_TO_INT,
    LOCAL_SCALE,
    MissionItem,
    Origin,
    home_offset,
)
from auv_common.mission_yaml import Circle, GoalPose
from onboard.adapters.mavlink.peers import Sender
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.validate import Problem, check_goal_values
from onboard.protocol.conventions import wrap_pi

TYPE_MISSION = mavlink.MAV_MISSION_TYPE_MISSION
TYPE_FENCE = mavlink.MAV_MISSION_TYPE_FENCE
TYPE_RALLY = mavlink.MAV_MISSION_TYPE_RALLY
TYPE_ALL = mavlink.MAV_MISSION_TYPE_ALL


@dataclass(frozen=True)
class MissionLimits:
    """The protocol's settings: the local origin of the global frames and the transfer timers.

    No positional limits: the operating area, depth and counts belong to the mission validator.
    """

    origin_lat_deg: float = 35.1
    origin_lon_deg: float = 129.04
    origin_alt_m: float = 0.0
    item_timeout_s: float = 0.25
    upload_timeout_s: float = 5.0

    @property
    def origin(self) -> Origin:
        """The geodetic origin of the global frames' projection."""
        return Origin(self.origin_lat_deg, self.origin_lon_deg, self.origin_alt_m)


def _is_nan_or_finite(v: float) -> bool:
    return math.isnan(v) or math.isfinite(v)


def is_home_item(item: MissionItem, seq: int, mission_type: int = TYPE_MISSION) -> bool:
    """True if ``item`` at ``seq`` is the ArduPilot-style home placeholder (see the module docstring)."""
    return mission_type == TYPE_MISSION and seq == 0 and enc.is_home_placeholder(item)


def check_home_item(item: MissionItem) -> int:
    """Validity checks of a home item (no operating-area or depth check: it is not flown): the numbers of
    :func:`check_item`, and an altitude that is a number."""
    return _check_numbers(item, z_finite=True)


def _check_numbers(item: MissionItem, *, z_finite: bool) -> int:
    """The number checks every item passes: lat/lon within range in the global frames, param1..4 (and z)
    NaN or finite (``z_finite``: z must be finite), x/y within int32."""
    if item.frame != FRAME_LOCAL:
        if abs(item.x) > 90 * GLOBAL_SCALE:
            return mavlink.MAV_MISSION_INVALID_PARAM5_X
        if abs(item.y) > 180 * GLOBAL_SCALE:
            return mavlink.MAV_MISSION_INVALID_PARAM6_Y
    for value, code in (
        (item.param1, mavlink.MAV_MISSION_INVALID_PARAM1),
        (item.param2, mavlink.MAV_MISSION_INVALID_PARAM2),
        (item.param3, mavlink.MAV_MISSION_INVALID_PARAM3),
        (item.param4, mavlink.MAV_MISSION_INVALID_PARAM4),
    ):
        if not _is_nan_or_finite(value):
            return code
    if not (math.isfinite(item.z) if z_finite else _is_nan_or_finite(item.z)):
        return mavlink.MAV_MISSION_INVALID_PARAM7
    if not enc.fits_int32(item.x):
        return mavlink.MAV_MISSION_INVALID_PARAM5_X
    if not enc.fits_int32(item.y):
        return mavlink.MAV_MISSION_INVALID_PARAM6_Y
    return mavlink.MAV_MISSION_ACCEPTED


def goal_items(items: tuple[MissionItem, ...]) -> tuple[MissionItem, ...]:
    """The items of a MISSION plan that are goals (all but a leading home item)."""
    return items[home_offset(items) :]


def seq_of_goal(index: int, offset: int) -> int:
    """The MAVLink mission seq of goal ``index`` (``offset`` from :func:`home_offset`)."""
    return index + offset


def goal_of_seq(seq: int, offset: int, n_goals: int) -> int | None:
    """The goal index of MAVLink mission ``seq``; the home seq 0 maps to goal 0; None if out of range."""
    index = max(seq - offset, 0) if seq >= 0 else -1
    return index if 0 <= index < n_goals else None


def item_position(item: MissionItem, limits: MissionLimits) -> tuple[float, float, float]:
    """(x_m north, y_m east, depth_m) of a checked item (a frame the vehicle takes) in the local NED frame
    about the origin (:func:`auv_common.mission_items.item_position`)."""
    where = enc.item_position(item, limits.origin)
    if where is None:
        raise ValueError(f"frame {item.frame} is not one the vehicle takes (check_item first)")
    return where


def local_to_global(x_m: float, y_m: float, limits: MissionLimits) -> tuple[float, float]:
    """(lat_deg, lon_deg) of a local NED point: the inverse of :func:`item_position`'s projection."""
    return enc.local_to_global(x_m, y_m, limits.origin)


def plan_of_item(item: MissionItem) -> int:
    """The plan an item of a whole-plan (MAV_MISSION_TYPE_ALL) upload belongs to: a fence circle is FENCE,
    anything else MISSION (where :func:`check_item` judges its command)."""
    return TYPE_FENCE if item.command == mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION else TYPE_MISSION


def split_plans(items: tuple[MissionItem, ...]) -> dict[int, tuple[MissionItem, ...]]:
    """The MISSION and FENCE plans of a whole-plan upload (each keeps the items' order)."""
    return {mt: tuple(i for i in items if plan_of_item(i) == mt) for mt in (TYPE_MISSION, TYPE_FENCE)}


def check_item(item: MissionItem, mission_type: int, limits: MissionLimits, seq: int | None = None) -> int:
    """MAV_MISSION_ACCEPTED or the MAV_MISSION error code of the first failing format check on one item.

    Format only: the command, the frame, every number NaN or finite, lat/lon within range in the global
    frames, and a waypoint's yaw (param4) NaN or within +-360 deg, the validator's rule asked here because
    only the item has the yaw as sent (:func:`goal_yaw_problem` -> MAV_MISSION_INVALID_PARAM4). Whether the
    vehicle can fly it (area, depth, radius, counts, plan) is the validator's.
    With ``seq`` given, a home item at seq 0 (:func:`is_home_item`) gets :func:`check_home_item` instead.
    An item of a whole-plan upload (MAV_MISSION_TYPE_ALL) is checked as an item of its plan.
    """
    if mission_type == TYPE_ALL:
        return check_item(item, plan_of_item(item), limits, seq)
    if seq is not None and is_home_item(item, seq, mission_type):
        return check_home_item(item)
    if mission_type == TYPE_MISSION:
        if item.command != mavlink.MAV_CMD_NAV_WAYPOINT:
            return mavlink.MAV_MISSION_UNSUPPORTED
    elif mission_type == TYPE_FENCE:
        if item.command != mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION:
            return mavlink.MAV_MISSION_UNSUPPORTED
    else:
        return mavlink.MAV_MISSION_UNSUPPORTED
    if item.frame not in enc.VEHICLE_FRAMES:
        return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
    code = _check_numbers(item, z_finite=False)
    if code == mavlink.MAV_MISSION_ACCEPTED and mission_type == TYPE_MISSION:
        if goal_yaw_problem(item, limits, 0 if seq is None else seq) is not None:
            return mavlink.MAV_MISSION_INVALID_PARAM4
    return code


def goal_yaw_problem(item: MissionItem, limits: MissionLimits, index: int) -> Problem | None:
    """The validator's yaw rule (:func:`~onboard.core.mission.validate.check_goal_values`: NaN or within
    +-360 deg) on a waypoint item's param4 as sent, before :func:`goal_from_item` wraps it; the problem names
    goal ``index``. None when the yaw is good."""
    goal = goal_from_item(item, limits, wrap=False)
    return next((p for p in check_goal_values(index, goal) if p.field == "yaw"), None)


def goal_from_item(item: MissionItem, limits: MissionLimits, *, wrap: bool = True) -> Goal:
    """The goal pose of a checked waypoint item (yaw degrees -> radians, wrapped into (-pi, pi] unless
    ``wrap`` is False; NaN -> None; param2 the acceptance radius, NaN or 0 = the default:
    :func:`auv_common.mission_items.radius_of_item`)."""
    x_m, y_m, depth_m = item_position(item, limits)
    yaw_rad = None if math.isnan(item.param4) else math.radians(item.param4)
    if wrap and yaw_rad is not None:
        yaw_rad = wrap_pi(yaw_rad)
    radius_m = enc.radius_of_item(item)
    return Goal(x_m=x_m, y_m=y_m, depth_m=depth_m, yaw_rad=yaw_rad, radius_m=radius_m)


def obstacle_from_item(item: MissionItem, limits: MissionLimits) -> Obstacle:
    """The obstacle circle of a checked fence item (param1 = radius, m)."""
    x_m, y_m, _ = item_position(item, limits)
    return Obstacle(x_m=x_m, y_m=y_m, radius_m=item.param1)


def mission_from_items(
    items: tuple[MissionItem, ...], fences: tuple[MissionItem, ...], limits: MissionLimits
) -> Mission:
    """Combine the stored mission and fence plans into one :class:`Mission` (a home item is no goal)."""
    return Mission(
        goals=tuple(goal_from_item(i, limits) for i in goal_items(items)),
        obstacles=tuple(obstacle_from_item(i, limits) for i in fences),
    )


def items_from_mission(mission: Mission) -> tuple[tuple[MissionItem, ...], tuple[MissionItem, ...]]:
    """Local-frame items for a :class:`Mission` (used for a ``--mission`` file given at start); a position
    that MISSION_ITEM_INT cannot carry raises :class:`auv_common.mission_items.EncodingError` (the file's
    door refuses it first, :mod:`onboard.app.mission_file`)."""
    goals = tuple(
        enc.goal_item(
            GoalPose(
                g.x_m, g.y_m, g.depth_m, None if g.yaw_rad is None else math.degrees(g.yaw_rad), g.radius_m
            )
        )
        for g in mission.goals
    )
    fences = tuple(enc.obstacle_item(Circle(o.x_m, o.y_m, o.radius_m)) for o in mission.obstacles)
    return goals, fences


def item_from_message(msg: mavlink.MAVLink_message) -> MissionItem | None:
    """A :class:`MissionItem` from MISSION_ITEM_INT or legacy MISSION_ITEM (None if unrepresentable)."""
    if msg.get_type() == "MISSION_ITEM_INT":
        x, y, frame = int(msg.x), int(msg.y), int(msg.frame)
    else:  # legacy float MISSION_ITEM: local metres as-is, global degrees as-is
        frame = LEGACY_FRAME_TO_INT.get(int(msg.frame), int(msg.frame))
        scale = LOCAL_SCALE if frame == FRAME_LOCAL else GLOBAL_SCALE
        try:
            x, y = enc.to_int(float(msg.x), scale, "x"), enc.to_int(float(msg.y), scale, "y")
        except enc.EncodingError:
            return None  # not representable in MISSION_ITEM_INT
    return MissionItem(
        frame=frame,
        command=int(msg.command),
        param1=float(msg.param1),
        param2=float(msg.param2),
        param3=float(msg.param3),
        param4=float(msg.param4),
        x=x,
        y=y,
        z=float(msg.z),
        autocontinue=int(msg.autocontinue),
    )


@dataclass
class _Upload:
    sender: Sender
    mission_type: int
    count: int
    last_rx_s: float
    last_req_s: float
    items: list[MissionItem] = field(default_factory=list)


@dataclass
class MissionStats:
    """Counters of the mission service (read by tests and SYS_STATUS)."""

    uploads_accepted: int = 0
    uploads_rejected: int = 0
    uploads_cancelled: int = 0
    rerequests: int = 0
    out_of_sequence: int = 0
    denied: int = 0
    stray_items: int = 0
    acks_resent: int = 0


@dataclass(frozen=True)
class Candidate:
    """A complete transfer waiting for its judgement: the new plan of each type it changes.

    ``mission_type`` is the type the final MISSION_ACK carries (MAV_MISSION_TYPE_ALL for a clear of both or a
    whole-plan upload); ``plans`` holds the new items of every type it replaces (both for either of those).
    """

    sender: Sender
    mission_type: int
    plans: dict[int, tuple[MissionItem, ...]]


@dataclass
class _Judging:
    candidate: Candidate
    final: tuple[int, MissionItem] | None  # (count, last item) of an item upload
    taken: bool = False


class MissionServer:
    """Vehicle side of the mission protocol for the MISSION and FENCE plan types.

    ``handle(msg, sender, now_s)`` and ``poll(now_s)`` return the messages to send (already addressed);
    ``now_s`` is a monotonic wall-clock time. A complete transfer enters the judging state: the caller takes
    it with :meth:`take_candidate` and ends it with :meth:`finish` (which returns the final MISSION_ACK);
    only an ACCEPTED finish replaces the stored plans. After it, :meth:`take_changed` reports the change.
    """

    def __init__(
        self,
        limits: MissionLimits,
        own: tuple[int, int] = (1, 1),
        stored: dict[int, tuple[MissionItem, ...]] | None = None,
    ) -> None:
        self.limits = limits
        self.own = own
        self._plans: dict[int, tuple[MissionItem, ...]] = {TYPE_MISSION: (), TYPE_FENCE: ()}
        if stored:
            self._plans.update({k: v for k, v in stored.items() if k in self._plans})
        self._upload: _Upload | None = None
        self._judging: _Judging | None = None
        self._last_done: tuple[Sender, int, int, MissionItem] | None = None
        self._changed = False
        self.stats = MissionStats()
        self._refusals: list[tuple[Sender, str]] = []

    # ---- queries -------------------------------------------------------------------------------
    def items(self, mission_type: int) -> tuple[MissionItem, ...]:
        """The stored plan of one type."""
        return self._plans.get(mission_type, ())

    @property
    def upload_in_progress(self) -> bool:
        """True while items are transferred or a complete transfer is being judged."""
        return self._upload is not None or self._judging is not None

    @property
    def judging(self) -> bool:
        return self._judging is not None

    @property
    def transfer_sender(self) -> Sender | None:
        """Whose transfer is in progress (items coming, or judged): its requests and ACK go to it alone."""
        if self._judging is not None:
            return self._judging.candidate.sender
        return self._upload.sender if self._upload is not None else None

    def take_refusals(self) -> list[tuple[Sender, str]]:
        """(sender, why) of each transfer refused because another was in progress, or because of a goal's
        yaw (the item's reason), since the last call."""
        out, self._refusals = self._refusals, []
        return out

    def mission(self) -> Mission:
        """The stored mission and fence as one :class:`Mission`."""
        return mission_from_items(self._plans[TYPE_MISSION], self._plans[TYPE_FENCE], self.limits)

    def candidate_mission(self, candidate: Candidate) -> Mission:
        """The mission ``candidate`` would make: its new plan(s) plus the stored plan of the other type."""
        plans = {**self._plans, **candidate.plans}
        return mission_from_items(plans[TYPE_MISSION], plans[TYPE_FENCE], self.limits)

    def home_offset(self) -> int:
        """1 if the stored MISSION plan starts with a home item (MAVLink seq = goal index + 1), else 0."""
        return home_offset(self._plans[TYPE_MISSION])

    def goal_count(self) -> int:
        """The number of goals in the stored MISSION plan (a home item is not counted)."""
        return len(self._plans[TYPE_MISSION]) - self.home_offset()

    def take_changed(self) -> bool:
        """True once after each change of the stored plans."""
        changed, self._changed = self._changed, False
        return changed

    def replace(self, mission_type: int, items: tuple[MissionItem, ...]) -> None:
        """Replace a plan outside the protocol (e.g. ``--mission`` at start)."""
        self._plans[mission_type] = items
        self._changed = True

    # ---- judging -------------------------------------------------------------------------------
    def take_candidate(self) -> Candidate | None:
        """The complete transfer to judge, once (None when there is none or it was already taken)."""
        j = self._judging
        if j is None or j.taken:
            return None
        j.taken = True
        return j.candidate

    def finish(self, result: int) -> list[mavlink.MAVLink_message]:
        """End the transfer being judged with ``result`` (a MAV_MISSION code); returns the final ACK.

        MAV_MISSION_ACCEPTED stores the candidate's plans; any other result leaves them as they were.
        """
        j = self._judging
        if j is None:
            return []
        self._judging = None
        c = j.candidate
        if result == mavlink.MAV_MISSION_ACCEPTED:
            self._plans.update(c.plans)
            self._changed = True
            self.stats.uploads_accepted += 1
            if j.final is not None:
                self._last_done = (c.sender, c.mission_type, j.final[0], j.final[1])
        else:
            self.stats.uploads_rejected += 1
        return [self._ack(c.sender, result, c.mission_type)]

    def _judge(
        self, sender: Sender, mission_type: int, plans: dict[int, tuple[MissionItem, ...]],
        final: tuple[int, MissionItem] | None = None,
    ) -> list[mavlink.MAVLink_message]:  # fmt: skip
        self._upload = None
        self._last_done = None
        self._judging = _Judging(Candidate(sender, mission_type, plans), final)
        return []  # the final ACK comes from finish()

    # ---- protocol ------------------------------------------------------------------------------
    def _for_us(self, msg: mavlink.MAVLink_message) -> bool:
        ts = int(getattr(msg, "target_system", 0))
        tc = int(getattr(msg, "target_component", 0))
        return ts in (0, self.own[0]) and tc in (0, self.own[1])

    def _ack(self, sender: Sender, result: int, mission_type: int) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_mission_ack_message(sender[0], sender[1], result, mission_type)

    def _request(self, up: _Upload) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_mission_request_int_message(
            up.sender[0], up.sender[1], len(up.items), up.mission_type
        )

    def handle(
        self, msg: mavlink.MAVLink_message, sender: Sender, now_s: float
    ) -> list[mavlink.MAVLink_message]:
        """React to one mission-protocol message from ``sender``; other messages give []."""
        kind = msg.get_type()
        if kind not in _HANDLED or not self._for_us(msg):
            return []
        if kind == "MISSION_COUNT":
            return self._on_count(msg, sender, now_s)
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM"):
            return self._on_item(msg, sender, now_s)
        if kind == "MISSION_REQUEST_LIST":
            mt = int(msg.mission_type)
            if mt not in (TYPE_MISSION, TYPE_FENCE, TYPE_RALLY):
                return [self._ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mt)]
            return [mavlink.MAVLink_mission_count_message(sender[0], sender[1], len(self.items(mt)), mt)]
        if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            return self._on_download_request(msg, sender)
        if kind == "MISSION_CLEAR_ALL":
            return self._on_clear(msg, sender)
        return []  # MISSION_ACK from a downloader: nothing to do (download is stateless)

    def _busy(self, sender: Sender, mission_type: int) -> list[mavlink.MAVLink_message]:
        self.stats.denied += 1
        owner = self.transfer_sender
        who = f"{owner[0]}/{owner[1]}" if owner is not None else "another ground station"
        same = (
            " (the same ids, another link)"
            if owner is not None and tuple(owner[:2]) == tuple(sender[:2])
            else ""
        )
        self._refusals.append(
            (sender, f"mission transfer refused: {who}{same} is uploading; try again after")
        )
        return [self._ack(sender, mavlink.MAV_MISSION_DENIED, mission_type)]

    def _on_count(
        self, msg: mavlink.MAVLink_message, sender: Sender, now_s: float
    ) -> list[mavlink.MAVLink_message]:
        mt, count = int(msg.mission_type), int(msg.count)
        if self._judging is not None:
            return self._busy(sender, mt)
        up = self._upload
        if up is not None and up.sender != sender:
            return self._busy(sender, mt)
        if mt not in (TYPE_MISSION, TYPE_FENCE, TYPE_ALL):
            self.stats.uploads_rejected += 1
            return [self._ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mt)]
        if up is not None and up.mission_type == mt and up.count == count and not up.items:
            # the GCS repeated MISSION_COUNT because our first request was lost: request again
            up.last_req_s = now_s
            self.stats.rerequests += 1
            return [self._request(up)]
        self._upload = None  # a new MISSION_COUNT from the uploader restarts its upload
        if count == 0:  # an empty upload clears the plan (both for a whole-plan upload)
            return self._judge(sender, mt, split_plans(()) if mt == TYPE_ALL else {mt: ()})
        self._upload = _Upload(sender, mt, count, last_rx_s=now_s, last_req_s=now_s)
        return [self._request(self._upload)]

    def _on_item(
        self, msg: mavlink.MAVLink_message, sender: Sender, now_s: float
    ) -> list[mavlink.MAVLink_message]:
        mt, seq = int(msg.mission_type), int(msg.seq)
        j = self._judging
        if j is not None:
            c = j.candidate
            if c.sender == sender and c.mission_type == mt and j.final is not None and seq == j.final[0] - 1:
                return []  # the final item again: its ACK comes when the judgement is done
            if c.sender != sender:
                return self._busy(sender, mt)
            self.stats.stray_items += 1
            return []
        up = self._upload
        if up is None:
            done = self._last_done
            item = item_from_message(msg)
            if (
                done is not None
                and item is not None
                and done[0] == sender
                and done[1] == mt
                and seq == done[2] - 1
                and done[3].key() == item.key()
            ):
                self.stats.acks_resent += 1  # our final ACK was lost: answer again, change nothing
                return [self._ack(sender, mavlink.MAV_MISSION_ACCEPTED, mt)]
            self.stats.stray_items += 1
            return []
        if up.sender != sender:
            return self._busy(sender, mt)
        if mt != up.mission_type or seq != len(up.items):
            if seq >= up.count and mt == up.mission_type:
                self._upload = None
                self.stats.uploads_rejected += 1
                return [self._ack(sender, mavlink.MAV_MISSION_INVALID_SEQUENCE, mt)]
            self.stats.out_of_sequence += 1  # dropped; ask again for the one we need
            up.last_req_s = now_s
            return [self._request(up)]
        item = item_from_message(msg)
        result = (
            mavlink.MAV_MISSION_INVALID_PARAM5_X if item is None else check_item(item, mt, self.limits, seq)
        )
        if result != mavlink.MAV_MISSION_ACCEPTED or item is None:
            self._upload = None
            self.stats.uploads_rejected += 1
            if item is not None and result == mavlink.MAV_MISSION_INVALID_PARAM4:
                goals = [i for i in up.items if mt != TYPE_ALL or plan_of_item(i) == TYPE_MISSION]
                problem = goal_yaw_problem(item, self.limits, len(goals) - home_offset(goals))
                if problem is not None:  # the operator reads which goal and why, not only PARAM4
                    self._refusals.append((sender, f"mission upload refused: {problem}"))
            return [self._ack(sender, result, mt)]
        up.items.append(item)
        up.last_rx_s = now_s
        up.last_req_s = now_s
        if len(up.items) < up.count:
            return [self._request(up)]
        items = tuple(up.items)
        plans = split_plans(items) if mt == TYPE_ALL else {mt: items}
        return self._judge(sender, mt, plans, final=(up.count, item))

    def _on_download_request(
        self, msg: mavlink.MAVLink_message, sender: Sender
    ) -> list[mavlink.MAVLink_message]:
        mt, seq = int(msg.mission_type), int(msg.seq)
        items = self.items(mt)
        if seq >= len(items):
            return [self._ack(sender, mavlink.MAV_MISSION_INVALID_SEQUENCE, mt)]
        it = items[seq]
        if msg.get_type() == "MISSION_REQUEST":  # legacy: answered in kind, float metres / degrees
            scale = LOCAL_SCALE if it.frame == FRAME_LOCAL else GLOBAL_SCALE
            return [
                mavlink.MAVLink_mission_item_message(
                    sender[0], sender[1], seq, INT_FRAME_TO_LEGACY.get(it.frame, it.frame), it.command, 0,
                    it.autocontinue,
                    it.param1, it.param2, it.param3, it.param4, it.x / scale, it.y / scale, it.z, mt,
                )
            ]  # fmt: skip
        return [
            mavlink.MAVLink_mission_item_int_message(
                sender[0], sender[1], seq, it.frame, it.command, 0, it.autocontinue,
                it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mt,
            )
        ]  # fmt: skip

    def _on_clear(self, msg: mavlink.MAVLink_message, sender: Sender) -> list[mavlink.MAVLink_message]:
        mt = int(msg.mission_type)
        types = (TYPE_MISSION, TYPE_FENCE) if mt == TYPE_ALL else (mt,)
        if any(t not in (TYPE_MISSION, TYPE_FENCE) for t in types):
            return [self._ack(sender, mavlink.MAV_MISSION_UNSUPPORTED, mt)]
        if self._judging is not None:
            return self._busy(sender, mt)
        up = self._upload
        if up is not None:
            # one transfer at a time: only the uploader may clear, and only what it uploads (which ends its
            # upload); any other clear would be judged and end the upload without a word to its owner
            if up.sender != sender or up.mission_type not in types:
                return self._busy(sender, mt)
            self._upload = None
        if not any(self._plans[t] for t in types):
            self.stats.uploads_accepted += 1
            return [self._ack(sender, mavlink.MAV_MISSION_ACCEPTED, mt)]  # nothing to clear
        return self._judge(sender, mt, {t: () for t in types})

    def poll(self, now_s: float) -> list[mavlink.MAVLink_message]:
        """Timers: re-request the missing item, or cancel a stalled upload (none while judging)."""
        up = self._upload
        if up is None:
            return []
        if now_s - up.last_rx_s >= self.limits.upload_timeout_s:
            self._upload = None
            self.stats.uploads_cancelled += 1
            return [self._ack(up.sender, mavlink.MAV_MISSION_OPERATION_CANCELLED, up.mission_type)]
        if now_s - up.last_req_s >= self.limits.item_timeout_s:
            up.last_req_s = now_s
            self.stats.rerequests += 1
            return [self._request(up)]
        return []

    def next_deadline(self) -> float | None:
        """Monotonic time at which :meth:`poll` has something to do (None = nothing pending)."""
        up = self._upload
        if up is None:
            return None
        return min(up.last_req_s + self.limits.item_timeout_s, up.last_rx_s + self.limits.upload_timeout_s)


_HANDLED = frozenset(
    {
        "MISSION_COUNT",
        "MISSION_ITEM_INT",
        "MISSION_ITEM",
        "MISSION_REQUEST_LIST",
        "MISSION_REQUEST_INT",
        "MISSION_REQUEST",
        "MISSION_CLEAR_ALL",
        "MISSION_ACK",
    }
)
