"""The per-tick exchange between the autopilot and the MAVLink link (loop thread; no pymavlink here).

``onboard/core/DESIGN.md``, "The per-tick exchange":

- :func:`before_tick`: every request the link holds is judged by the one judge, ``Autopilot.handle``, and
  answered with its verdict (each request taken once, answered once).
- :func:`after_tick`: the core's notes to the link (one STATUSTEXT each), then the telemetry snapshot.
- :func:`snapshot`: what the link publishes, from one tick's output; :func:`status_fields` is its part that
  carries the truth (state, armed, ready, reason, progress), for callers without a step output.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Any, Protocol

from onboard.adapters.mavlink import api
from onboard.core import commands as core
from onboard.core.autopilot import Autopilot
from onboard.core.control.actuators import ActuatorFlag
from onboard.core.mission.state import MissionState
from onboard.core.record import TickRecord

log = logging.getLogger(__name__)


class Link(Protocol):
    """The loop's side of :class:`onboard.adapters.mavlink.endpoint.VehicleLink`."""

    def take_requests(self) -> list[api.Request]: ...
    def answer(self, request_id: int, verdict: core.Verdict) -> None: ...
    def notify(self, notes: list[core.Note]) -> None: ...
    def publish(self, snapshot: api.VehicleSnapshot) -> None: ...


def before_tick(autopilot: Autopilot, link: Link) -> None:
    """Judge every pending request with ``autopilot.handle`` and answer it (exactly once each)."""
    for req in link.take_requests():
        try:
            verdict = autopilot.handle(req.command)
        except Exception as exc:  # a bug in the judge must still answer the ground station
            log.exception("handling %s failed", type(req.command).__name__)
            verdict = core.Verdict(core.Outcome.FAILED, f"{type(req.command).__name__} failed: {exc}")
        link.answer(req.id, verdict)


def after_tick(
    autopilot: Autopilot,
    link: Link,
    out: TickRecord,
    now_s: float,
    overruns: int = 0,
    loop_load: float = math.nan,
) -> None:
    """The core's notes, then the snapshot of this tick."""
    link.notify(autopilot.take_notes())
    link.publish(snapshot(autopilot, out, now_s, overruns, loop_load))


def status_fields(autopilot: Any) -> dict[str, Any]:
    """state, armed, ready, ready_reason, reason, bus_lost, current_goal, goals_reached of the autopilot
    now."""
    status = autopilot.status
    ready, ready_reason = autopilot.ready
    return {
        "state": status.state,
        "armed": bool(autopilot.actuators_live),
        "loitering": status.state is MissionState.COMPLETE and bool(autopilot.executive.loitering(autopilot)),
        "ready": bool(ready),
        "ready_reason": ready_reason,
        "reason": status.reason,
        "bus_lost": autopilot.bus_lost,
        "current_goal": status.goal_index,
        "goals_reached": autopilot.goals_reached,
        "mission_goals": autopilot.mission.goals,
    }


def snapshot(
    ap: Autopilot, out: TickRecord, now_s: float, overruns: int = 0, loop_load: float = math.nan
) -> api.VehicleSnapshot:
    """The telemetry snapshot of one tick: the tick record's numbers under the record's own names (every
    :meth:`~onboard.core.record.TickRecord.row` value whose name the snapshot has), the state's truth
    (:func:`status_fields`), and what only the link needs (goal distance, saturation bits, the path)."""
    n, c = out.nav, out.command
    goal_distance = math.nan
    if ap.mission.goals and out.status.goal_index < len(ap.mission.goals):
        g = ap.mission.goals[out.status.goal_index]
        goal_distance = math.hypot(g.x_m - n.x_m, g.y_m - n.y_m)
    fields = status_fields(ap)
    fields.update(state=out.status.state, current_goal=out.status.goal_index, reason=out.status.reason)
    fields.update((k, v) for k, v in out.row().items() if k in _FROM_RECORD)
    return api.VehicleSnapshot(
        t_s=now_s,
        **fields,
        goal_distance_m=goal_distance,
        rudder_saturated=bool(c.flags & ActuatorFlag.RUDDER_LIMIT),
        stern_saturated=bool(c.flags & ActuatorFlag.STERN_LIMIT),
        propeller_saturated=bool(c.flags & ActuatorFlag.PROPELLER_LIMIT),
        failsafe=out.status.reason if out.status.state is MissionState.ABORT else None,
        overruns=overruns,
        loop_load=loop_load,
        path=ap.path,
        path_kind=ap.path_kind if ap.path is not None else "",
        path_goal_index=ap.path_goal_index if ap.path is not None else -1,
    )


#: The snapshot's fields that come from the tick record, under the same name (the state is the snapshot's
#: enum, not the row's name of it).
_FROM_RECORD = frozenset(f.name for f in dataclasses.fields(api.VehicleSnapshot)) - {"state"}
