"""What the judge and the tick read and change of the vehicle: a protocol, so that
:mod:`onboard.core.commander` and :mod:`onboard.core.pipeline` depend on this file and not on
:class:`onboard.core.autopilot.Autopilot`, which composes them (no import circle, not even for typing)."""

from __future__ import annotations

from typing import Protocol

from onboard.core.executive import Executive
from onboard.core.executive.maneuver import Vehicle
from onboard.core.mission.state import MissionStatus
from onboard.core.params import BusLimits


class Core(Vehicle, Protocol):
    """The vehicle's state beside what a maneuver sees (:class:`~onboard.core.executive.maneuver.Vehicle`):
    the executive, the bus and actuator conditions, the autostart, the loop's lateness and the faults named
    on the mission (:mod:`onboard.core.safety.diagnosis`)."""

    now_s: float
    bus_limits: BusLimits | None
    executive: Executive
    autostart_pending: bool
    actuator_failsafe: bool
    encode_fault: str
    bus_lost: str
    bus_abort: MissionStatus | None
    loop_late_s: float
    faults_named: str

    @property
    def actuators_live(self) -> bool: ...
