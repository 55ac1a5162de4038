"""The parameter table: generated from the running :class:`~onboard.core.config.CoreConfig`, bounded by the
configuration's own rules and by the DBC.

One table (``onboard/core/DESIGN.md``, "Parameters: one table"). Each :class:`ParamSpec` names the
configuration key it sets (``path``, e.g. ``control.limits.rudder_limit_deg``); its default is the running
configuration's value; its ``[min, max]`` is the intersection of

- the operator range declared below (``sane``: the widest value anyone could mean, for keys the
  configuration does not bound, e.g. the PD gains; widened to include the configured value),
- the configuration dataclass's own rules, *read from the dataclass* by trying values (no rule is
  written twice): the closure of the accepted values. Every bound the rules give is closed and means
  something: a key whose 0 is refused declares a meaningful minimum beside its rule (e.g.
  ``FIN_LIMIT_MIN_DEG`` in ``onboard.core.control.actuators``: ``rudder_limit_deg >= 1``), never an open
  ``> 0`` that a subnormal 1.4e-45 passes; so the configuration file and the parameter agree (a file value
  below the minimum stops start-up), the minimum is served as the parameter's ``min`` and a PARAM_SET
  below it is refused with the dataclass's reason, which states it,
- the DBC signal ranges of the command frames (:class:`BusLimits`, read from the DBC by the app), so no
  value in range can make a FIN_CMD / PROP_CMD that the codec refuses to encode.

:func:`apply_param` returns a new configuration (built with :func:`dataclasses.replace`, so every
``__post_init__`` rule runs, the ones that span several values included) or raises :class:`ParamError` with
a reason a human can act on. MAVLink carries float32: a value equal in float32 to ``min``, ``max`` or the
value in force is taken as exactly that value, and :func:`is_default` compares in float32.

Pure: no cantools here (the DBC ranges come in as data).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import struct
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from auv_common.config import ConfigError
from onboard.core.config import CoreConfig

NAME_MAX_CHARS = 16  # MAVLink param_id


class ParamError(ValueError):
    """A parameter value that is not applied; ``reason`` says why (one sentence for the operator)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class BusLimits:
    """The DBC ranges of the command signals the core's limits must stay within, SI units, (min, max).

    ``stern_rad`` is the range both stern planes can carry (the intersection of port and starboard).
    Fill it with :meth:`from_ranges` from ``onboard.protocol.codec.command_ranges()``.
    """

    rudder_rad: tuple[float, float]
    stern_rad: tuple[float, float]
    propeller_rps: tuple[float, float]

    def __post_init__(self) -> None:
        for name in ("rudder_rad", "stern_rad", "propeller_rps"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ConfigError(f"bus limit {name}: need finite min < max, got ({lo}, {hi})")

    @classmethod
    def from_ranges(cls, ranges: Mapping[str, tuple[float, float]]) -> BusLimits:
        """From ``{"FIN_CMD.rudder_rad": (lo, hi), ...}`` (``onboard.protocol.codec.command_ranges()``)."""
        try:
            port, stbd = ranges["FIN_CMD.stern_port_rad"], ranges["FIN_CMD.stern_starboard_rad"]
            return cls(
                rudder_rad=tuple(ranges["FIN_CMD.rudder_rad"]),  # type: ignore[arg-type]
                stern_rad=(max(port[0], stbd[0]), min(port[1], stbd[1])),
                propeller_rps=tuple(ranges["PROP_CMD.propeller_rps"]),  # type: ignore[arg-type]
            )
        except KeyError as exc:
            raise ConfigError(f"the DBC has no command signal {exc.args[0]}") from None


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: ``name`` (<= 16 chars), ``default`` (the configured value), inclusive ``[min, max]``,
    ``unit``, a one-line ``description`` and ``path``, the configuration key it sets."""

    name: str
    default: float
    min: float
    max: float
    unit: str
    description: str
    path: str

    def __post_init__(self) -> None:
        if not 1 <= len(self.name) <= NAME_MAX_CHARS:
            raise ValueError(f"parameter name {self.name!r} must have 1..{NAME_MAX_CHARS} characters")
        if not self.min <= self.default <= self.max:
            raise ValueError(
                f"parameter {self.name}: default {self.default} outside [{self.min}, {self.max}]"
            )


# --- float32 ------------------------------------------------------------------------------------------


def float32(x: float) -> float:
    """``x`` rounded to the nearest float32 (what MAVLink carries); beyond the float32 range: +-inf."""
    try:
        return float(struct.unpack("<f", struct.pack("<f", x))[0])
    except OverflowError:
        return math.copysign(math.inf, x)


def _f32_next(y: float, up: bool) -> float:
    """The float32 neighbour of the float32 value ``y`` (towards +inf when ``up``)."""
    if y == 0.0:
        tiny = float(struct.unpack("<f", struct.pack("<I", 1))[0])
        return tiny if up else -tiny
    bits = struct.unpack("<I", struct.pack("<f", y))[0]
    bits += 1 if (y > 0.0) == up else -1
    return float(struct.unpack("<f", struct.pack("<I", bits))[0])


def _f32_inward(x: float, up: bool) -> float:
    """The float32 nearest ``x`` on the inside: >= x when ``up`` (a lower bound), <= x otherwise."""
    y = float32(x)
    if (y < x) if up else (y > x):
        y = _f32_next(y, up)
    return y


def is_default(spec: ParamSpec, value: float) -> bool:
    """True if ``value`` is the spec's default as MAVLink carries it (equal in float32)."""
    return float32(value) == float32(spec.default)


# --- the declarations: the ONE list of parameters ---------------------------------------------------


@dataclass(frozen=True)
class _Decl:
    name: str
    path: str  # "{profile}" = the active control profile
    unit: str
    description: str
    sane: tuple[float, float]  # the operator range; the config's rules and the DBC narrow it


def _gain_decls() -> tuple[_Decl, ...]:
    # eqs. 8-10: which output each gain drives from which error (units from onboard.core.control.pd)
    rows = (
        ("rps", "e_x", "rps/m", "rps.s/m"),
        ("rps", "e_y", "rps/m", "rps.s/m"),
        ("rps", "e_z", "rps/m", "rps.s/m"),
        ("rudder", "e_x", "rad/m", "rad.s/m"),
        ("rudder", "e_y", "rad/m", "rad.s/m"),
        ("rudder", "e_psi", "rad/rad", "rad.s/rad"),
        ("stern", "e_z", "rad/m", "rad.s/m"),
        ("stern", "e_theta", "rad/rad", "rad.s/rad"),
    )
    out = []
    for i, (output, error, p_unit, d_unit) in enumerate(rows, start=1):
        out.append(_Decl(f"PD_KP{i}", f"control.{{profile}}.Kp{i}", p_unit, f"PD {output} P gain on {error}",
                         (-100.0, 100.0)))  # fmt: skip
        out.append(_Decl(f"PD_KD{i}", f"control.{{profile}}.KD{i}", d_unit, f"PD {output} D gain on {error}",
                         (-100.0, 100.0)))  # fmt: skip
    return tuple(out)


_DECLS: tuple[_Decl, ...] = (
    *_gain_decls(),
    _Decl("PD_RUD_FF_RADM", "control.{profile}.rudder_per_curvature_radm", "rad.m",
          "rudder feed-forward per path curvature", (0.0, 10.0)),
    _Decl("PD_ROLL_KP", "control.{profile}.roll_kp", "rad/rad", "roll damping P gain (split stern)",
          (-10.0, 10.0)),
    _Decl("PD_ROLL_KD", "control.{profile}.roll_kd", "rad.s/rad", "roll damping D gain (split stern)",
          (-10.0, 10.0)),
    _Decl("PD_DTAU_S", "control.{profile}.derivative_tau_s", "s", "derivative low-pass time constant",
          (0.0, 10.0)),
    _Decl("LIM_RUDDER_DEG", "control.limits.rudder_limit_deg", "deg", "rudder angle limit", (0.0, 90.0)),
    _Decl("LIM_STERN_DEG", "control.limits.stern_limit_deg", "deg", "stern-plane angle limit (each plane)",
          (0.0, 90.0)),
    _Decl("LIM_RPS_MAX", "control.limits.propeller_max_rps", "rps", "propeller speed limit", (0.0, 100.0)),
    _Decl("LIM_FIN_RATE_DPS", "control.limits.fin_rate_limit_degps", "deg/s", "fin rate limit (0 = off)",
          (0.0, 360.0)),
    _Decl("LIM_RPS_RATE", "control.limits.propeller_rate_limit_rps_per_s", "rps/s",
          "propeller acceleration limit (0 = off)", (0.0, 200.0)),
    _Decl("PLN_W_D", "planner.weight_distance", "1/m", "planner weight on distance", (0.0, 1000.0)),
    _Decl("PLN_W_PSI", "planner.weight_yaw", "1/rad", "planner weight on cumulative yaw change",
          (0.0, 1000.0)),
    _Decl("PLN_W_DR", "planner.weight_rudder", "1/(rad.m)", "planner weight on cumulative rudder",
          (0.0, 1000.0)),
    _Decl("PLN_MARGIN_M", "planner.obstacle_margin_m", "m", "obstacle safety margin", (0.0, 50.0)),
    _Decl("PLN_R_MIN_M", "planner.turning_radius_m", "m", "planning turning radius", (0.0, 100.0)),
    _Decl("PLN_MAX_SLOPE", "planner.max_depth_slope", "", "largest depth change per metre of path",
          (0.0, 2.0)),
    _Decl("GDE_SPEED_MPS", "guidance.speed_mps", "m/s", "speed along the path", (0.0, 5.0)),
    _Decl("GDE_LOOKAHD_M", "guidance.lookahead_m", "m", "LOS lookahead distance", (0.0, 50.0)),
    _Decl("GDE_ILOS_GAIN", "guidance.ilos_gain", "", "ILOS integral gain", (0.0, 10.0)),
    _Decl("GDE_XERR_LIM_M", "guidance.cross_error_limit_m", "m", "cross-track error limit (0 = none)",
          (0.0, 50.0)),
    _Decl("GDE_PREVIEW_S", "guidance.curvature_preview_s", "s", "curvature feed-forward preview",
          (0.0, 10.0)),
    _Decl("GDE_ACCEL_MPS2", "guidance.reference_accel_mps2", "m/s^2", "track reference acceleration",
          (0.0, 5.0)),
    _Decl("MIS_ARRIVE_R_M", "mission.arrival_radius_m", "m", "goal arrival radius", (0.0, 100.0)),
    _Decl("MIS_MAX_TRIES", "mission.max_tries", "", "attempts at one goal before HOLD", (1.0, 100.0)),
    _Decl("MIS_LOITER_R_M", "mission.loiter_radius_m", "m", "loiter radius (0 = twice the turning radius)",
          (0.0, 1000.0)),
    _Decl("FS_MAX_DEPTH_M", "failsafe.max_depth_m", "m", "depth failsafe limit", (0.0, 100.0)),
    _Decl("FS_NAV_TMO_S", "failsafe.nav_timeout_s", "s", "navigation staleness timeout", (0.0, 10.0)),
    _Decl("FS_ABORT_STN_DEG", "failsafe.abort_stern_deg", "deg", "nose-up stern of the abort command",
          (0.0, 90.0)),
)  # fmt: skip

_BY_NAME: dict[str, _Decl] = {d.name: d for d in _DECLS}
if len(_BY_NAME) != len(_DECLS):  # pragma: no cover - a declaration mistake
    raise RuntimeError("duplicate parameter names")

PARAM_NAMES: tuple[str, ...] = tuple(d.name for d in _DECLS)


def _deg_within(rad_range: tuple[float, float]) -> float:
    """The largest float32 angle in degrees whose radians fit within +-the range's magnitude."""
    magnitude = min(-rad_range[0], rad_range[1])
    deg = _f32_inward(math.degrees(magnitude), up=False)
    while math.radians(deg) > magnitude:
        deg = _f32_next(deg, up=False)
    return deg


# The DBC bound of each configuration key that reaches a command frame, in the key's unit: (lo, hi, what).
# Used for the table's ranges and for the start-up check (check_against_bus), the one place it is written.
_BUS_BOUNDS: dict[str, Any] = {
    "control.limits.rudder_limit_deg": lambda b: (-math.inf, _deg_within(b.rudder_rad), "FIN_CMD rudder"),
    "control.limits.stern_limit_deg": lambda b: (-math.inf, _deg_within(b.stern_rad), "FIN_CMD stern"),
    "control.limits.propeller_max_rps": lambda b: (
        _f32_inward(b.propeller_rps[0], up=True),
        _f32_inward(b.propeller_rps[1], up=False),
        "PROP_CMD propeller",
    ),
    "control.limits.propeller_min_rps": lambda b: (
        _f32_inward(b.propeller_rps[0], up=True),
        _f32_inward(b.propeller_rps[1], up=False),
        "PROP_CMD propeller",
    ),
}


# --- reading the configuration's rules by trying values ---------------------------------------------


def _path(decl: _Decl, config: CoreConfig) -> str:
    return decl.path.format(profile=config.control.profile)


def _get(config: Any, path: str) -> Any:
    node = config
    for part in path.split("."):
        node = getattr(node, part)
    return node


def _replace(node: Any, parts: list[str], value: Any) -> Any:
    """``node`` with the key at ``parts`` set to ``value``, every dataclass on the way rebuilt (so every
    ``__post_init__`` runs)."""
    head = parts[0]
    new = value if len(parts) == 1 else _replace(getattr(node, head), parts[1:], value)
    return dataclasses.replace(node, **{head: new})


def _refusal(leaf: Any, key: str, value: float) -> str | None:
    """None if the dataclass ``leaf`` accepts ``value`` for ``key``, else its reason."""
    try:
        dataclasses.replace(leaf, **{key: value})
    except (ValueError, TypeError) as exc:  # ConfigError (require) and PlannerConfigError are ValueErrors
        return str(exc) or type(exc).__name__
    return None


def _ordered(x: float) -> int:
    """Floats as integers in the same order, neighbours one apart."""
    bits = struct.unpack("<Q", struct.pack("<d", x))[0]
    return -(bits & ((1 << 63) - 1)) if bits >> 63 else bits


def _unordered(i: int) -> float:
    bits = (-i) | (1 << 63) if i < 0 else i
    return float(struct.unpack("<d", struct.pack("<Q", bits))[0])


def _config_bound(leaf: Any, key: str, start: float, end: float) -> float:
    """The bound of the values the dataclass accepts going from ``start`` (accepted) towards ``end``.

    ``end`` if accepted; else the boundary found by bisection to the last float, taken as the closure
    (of the two neighbouring floats at the boundary, the one the rule's constant is: the shorter number),
    so ``x >= 1`` gives 1 and ``x <= 45`` gives 45 (an open ``x > 0`` would give 0, itself refused: the
    rules declare closed, meaningful bounds instead, see the module docstring).
    """
    if _refusal(leaf, key, end) is None:
        return end
    good, bad = _ordered(start), _ordered(end)
    while abs(good - bad) > 1:
        mid = (good + bad) // 2
        if _refusal(leaf, key, _unordered(mid)) is None:
            good = mid
        else:
            bad = mid
    a, r = _unordered(good), _unordered(bad)
    return r if len(repr(r)) < len(repr(a)) else a


@dataclass(frozen=True)
class _Bounds:
    spec: ParamSpec
    lo_why: str  # where min comes from, for the refusal reason
    hi_why: str


@functools.lru_cache(maxsize=1024)
def _bounds(decl: _Decl, path: str, leaf: Any, bus: BusLimits) -> _Bounds:
    key = path.rsplit(".", 1)[1]
    default = float(getattr(leaf, key))
    sane_lo, sane_hi = min(decl.sane[0], default), max(decl.sane[1], default)
    lo, hi = _config_bound(leaf, key, default, sane_lo), _config_bound(leaf, key, default, sane_hi)
    lo_why = "the configuration's rules" if lo != sane_lo else "the operator range"
    hi_why = "the configuration's rules" if hi != sane_hi else "the operator range"
    if path in _BUS_BOUNDS:
        bus_lo, bus_hi, what = _BUS_BOUNDS[path](bus)
        if bus_lo > lo:
            lo, lo_why = bus_lo, f"the DBC {what} range"
        if bus_hi < hi:
            hi, hi_why = bus_hi, f"the DBC {what} range"
    spec = ParamSpec(decl.name, default, lo, hi, decl.unit, decl.description, path)
    return _Bounds(spec, lo_why, hi_why)


def _decl(name: str) -> _Decl:
    decl = _BY_NAME.get(name)
    if decl is None:
        raise ParamError(f"unknown parameter {name!r}")
    return decl


def _bounds_for(config: CoreConfig, name: str, bus: BusLimits) -> _Bounds:
    decl = _decl(name)
    path = _path(decl, config)
    return _bounds(decl, path, _get(config, path.rsplit(".", 1)[0]), bus)


def _fmt(value: float, unit: str) -> str:
    return f"{value:g} {unit}" if unit else f"{value:g}"


# --- the API ----------------------------------------------------------------------------------------


def check_against_bus(config: CoreConfig, bus_limits: BusLimits) -> None:
    """Raise :class:`ConfigError` (one line) if a configured limit exceeds the DBC command ranges."""
    for path, bound in _BUS_BOUNDS.items():
        value = float(_get(config, path))
        lo, hi, what = bound(bus_limits)
        if not lo <= value <= hi:
            raise ConfigError(
                f"{path} = {value:g} is outside the DBC {what} range [{lo:g}, {hi:g}]: "
                "the vehicle could command a frame the bus refuses"
            )


def param_table(config: CoreConfig, bus_limits: BusLimits) -> tuple[ParamSpec, ...]:
    """Every parameter, with the values of ``config`` as defaults. Raises :class:`ConfigError` if the
    configured limits themselves exceed the DBC ranges (:func:`check_against_bus`)."""
    check_against_bus(config, bus_limits)
    return tuple(_bounds_for(config, d.name, bus_limits).spec for d in _DECLS)


def param_path(config: CoreConfig, name: str) -> str:
    """The configuration key parameter ``name`` sets (gains: those of the active profile)."""
    return _path(_decl(name), config)


def param_value(config: CoreConfig, name: str) -> float:
    """The value in force of parameter ``name`` (raises :class:`ParamError` for an unknown name)."""
    return float(_get(config, param_path(config, name)))


def apply_param(config: CoreConfig, name: str, value: float, bus_limits: BusLimits) -> CoreConfig:
    """``config`` with parameter ``name`` set to ``value``, or :class:`ParamError` with the reason: unknown
    name, not a finite number, outside ``[min, max]`` (the configuration's own reason where it has one), not
    a whole number for a count, or refused by a rule of the configuration that spans several values."""
    try:
        check_against_bus(config, bus_limits)
    except ConfigError as exc:
        raise ParamError(f"{name} not set: the running configuration is not within the DBC: {exc}") from None
    b = _bounds_for(config, name, bus_limits)
    spec = b.spec
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ParamError(f"{name}: {value!r} is not a number") from None
    if not math.isfinite(value):
        raise ParamError(f"{name}: {value!r} is not a finite number")
    # MAVLink carries float32: the float32 of a bound or of the value in force means exactly that value.
    v32 = float32(value)
    for exact in (spec.default, spec.min, spec.max):
        if v32 == float32(exact):
            value = exact
            break
    key = spec.path.rsplit(".", 1)[1]
    leaf = _get(config, spec.path.rsplit(".", 1)[0])
    new: Any = value
    current = getattr(leaf, key)
    if isinstance(current, int) and not isinstance(current, bool):
        if value != math.floor(value):
            raise ParamError(f"{name} = {value:g} refused: a count, it must be a whole number")
        new = int(value)
    if not spec.min <= value <= spec.max:
        own = _refusal(leaf, key, new)
        allowed = f"allowed [{spec.min:g}, {_fmt(spec.max, spec.unit)}]"
        if own is not None:  # the configuration's reason, and the range it gives with the values in force
            raise ParamError(f"{name} = {value:g} refused: {own}; {allowed}")
        low = value < spec.min
        bound, why = (spec.min, b.lo_why) if low else (spec.max, b.hi_why)
        raise ParamError(
            f"{name} = {_fmt(value, spec.unit)} is {'below the minimum' if low else 'above the maximum'} "
            f"{_fmt(bound, spec.unit)} ({why}; allowed [{spec.min:g}, {spec.max:g}])"
        )
    try:
        return _replace(config, spec.path.split("."), new)
    except (ValueError, TypeError) as exc:
        raise ParamError(f"{name} = {value:g} refused: {exc}") from None


__all__ = [
    "NAME_MAX_CHARS",
    "PARAM_NAMES",
    "BusLimits",
    "ParamError",
    "ParamSpec",
    "apply_param",
    "check_against_bus",
    "float32",
    "is_default",
    "param_path",
    "param_table",
    "param_value",
]
