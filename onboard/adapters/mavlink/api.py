"""The thread-safe seam between the control loop and the MAVLink endpoint: snapshot in, events out.

No pymavlink types appear here: the loop imports this module only. The loop calls ``VehicleLink.publish``
(:mod:`onboard.adapters.mavlink.endpoint`) with a :class:`VehicleSnapshot` once per tick (cheap: it stores a
reference) and ``VehicleLink.take_events`` once per tick to receive the :class:`VehicleEvent` objects that the
ground station caused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from onboard.core.mission.model import Mission

MissionStateName = Literal["IDLE", "ARMED", "RUNNING", "HOLD", "ABORT", "COMPLETE"]
MISSION_STATES: tuple[MissionStateName, ...] = ("IDLE", "ARMED", "RUNNING", "HOLD", "ABORT", "COMPLETE")
NAN = math.nan


@dataclass(frozen=True)
class VehicleSnapshot:
    """What the loop knows at the end of one tick (SI units, radians, NED world frame, FRD body frame).

    ``t_s`` is the loop's time of the sample (monotonic or simulated; MAVLink timers never use it).
    Unknown values are NaN. ``goals_reached`` counts goals reached since the mission (re)started; the
    endpoint sends MISSION_ITEM_REACHED whenever it increases.
    """

    t_s: float = 0.0
    state: MissionStateName = "IDLE"
    current_goal: int = 0
    goals_reached: int = 0
    x_m: float = NAN
    y_m: float = NAN
    depth_m: float = NAN
    roll_rad: float = NAN
    pitch_rad: float = NAN
    yaw_rad: float = NAN
    u_mps: float = NAN
    v_mps: float = NAN
    w_mps: float = NAN
    p_radps: float = NAN
    q_radps: float = NAN
    r_radps: float = NAN
    cross_track_m: float = NAN
    along_track_m: float = NAN
    yaw_error_rad: float = NAN
    depth_error_m: float = NAN
    goal_distance_m: float = NAN
    rudder_rad: float = NAN
    stern_port_rad: float = NAN
    stern_starboard_rad: float = NAN
    propeller_rps: float = NAN
    rudder_saturated: bool = False
    stern_saturated: bool = False
    propeller_saturated: bool = False
    failsafe: str | None = None
    overruns: int = 0
    loop_load: float = NAN  # fraction of the tick period used by the last tick (0..1+)


@dataclass(frozen=True)
class MissionReplaced:
    """A complete, validated mission (goals and fence obstacles) replaced the previous one."""

    mission: Mission


@dataclass(frozen=True)
class Arm:
    """Arm (accepted only in IDLE or COMPLETE)."""


@dataclass(frozen=True)
class Disarm:
    """Disarm (accepted in ARMED, COMPLETE, ABORT; in RUNNING/HOLD only when forced)."""

    forced: bool = False


@dataclass(frozen=True)
class StartMission:
    """Start (or restart) the mission at ``first_index`` (None = the current goal)."""

    first_index: int | None = None


@dataclass(frozen=True)
class Abort:
    """Abort: propeller off, fins to surface. Always accepted."""

    reason: str = "operator"


@dataclass(frozen=True)
class Hold:
    """Pause a running mission (keep station as the vehicle can)."""


@dataclass(frozen=True)
class Resume:
    """Continue a held mission."""


@dataclass(frozen=True)
class SetCurrent:
    """Make goal ``index`` the current goal; while RUNNING the loop re-plans to it."""

    index: int


@dataclass(frozen=True)
class ParamChanged:
    """A parameter has a new value (also emitted at start for each persisted value: each one set away from
    its default)."""

    name: str
    value: float


@dataclass(frozen=True)
class GcsLinkLost:
    """No ground-station heartbeat for ``gcs_timeout_s``; ``action`` is the configured reaction."""

    action: Literal["continue", "hold", "surface"]


@dataclass(frozen=True)
class GcsLinkRegained:
    """A ground-station heartbeat arrived again after a loss."""


VehicleEvent = (
    MissionReplaced
    | Arm
    | Disarm
    | StartMission
    | Abort
    | Hold
    | Resume
    | SetCurrent
    | ParamChanged
    | GcsLinkLost
    | GcsLinkRegained
)
