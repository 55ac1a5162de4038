"""Actuator command, its flags, and the ONE place where limits are applied (:func:`saturate`).

Signs (``onboard/protocol/conventions.py``, Prestero's REMUS model): +rudder turns the vehicle to PORT
(negative yaw rate); +stern plane pitches NOSE DOWN. The stern is split into a port and a starboard plane;
their mean is the pitch (common) command and half their difference, starboard minus port, the roll
(differential) command. A positive differential lifts the starboard side of the tail more than the port side
and so rolls the vehicle to port (negative roll moment), which is what opposes a positive roll (starboard
down).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

from auv_common.config import Bound, check_declared, param
from onboard.protocol.conventions import stern_combine, stern_split


class ActuatorFlag(enum.IntFlag):
    """What :func:`saturate` did to the desired command (bit flags for telemetry; 0 = untouched)."""

    RUDDER_LIMIT = enum.auto()
    STERN_LIMIT = enum.auto()
    ROLL_LIMIT = enum.auto()
    PROPELLER_LIMIT = enum.auto()
    RUDDER_RATE = enum.auto()
    STERN_RATE = enum.auto()
    PROPELLER_RATE = enum.auto()
    NAN_INPUT = enum.auto()


@dataclass(frozen=True)
class ActuatorCommand:
    """Fin angles (rad, signs above) and propeller speed (rev/s); ``flags`` says how it was limited."""

    rudder_rad: float
    stern_port_rad: float
    stern_starboard_rad: float
    propeller_rps: float
    flags: ActuatorFlag = ActuatorFlag(0)  # noqa: RUF009 (an immutable IntFlag value)

    @property
    def stern_rad(self) -> float:
        """The common (pitch) stern command, rad."""
        return stern_combine(self.stern_port_rad, self.stern_starboard_rad)[0]

    @property
    def roll_diff_rad(self) -> float:
        """The differential (roll) stern command, rad."""
        return stern_combine(self.stern_port_rad, self.stern_starboard_rad)[1]

    def is_finite(self) -> bool:
        return (
            math.isfinite(self.rudder_rad)
            and math.isfinite(self.stern_port_rad)
            and math.isfinite(self.stern_starboard_rad)
            and math.isfinite(self.propeller_rps)
        )


#: Fins centred, propeller stopped.
NEUTRAL = ActuatorCommand(0.0, 0.0, 0.0, 0.0)


#: The smallest fin angle limit that means a fin (rudder, each stern plane), deg: the steady-turn table's
#: widest turn (50 m) needs 1.2 deg of rudder, so a limit below 1 deg cannot steer (and a subnormal one is
#: no limit anyone means). Stated here once; the parameter table serves it as the minimum.
FIN_LIMIT_MIN_DEG = 1.0
#: The smallest propeller speed range (max - min) that means a propeller, rev/s: below 1 rps (100 DBC
#: steps) the vehicle has no steerage way; a subnormal maximum is a stopped propeller that looks armed.
PROPELLER_SPAN_MIN_RPS = 1.0
_PROPELLER_MAX_MIN = Bound(
    lambda limits: limits.propeller_min_rps + PROPELLER_SPAN_MIN_RPS,
    f"propeller_min_rps + {PROPELLER_SPAN_MIN_RPS:g}",
)


@dataclass(frozen=True)
class ActuatorLimits:
    """The ``[control.limits]`` table: angle, speed and rate limits. A rate limit of 0 disables it.

    Each key is declared once below (unit, range, description, MAVLink name; ``docs/parameters.md``); the
    DBC's command ranges bound the angle and speed limits further (``onboard.core.params``).
    """

    rudder_limit_deg: float = param(
        20.0, unit="deg", min=FIN_LIMIT_MIN_DEG, max=45.0, mavlink="LIM_RUDDER_DEG", desc="rudder angle limit"
    )
    stern_limit_deg: float = param(
        20.0, unit="deg", min=FIN_LIMIT_MIN_DEG, max=45.0, mavlink="LIM_STERN_DEG",
        desc="stern-plane angle limit (each plane)",
    )  # fmt: skip
    propeller_min_rps: float = param(0.0, unit="rps", min=0.0, desc="propeller speed, lowest command")
    propeller_max_rps: float = param(
        30.0, unit="rps", min=_PROPELLER_MAX_MIN, operator=(0.0, 100.0), mavlink="LIM_RPS_MAX",
        desc="propeller speed limit",
    )  # fmt: skip
    fin_rate_limit_degps: float = param(
        60.0, unit="deg/s", min=0.0, operator=(0.0, 360.0), mavlink="LIM_FIN_RATE_DPS",
        desc="fin rate limit (0 = off)",
    )  # fmt: skip
    propeller_rate_limit_rps_per_s: float = param(
        20.0, unit="rps/s", min=0.0, operator=(0.0, 200.0), mavlink="LIM_RPS_RATE",
        desc="propeller acceleration limit (0 = off)",
    )  # fmt: skip
    rudder_limit_rad: float = field(init=False, repr=False)
    stern_limit_rad: float = field(init=False, repr=False)
    fin_rate_limit_radps: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        check_declared(self)
        object.__setattr__(self, "rudder_limit_rad", math.radians(self.rudder_limit_deg))
        object.__setattr__(self, "stern_limit_rad", math.radians(self.stern_limit_deg))
        object.__setattr__(self, "fin_rate_limit_radps", math.radians(self.fin_rate_limit_degps))


def _clamp(value: float, lo: float, hi: float) -> tuple[float, bool]:
    clamped = min(max(value, lo), hi)
    return clamped, clamped != value


def _rate(target: float, previous: float, rate: float, dt_s: float) -> tuple[float, bool]:
    """Move from ``previous`` towards ``target`` by at most rate*dt_s (rate 0 = unlimited)."""
    if rate <= 0.0:
        return target, False
    step = rate * dt_s
    return _clamp(target, previous - step, previous + step)


def saturate(
    desired: ActuatorCommand, previous: ActuatorCommand, limits: ActuatorLimits, dt_s: float
) -> ActuatorCommand:
    """Apply angle/speed limits, then rate limits against ``previous`` over ``dt_s`` (s); return the command
    with its :class:`ActuatorFlag` set.

    - NaN/inf anywhere in ``desired`` -> :data:`NEUTRAL` with ``NAN_INPUT`` (no rate limit: safety first).
    - The stern keeps pitch authority first: the common command is clamped to the plane limit and the roll
      differential gets what remains, so neither plane exceeds ``stern_limit``.
    - ``dt_s`` = 0 (or negative/NaN) allows no change: the previous command is held.
    """
    if not desired.is_finite():
        return ActuatorCommand(0.0, 0.0, 0.0, 0.0, ActuatorFlag.NAN_INPUT)
    flags = ActuatorFlag(0)
    dt_s = dt_s if math.isfinite(dt_s) and dt_s > 0.0 else 0.0

    rud_lim, st_lim = limits.rudder_limit_rad, limits.stern_limit_rad
    rudder, hit = _clamp(desired.rudder_rad, -rud_lim, rud_lim)
    if hit:
        flags |= ActuatorFlag.RUDDER_LIMIT
    common, diff = stern_combine(desired.stern_port_rad, desired.stern_starboard_rad)
    common, hit = _clamp(common, -st_lim, st_lim)
    if hit:
        flags |= ActuatorFlag.STERN_LIMIT
    room = st_lim - abs(common)
    diff, hit = _clamp(diff, -room, room)
    if hit:
        flags |= ActuatorFlag.ROLL_LIMIT
    port, stbd = stern_split(common, diff)
    rps, hit = _clamp(desired.propeller_rps, limits.propeller_min_rps, limits.propeller_max_rps)
    if hit:
        flags |= ActuatorFlag.PROPELLER_LIMIT

    fin_rate = limits.fin_rate_limit_radps
    rudder, hit = _rate(rudder, previous.rudder_rad, fin_rate, dt_s)
    if hit:
        flags |= ActuatorFlag.RUDDER_RATE
    port, hit_p = _rate(port, previous.stern_port_rad, fin_rate, dt_s)
    stbd, hit_s = _rate(stbd, previous.stern_starboard_rad, fin_rate, dt_s)
    if hit_p or hit_s:
        flags |= ActuatorFlag.STERN_RATE
    rps, hit = _rate(rps, previous.propeller_rps, limits.propeller_rate_limit_rps_per_s, dt_s)
    if hit:
        flags |= ActuatorFlag.PROPELLER_RATE

    # A previous command from outside (e.g. an abort command) may lie beyond the limits: clamp once more.
    rudder = min(max(rudder, -rud_lim), rud_lim)
    port = min(max(port, -st_lim), st_lim)
    stbd = min(max(stbd, -st_lim), st_lim)
    rps = min(max(rps, limits.propeller_min_rps), limits.propeller_max_rps)
    return ActuatorCommand(rudder, port, stbd, rps, flags)
