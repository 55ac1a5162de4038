"""Parameters exposed through the MAVLink parameter protocol: declared with unit, range and default.

The table below is the default set (PD gains of paper eqs. 8 to 10, actuator limits, planner weights).
The loop receives every value as a :class:`~onboard.adapters.mavlink.api.ParamChanged` event (once at
start, then on
each accepted PARAM_SET) and maps names to its own configuration. A caller may pass its own table to
:class:`~onboard.adapters.mavlink.endpoint.VehicleLink`. Names are at most 16 characters (MAVLink param_id).
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: name (<= 16 chars), default, inclusive range, unit and a one-line description."""

    name: str
    default: float
    min: float
    max: float
    unit: str
    description: str

    def __post_init__(self) -> None:
        if not 1 <= len(self.name) <= 16:
            raise ValueError(f"parameter name {self.name!r} must have 1..16 characters")
        if not self.min <= self.default <= self.max:
            raise ValueError(
                f"parameter {self.name}: default {self.default} outside [{self.min}, {self.max}]"
            )


def _p(name: str, default: float, lo: float, hi: float, unit: str, text: str) -> ParamSpec:
    return ParamSpec(name, default, lo, hi, unit, text)


DEFAULT_PARAMS: tuple[ParamSpec, ...] = (
    # propeller (eq. 8): from e_x, e_y, e_z
    _p("PD_RPS_KP_X", 2.0, 0.0, 100.0, "rps/m", "propeller P gain on along-track error"),
    _p("PD_RPS_KD_X", 0.5, 0.0, 100.0, "rps.s/m", "propeller D gain on along-track error"),
    _p("PD_RPS_KP_Y", 0.0, 0.0, 100.0, "rps/m", "propeller P gain on cross-track error"),
    _p("PD_RPS_KD_Y", 0.0, 0.0, 100.0, "rps.s/m", "propeller D gain on cross-track error"),
    _p("PD_RPS_KP_Z", 0.0, 0.0, 100.0, "rps/m", "propeller P gain on depth error"),
    _p("PD_RPS_KD_Z", 0.0, 0.0, 100.0, "rps.s/m", "propeller D gain on depth error"),
    # rudder (eq. 9): from e_x, e_y, e_psi
    _p("PD_RUD_KP_X", 0.0, -10.0, 10.0, "rad/m", "rudder P gain on along-track error"),
    _p("PD_RUD_KD_X", 0.0, -10.0, 10.0, "rad.s/m", "rudder D gain on along-track error"),
    _p("PD_RUD_KP_Y", 0.1, -10.0, 10.0, "rad/m", "rudder P gain on cross-track error"),
    _p("PD_RUD_KD_Y", 0.05, -10.0, 10.0, "rad.s/m", "rudder D gain on cross-track error"),
    _p("PD_RUD_KP_PSI", 1.0, -20.0, 20.0, "rad/rad", "rudder P gain on yaw error"),
    _p("PD_RUD_KD_PSI", 0.3, -20.0, 20.0, "rad.s/rad", "rudder D gain on yaw error"),
    # stern planes (eq. 10): from e_z, e_theta
    _p("PD_STN_KP_Z", 0.2, -10.0, 10.0, "rad/m", "stern P gain on depth error"),
    _p("PD_STN_KD_Z", 0.1, -10.0, 10.0, "rad.s/m", "stern D gain on depth error"),
    _p("PD_STN_KP_THT", 1.0, -20.0, 20.0, "rad/rad", "stern P gain on pitch error"),
    _p("PD_STN_KD_THT", 0.3, -20.0, 20.0, "rad.s/rad", "stern D gain on pitch error"),
    # limits
    _p("LIM_RUDDER_DEG", 30.0, 1.0, 45.0, "deg", "rudder angle limit"),
    _p("LIM_STERN_DEG", 30.0, 1.0, 45.0, "deg", "stern-plane angle limit"),
    _p("LIM_RPS", 25.0, 0.0, 60.0, "rps", "propeller speed limit"),
    _p("LIM_DEPTH_M", 50.0, 0.5, 100.0, "m", "depth failsafe limit"),
    # planner weights and geometry
    _p("PLN_W_D", 1.0, 0.0, 1000.0, "1/m", "planner weight on distance"),
    _p("PLN_W_PSI", 0.0, 0.0, 1000.0, "1/rad", "planner weight on cumulative yaw change"),
    _p("PLN_W_DR", 0.0, 0.0, 1000.0, "1/rad", "planner weight on cumulative rudder"),
    _p("PLN_R_MIN_M", 5.0, 0.5, 100.0, "m", "minimum turning radius"),
    _p("PLN_MARGIN_M", 2.0, 0.0, 50.0, "m", "obstacle safety margin"),
)


class ParamTable:
    """Thread-safe parameter values with range checks. ``set`` returns (accepted, value now in force)."""

    def __init__(self, specs: tuple[ParamSpec, ...] = DEFAULT_PARAMS, values: dict[str, float] | None = None):
        names = [s.name for s in specs]
        if len(set(names)) != len(names):
            raise ValueError("duplicate parameter names")
        self.specs = specs
        self._index = {s.name: i for i, s in enumerate(specs)}
        self._values = {s.name: s.default for s in specs}
        self._lock = threading.Lock()
        for name, value in (values or {}).items():
            spec = self.spec(name)
            if spec is not None and math.isfinite(value) and spec.min <= value <= spec.max:
                self._values[name] = value

    def spec(self, name: str) -> ParamSpec | None:
        i = self._index.get(name)
        return None if i is None else self.specs[i]

    def index(self, name: str) -> int:
        return self._index[name]

    def get(self, name: str) -> float:
        with self._lock:
            return self._values[name]

    def values(self) -> dict[str, float]:
        with self._lock:
            return dict(self._values)

    def changed(self) -> dict[str, float]:
        """The values that differ from their declared defaults (what is persisted and announced)."""
        with self._lock:
            return {s.name: self._values[s.name] for s in self.specs if self._values[s.name] != s.default}

    def check(self, name: str, value: float) -> bool:
        """True if ``value`` is acceptable for parameter ``name``."""
        spec = self.spec(name)
        return spec is not None and math.isfinite(value) and spec.min <= value <= spec.max

    def set(self, name: str, value: float) -> None:
        """Store a checked value (call :meth:`check` first)."""
        with self._lock:
            self._values[name] = value
