"""What the MAVLink link needs of the vehicle's state store, and what a stored plan means to MAVLink.

The store (atomic JSON files, the storage health, files set aside; :class:`onboard.app.store.StateStore`,
configured by ``[store]``) belongs to the vehicle program, which opens it with or without MAVLink. The layers
put the program above the adapters: the link does not import it, the program hands it in, typed by
:class:`Store` (the part of it the link uses).

The stored plans are MISSION_ITEM_INT items (:class:`auv_common.mission_items.MissionItem`); the store checks
the file's shape and each item's JSON types. What an item means here is checked by :func:`load_plan`, as an
upload is checked: :func:`~onboard.adapters.mavlink.mission_protocol.check_item` (frame, command, numbers,
lat/lon; said by :func:`describe_item_error`, e.g. "frame 99 unsupported") and the validator's
configuration-free rules for the goal or obstacle each item stands for
(:func:`~onboard.core.mission.validate.check_goal_values` / ``check_obstacle_values``: a null z, a fence
radius <= 0). The operating-area, depth and count *limits* are not applied here: the mission service checks
the whole mission with the validator after conversion and may set aside a plan it refuses
(``Store.quarantine_plan``).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Literal, Protocol

from pymavlink.dialects.v20 import common as mavlink

from auv_common.mission_items import MissionItem
from onboard.adapters.mavlink.mission_protocol import (
    TYPE_FENCE,
    TYPE_MISSION,
    MissionLimits,
    check_item,
    goal_from_item,
    is_home_item,
    items_from_mission,
    obstacle_from_item,
)
from onboard.core.mission.model import Mission
from onboard.core.mission.validate import Problem, check_goal_values, check_obstacle_values

PlanKind = Literal["mission", "fence"]
#: The store's name of the plan of a MAV_MISSION_TYPE.
PLAN_KINDS: dict[int, PlanKind] = {TYPE_MISSION: "mission", TYPE_FENCE: "fence"}

#: ``(seq, item) -> why the item is invalid`` ("" valid): the check :meth:`Store.load_plan` applies.
ItemCheck = Callable[[int, MissionItem], str]

# check_item checks the format only (the limits belong to the whole-mission check); the origin is irrelevant.
_FORMAT_LIMITS = MissionLimits()


class Store(Protocol):
    """The vehicle's state store as the link uses it (:class:`onboard.app.store.StateStore`). Saves raise
    ``OSError`` with one line for the operator when the directory cannot be written; loads never raise
    (an invalid file is set aside and listed by :meth:`quarantined`)."""

    @property
    def dir(self) -> Path: ...
    def open(self) -> str: ...
    def problem(self) -> str: ...
    def reprobe(self, now_s: float) -> str: ...
    def quarantined(self) -> list[str]: ...
    def quarantine_plan(self, kind: PlanKind, why: str) -> str: ...
    def save_plan(self, kind: PlanKind, items: Sequence[MissionItem]) -> None: ...
    def load_plan(self, kind: PlanKind, check: ItemCheck | None = None) -> tuple[MissionItem, ...] | None: ...
    def save_params(self, values: dict[str, float]) -> None: ...
    def load_params(self) -> dict[str, float]: ...
    def save_origin(self, lat_deg: float, lon_deg: float, alt_m: float) -> None: ...
    def load_origin(self) -> tuple[float, float, float] | None: ...
    def load_progress(self, mission_key: str) -> int | None: ...
    def keep_progress(self, goal_index: int, mission_key: str, now_s: float) -> tuple[bool, str] | None: ...
    def save_signing_key(self, key: bytes | None) -> None: ...
    def load_signing_key(self) -> tuple[bool, bytes | None]: ...
    def save_signing_timestamp(self, timestamp: int) -> None: ...
    def load_signing_timestamp(self) -> int: ...


def _null(v: float) -> str:
    return "null" if math.isnan(v) else f"{v:g}"


def describe_item_error(item: MissionItem, code: int, mission_type: int) -> str:
    """A human phrase for the MAV_MISSION code of one item, e.g. "frame 99 unsupported"."""
    params = (item.param1, item.param2, item.param3, item.param4)
    if code == mavlink.MAV_MISSION_UNSUPPORTED_FRAME:
        return f"frame {item.frame} unsupported"
    if code == mavlink.MAV_MISSION_UNSUPPORTED:
        return f"command {item.command} unsupported"
    if code == mavlink.MAV_MISSION_INVALID_PARAM1 and mission_type == TYPE_FENCE:
        return f"fence radius (param1) {_null(item.param1)} invalid"
    if mavlink.MAV_MISSION_INVALID_PARAM1 <= code <= mavlink.MAV_MISSION_INVALID_PARAM4:
        n = code - mavlink.MAV_MISSION_INVALID_PARAM1
        return f"param{n + 1} {_null(params[n])} invalid"
    if code == mavlink.MAV_MISSION_INVALID_PARAM5_X:
        return f"x {item.x} invalid"
    if code == mavlink.MAV_MISSION_INVALID_PARAM6_Y:
        return f"y {item.y} invalid"
    if code == mavlink.MAV_MISSION_INVALID_PARAM7:
        return f"z {_null(item.z)} invalid"
    entry = mavlink.enums["MAV_MISSION_RESULT"].get(code)
    return f"refused ({entry.name if entry is not None else code})"


def _value_problems(item: MissionItem, mission_type: int, seq: int) -> list[Problem]:
    """The validator's configuration-free rules for the goal or obstacle an item stands for (e.g. a null z,
    a fence radius <= 0); a home item is not a goal."""
    if mission_type == TYPE_FENCE:
        return check_obstacle_values(seq, obstacle_from_item(item, _FORMAT_LIMITS))
    if is_home_item(item, seq, mission_type):
        return []
    return check_goal_values(seq, goal_from_item(item, _FORMAT_LIMITS))


def stored_item_problem(mission_type: int, seq: int, item: MissionItem) -> str:
    """Why the stored item ``seq`` of a ``mission_type`` plan is invalid ("" valid): the format checks of
    an upload (module docstring)."""
    code = check_item(item, mission_type, _FORMAT_LIMITS, seq)
    if code != mavlink.MAV_MISSION_ACCEPTED:
        return describe_item_error(item, code, mission_type)
    problems = _value_problems(item, mission_type, seq)
    return problems[0].reason if problems else ""


def mission_key(items: Sequence[MissionItem]) -> str:
    """A stable hash (hex SHA-256) of a stored MISSION plan: progress is kept for exactly this plan (the
    store keeps the key with the goal index, :meth:`Store.keep_progress`, and gives the index back only
    for the same key)."""
    canonical = json.dumps([i.to_json() for i in items], sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


def progress_key(mission: Mission) -> str:
    """The :func:`mission_key` of ``mission`` as the link stores a ``--mission`` file (its goals as local
    waypoints): a vehicle without MAVLink keeps its progress under the same key as one with it."""
    return mission_key(items_from_mission(mission)[0])


def load_plan(store: Store, mission_type: int) -> tuple[MissionItem, ...] | None:
    """The stored plan of ``mission_type``, every item checked (:func:`stored_item_problem`); None: nothing
    stored, or the file was invalid and was set aside (the store says why: ``quarantined()``)."""

    def check(seq: int, item: MissionItem) -> str:
        return stored_item_problem(mission_type, seq, item)

    return store.load_plan(PLAN_KINDS[mission_type], check)


__all__ = [
    "PLAN_KINDS",
    "ItemCheck",
    "PlanKind",
    "Store",
    "describe_item_error",
    "load_plan",
    "mission_key",
    "progress_key",
    "stored_item_problem",
]
