"""The paper's path cost, eq. (2): J = Wd * Delta_d + Wpsi * delta_psi + WdR * delta_R.

- Delta_d: horizontal path length (m).
- delta_psi: cumulative |yaw change| (rad) = the sum of the arc sweeps (straights do not turn).
- delta_R: cumulative rudder (rad*m) = the integral over arc length of the rudder magnitude each arc needs,
  read from the vehicle's steady-turn map (radius -> rudder). A straight needs no rudder.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Iterable
from dataclasses import dataclass

from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.path import ArcSegment, Segment


@dataclass(frozen=True)
class CostTerms:
    """The three integrals of eq. (2) and the weighted total J."""

    distance_m: float
    yaw_change_rad: float
    rudder_rad_m: float
    total: float


def rudder_rad(radius_m: float, config: PlannerConfig) -> float:
    """Rudder magnitude (rad) for a steady turn of ``radius_m`` (m), from the config's steady-turn map.

    Interpolated linearly in curvature 1/radius, which is exact for the linear manoeuvring model where
    rudder is proportional to curvature; the point (curvature 0, rudder 0) is implied, so very wide turns
    fade to zero rudder. Turns tighter than the table's smallest radius hold its rudder (the map should
    start at r_min; the planner never flies tighter).
    """
    kappas = [1.0 / r for r in reversed(config.rudder_map_radius_m)]  # increasing curvature
    rudders = list(reversed(config.rudder_map_rudder_deg))
    kappa = 1.0 / radius_m
    if kappas[0] > 0.0:
        kappas.insert(0, 0.0)
        rudders.insert(0, 0.0)
    if kappa >= kappas[-1]:
        return math.radians(rudders[-1])
    i = bisect.bisect_right(kappas, kappa) - 1
    frac = (kappa - kappas[i]) / (kappas[i + 1] - kappas[i])
    return math.radians(rudders[i] + frac * (rudders[i + 1] - rudders[i]))


def arc_cost_per_rad(radius_m: float, config: PlannerConfig) -> float:
    """d J / d sweep for an arc of ``radius_m``: Wd * r + Wpsi + WdR * rudder(r) * r (per rad of sweep)."""
    r = radius_m
    rud = rudder_rad(r, config) if config.weight_rudder > 0.0 else 0.0
    return config.weight_distance * r + config.weight_yaw + config.weight_rudder * rud * r


def cost_terms(segments: Iterable[Segment], config: PlannerConfig) -> CostTerms:
    """Eq. (2) for a sequence of segments."""
    dist = yaw = rud = 0.0
    for seg in segments:
        dist += seg.length_m
        if isinstance(seg, ArcSegment):
            yaw += seg.sweep_rad
            rud += rudder_rad(seg.radius_m, config) * seg.length_m
    total = config.weight_distance * dist + config.weight_yaw * yaw + config.weight_rudder * rud
    return CostTerms(dist, yaw, rud, total)
