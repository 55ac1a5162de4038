"""Surface: the ``surface`` end action (and a loiter's fallback): propeller 0 and fins neutral at once.

Positive buoyancy brings the vehicle up; nothing drives on past the last goal. There is no path and no
plan, so nothing can fail; it has ended as soon as it starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from onboard.core.executive.maneuver import Leg, Progress, Vehicle
from onboard.core.nav.types import NavState

if TYPE_CHECKING:
    from onboard.core.executive.executive import Executive


class Surface:
    """Nothing to fly: the pipeline sends NEUTRAL (the actuators are not live, :func:`actuators_live`)."""

    kind = "surface"

    def start(self, ex: Executive, v: Vehicle) -> None:
        ex.drop_path()

    def step(self, ex: Executive, v: Vehicle, nav: NavState, dt_s: float) -> Leg | None:
        return None

    def plan_failed(self, ex: Executive, v: Vehicle, why: str, late: bool) -> None:
        return None

    def done(self, v: Vehicle) -> bool:
        return True

    def progress(self, ex: Executive, v: Vehicle) -> Progress:
        return Progress("surfacing", 1.0)
