"""Failsafes: pure checks that request ABORT, and the abort actuator command.

Checks (thresholds in the ``[failsafe]`` table, :class:`FailsafeParams`):

- ``NAV_STALE``: the navigation solution is unusable: a blocking :class:`~onboard.core.nav.types.NavCondition`
  (position invalid, attitude or depth missing, or stale: older than ``nav_timeout_s``, FS_NAV_TMO_S, the
  one staleness timeout, which the estimator applies:
  :meth:`onboard.core.nav.estimator.NavParams.with_stale_after`), or a non-finite position/depth.
- ``DEPTH_LIMIT``: depth below ``max_depth_m``.
- ``AREA_BOUND``: horizontal position outside the operating rectangle [area_x_min_m, area_x_max_m] x
  [area_y_min_m, area_y_max_m] (NED, m).
- ``OVERRUNS``: the loop has been behind its schedule continuously for more than ``max_loop_late_s`` (the
  loop says how long: from the first deadline it missed to the end of its latest tick; 0 once a tick ends
  before its next deadline). In seconds, not ticks, so the limit means the same at every control rate: one
  stall of the process (a loaded machine) counts for its length, a loop too slow for its rate for the time
  it keeps falling behind.

Any of them -> ``FailsafeResult.abort`` with a reason; the loop feeds ``MissionEvent.FAILSAFE`` with that
reason to the state machine and logs the flags in ``newly`` (set this tick) once, on the transition.

Abort (the vehicle is positively buoyant): propeller off, rudder centred, both stern planes at
``-abort_stern_deg`` (negative stern = nose up, by the sign convention), so it pitches up hard and climbs
to the surface, stopping ahead (from 1.2 m/s: 3.6 m at 1 m deep, 5.9 m at 5 m, 7.5 m at 10 m; never deeper).
Its default is the bus contract's ``ABORT_STERN_DEG``, the angle the actuator node takes on its own when
its command watchdog fires (the onboard, or the bus to it, is what failed).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

from auv_common.config import check_declared, param, require
from onboard.core.control.actuators import ActuatorCommand
from onboard.core.nav.estimator import NAV_TIMEOUT_DEFAULT_S
from onboard.core.nav.types import NavState
from onboard.protocol.messages import ABORT_STERN_DEG

#: The shortest navigation timeout that means one, s: the AHRS and the depth sensor send at 20 Hz
#: (``hil_sim/params/isimi100.toml``), so a shorter timeout aborts on data as fresh as they send it (and a
#: subnormal one on every tick). The parameter table serves it as FS_NAV_TMO_S's minimum.
NAV_TIMEOUT_MIN_S = 0.05
#: The shallowest depth limit that means one, m: shallower, waves and the depth sensor's noise trip it at
#: the surface, and no goal could be deeper than it.
MAX_DEPTH_MIN_M = 1.0


@dataclass(frozen=True)
class FailsafeParams:
    """The ``[failsafe]`` table. Every key is optional.

    - ``nav_timeout_s``: max age of attitude and depth (the one staleness timeout: the estimator marks them
      stale after it, and stale navigation aborts).
    - ``area_x_min_m``, ``area_x_max_m``, ``area_y_min_m``, ``area_y_max_m``: operating rectangle, NED m.
    - ``abort_stern_deg``: sent as negative stern.
    """

    nav_timeout_s: float = param(
        NAV_TIMEOUT_DEFAULT_S, unit="s", min=NAV_TIMEOUT_MIN_S, operator=(0.0, 10.0),
        mavlink="FS_NAV_TMO_S",
        desc="attitude or depth older than this is stale navigation: ABORT, START waits",
    )  # fmt: skip
    max_depth_m: float = param(
        10.0, unit="m", min=MAX_DEPTH_MIN_M, operator=(0.0, 100.0), mavlink="FS_MAX_DEPTH_M",
        desc="depth failsafe limit",
    )  # fmt: skip
    area_x_min_m: float = -500.0
    area_x_max_m: float = 500.0
    area_y_min_m: float = -500.0
    area_y_max_m: float = 500.0
    max_loop_late_s: float = param(
        0.5, unit="s", min=0.01, max=10.0,
        desc="the loop behind its schedule continuously for longer than this aborts",
    )  # fmt: skip
    abort_stern_deg: float = param(
        ABORT_STERN_DEG, unit="deg", min=0.0, max=45.0, mavlink="FS_ABORT_STN_DEG",
        desc="nose-up stern of the abort command",
    )  # fmt: skip
    abort_stern_rad: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        check_declared(self)
        require(self.area_x_min_m < self.area_x_max_m, "need area_x_min_m < area_x_max_m")
        require(self.area_y_min_m < self.area_y_max_m, "need area_y_min_m < area_y_max_m")
        object.__setattr__(self, "abort_stern_rad", math.radians(self.abort_stern_deg))


class FailsafeFlag(enum.IntFlag):
    """Which failsafe checks fail (bit flags; 0 = all pass)."""

    NAV_STALE = enum.auto()
    DEPTH_LIMIT = enum.auto()
    AREA_BOUND = enum.auto()
    OVERRUNS = enum.auto()


@dataclass(frozen=True)
class FailsafeState:
    """The failsafe memory: the flags of the previous check."""

    flags: FailsafeFlag = FailsafeFlag(0)  # noqa: RUF009 (an immutable IntFlag value)


@dataclass(frozen=True)
class FailsafeResult:
    """``abort``: request ABORT; ``flags``: failing checks; ``newly``: those that started failing this tick;
    ``reason``: one line naming each failing check and its numbers."""

    abort: bool
    flags: FailsafeFlag
    newly: FailsafeFlag
    reason: str


def check(
    nav: NavState, loop_late_s: float, state: FailsafeState, params: FailsafeParams
) -> tuple[FailsafeResult, FailsafeState]:
    """Run every failsafe check on the navigation solution ``nav`` and how long the loop has been behind its
    schedule, ``loop_late_s`` (s, 0 = on time)."""
    flags = FailsafeFlag(0)
    reasons: list[str] = []

    finite = math.isfinite(nav.x_m) and math.isfinite(nav.y_m) and math.isfinite(nav.depth_m)
    if not nav.valid or not finite:  # stale: the estimator's conditions, with params.nav_timeout_s
        flags |= FailsafeFlag.NAV_STALE
        reasons.append(
            f"navigation stale (conditions {nav.conditions.name or 0}, attitude age "
            f"{nav.attitude_age_s:.2f} s, depth age {nav.depth_age_s:.2f} s)"
        )
    if math.isfinite(nav.depth_m) and nav.depth_m > params.max_depth_m:
        flags |= FailsafeFlag.DEPTH_LIMIT
        reasons.append(f"depth {nav.depth_m:.2f} m beyond limit {params.max_depth_m:.2f} m")
    if finite and not (
        params.area_x_min_m <= nav.x_m <= params.area_x_max_m
        and params.area_y_min_m <= nav.y_m <= params.area_y_max_m
    ):
        flags |= FailsafeFlag.AREA_BOUND
        reasons.append(f"position ({nav.x_m:.1f}, {nav.y_m:.1f}) m outside the operating area")
    if loop_late_s > params.max_loop_late_s:
        flags |= FailsafeFlag.OVERRUNS
        reasons.append(
            f"control loop behind its schedule for {loop_late_s:.2f} s (limit {params.max_loop_late_s:g} s)"
        )

    new_state = state if flags == state.flags else FailsafeState(flags=flags)
    newly = flags & ~state.flags
    return FailsafeResult(abort=bool(flags), flags=flags, newly=newly, reason="; ".join(reasons)), new_state


#: The steepest nose-up pitch an ABORT flies (rad): the stern planes, hard over until the pitch nears it,
#: ease off (one radian of stern a radian of pitch error, within ``abort_stern_deg``) and go nose down
#: beyond. Hard over to the end, a vehicle aborted at 1.2 m/s from 10 m or deeper pitched over the top
#: (224 deg: a loop, upside down at the surface); held at 85 deg it climbs nearly vertically and stops ahead
#: sooner (10 m deep: 7.5 m against 9.6 m).
ABORT_PITCH_MAX_RAD = math.radians(85.0)


def abort_command(params: FailsafeParams, pitch_rad: float = math.nan) -> ActuatorCommand:
    """Propeller off, rudder centred, stern planes nose up (negative stern) to surface: hard over until the
    pitch ``pitch_rad`` nears :data:`ABORT_PITCH_MAX_RAD` (not known, e.g. the AHRS silent: hard over)."""
    stern = -params.abort_stern_rad
    if math.isfinite(pitch_rad):
        stern = min(max(pitch_rad - ABORT_PITCH_MAX_RAD, stern), params.abort_stern_rad)
    return ActuatorCommand(
        rudder_rad=0.0,
        stern_port_rad=stern,
        stern_starboard_rad=stern,
        propeller_rps=0.0,
    )
