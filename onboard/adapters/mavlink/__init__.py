"""MAVLink 2 adapter of the vehicle: endpoint, mission service, parameters, signing.

The loop uses :class:`VehicleLink` with :class:`VehicleSnapshot` in and :data:`VehicleEvent` out; no
pymavlink type leaves this package.
"""

from onboard.adapters.mavlink.api import (
    Abort,
    Arm,
    Disarm,
    GcsLinkLost,
    GcsLinkRegained,
    Hold,
    MissionReplaced,
    ParamChanged,
    Resume,
    SetCurrent,
    StartMission,
    VehicleEvent,
    VehicleSnapshot,
)
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink

__all__ = [
    "Abort",
    "Arm",
    "Disarm",
    "GcsLinkLost",
    "GcsLinkRegained",
    "Hold",
    "MavlinkConfig",
    "MissionReplaced",
    "ParamChanged",
    "Resume",
    "SetCurrent",
    "StartMission",
    "VehicleEvent",
    "VehicleLink",
    "VehicleSnapshot",
]
