"""The ``[mission]`` table: arrival, misses, the end of a mission, mission capacities, planning deadline."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from auv_common.config import check_declared, param, require

EndAction = Literal["surface", "loiter"]

#: The smallest arrival radius that means one, m: the navigation estimate is good to decimetres (a fix's
#: sigma is 0.3 m), so a radius below 0.1 m turns every arrival into a miss.
ARRIVAL_RADIUS_MIN_M = 0.1
#: The arrival radius's default, m: MIS_ARRIVE_R_M declares it with this value; guidance built without a
#: configuration (tests) uses it too.
ARRIVAL_RADIUS_DEFAULT_M = 0.5


@dataclass(frozen=True)
class MissionParams:
    """How a mission is flown and judged. Every key is optional; each is declared once below (unit, range,
    description, MAVLink name: ``docs/parameters.md``).

    ``arrival_radius_m`` is the one arrival distance: the path to a goal is done when the vehicle's estimate
    comes within it of the goal with the heading within ``[guidance] arrival_yaw_tol_deg``, or crosses the
    goal line (guidance gets it from :class:`~onboard.core.config.CoreConfig`); the goal is then reached
    if the estimate is within it of the goal, else it is a miss, re-planned until ``max_tries``, then HOLD.
    After the last goal, ``end_action``: ``surface`` (propeller 0 and fins neutral at once, the positively
    buoyant vehicle floats up; disarmed) or ``loiter`` (circle the last goal at its depth; armed).
    """

    arrival_radius_m: float = param(
        ARRIVAL_RADIUS_DEFAULT_M,
        unit="m",
        min=ARRIVAL_RADIUS_MIN_M,
        max=50.0,
        mavlink="MIS_ARRIVE_R_M",
        desc="goal arrival radius",
    )
    max_tries: int = param(3, min=1, max=20, mavlink="MIS_MAX_TRIES", desc="attempts at one goal before HOLD")
    end_action: EndAction = "surface"
    loiter_radius_m: float = param(
        0.0, unit="m", min=0.0, max=100.0, mavlink="MIS_LOITER_R_M",
        desc="loiter radius (0 = twice the turning radius)",
    )  # fmt: skip
    max_goals: int = param(1000, min=1, max=10000, desc="goals in one mission, at most")
    max_obstacles: int = param(64, min=0, max=1000, desc="fence circles in one mission, at most")
    plan_deadline_s: float = param(
        2.0, unit="s", min=0.05, max=60.0,
        desc="a plan (in the planning worker) that takes longer is a refusal with a reason",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_declared(self)
        require(
            self.end_action in ("surface", "loiter"),
            f"end_action must be surface or loiter, got {self.end_action!r}",
        )
