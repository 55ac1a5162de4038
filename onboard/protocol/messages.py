"""Typed messages of the ISiMI100 bus: one frozen dataclass per DBC message.

Field names are the DBC signal names (SI units in the name) plus ``t_sample_s``: the time the value was
sampled or commanded, in the sender's clock. On receipt, ``t_sample_s`` is the time of arrival (the frames
carry no timestamp, except SYNC whose ``sim_time_s`` is the simulated time). The E2E signals
(``e2e_counter``, ``e2e_crc``) are not fields: the codec adds and checks them.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import ClassVar


class ActuatorMode(IntEnum):
    """Mode field of PROP_CMD."""

    SAFE = 0  # fins neutral, propeller off
    ARMED = 1  # follow the commands
    ABORT = 2  # propeller off, fins as commanded (stern nose up: to surface)


#: The stern planes' nose-up angle of ABORT (deg; sent as a negative stern angle): the actuator node's own
#: in its command watchdog's failsafe (nobody commands the fins then: the onboard, or the bus to it, failed)
#: and the default of the onboard's ``[failsafe] abort_stern_deg``. Hard over on purpose: a positively
#: buoyant hull pitched up a little is driven on along its axis by its buoyancy; pitched up hard it climbs
#: nearly vertically and stops ahead (from 1.2 m/s: 3.6 m ahead at 1 m deep, 5.9 m at 5 m, against 22 m of
#: glide with the fins neutral).
ABORT_STERN_DEG = 15.0


class MissionStateCode(IntEnum):
    """node_state of ONBOARD_HEARTBEAT: the onboard mission state."""

    IDLE = 0
    ARMED = 1
    RUNNING = 2
    HOLD = 3
    ABORT = 4
    COMPLETE = 5


#: The bus contract's rule for the actuator node: the onboard states in which its ARMED commands are obeyed
#: (the onboard's ``Autopilot.actuators_live``; in COMPLETE only with the loiter end action, the surface
#: one commands SAFE itself).
LIVE_MISSION_STATES: frozenset[MissionStateCode] = frozenset(
    {MissionStateCode.ARMED, MissionStateCode.RUNNING, MissionStateCode.HOLD, MissionStateCode.COMPLETE}
)


class NodeHealth(IntEnum):
    """node_state of the actuator and sensor heartbeats."""

    OK = 0
    FAILSAFE = 1  # actuators: latched failsafe / sensors: DEGRADED
    FAULT = 2


@dataclass(frozen=True)
class FinCmd:
    DBC_NAME: ClassVar[str] = "FIN_CMD"
    rudder_rad: float
    stern_port_rad: float
    stern_starboard_rad: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class PropCmd:
    DBC_NAME: ClassVar[str] = "PROP_CMD"
    propeller_rps: float
    mode: ActuatorMode
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class SyncAck:
    DBC_NAME: ClassVar[str] = "SYNC_ACK"
    tick: int
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class Sync:
    DBC_NAME: ClassVar[str] = "SYNC"
    tick: int
    sim_time_s: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class FinStatus:
    DBC_NAME: ClassVar[str] = "FIN_STATUS"
    rudder_rad: float
    stern_port_rad: float
    stern_starboard_rad: float
    fault: bool
    failsafe: bool
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class PropStatus:
    DBC_NAME: ClassVar[str] = "PROP_STATUS"
    propeller_rps: float
    armed: bool
    failsafe: bool
    fault: bool
    rejected_frames: int
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class AhrsAttitude:
    DBC_NAME: ClassVar[str] = "AHRS_ATTITUDE"
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class AhrsRates:
    DBC_NAME: ClassVar[str] = "AHRS_RATES"
    p_radps: float
    q_radps: float
    r_radps: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class DepthMeas:
    DBC_NAME: ClassVar[str] = "DEPTH"
    depth_m: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class DvlVelocity:
    DBC_NAME: ClassVar[str] = "DVL_VELOCITY"
    u_mps: float
    v_mps: float
    w_mps: float
    valid: bool
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class PositionFix:
    """A horizontal position fix; ``std_m``: the sensor's own 1-sigma accuracy in 0.25 m steps (0: better
    than 0.25 m, or not stated: the onboard uses its configured ``[nav] fix_sigma_m``)."""

    DBC_NAME: ClassVar[str] = "POSITION_FIX"
    x_m: float
    y_m: float
    t_sample_s: float = 0.0
    std_m: float = 0.0


@dataclass(frozen=True)
class OnboardHeartbeat:
    DBC_NAME: ClassVar[str] = "ONBOARD_HEARTBEAT"
    node_state: MissionStateCode
    uptime_s: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class ActuatorsHeartbeat:
    DBC_NAME: ClassVar[str] = "ACTUATORS_HEARTBEAT"
    node_state: NodeHealth
    uptime_s: float
    t_sample_s: float = 0.0


@dataclass(frozen=True)
class SensorsHeartbeat:
    DBC_NAME: ClassVar[str] = "SENSORS_HEARTBEAT"
    node_state: NodeHealth
    uptime_s: float
    t_sample_s: float = 0.0


BusMessage = (
    FinCmd
    | PropCmd
    | SyncAck
    | Sync
    | FinStatus
    | PropStatus
    | AhrsAttitude
    | AhrsRates
    | DepthMeas
    | DvlVelocity
    | PositionFix
    | OnboardHeartbeat
    | ActuatorsHeartbeat
    | SensorsHeartbeat
)

ALL_MESSAGE_TYPES: tuple[type[BusMessage], ...] = (
    FinCmd,
    PropCmd,
    SyncAck,
    Sync,
    FinStatus,
    PropStatus,
    AhrsAttitude,
    AhrsRates,
    DepthMeas,
    DvlVelocity,
    PositionFix,
    OnboardHeartbeat,
    ActuatorsHeartbeat,
    SensorsHeartbeat,
)
