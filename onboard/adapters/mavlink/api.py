"""The thread-safe seam between the control loop and the MAVLink link: requests in, verdicts, notes and a
snapshot out.

No pymavlink types appear here: the loop imports this module only. Per tick the loop (through
:mod:`onboard.adapters.mavlink.bridge`) calls ``VehicleLink.take_requests()`` and answers each
:class:`Request` with the core's verdict (``VehicleLink.answer``), then ``VehicleLink.notify(notes)`` and
``VehicleLink.publish(snapshot)`` with a :class:`VehicleSnapshot`. The link never judges a command itself
(see ``onboard/core/DESIGN.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from onboard.core.commands import Command
from onboard.core.mission.model import Goal
from onboard.core.mission.state import MissionState
from onboard.core.planner.path import Path

# The one vocabulary of states (their names).
MISSION_STATES: tuple[str, ...] = tuple(s.name for s in MissionState)
NAN = math.nan


@dataclass(frozen=True)
class Request:
    """One command for the core, taken once by the loop and answered exactly once (``VehicleLink.answer``)."""

    id: int
    command: Command


@dataclass(frozen=True)
class VehicleSnapshot:
    """What the loop knows at the end of one tick (SI units, radians, NED world frame, FRD body frame).

    ``t_s`` is the loop's time of the sample (monotonic or simulated; MAVLink timers never use it).
    Unknown values are NaN. ``goals_reached`` counts goals reached since the mission (re)started; the link
    sends MISSION_ITEM_REACHED whenever it increases. ``armed`` is ``Autopilot.actuators_live`` (HEARTBEAT
    SAFETY_ARMED is this bit and nothing else; it is also set while the ``surface`` end action still
    brakes); ``loitering`` is the ``loiter`` end action circling (the CIRCLE mode); ``ready`` /
    ``ready_reason`` say whether START would be accepted as far as the vehicle's own checks go; ``reason``
    says why the last transition happened.
    ``bus_lost`` says why the CAN bus is lost ("" while it is up: SYS_STATUS MOTOR_OUTPUTS healthy).
    ``path`` is the path the autopilot flies now (``path_kind`` "goal" to goal ``path_goal_index``, or
    "loiter"), None when it flies none; a new plan is a new object (the link compares by identity).
    """

    t_s: float = 0.0
    state: MissionState = MissionState.IDLE
    armed: bool = False
    loitering: bool = False  # COMPLETE with the loiter end action, not fallen back to surfacing (CIRCLE)
    ready: bool = False
    ready_reason: str = ""
    reason: str = ""
    bus_lost: str = ""
    current_goal: int = 0
    goals_reached: int = 0
    mission_goals: tuple[Goal, ...] = ()  # the goals ``current_goal`` counts in (the mission in force)
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
    e_yaw_rad: float = NAN  # guidance's errors, desired - actual (the tick record's names)
    e_depth_m: float = NAN
    goal_distance_m: float = NAN
    rudder_rad: float = NAN
    stern_port_rad: float = NAN
    stern_starboard_rad: float = NAN
    propeller_rps: float = NAN
    rudder_saturated: bool = False
    stern_saturated: bool = False
    propeller_saturated: bool = False
    actuator_flags: int = 0  # onboard.core.control.actuators.ActuatorFlag bits of the command
    nav_conditions: int = 0  # onboard.core.nav.types.NavCondition bits: what is wrong with navigation
    failsafe_flags: int = 0  # onboard.core.safety.failsafe.FailsafeFlag bits: the checks failing this tick
    fault_flags: int = 0  # onboard.core.safety.diagnosis.FaultFlag bits: the faults the vehicle names
    fixes_rejected: int = 0  # fixes the navigation refused since boot (NAMED_VALUE_INT FIX_REJ)
    failsafe: str | None = None
    overruns: int = 0
    loop_load: float = NAN  # fraction of the tick period used by the last tick (0..1+)
    path: Path | None = None
    path_kind: str = ""
    path_goal_index: int = -1
