"""MAVLink 2 adapter of the vehicle: a carrier, never a judge.

The loop uses :class:`VehicleLink` through the per-tick exchange (:mod:`onboard.adapters.mavlink.bridge`):
:class:`Request` objects in (each judged by ``Autopilot.handle`` and answered), notes and a
:class:`VehicleSnapshot` out; no pymavlink type leaves this package.
"""

from onboard.adapters.mavlink.api import Request, VehicleSnapshot
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink

__all__ = ["MavlinkConfig", "Request", "VehicleLink", "VehicleSnapshot"]
