"""The per-tick exchange between the autopilot and the MAVLink link (loop thread; no pymavlink here).

``onboard/core/DESIGN.md``, "The per-tick exchange":

- :func:`before_tick`: every request the link holds is judged by the one judge, ``Autopilot.handle``, and
  answered with its verdict (each request taken once, answered once).
- :func:`after_tick`: the core's notes to the link (one STATUSTEXT each), then the telemetry snapshot.
- :func:`snapshot`: what the link publishes, from one tick's output; :func:`status_fields` is its part that
  carries the truth (state, armed, ready, reason, progress), for callers without a step output.
"""

from __future__ import annotations

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
    """The telemetry snapshot of one tick."""
    n, r, c = out.nav, out.reference, out.command
    nan = math.nan
    goal_distance = nan
    if ap.mission.goals and out.status.goal_index < len(ap.mission.goals):
        g = ap.mission.goals[out.status.goal_index]
        goal_distance = math.hypot(g.x_m - n.x_m, g.y_m - n.y_m)
    fields = status_fields(ap)
    fields.update(state=out.status.state, current_goal=out.status.goal_index, reason=out.status.reason)
    return api.VehicleSnapshot(
        t_s=now_s,
        **fields,
        x_m=n.x_m,
        y_m=n.y_m,
        depth_m=n.depth_m,
        roll_rad=n.roll_rad,
        pitch_rad=n.pitch_rad,
        yaw_rad=n.yaw_rad,
        u_mps=n.u_mps,
        v_mps=n.v_mps,
        w_mps=n.w_mps,
        p_radps=n.p_radps,
        q_radps=n.q_radps,
        r_radps=n.r_radps,
        cross_track_m=r.cross_track_m if r else nan,
        along_track_m=r.along_track_m if r else nan,
        yaw_error_rad=r.e_yaw_rad if r else nan,
        depth_error_m=r.e_depth_m if r else nan,
        goal_distance_m=goal_distance,
        rudder_rad=c.rudder_rad,
        stern_port_rad=c.stern_port_rad,
        stern_starboard_rad=c.stern_starboard_rad,
        propeller_rps=c.propeller_rps,
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
