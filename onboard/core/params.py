"""The parameter table: the settings of :class:`~onboard.core.config.CoreConfig` declared with a MAVLink
name, their defaults the running configuration's values, bounded by their declarations and by the DBC.

Each parameter is declared once, beside its default, with ``auv_common.config.param`` (unit, closed range,
description, MAVLink name; e.g. ``PdGains.Kp5`` is ``PD_KP5``). The dataclass's ``__post_init__`` enforces
the range (the TOML file, ``--set`` and every PARAM_SET go through it); this module reads the same
declarations for the table (``onboard/core/DESIGN.md``, "Parameters: one table") and
:func:`parameters_markdown` renders them as ``docs/parameters.md``. A parameter's ``[min, max]`` is the
intersection of

- its declared range (a number, or a ``Bound`` on other values of its table, evaluated with the values in
  force: e.g. LIM_RPS_MAX >= propeller_min_rps + 1); every bound is closed and means something: a key
  whose 0 is refused declares a meaningful minimum (e.g. ``FIN_LIMIT_MIN_DEG``), never an open ``> 0``
  that a subnormal 1.4e-45 passes, so the file and the parameter agree,
- its operator range (``operator``: the widest value a ground station may set, for keys the configuration
  bounds loosely, e.g. the PD gains; widened to include the configured value),
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
import math
import struct
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from auv_common.config import (
    MARKDOWN_HEADER,
    Bound,
    ConfigError,
    Param,
    bound_notes,
    declared,
    declared_bounds,
    declared_markdown,
    markdown_row,
    range_cell,
)
from onboard.core.config import CoreConfig
from onboard.core.control.pd import ProfileName

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


# --- the declarations, read from the configuration's dataclasses -------------------------------------

#: The tables the parameter table reads, in its order ("{profile}": the active control profile's gains).
SECTIONS: tuple[str, ...] = (
    "control.{profile}",
    "control.limits",
    "planner",
    "guidance",
    "mission",
    "failsafe",
    "diagnosis",
)


@dataclass(frozen=True)
class _Entry:
    name: str  # the MAVLink name
    section: str  # a member of SECTIONS
    key: str
    meta: Param


def _get(config: Any, path: str) -> Any:
    node = config
    for part in path.split(".") if path else ():
        node = getattr(node, part)
    return node


def _read_entries() -> tuple[_Entry, ...]:
    defaults = CoreConfig()
    out = []
    for section in SECTIONS:
        table = type(_get(defaults, section.format(profile=defaults.control.profile)))
        for key, meta in declared(table):
            if meta.mavlink is not None:
                out.append(_Entry(meta.mavlink, section, key, meta))
    return tuple(out)


_ENTRIES: tuple[_Entry, ...] = _read_entries()
_BY_NAME: dict[str, _Entry] = {e.name: e for e in _ENTRIES}
if len(_BY_NAME) != len(_ENTRIES):  # pragma: no cover - a declaration mistake
    raise RuntimeError("duplicate parameter names")

PARAM_NAMES: tuple[str, ...] = tuple(e.name for e in _ENTRIES)


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


# --- the range of one parameter -----------------------------------------------------------------------


def _path(entry: _Entry, config: CoreConfig) -> str:
    return f"{entry.section.format(profile=config.control.profile)}.{entry.key}"


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


@dataclass(frozen=True)
class _Bounds:
    spec: ParamSpec
    lo_why: str  # where min comes from, for the refusal reason
    hi_why: str


def _bounds(entry: _Entry, config: CoreConfig, bus: BusLimits) -> _Bounds:
    """The declared range (with the values in force) within the operator range (widened to the configured
    value) and the DBC's."""
    path = _path(entry, config)
    leaf = _get(config, path.rsplit(".", 1)[0])
    default = float(getattr(leaf, entry.key))
    rule_lo, rule_hi = declared_bounds(leaf, entry.key)
    op_lo, op_hi = entry.meta.operator or (-math.inf, math.inf)
    op_lo, op_hi = min(op_lo, default), max(op_hi, default)
    lo, lo_why = (rule_lo, "the configuration's rules") if rule_lo > op_lo else (op_lo, "the operator range")
    hi, hi_why = (rule_hi, "the configuration's rules") if rule_hi < op_hi else (op_hi, "the operator range")
    if path in _BUS_BOUNDS:
        bus_lo, bus_hi, what = _BUS_BOUNDS[path](bus)
        if bus_lo > lo:
            lo, lo_why = bus_lo, f"the DBC {what} range"
        if bus_hi < hi:
            hi, hi_why = bus_hi, f"the DBC {what} range"
    spec = ParamSpec(entry.name, default, lo, hi, entry.meta.unit, entry.meta.desc, path)
    return _Bounds(spec, lo_why, hi_why)


def _entry(name: str) -> _Entry:
    entry = _BY_NAME.get(name)
    if entry is None:
        raise ParamError(f"unknown parameter {name!r}")
    return entry


def _bounds_for(config: CoreConfig, name: str, bus: BusLimits) -> _Bounds:
    return _bounds(_entry(name), config, bus)


def _fmt(value: float, unit: str) -> str:
    return f"{value:g} {unit}" if unit else f"{value:g}"


# --- the reference page ---------------------------------------------------------------------------------

_PAGE_HEAD = """# Parameters

Generated by `python -m onboard.app.params_doc > docs/parameters.md` from the declarations in the code; do
not edit it by hand (`tests/unit/params/test_params_doc.py` fails when it is out of date).

Every setting below is declared once, beside its default, in the dataclass of its `onboard.toml` table
(`auv_common.config.param`: unit, range, description, MAVLink name); the configuration loader, the MAVLink
parameter table and this page read that declaration.

- **Config key**: the key in `onboard/config/onboard.toml` (or `--set KEY=VALUE`); a value outside the range
  stops start-up with one line.
- **MAVLink**: the parameter a ground station reads and sets (PARAM_SET, float32); a PARAM_SET outside the
  range is refused with the reason in a STATUSTEXT and the value in force. The gains are those of the active
  profile (`control.profile`).
- **Range**: closed (`[a, b]`, `>=`) unless written open (`(a, b)`, `>`); for a MAVLink parameter, the range
  the vehicle serves with the defaults below. Notes: *operator range*, a ground station may set no further (a
  configured value beyond it widens it); *DBC*, the command frame's signal range narrows it; a rule on other
  values of the table is named. `-`: not a number (a name, a flag, a path): its type and its rules are
  checked at start-up.
- **Default**: the dataclass's default (the packaged `onboard.toml` may set another).
"""


def _notes(meta: Param, b: _Bounds | None) -> list[str]:
    """Where each end of a range comes from, where it is not a plain number of the declaration."""
    if b is None:
        return bound_notes(meta)
    ends = []
    for end, bound, why in (("min", meta.min, b.lo_why), ("max", meta.max, b.hi_why)):
        if isinstance(bound, Bound):
            ends.append((end, bound.why))
        elif why and why != "the configuration's rules":
            ends.append((end, why.removeprefix("the ")))
    if len(ends) == 2 and ends[0][1] == ends[1][1]:
        return [ends[0][1]]
    return [f"{end}: {why}" for end, why in ends]


_HEADER = [markdown_row(("MAVLink", *MARKDOWN_HEADER)), "|---|---|---|---|---|---|"]


def _row(key: str, meta: Param, section: str, lo: float, hi: float, default: str, b: _Bounds | None) -> str:
    row = (
        f"`{meta.mavlink}`" if meta.mavlink else "-",
        f"`{section.replace('{profile}', '<profile>')}.{key}`",
        meta.unit or "-",
        range_cell(meta, lo, hi, _notes(meta, b)),
        default,
        meta.desc,
    )
    return markdown_row(row)


def parameters_markdown(bus_limits: BusLimits, more: Sequence[tuple[str, Any]] = ()) -> str:
    """``docs/parameters.md``: every declared setting of the parameter table's sections, one Markdown table
    per section (MAVLink name, config key, unit, range, default, description), with the defaults of
    :class:`CoreConfig` and the DBC ranges ``bus_limits``; then the tables ``more`` (``(table name, its
    default dataclass)``, e.g. the app's ``[mavlink]``), which have no MAVLink parameter."""
    defaults = CoreConfig()
    profiles: tuple[ProfileName, ...] = ("improved", "paper")
    configs = {
        p: dataclasses.replace(defaults, control=dataclasses.replace(defaults.control, profile=p))
        for p in profiles
    }
    out = [_PAGE_HEAD]
    for section in SECTIONS:
        path = section.format(profile=defaults.control.profile)
        leaf = _get(defaults, path)
        if "{profile}" in section:
            title = " and ".join(f"`[{section.format(profile=p)}]`" for p in profiles)
            title += ": the PD gains of the active profile"
        else:
            title = f"`[{path}]`"
        out += [f"## {title}", "", *_HEADER]
        for key, meta in declared(type(leaf)):
            b = _bounds(_BY_NAME[meta.mavlink], defaults, bus_limits) if meta.mavlink is not None else None
            lo, hi = (b.spec.min, b.spec.max) if b is not None else declared_bounds(leaf, key)
            values = {p: getattr(_get(configs[p], section.format(profile=p)), key) for p in profiles}
            default = (
                " / ".join(f"{v:g} ({p})" for p, v in values.items())
                if len(set(values.values())) > 1
                else f"{getattr(leaf, key):g}"
            )
            out.append(_row(key, meta, section, lo, hi, default, b))
        out.append("")
    for path, table in more:
        out += declared_markdown(path, table, mavlink=True)
    return "\n".join(out)


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
    return tuple(_bounds(e, config, bus_limits).spec for e in _ENTRIES)


def param_path(config: CoreConfig, name: str) -> str:
    """The configuration key parameter ``name`` sets (gains: those of the active profile)."""
    return _path(_entry(name), config)


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
    "parameters_markdown",
]
