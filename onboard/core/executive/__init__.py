"""The executive: what the vehicle is doing now, one maneuver per file (see :mod:`.executive`)."""

from onboard.core.executive.executive import Executive
from onboard.core.executive.goto import Goto
from onboard.core.executive.loiter import Loiter
from onboard.core.executive.maneuver import Leg, Maneuver, Progress, Vehicle
from onboard.core.executive.surface import Surface

__all__ = ["Executive", "Goto", "Leg", "Loiter", "Maneuver", "Progress", "Surface", "Vehicle"]
