"""Planner configuration: the ``[planner]`` table of the onboard TOML file, as a frozen dataclass.

Build it from TOML with
``auv_common.config.from_table(PlannerConfig, table, "onboard.toml [planner]")``:
unknown keys and wrong types raise ``ConfigError``; the range checks below raise
:class:`~onboard.core.planner.errors.PlannerConfigError`, which is a ``ConfigError`` and a ``PlannerError``.

Weights of the paper's cost, eq. (2): ``J = Wd * distance_m + Wpsi * yaw_change_rad + WdR * rudder_rad_m``,
where ``rudder_rad_m`` is the rudder magnitude each arc needs (from the radius-to-rudder map) integrated over
arc length. The defaults (Wd = 1, Wpsi = WdR = 0) give the true Dubins shortest path.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

from auv_common.config import Bound, check_declared, param
from onboard.core.planner.errors import PlannerConfigError

# A placeholder steady-turn table (radius m -> rudder deg) until the simulator's steady-turn run fills it; it
# follows rudder ~ 1/radius (linear manoeuvring model), which is also how it is interpolated (in curvature).
_DEFAULT_MAP_RADIUS_M = (3.0, 5.0, 10.0, 20.0, 50.0)
_DEFAULT_MAP_RUDDER_DEG = (20.0, 12.0, 6.0, 3.0, 1.2)


#: The tightest turning radius that means one, m: a fin-steered torpedo AUV of 1.6 m turns on metres
#: (this one on 2.9 m); below 0.5 m the Dubins geometry is a point turn nobody flies (0 = none).
TURNING_RADIUS_MIN_M = 0.5
#: The flattest depth slope that means one: 1 cm of depth per metre of path (a 1 m depth change over 100 m).
DEPTH_SLOPE_MIN = 0.01
#: The smallest scale of the cost weights that means one (the largest weight, J per metre or radian):
#: the weights are relative, but a cost scale below 1e-3 (or subnormal, where the floats lose their
#: precision) is no choice anyone means.
WEIGHT_SCALE_MIN = 1e-3


def _check(condition: bool, reason: str, message: str) -> None:
    """Like ``auv_common.config.require``, but the error also carries a planner ``reason``."""
    if not condition:
        raise PlannerConfigError(reason, message)


def _finite(value: float) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


def _weight_min(key: str) -> Bound:
    """A cost weight's minimum: 0 while another weight carries the scale, else :data:`WEIGHT_SCALE_MIN`."""
    others = tuple(k for k in ("weight_distance", "weight_yaw", "weight_rudder") if k != key)
    return Bound(
        lambda c: 0.0 if max(getattr(c, k) for k in others) >= WEIGHT_SCALE_MIN else WEIGHT_SCALE_MIN,
        f"0 only while one of the other cost weights is >= {WEIGHT_SCALE_MIN:g}",
    )


def _config_error(key: str, message: str) -> PlannerConfigError:
    return PlannerConfigError("radius" if key == "turning_radius_m" else "config", message)


@dataclass(frozen=True)
class PlannerConfig:
    """Parameters of the homing path planner (paper section 3).

    The declared keys (unit, range, description, MAVLink name) are in ``docs/parameters.md``. Why:

    Attributes:
        turning_radius_m: minimum turning radius r_min of the vehicle.
        obstacle_margin_m: the inflated radius is ``max(R + margin, r_min)`` so the vehicle can fly an
            obstacle's boundary as an arc.
        weight_distance, weight_yaw, weight_rudder: Wd, Wpsi, WdR of eq. (2), per metre, per radian of
            cumulative |yaw change|, per rad*m of cumulative rudder; the largest of the three is >=
            :data:`WEIGHT_SCALE_MIN`.
        max_depth_slope: largest |d depth / d s| along the path (tan of the flight-path angle).
        rudder_map_radius_m: radii of the steady-turn table (m), strictly increasing, > 0.
        rudder_map_rudder_deg: rudder magnitude for each radius (deg), >= 0.
        goal_run_in_m: a goal with a heading is approached along a straight of this length ending at it
            (m, >= 0; 0 = the paper: the last arc ends at the goal), so the errors (and a crab into a
            current) settle before the goal; where the run-in's start is blocked or unreachable, direct.
        start_run_up_m: the path begins with a straight of this length along the start heading (m, >= 0;
            0 = the paper: the first arc starts at once), so a vehicle that starts at rest gains steerage
            before it turns; where the straight is blocked, or the goal is within it and two turning radii,
            the path turns from the start.
        current_aware: plan, in a current of speed c (the vehicle's estimate), with the turning radius
            widened to r * U / (U - c) at the path speed U: the turn rate a fin gives is proportional to the
            speed through the water, which a following current lowers while the speed over ground is held.
            Where the wider turns find no path, the nominal radius is used.
        min_turning_radius_m: where the planning radius finds no path (both turning circles blocked,
            no way among the obstacles, a start or goal inside an obstacle inflated to the radius), plan
            again with this tighter radius (m; 0 = never; below ``turning_radius_m``): the path then says so
            (``Path.note``, a warning to the operator); if that fails too, the refusal at the planning radius.
        min_obstacle_margin_m: where the start or the goal is inside an obstacle's margin and the tighter
            radius does not help, plan once more with it and the obstacle margin reduced to this (m; None =
            never; below ``obstacle_margin_m``); the path's note says so.
        current_margin_s: the obstacle margin grows with the water current (issue 23 item 4): a goal plan
            first inflates the obstacles by ``obstacle_margin_m`` + the larger of this times the estimated
            current (s x m/s: how far the vehicle drifts before its fins correct it) and the cross-track
            the vehicle has been measured to keep on the mission so far, at most ``current_margin_max_m``;
            where that finds no way, the nominal margin (with its fallbacks) and the path's note says so.
            0 = the fixed margin.
        current_margin_max_m: the most the margin grows for the current and the measured cross-track (m).
        replan_hold_m: a re-plan for the current (wider turns) is taken only where no point of it lies
            farther than this from the path flown (m; 0 = always taken): the path holds, the turns it has
            are flown in the current (a wider word that loops elsewhere is not taken, 9 m off the first
            plan in clutter_current r7).
        csc_only: True = the paper's candidate set (the four direction-consistent tangent words LSL, RSR,
            LSR, RSL); False = also the CCC words (RLR, LRL), the complete Dubins set.
    """

    turning_radius_m: float = param(
        3.0, unit="m", min=TURNING_RADIUS_MIN_M, operator=(0.0, 100.0), mavlink="PLN_R_MIN_M",
        desc="planning turning radius",
    )  # fmt: skip
    obstacle_margin_m: float = param(
        1.0, unit="m", min=0.0, operator=(0.0, 50.0), mavlink="PLN_MARGIN_M", desc="obstacle safety margin"
    )
    weight_distance: float = param(
        1.0, unit="1/m", min=_weight_min("weight_distance"), operator=(0.0, 1000.0), mavlink="PLN_W_D",
        desc="planner weight on distance",
    )  # fmt: skip
    weight_yaw: float = param(
        0.0, unit="1/rad", min=_weight_min("weight_yaw"), operator=(0.0, 1000.0), mavlink="PLN_W_PSI",
        desc="planner weight on cumulative yaw change",
    )  # fmt: skip
    weight_rudder: float = param(
        0.0, unit="1/(rad.m)", min=_weight_min("weight_rudder"), operator=(0.0, 1000.0), mavlink="PLN_W_DR",
        desc="planner weight on cumulative rudder",
    )  # fmt: skip
    max_depth_slope: float = param(
        0.25, min=DEPTH_SLOPE_MIN, operator=(0.0, 2.0), mavlink="PLN_MAX_SLOPE",
        desc="largest depth change per metre of path",
    )  # fmt: skip
    rudder_map_radius_m: tuple[float, ...] = _DEFAULT_MAP_RADIUS_M
    rudder_map_rudder_deg: tuple[float, ...] = _DEFAULT_MAP_RUDDER_DEG
    goal_run_in_m: float = param(
        0.0, unit="m", min=0.0, desc="straight run-in to a goal with a heading (0 = none)"
    )
    start_run_up_m: float = param(
        0.0, unit="m", min=0.0, desc="straight run-up along the start heading (0 = none)"
    )
    current_margin_s: float = param(
        4.0, unit="s", min=0.0, operator=(0.0, 60.0), mavlink="PLN_CUR_MRG_S",
        desc="obstacle margin added per m/s of estimated current (0 = fixed margin)",
    )  # fmt: skip
    current_margin_max_m: float = param(
        3.0, unit="m", min=0.0, operator=(0.0, 50.0), mavlink="PLN_CUR_MRG_MAX",
        desc="most the obstacle margin grows for the current and the measured cross-track",
    )  # fmt: skip
    replan_hold_m: float = param(
        3.0, unit="m", min=0.0, operator=(0.0, 50.0), mavlink="PLN_REPLAN_HOLD",
        desc="a re-plan for the current departing farther from the path flown is not taken (0 = always)",
    )  # fmt: skip
    min_turning_radius_m: float = 0.0
    min_obstacle_margin_m: float | None = None
    current_aware: bool = False
    csc_only: bool = False

    def __post_init__(self) -> None:
        check_declared(self, _config_error)
        t = self.min_turning_radius_m
        _check(
            _finite(t) and (t == 0.0 or t >= TURNING_RADIUS_MIN_M),
            "config",
            f"min_turning_radius_m must be 0 (none) or >= {TURNING_RADIUS_MIN_M:g} m and finite, got {t!r}",
        )
        mm = self.min_obstacle_margin_m
        _check(
            mm is None or (_finite(mm) and mm >= 0.0),
            "config",
            f"min_obstacle_margin_m must be >= 0 and finite, got {mm!r}",
        )
        radii, rudders = self.rudder_map_radius_m, self.rudder_map_rudder_deg
        _check(len(radii) >= 1, "config", "rudder_map_radius_m must have at least one entry")
        _check(
            len(radii) == len(rudders),
            "config",
            "rudder_map_radius_m and rudder_map_rudder_deg differ in length "
            f"({len(radii)} vs {len(rudders)})",
        )
        _check(
            all(_finite(x) and x > 0.0 for x in radii),
            "config",
            f"rudder_map_radius_m must be positive and finite, got {radii!r}",
        )
        _check(
            all(b > a for a, b in itertools.pairwise(radii)),
            "config",
            f"rudder_map_radius_m must be strictly increasing, got {radii!r}",
        )
        _check(
            all(_finite(x) and 0.0 <= x <= 90.0 for x in rudders),
            "config",
            f"rudder_map_rudder_deg must be in [0, 90] deg, got {rudders!r}",
        )

    @property
    def fallbacks(self) -> tuple[PlannerConfig, ...]:
        """The configurations a plan falls back to where this one finds no path, in order: the tighter
        turning radius (``min_turning_radius_m``), then it with the reduced margin
        (``min_obstacle_margin_m``); empty when neither is set."""
        out: list[PlannerConfig] = []
        cfg = self
        tight = self.min_turning_radius_m
        if 0.0 < tight < self.turning_radius_m:
            cfg = dataclasses.replace(cfg, turning_radius_m=tight)
            out.append(cfg)
        margin = self.min_obstacle_margin_m
        if margin is not None and margin < self.obstacle_margin_m:
            out.append(dataclasses.replace(cfg, obstacle_margin_m=margin))
        return tuple(out)

    def grown_margin_m(self, current_mps: float, cross_track_bound_m: float = 0.0) -> float:
        """The margin (m) added to ``obstacle_margin_m`` in a current of ``current_mps`` (m/s) by a vehicle
        measured to keep within ``cross_track_bound_m`` (m) of its path: the larger of
        ``current_margin_s`` x the current and the bound, at most ``current_margin_max_m`` (NaN counts 0)."""
        drift_m = self.current_margin_s * current_mps if current_mps > 0.0 else 0.0
        bound_m = cross_track_bound_m if cross_track_bound_m > 0.0 else 0.0
        return min(max(drift_m, bound_m), self.current_margin_max_m)

    @property
    def tightest(self) -> PlannerConfig:
        """The last of :attr:`fallbacks`, the tightest a plan may fall back to (itself when there is none):
        what the mission validator judges a goal's clearance with."""
        return (self.fallbacks or (self,))[-1]

    def without_fallbacks(self) -> PlannerConfig:
        """This configuration with no :attr:`fallbacks` of its own (e.g. the wide turns in a current, after
        which the nominal radius and its fallbacks come)."""
        return dataclasses.replace(self, min_turning_radius_m=0.0, min_obstacle_margin_m=None)
