"""The ``[mission]`` table: arrival, misses, the end of a mission, mission capacities, planning deadline."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from auv_common.config import require

EndAction = Literal["surface", "loiter"]

#: The smallest arrival radius that means one, m: the navigation estimate is good to decimetres (a fix's
#: sigma is 0.3 m), so a radius below 0.1 m turns every arrival into a miss.
ARRIVAL_RADIUS_MIN_M = 0.1


@dataclass(frozen=True)
class MissionParams:
    """How a mission is flown and judged. Every key is optional.

    - ``arrival_radius_m``: a goal is reached when the vehicle's estimate crosses the goal line within this
      horizontal distance of the goal; farther off it is a miss (>= :data:`ARRIVAL_RADIUS_MIN_M`).
    - ``max_tries``: attempts at one goal (the first and the re-plans after a miss); then HOLD.
    - ``end_action``: after the last goal: ``surface`` (propeller 0 and fins neutral at once, the positively
      buoyant vehicle floats up; disarmed) or ``loiter`` (circle the last goal at its depth; armed).
    - ``loiter_radius_m``: radius of the loiter circle (0 = twice the planner's turning radius).
    - ``max_goals``, ``max_obstacles``: capacities of one mission (goals; fence circles).
    - ``plan_deadline_s``: a plan (in the planning worker) that takes longer is a refusal with a reason.
    """

    arrival_radius_m: float = 0.5
    max_tries: int = 3
    end_action: EndAction = "surface"
    loiter_radius_m: float = 0.0
    max_goals: int = 1000
    max_obstacles: int = 64
    plan_deadline_s: float = 2.0

    def __post_init__(self) -> None:
        require(
            ARRIVAL_RADIUS_MIN_M <= self.arrival_radius_m <= 50.0,
            f"arrival_radius_m must be in [{ARRIVAL_RADIUS_MIN_M:g}, 50] m, got {self.arrival_radius_m:g}",
        )
        require(1 <= self.max_tries <= 20, f"max_tries must be 1..20, got {self.max_tries}")
        require(
            self.end_action in ("surface", "loiter"),
            f"end_action must be surface or loiter, got {self.end_action!r}",
        )
        require(
            0.0 <= self.loiter_radius_m <= 100.0,
            f"loiter_radius_m must be in [0, 100], got {self.loiter_radius_m}",
        )
        require(1 <= self.max_goals <= 10000, f"max_goals must be 1..10000, got {self.max_goals}")
        require(0 <= self.max_obstacles <= 1000, f"max_obstacles must be 0..1000, got {self.max_obstacles}")
        require(
            0.05 <= self.plan_deadline_s <= 60.0,
            f"plan_deadline_s must be in [0.05, 60], got {self.plan_deadline_s}",
        )
