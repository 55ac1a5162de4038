"""Vehicle variants: the packaged ISiMI100 parameters with some coefficients scaled or some values set.

A campaign flies the same onboard against vehicles that are not quite the one it was tuned on (robustness).
A variant is the TOML as read plus

- ``sets``: dotted key paths into the TOML, each setting one value, e.g. ``{"fins.area_m2": 0.035,
  "actuators.fin_limit_deg": 18, "sensors.sea.fix_std_m": 1.0}``; the value is checked against the field's
  type exactly as the TOML's would be;
- ``scale``: group name -> factor (finite, > 0) that multiplies the (possibly set) TOML values of a group:

  - ``fin_lift``: ``[fins] lift_slope_per_rad`` (the fin lift of every fin term, F = rho C_L_alpha S_fin);
  - ``added_mass``: the ``[remus]`` acceleration coefficients (Xudot, Yvdot, Yrdot, Zwdot, Zqdot, Kpdot,
    Mwdot, Mqdot, Nvdot, Nrdot) and the pure added-mass coupling terms that Prestero (2001) derives from
    them (Xwq = Zwdot, Xqq = Zqdot, Xvr = -Yvdot, Xrr = -Yrdot, Ywp = -Zwdot, Ypq = -Zqdot, Zvp = Yvdot,
    Zrp = Yrdot, Mvp = -Yrdot, Mrp = Kpdot - Nrdot, Nwp = Zqdot, Npq = -Kpdot + Mqdot), so that the
    relations still hold in a variant. Mrp and Npq are scaled as they stand in the TOML (4.86 and -4.86
    from Prestero's table, 1 % off Kpdot - Nrdot = 4.81 and -Kpdot + Mqdot = -4.81). Not the combined
    coupling terms Yur, Zuq, Muq, Nur (added mass mixed with fin terms) nor Muw, Nuv (the Munk moment
    mixed with hull lift and fin terms): they keep their values (Muw and Nuv are in ``damping``);
  - ``damping``: the ``[remus]`` damping coefficients (Xuu, Yvv, Yrr, Zww, Zqq, Kpp, Mww, Nvv, Yuv, Zuw, Muw,
    Nuv) and the ``[crossflow]`` drag coefficients hull_cd and fin_cd (Mqq = Nrr);
  - ``actuator_time``: slower actuators, ``[actuators] propeller_time_constant_s`` times the factor and
    ``fin_rate_degps`` divided by it (1.3 = 30 % slower).

Sets are applied first, then the scales. The combined REMUS coefficients (Yuv, Zuw, Muw, Nuv) are scaled as
they stand in the TOML; :func:`hil_sim.model.params.scaled_coefficients` then removes the REMUS fin part as
usual. Every changed section is rebuilt with :func:`dataclasses.replace`, so its ``__post_init__`` range
checks run again; any problem is one :class:`auv_common.config.ConfigError` naming the key, e.g.
``vehicle.scale.fin_lif: unknown group (known: actuator_time, added_mass, damping, fin_lift)``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from auv_common.config import ConfigError, from_table
from hil_sim.model.params import VehicleConfig, VehicleParams, derive_params, load_config

#: Group name -> what its factor multiplies (see the module docstring).
SCALE_GROUPS: dict[str, str] = {
    "actuator_time": "[actuators] propeller_time_constant_s x factor, fin_rate_degps / factor (slower)",
    "added_mass": (
        "[remus] acceleration coefficients (X/Y/Z/K/M/N ...dot) and the pure added-mass coupling terms "
        "Xwq Xqq Xvr Xrr Ywp Ypq Zvp Zrp Mvp Mrp Nwp Npq (not the combined Yur Zuq Muq Nur Muw Nuv, "
        "which mix in hull lift, the Munk moment or fin terms)"
    ),
    "damping": "[remus] Xuu Yvv Yrr Zww Zqq Kpp Mww Nvv Yuv Zuw Muw Nuv and [crossflow] hull_cd, fin_cd",
    "fin_lift": "[fins] lift_slope_per_rad",
}

_ADDED_MASS = ("Xudot", "Yvdot", "Yrdot", "Zwdot", "Zqdot", "Kpdot", "Mwdot", "Mqdot", "Nvdot", "Nrdot")
#: The coupling terms that are added mass only (Prestero 2001 sec. 3.3): linear in the ``*dot`` terms.
_ADDED_MASS_COUPLING = ("Xwq", "Xqq", "Xvr", "Xrr", "Ywp", "Ypq", "Zvp", "Zrp", "Mvp", "Mrp", "Nwp", "Npq")
_DAMPING = ("Xuu", "Yvv", "Yrr", "Zww", "Zqq", "Kpp", "Mww", "Nvv", "Yuv", "Zuw", "Muw", "Nuv")

#: Group -> ((section, key, power), ...): the value is multiplied by factor ** power.
_GROUP_FIELDS: dict[str, tuple[tuple[str, str, int], ...]] = {
    "fin_lift": (("fins", "lift_slope_per_rad", 1),),
    "added_mass": tuple(("remus", k, 1) for k in (*_ADDED_MASS, *_ADDED_MASS_COUPLING)),
    "damping": (
        *(("remus", k, 1) for k in _DAMPING),
        ("crossflow", "hull_cd", 1),
        ("crossflow", "fin_cd", 1),
    ),
    "actuator_time": (("actuators", "propeller_time_constant_s", 1), ("actuators", "fin_rate_degps", -1)),
}


def _factor(where: str, value: Any) -> float:
    """A scale factor: a finite number > 0."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(f"{where}: expected a number, got {value!r}")
    factor = float(value)
    if not math.isfinite(factor) or factor <= 0.0:
        raise ConfigError(f"{where}: factor must be finite and > 0, got {value!r}")
    return factor


def _replace(where: str, section: Any, changes: dict[str, Any]) -> Any:
    """``dataclasses.replace`` with the section's range checks; their error is prefixed by ``where``."""
    try:
        return dataclasses.replace(section, **changes)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def _set_one(cfg: VehicleConfig, key: str, value: Any, where: str) -> VehicleConfig:
    """``cfg`` with the value at the dotted ``key`` replaced (type- and range-checked)."""
    if not isinstance(key, str) or not key:
        raise ConfigError(f"{where}: expected a dotted key (section.key), got {key!r}")
    parts = key.split(".")
    if len(parts) < 2:
        raise ConfigError(f"{where}.{key}: expected section.key, got {key!r}")
    # Walk down to the leaf's section, keeping the chain of (dataclass, field name) to rebuild upwards.
    chain: list[tuple[Any, str]] = []
    node: Any = cfg
    for i, name in enumerate(parts):
        names = [f.name for f in dataclasses.fields(node) if f.init]
        if name not in names:
            at = ".".join(parts[:i]) or "the file"
            raise ConfigError(
                f"{where}.{key}: unknown key {name!r} in {at} (known: {', '.join(sorted(names))})"
            )
        chain.append((node, name))
        child = getattr(node, name)
        if i < len(parts) - 1 and not dataclasses.is_dataclass(child):
            raise ConfigError(f"{where}.{key}: {'.'.join(parts[: i + 1])} is a value, not a table")
        node = child
    if dataclasses.is_dataclass(node):
        raise ConfigError(f"{where}.{key}: is a table, set its keys ({key}.KEY)")
    # Type-check the value as the TOML's would be, then rebuild from the leaf up (each replace re-checks).
    section, leaf = chain[-1]
    section_where = f"{where}.{'.'.join(parts[:-1])}"
    current = {f.name: getattr(section, f.name) for f in dataclasses.fields(section) if f.init}
    current[leaf] = value
    try:
        new: Any = from_table(type(section), current, section_where)
    except ConfigError as exc:
        text = str(exc)  # "{section_where}.{leaf}: bad type" or "{section_where}: range check"
        for prefix in (f"{where}.{key}: ", section_where + ": "):
            text = text.removeprefix(prefix)
        raise ConfigError(f"{where}.{key}: {text}") from None
    for parent, name in reversed(chain[:-1]):
        new = _replace(f"{where}.{key}", parent, {name: new})
    result: VehicleConfig = new
    return result


def _scale_group(cfg: VehicleConfig, group: str, factor: float, where: str) -> VehicleConfig:
    """``cfg`` with the values of ``group`` multiplied by ``factor`` (see :data:`SCALE_GROUPS`)."""
    by_section: dict[str, dict[str, float]] = {}
    for section, key, power in _GROUP_FIELDS[group]:
        value = getattr(getattr(cfg, section), key)
        by_section.setdefault(section, {})[key] = value * factor**power
    sections = {
        name: _replace(f"{where}.{group}: [{name}]", getattr(cfg, name), changes)
        for name, changes in by_section.items()
    }
    return dataclasses.replace(cfg, **sections)


def vary_config(
    cfg: VehicleConfig,
    scale: Mapping[str, float] | None = None,
    sets: Mapping[str, Any] | None = None,
    *,
    where: str = "vehicle",
) -> VehicleConfig:
    """``cfg`` with the ``sets`` (dotted TOML key -> value) applied, then the ``scale`` (group -> factor).

    Empty or ``None`` mappings leave ``cfg`` as it is. ``where`` prefixes every error message
    (``{where}.scale.GROUP: ...``, ``{where}.set.KEY: ...``); raises :class:`ConfigError`.
    """
    out = cfg
    if sets is not None and not isinstance(sets, Mapping):
        raise ConfigError(f"{where}.set: expected a mapping of key.path: value, got {sets!r}")
    if scale is not None and not isinstance(scale, Mapping):
        raise ConfigError(f"{where}.scale: expected a mapping of group: factor, got {scale!r}")
    for key, value in (sets or {}).items():
        out = _set_one(out, key, value, f"{where}.set")
    for group, raw in (scale or {}).items():
        w = f"{where}.scale.{group}"
        if group not in _GROUP_FIELDS:
            raise ConfigError(f"{w}: unknown group (known: {', '.join(sorted(SCALE_GROUPS))})")
        out = _scale_group(out, group, _factor(w, raw), f"{where}.scale")
    return out


def vehicle_params(
    scale: Mapping[str, float] | None = None,
    sets: Mapping[str, Any] | None = None,
    path: str | Path | None = None,
    *,
    where: str = "vehicle",
) -> VehicleParams:
    """The derived model of a variant: ``load_config(path)`` -> :func:`vary_config` -> ``derive_params``."""
    return derive_params(vary_config(load_config(path), scale, sets, where=where))


__all__ = ["SCALE_GROUPS", "vary_config", "vehicle_params"]
