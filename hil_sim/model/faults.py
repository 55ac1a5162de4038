"""Faults the bench injects (issue 24 item 4): one schedule per run, pure, shared by ``auv-hil run`` and
campaign specs.

Six kinds, each a frozen dataclass validated on construction (every refusal names the key and why):

- ``dvl_dropout``: no DVL frame while active (the sensor is silent: bottom lock lost);
- ``fix_outage``: no POSITION_FIX while active (LBL / tracking lost);
- ``compass_bias``: the AHRS heading reads ``bias_deg`` more than the truth (wrapped);
- ``depth_stuck``: the depth sensor repeats its first reading at or after ``start_s``;
- ``fin_stuck``: ``fin`` (rudder, stern_port, stern_starboard) is driven to ``angle_deg`` at its slew rate
  and held there whatever is commanded; FIN_STATUS reports it (it is the truth);
- ``thrust_loss``: the propeller turns as commanded (PROP_STATUS unchanged) but gives ``1 - fraction`` of
  its thrust (a fouled or damaged blade).

Every kind has ``start_s`` (simulated s after the start, >= 0) and an optional ``duration_s`` (> 0; absent:
to the end of the run). A fault is active on ``start_s <= t < start_s + duration_s``: a sensor sample by its
own ``t_sample_s``, an actuator over the control period that starts at ``t``. The fault clock is the run's
simulated time, which starts when the onboard reports RUNNING: the samples the bench sends while the vehicle
waits at rest before that are not faulted (a fix outage from 0 s still lets the vehicle start, as after a
surface fix).

Seeded: no fault draws a random number. Faults act on the measurements after they are sampled, so a run's
sensor noise is the same with and without faults (a faulted run differs from its fault-free twin only by the
fault) and one seed still reproduces a run bit for bit.

Given as mappings ``{kind: dvl_dropout, start_s: 10, duration_s: 20}`` (campaign specs,
:func:`parse_faults`) or ``kind=dvl_dropout,start_s=10,duration_s=20`` (``auv-hil run --fault``,
:func:`parse_fault_option`); both end in :func:`parse_fault`, the one parser.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from hil_sim.model.actuators import ActuatorCommand
from hil_sim.model.params import Coefficients
from hil_sim.model.sensors import (
    AhrsMeasurement,
    DepthMeasurement,
    DvlMeasurement,
    Measurement,
    PositionFix,
)
from onboard.protocol.conventions import wrap_pi

#: The fins a ``fin_stuck`` may name (the fields of :class:`ActuatorCommand` without ``_rad``).
FINS = ("rudder", "stern_port", "stern_starboard")
#: The largest stuck fin angle (deg): FIN_STATUS's range (the vehicle's own fin limit clips further).
MAX_FIN_ANGLE_DEG = 30.0
#: The largest compass bias (deg).
MAX_BIAS_DEG = 180.0


class FaultError(ValueError):
    """A bad fault: one line ``KEY: what is wrong`` (the caller adds where the fault came from).

    ``key`` is the key at fault ("" for the whole fault), ``problem`` what is wrong with it.
    """

    def __init__(self, key: str, problem: str) -> None:
        super().__init__(f"{key}: {problem}" if key else problem)
        self.key = key
        self.problem = problem


def _finite(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FaultError(key, f"expected a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise FaultError(key, f"must be finite, got {value!r}")
    return out


@dataclass(frozen=True, slots=True)
class _Window:
    """When a fault acts: from ``start_s`` for ``duration_s`` (None: to the end of the run), simulated s."""

    kind: ClassVar[str] = ""
    start_s: float
    duration_s: float | None = None

    def __post_init__(self) -> None:
        start = _finite("start_s", self.start_s)
        if start < 0.0:
            raise FaultError("start_s", f"must be >= 0 (s after the start), got {self.start_s!r}")
        if self.duration_s is not None and _finite("duration_s", self.duration_s) <= 0.0:
            raise FaultError(
                "duration_s", f"must be > 0 (omit it for a fault to the end), got {self.duration_s!r}"
            )

    @property
    def end_s(self) -> float:
        """When it stops acting (inf: never)."""
        return math.inf if self.duration_s is None else self.start_s + self.duration_s

    def active(self, t_s: float) -> bool:
        """True at ``t_s`` (simulated s): ``start_s <= t_s < end_s``."""
        return self.start_s <= t_s < self.end_s


@dataclass(frozen=True, slots=True)
class DvlDropout(_Window):
    """No DVL frame while active."""

    kind: ClassVar[str] = "dvl_dropout"


@dataclass(frozen=True, slots=True)
class FixOutage(_Window):
    """No POSITION_FIX while active."""

    kind: ClassVar[str] = "fix_outage"


@dataclass(frozen=True, slots=True)
class CompassBias(_Window):
    """The AHRS heading reads ``bias_deg`` (deg, + clockwise from north) more than the truth while active."""

    kind: ClassVar[str] = "compass_bias"
    bias_deg: float = 0.0

    def __post_init__(self) -> None:
        _Window.__post_init__(self)
        bias = _finite("bias_deg", self.bias_deg)
        if not 0.0 < abs(bias) <= MAX_BIAS_DEG:
            raise FaultError(
                "bias_deg", f"must be non-zero, within +-{MAX_BIAS_DEG:g} deg, got {self.bias_deg!r}"
            )


@dataclass(frozen=True, slots=True)
class DepthStuck(_Window):
    """The depth sensor repeats its first reading at or after ``start_s`` while active."""

    kind: ClassVar[str] = "depth_stuck"


@dataclass(frozen=True, slots=True)
class FinStuck(_Window):
    """``fin`` is driven to ``angle_deg`` (deg; the fin signs of :class:`ActuatorCommand`) at its slew rate
    and held there while active, whatever is commanded."""

    kind: ClassVar[str] = "fin_stuck"
    fin: str = "rudder"
    angle_deg: float = 0.0

    def __post_init__(self) -> None:
        _Window.__post_init__(self)
        if self.fin not in FINS:
            raise FaultError("fin", f"must be one of {', '.join(FINS)}, got {self.fin!r}")
        angle = _finite("angle_deg", self.angle_deg)
        if abs(angle) > MAX_FIN_ANGLE_DEG:
            raise FaultError(
                "angle_deg", f"must be within +-{MAX_FIN_ANGLE_DEG:g} deg, got {self.angle_deg!r}"
            )


@dataclass(frozen=True, slots=True)
class ThrustLoss(_Window):
    """The propeller gives ``1 - fraction`` of its thrust while active (its rps, PROP_STATUS, unchanged)."""

    kind: ClassVar[str] = "thrust_loss"
    fraction: float = 0.0

    def __post_init__(self) -> None:
        _Window.__post_init__(self)
        fraction = _finite("fraction", self.fraction)
        if not 0.0 < fraction <= 1.0:
            raise FaultError(
                "fraction", f"must be in (0, 1] (the share of thrust lost), got {self.fraction!r}"
            )


Fault = DvlDropout | FixOutage | CompassBias | DepthStuck | FinStuck | ThrustLoss
#: kind -> class, in the order of the truth log's ``fault_*`` columns.
KINDS: dict[str, type[Fault]] = {
    c.kind: c for c in (DvlDropout, FixOutage, CompassBias, DepthStuck, FinStuck, ThrustLoss)
}
#: The truth log's columns, one per kind: 1 while a fault of that kind is active.
TRUTH_COLUMNS = tuple(f"fault_{kind}" for kind in KINDS)


def _keys(cls: type[Fault]) -> tuple[str, ...]:
    return ("kind", *(f.name for f in dataclasses.fields(cls)))


def _required(cls: type[Fault]) -> tuple[str, ...]:
    """The keys without a usable default: the window's start and the kind's own parameters."""
    return tuple(f.name for f in dataclasses.fields(cls) if f.name != "duration_s")


# ----------------------------------------------------------------------------------------------------
# Parsing: the one parser (campaign specs and the command line)


def parse_fault(data: Any) -> Fault:
    """A fault from a mapping ``{kind: ..., start_s: ..., ...}``; raises :class:`FaultError` (``KEY: why``).

    Unknown keys are refused with the kind's known ones; every kind needs ``start_s`` and its own parameters
    (``bias_deg``; ``fin`` and ``angle_deg``; ``fraction``); ``duration_s`` is optional (to the end).
    """
    if not isinstance(data, Mapping):
        raise FaultError("", f"expected a mapping {{kind: ..., start_s: ...}}, got {data!r}")
    kind = data.get("kind")
    if kind not in KINDS:
        got = "none" if kind is None else repr(kind)
        raise FaultError("kind", f"must be one of {', '.join(KINDS)}, got {got}")
    cls = KINDS[kind]
    known = _keys(cls)
    for key in data:
        if key not in known:
            raise FaultError(key, f"unknown key for {kind} (known: {', '.join(known)})")
    for key in _required(cls):
        if key not in data:
            raise FaultError(key, f"missing (a {kind} needs {', '.join(_required(cls))})")
    args = {k: v for k, v in data.items() if k != "kind"}
    if "fin" in args and not isinstance(args["fin"], str):
        raise FaultError("fin", f"must be one of {', '.join(FINS)}, got {args['fin']!r}")
    for key, value in args.items():
        if key != "fin" and not (key == "duration_s" and value is None):
            args[key] = _finite(key, value)
    return cls(**args)


def parse_faults(data: Any) -> tuple[Fault, ...]:
    """A run's faults from a list of mappings (``[]`` or ``None``: none); a problem names its index:
    ``[1].start_s: ...``."""
    if data is None:
        return ()
    if not isinstance(data, list | tuple):
        raise FaultError("", f"expected a list of faults [{{kind: ..., start_s: ...}}, ...], got {data!r}")
    out = []
    for i, item in enumerate(data):
        try:
            out.append(parse_fault(item))
        except FaultError as exc:
            raise FaultError(f"[{i}].{exc.key}" if exc.key else f"[{i}]", exc.problem) from None
    return tuple(out)


def parse_fault_option(text: str) -> Fault:
    """``auv-hil run --fault`` text ``kind=KIND,KEY=VALUE,...`` (numbers as numbers, ``fin`` a name)."""
    data: dict[str, Any] = {}
    for part in text.split(","):
        key, sep, value = (s.strip() for s in part.partition("="))
        if not sep or not key:
            raise FaultError(
                "", f"expected kind=KIND,KEY=VALUE,... (e.g. kind=dvl_dropout,start_s=10), got {text!r}"
            )
        if key in data:
            raise FaultError(key, f"given twice in {text!r}")
        if key in ("kind", "fin"):
            data[key] = value
        else:
            try:
                data[key] = float(value)
            except ValueError:
                raise FaultError(key, f"expected a number, got {value!r}") from None
    return parse_fault(data)


def to_dict(fault: Fault) -> dict[str, Any]:
    """The mapping :func:`parse_fault` reads back (no ``duration_s`` when the fault lasts to the end)."""
    out: dict[str, Any] = {"kind": fault.kind}
    for f in dataclasses.fields(fault):
        value = getattr(fault, f.name)
        if not (f.name == "duration_s" and value is None):
            out[f.name] = value
    return out


def describe(faults: Sequence[Fault]) -> str:
    """One line for people and result tables: ``dvl_dropout(start_s=10, duration_s=20)``, joined by ``; ``;
    ``none`` for no fault."""
    if not faults:
        return "none"
    parts = []
    for fault in faults:
        items = [(k, v) for k, v in to_dict(fault).items() if k != "kind"]
        args = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in items)
        parts.append(f"{fault.kind}({args})")
    return "; ".join(parts)


def short_label(faults: Sequence[Fault]) -> str:
    """The kinds, joined by ``+`` (``none`` for no fault): filename-safe, for run ids."""
    return "+".join(f.kind for f in faults) or "none"


# ----------------------------------------------------------------------------------------------------
# Applying the schedule


@dataclass(frozen=True, slots=True)
class FaultMemory:
    """What the faults remember between control periods: each stuck depth sensor's reading (fault index ->
    depth_m), taken from its first sample in the window."""

    stuck_depth_m: tuple[tuple[int, float], ...] = ()


def active_kinds(faults: Sequence[Fault], t_s: float) -> frozenset[str]:
    """The kinds with a fault active at ``t_s``."""
    return frozenset(f.kind for f in faults if f.active(t_s))


def active_indices(faults: Sequence[Fault], t_s: float) -> frozenset[int]:
    """The indices (in ``faults``) of the faults active at ``t_s``."""
    return frozenset(i for i, f in enumerate(faults) if f.active(t_s))


def truth_flags(faults: Sequence[Fault], t_s: float) -> list[int]:
    """The truth log's :data:`TRUTH_COLUMNS` at ``t_s``: 1 where a fault of that kind is active."""
    kinds = active_kinds(faults, t_s)
    return [int(kind in kinds) for kind in KINDS]


def apply_to_measurements(
    faults: Sequence[Fault], measurements: Iterable[Measurement], memory: FaultMemory
) -> tuple[list[Measurement], FaultMemory]:
    """The measurements the sensors send under ``faults`` (each judged at its own ``t_sample_s``): DVL and
    fixes dropped in their outages, the heading biased, a stuck depth repeated. Returns the new memory."""
    stuck = dict(memory.stuck_depth_m)
    out: list[Measurement] = []
    for meas in measurements:
        t = meas.t_sample_s
        keep: Measurement | None = meas
        for i, fault in enumerate(faults):
            if keep is None or not fault.active(t):
                continue
            if isinstance(fault, DvlDropout) and isinstance(keep, DvlMeasurement):
                keep = None
            elif isinstance(fault, FixOutage) and isinstance(keep, PositionFix):
                keep = None
            elif isinstance(fault, CompassBias) and isinstance(keep, AhrsMeasurement):
                keep = dataclasses.replace(keep, yaw_rad=wrap_pi(keep.yaw_rad + math.radians(fault.bias_deg)))
            elif isinstance(fault, DepthStuck) and isinstance(keep, DepthMeasurement):
                value = stuck.setdefault(i, keep.depth_m)
                keep = DepthMeasurement(t, value)
        if keep is not None:
            out.append(keep)
    return out, FaultMemory(tuple(sorted(stuck.items())))


def apply_to_command(faults: Sequence[Fault], command: ActuatorCommand, t_s: float) -> ActuatorCommand:
    """The command the actuators follow over the period starting at ``t_s``: a stuck fin's set-point replaced
    by its stuck angle (the fin slews there at its rate and stays; what FIN_STATUS reports)."""
    for fault in faults:
        if isinstance(fault, FinStuck) and fault.active(t_s):
            command = dataclasses.replace(command, **{f"{fault.fin}_rad": math.radians(fault.angle_deg)})
    return command


def thrust_factor(faults: Sequence[Fault], t_s: float) -> float:
    """The share of the propeller's thrust left at ``t_s`` (1: none lost; the product over active losses)."""
    factor = 1.0
    for fault in faults:
        if isinstance(fault, ThrustLoss) and fault.active(t_s):
            factor *= 1.0 - fault.fraction
    return factor


def thrust_scaled(coeffs: Coefficients, factor: float) -> Coefficients:
    """``coeffs`` with the thrust polynomial (paper eq. 7, ``T0..T3``) times ``factor`` (the torque ``Q2``
    kept: the shaft still turns at the commanded speed)."""
    if factor == 1.0:
        return coeffs
    return dataclasses.replace(
        coeffs, T0=coeffs.T0 * factor, T1=coeffs.T1 * factor, T2=coeffs.T2 * factor, T3=coeffs.T3 * factor
    )


@dataclass(frozen=True, slots=True)
class FaultEvent:
    """A fault starting or ending, at its scheduled time (simulated s)."""

    t_s: float
    event: str  # "start" | "end"
    index: int  # in the run's fault list
    fault: Fault

    def to_dict(self) -> dict[str, Any]:
        return {"t_s": self.t_s, "event": self.event, "index": self.index, "fault": describe([self.fault])}


def events_between(faults: Sequence[Fault], before: frozenset[int], now: frozenset[int]) -> list[FaultEvent]:
    """The starts and ends between two sets of active indices (:func:`active_indices`), in time order."""
    out = [FaultEvent(faults[i].start_s, "start", i, faults[i]) for i in sorted(now - before)]
    out += [FaultEvent(faults[i].end_s, "end", i, faults[i]) for i in sorted(before - now)]
    return sorted(out, key=lambda e: (e.t_s, e.index))


__all__ = [
    "FINS",
    "KINDS",
    "TRUTH_COLUMNS",
    "CompassBias",
    "DepthStuck",
    "DvlDropout",
    "Fault",
    "FaultError",
    "FaultEvent",
    "FaultMemory",
    "FinStuck",
    "FixOutage",
    "ThrustLoss",
    "active_indices",
    "active_kinds",
    "apply_to_command",
    "apply_to_measurements",
    "describe",
    "events_between",
    "parse_fault",
    "parse_fault_option",
    "parse_faults",
    "short_label",
    "thrust_factor",
    "thrust_scaled",
    "to_dict",
]
