"""Vehicle parameters: the TOML file into frozen dataclasses, and the derived ISiMI100 model constants.

``load_params()`` reads ``hil_sim/params/isimi100.toml`` strictly (unknown keys and bad values raise
:class:`auv_common.config.ConfigError`) and derives, in code:

- hull volume, centre of buoyancy and inertia from the Myring numbers (:mod:`hil_sim.model.hull`);
- mass from the volume and the buoyancy margin (W = (1 - margin) * rho g nabla);
- the ISiMI100 coefficients: REMUS hull parts made non-dimensional with rho/2 L_remus^k and re-dimensionalised
  with rho/2 l^k; fin parts rebuilt from the ISiMI100 fin (area, lift slope, position);
- the inverse of the constant 6x6 mass matrix M = M_RB + M_A (paper eq. 1), as a flat tuple.

Symbols (Prestero/SNAME): X, Y, Z forces (N) and K, M, N moments (N m) in body axes; u, v, w (m/s), p, q, r
(rad/s); e.g. ``Yuv`` is dY/d(u v) in kg/m, ``Yuudr`` is dY/d(u^2 delta_r) in kg/(m rad).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from auv_common.config import ConfigError, check_declared, from_table, load_toml, param, require
from hil_sim.model.hull import HullProperties, MyringHull, hull_properties

DEFAULT_PARAMS_PATH = Path(__file__).resolve().parent.parent / "params" / "isimi100.toml"


# ----------------------------------------------------------------------------------------------------
# TOML sections: each key declared once (auv_common.config.param: unit, range, description beside its
# default; no default: required); ``check_declared`` in ``__post_init__`` enforces the ranges, the rules
# across keys follow it. ``python -m hil_sim.params_doc`` renders them as docs/bench-parameters.md.

# Power k of L in the scale rho/2 L^k for each coefficient (forces; moments one more), Prestero / SNAME.
SCALE_EXPONENT: dict[str, int] = {
    "Xudot": 3, "Yvdot": 3, "Yrdot": 4, "Zwdot": 3, "Zqdot": 4, "Kpdot": 5, "Mwdot": 4, "Mqdot": 5,
    "Nvdot": 4, "Nrdot": 5,
    "Xuu": 2, "Yvv": 2, "Yrr": 4, "Zww": 2, "Zqq": 4, "Kpp": 5, "Mww": 3, "Nvv": 3,
    "Yuv": 2, "Zuw": 2, "Muw": 3, "Nuv": 3,
    "Xwq": 3, "Xqq": 4, "Xvr": 3, "Xrr": 4, "Yur": 3, "Ywp": 3, "Ypq": 4, "Zuq": 3, "Zvp": 3, "Zrp": 4,
    "Muq": 4, "Mvp": 4, "Mrp": 5, "Nur": 4, "Nwp": 4, "Npq": 5,
}  # fmt: skip


def _remus_unit(name: str) -> str:
    """Prestero's dimensional unit of a REMUS coefficient: kg m^(k-3) (k its ``SCALE_EXPONENT``) per rad for
    each angular rate (p, q, r) it multiplies."""
    k = SCALE_EXPONENT[name]
    rads = sum(name[1:].removesuffix("dot").count(c) for c in "pqr")
    top = {0: "kg", 1: "kg.m", 2: "kg.m^2"}.get(k - 3, "kg")
    below = (["m"] if k == 2 else []) + ([f"rad^{rads}" if rads > 1 else "rad"] if rads else [])
    if not below:
        return top
    return f"{top}/{below[0]}" if len(below) == 1 else f"{top}/({'.'.join(below)})"


def _remus_desc(name: str) -> str:
    force, rest = name[0], name[1:]
    if rest.endswith("dot"):
        return f"d{force}/d(d{rest[0]}/dt): added mass"
    return f"d{force}/d({' '.join(rest)})"


def _remus(name: str) -> Any:
    """A REMUS 100 coefficient (required; dimensional SI, Prestero's symbol)."""
    return param(unit=_remus_unit(name), desc=_remus_desc(name))


@dataclass(frozen=True)
class MetaConfig:
    """Free-text description and source of the parameter set."""

    vehicle: str = param("", desc="the vehicle the set describes")
    source: str = param("", desc="where the numbers come from")


@dataclass(frozen=True)
class EnvironmentConfig:
    """The water and gravity."""

    rho_kgpm3: float = param(
        1030.0, unit="kg/m^3", min=900.0, max=1100.0, min_open=True, max_open=True, desc="water density"
    )
    g_mps2: float = param(9.81, unit="m/s^2", min=9.7, max=9.9, min_open=True, max_open=True, desc="gravity")

    def __post_init__(self) -> None:
        check_declared(self)


def _length(what: str) -> Any:
    return param(unit="m", min=0.0, min_open=True, desc=what)


@dataclass(frozen=True)
class HullConfig:
    """Paper Table 1 (a_m + b_m + c_m = lf_m, lf_m + c_offset_m = l_m) plus the Myring exponent and tail
    half-angle we chose (see the TOML)."""

    a_m: float = _length("nose length (Table 1 a)")
    b_m: float = _length("mid-body length (Table 1 b)")
    c_m: float = _length("tail length (Table 1 c)")
    d_m: float = _length("diameter (Table 1 d)")
    a_offset_m: float = param(unit="m", desc="nose offset: the blunted tip, left out of the volume")
    c_offset_m: float = param(unit="m", desc="tail offset: the propeller hub behind the tail point")
    lf_m: float = _length("Myring body length, nose tip to tail point (a + b + c)")
    l_m: float = _length("overall length (lf + c_offset): the scaling length of the coefficients")
    myring_n: float = param(2.0, min=1.0, max=4.0, desc="Myring nose exponent")
    tail_half_angle_deg: float = param(25.0, unit="deg", min=5.0, max=40.0, desc="Myring tail half-angle")

    def __post_init__(self) -> None:
        check_declared(self)
        require(
            abs(self.a_m + self.b_m + self.c_m - self.lf_m) < 1e-6,
            "a_m + b_m + c_m must equal lf_m (Table 1)",
        )
        require(abs(self.lf_m + self.c_offset_m - self.l_m) < 1e-6, "lf_m + c_offset_m must equal l_m")


@dataclass(frozen=True)
class MassConfig:
    """Buoyancy, centre of gravity and roll inertia."""

    buoyancy_margin_fraction: float = param(
        0.01, min=-0.05, max=0.1, desc="(B - W)/B: > 0 surfaces when power is lost"
    )
    zg_m: float = param(0.0205, unit="m", min=0.0, max=0.1, max_open=True, desc="CG below CB")
    roll_inertia_factor: float = param(
        1.0, min=0.5, max=3.0, desc="Ixx over the homogeneous solid's (mass sits at the shell)"
    )

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class RemusConfig:
    """Prestero's REMUS 100 coefficients (dimensional SI, origin at the CB, L_m = 1.33 m), yaml names.

    Symbols (Prestero/SNAME): X, Y, Z forces and K, M, N moments; u, v, w, p, q, r the body velocities and
    rates (``dr``: the rudder angle). Coefficients with fin terms (Yuv, Yur, ...) are combined: the code
    removes the REMUS fin part before scaling and adds the ISiMI100 one (:func:`scaled_coefficients`).
    """

    L_m: float = param(unit="m", desc="REMUS 100 length (the scale of its coefficients)")
    Sfin_m2: float = param(unit="m^2", desc="REMUS 100 fin area")
    x_fin_m: float = param(unit="m", desc="REMUS 100 fin post from the CB (negative aft)")
    Xudot: float = _remus("Xudot")
    Yvdot: float = _remus("Yvdot")
    Yrdot: float = _remus("Yrdot")
    Zwdot: float = _remus("Zwdot")
    Zqdot: float = _remus("Zqdot")
    Kpdot: float = _remus("Kpdot")
    Mwdot: float = _remus("Mwdot")
    Mqdot: float = _remus("Mqdot")
    Nvdot: float = _remus("Nvdot")
    Nrdot: float = _remus("Nrdot")
    Xuu: float = _remus("Xuu")
    Yvv: float = _remus("Yvv")
    Yrr: float = _remus("Yrr")
    Zww: float = _remus("Zww")
    Zqq: float = _remus("Zqq")
    Kpp: float = _remus("Kpp")
    Mww: float = _remus("Mww")
    Nvv: float = _remus("Nvv")
    Yuv: float = _remus("Yuv")
    Zuw: float = _remus("Zuw")
    Muw: float = _remus("Muw")
    Nuv: float = _remus("Nuv")
    Xwq: float = _remus("Xwq")
    Xqq: float = _remus("Xqq")
    Xvr: float = _remus("Xvr")
    Xrr: float = _remus("Xrr")
    Yur: float = _remus("Yur")
    Ywp: float = _remus("Ywp")
    Ypq: float = _remus("Ypq")
    Zuq: float = _remus("Zuq")
    Zvp: float = _remus("Zvp")
    Zrp: float = _remus("Zrp")
    Muq: float = _remus("Muq")
    Mvp: float = _remus("Mvp")
    Mrp: float = _remus("Mrp")
    Nur: float = _remus("Nur")
    Nwp: float = _remus("Nwp")
    Npq: float = _remus("Npq")
    Yuudr: float = param(unit="kg/(m.rad)", desc="dY/d(u u dr): the fin pair's lift")

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class FinConfig:
    """The ISiMI100 fins (one fin; the lift slope per fin pair)."""

    area_m2: float = param(
        unit="m^2", min=0.0, max=0.1, min_open=True, max_open=True, desc="one fin's planform area"
    )
    lift_slope_per_rad: float = param(
        1.407, unit="1/rad", min=0.1, max=7.0, min_open=True, max_open=True,
        desc="effective lift slope per fin pair",
    )  # fmt: skip
    x_from_tail_point_m: float = param(
        0.12, unit="m", min=0.0, max=0.5, max_open=True, desc="fin post ahead of the tail point"
    )
    aspect_ratio: float = param(1.1, min=0.2, max=5.0, min_open=True, max_open=True, desc="span over chord")

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class CrossflowConfig:
    """Cross-flow drag coefficients of Prestero's Mqq/Nrr formula."""

    hull_cd: float = param(1.1, min=0.0, max=2.0, desc="hull cross-flow drag coefficient (cylinder)")
    fin_cd: float = param(0.56, min=0.0, max=2.0, desc="fin cross-flow drag coefficient (flat plate)")

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class PropulsionConfig:
    """Paper eq. 7: X_prop = rho/2 l^2 (a_x + b_x n + c_x n|n| + d_x n^3), n in rev/s; the propeller's roll
    torque K_prop = rho/2 l^3 k_q n|n|."""

    a_x: float = param(0.0, unit="m^2/s^2", desc="thrust prime, constant term")
    b_x: float = param(0.0, unit="m^2/(s.rev)", desc="thrust prime on n")
    c_x: float = param(6.8029e-06, unit="m^2/rev^2", desc="thrust prime on n|n|")
    d_x: float = param(0.0, unit="m^2.s/rev^3", desc="thrust prime on n^3")
    k_q: float = param(-7.3053e-07, unit="m^2/rev^2", desc="propeller torque prime on n|n|")
    nominal_rps: float = param(
        25.0, unit="rps", min=0.0, max=100.0, min_open=True, desc="nominal propeller speed"
    )

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class ActuatorConfig:
    """The fins, the propeller and the actuator node's command watchdog. The command timeout is in seconds,
    not control periods, so one value means the same at every control rate (the bench counts it in whole
    periods, rounded up)."""

    fin_limit_deg: float = param(20.0, unit="deg", min=0.0, max=45.0, min_open=True, desc="fin angle limit")
    fin_rate_degps: float = param(
        40.0, unit="deg/s", min=0.0, max=1000.0, min_open=True, desc="fin rate limit"
    )
    propeller_min_rps: float = param(-10.0, unit="rps", max=0.0, desc="propeller speed, lowest (reverse)")
    propeller_max_rps: float = param(
        30.0, unit="rps", min=0.0, min_open=True, desc="propeller speed, highest"
    )
    propeller_time_constant_s: float = param(
        0.4, unit="s", min=0.0, min_open=True, desc="propeller first-order lag"
    )
    command_timeout_s: float = param(
        0.5, unit="s", min=0.0, max=10.0, min_open=True,
        desc="no valid command for this long latches the actuator node's failsafe",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class IntegrationConfig:
    """The RK4 step and the default control period it divides."""

    step_s: float = param(
        0.05, unit="s", min=0.0, max=0.2, min_open=True,
        desc="RK4 step; also the largest step the bench uses at another control rate",
    )  # fmt: skip
    control_period_s: float = param(
        0.05, unit="s", min=0.0, max=1.0, min_open=True, desc="default control period (step_s divides it)"
    )

    def __post_init__(self) -> None:
        check_declared(self)
        ratio = self.control_period_s / self.step_s  # inf for a subnormal step: refused, not an OverflowError
        require(
            math.isfinite(ratio) and abs(ratio - round(ratio)) < 1e-9, "step_s must divide control_period_s"
        )


@dataclass(frozen=True)
class CurrentConfig:
    """Ocean current in NED (at most 5 m/s) and its optional Gauss-Markov variation."""

    REMOVED_KEYS: ClassVar[dict[str, str]] = {
        "variation_time_constant_s": "renamed variation_period_s (the same time constant, the issue's name)"
    }

    north_mps: float = param(0.0, unit="m/s", desc="current towards north")
    east_mps: float = param(0.0, unit="m/s", desc="current towards east")
    down_mps: float = param(0.0, unit="m/s", desc="current downwards")
    variation_std_mps: float = param(
        0.0, unit="m/s", min=0.0, desc="Gauss-Markov variation, standard deviation (0 = constant)"
    )
    variation_period_s: float = param(
        300.0,
        unit="s",
        min=0.0,
        min_open=True,
        desc="Gauss-Markov variation, time constant: the current wanders about its mean over about this time",
    )

    def __post_init__(self) -> None:
        check_declared(self)
        require(math.hypot(self.north_mps, self.east_mps, self.down_mps) <= 5.0, "current above 5 m/s")


def _sensor_rate(default_hz: float, what: str) -> Any:
    return param(default_hz, unit="Hz", min=0.0, max=1000.0, min_open=True, desc=f"{what} rate")


def _noise(default: float, unit: str, what: str) -> Any:
    return param(default, unit=unit, min=0.0, desc=f"{what}, 1-sigma white noise")


@dataclass(frozen=True)
class SensorProfileConfig:
    """Rates and 1-sigma white noise of the four sensors; degrees only here."""

    ahrs_rate_hz: float = _sensor_rate(20.0, "AHRS")
    ahrs_attitude_std_deg: float = _noise(0.1, "deg", "AHRS roll and pitch")
    ahrs_yaw_std_deg: float = _noise(0.5, "deg", "AHRS yaw")
    ahrs_rate_std_degps: float = _noise(0.1, "deg/s", "AHRS angular rates")
    depth_rate_hz: float = _sensor_rate(20.0, "depth")
    depth_std_m: float = _noise(0.005, "m", "depth")
    dvl_rate_hz: float = _sensor_rate(10.0, "DVL")
    dvl_std_mps: float = _noise(0.005, "m/s", "DVL velocity")
    dvl_scale_bias_std: float = param(
        0.003,
        unit="-",
        min=0.0,
        max=0.1,
        desc="DVL scale-factor error, 1-sigma of the fraction drawn once per run from the seed (a"
        " bottom-track DVL: 0.2-0.5 % of speed); every velocity it reports is (1 + that) x the truth",
    )
    dvl_offset_bias_std_mps: float = param(
        0.001,
        unit="m/s",
        min=0.0,
        desc="DVL velocity offset, 1-sigma per body axis drawn once per run from the seed (a constant bias)",
    )
    fix_rate_hz: float = _sensor_rate(20.0, "position fix")
    fix_std_m: float = _noise(0.003, "m", "position fix")

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class SensorsConfig:
    """The two sensor profiles: ``basin`` (the paper's tank) and ``sea``."""

    basin: SensorProfileConfig = SensorProfileConfig()
    sea: SensorProfileConfig = SensorProfileConfig()


@dataclass(frozen=True)
class TurningConfig:
    """Recorded steady turning diameters at ``propeller_rps`` for each rudder angle: port (+rudder),
    starboard, and the wider of the two (``diameter_m``, for the planner). The lists have one length."""

    propeller_rps: float = param(25.0, unit="rps", desc="propeller speed of the recorded turns")
    rudder_deg: tuple[float, ...] = param((), unit="deg", desc="rudder angles of the recorded turns")
    diameter_port_m: tuple[float, ...] = param((), unit="m", desc="turning diameter to port (+rudder)")
    diameter_starboard_m: tuple[float, ...] = param((), unit="m", desc="turning diameter to starboard")
    diameter_m: tuple[float, ...] = param((), unit="m", desc="the wider of the two (the planner's)")

    def __post_init__(self) -> None:
        check_declared(self)
        n = len(self.rudder_deg)
        require(
            len(self.diameter_m) == len(self.diameter_port_m) == len(self.diameter_starboard_m) == n,
            "rudder_deg and the diameter lists differ in length",
        )


@dataclass(frozen=True)
class VehicleConfig:
    """The whole TOML file."""

    hull: HullConfig
    remus: RemusConfig
    fins: FinConfig
    meta: MetaConfig = MetaConfig()
    environment: EnvironmentConfig = EnvironmentConfig()
    mass: MassConfig = MassConfig()
    crossflow: CrossflowConfig = CrossflowConfig()
    propulsion: PropulsionConfig = PropulsionConfig()
    actuators: ActuatorConfig = ActuatorConfig()
    integration: IntegrationConfig = IntegrationConfig()
    current: CurrentConfig = CurrentConfig()
    sensors: SensorsConfig = SensorsConfig()
    turning: TurningConfig = TurningConfig()


# ----------------------------------------------------------------------------------------------------
# Derived model constants


def fin_parts(lift_n: float, x_fin_m: float) -> dict[str, float]:
    """Fin contributions to the combined coefficients, for a fin pair of lift factor F at x_fin (m from CB).

    F = rho * C_L_alpha * S_fin (kg/m): lift = F u^2 alpha. The fin sees the local cross-flow
    v_f = v + x_fin r (rudder) and w_f = w - x_fin q (stern), so (Prestero 2001 sec. 3.5):
    Y_f = F u^2 dr - F u v - F x_fin u r,  N_f = x_fin Y_f;  Z_f = -F u^2 ds - F u w + F x_fin u q,
    M_f = -x_fin Z_f. Sign: +dr gives +Y at the tail and -N (turn to port); +ds gives -Z, -M (nose down).
    """
    f, x = lift_n, x_fin_m
    return {
        "Yuudr": f,
        "Nuudr": f * x,
        "Zuuds": -f,
        "Muuds": f * x,
        "Yuv": -f,
        "Yur": -f * x,
        "Nuv": -f * x,
        "Nur": -f * x * x,
        "Zuw": -f,
        "Zuq": f * x,
        "Muw": f * x,
        "Muq": -f * x * x,
    }


@dataclass(frozen=True, slots=True)
class Coefficients:
    """Dimensional ISiMI100 model constants used by :func:`hil_sim.model.dynamics.derivatives` (SI).

    Hydrodynamic coefficients as in Prestero (see the module docstring). Others:
    ``W_N`` weight, ``B_N`` buoyancy (fully submerged), ``zg_m`` CG below CB, ``diameter_m`` (free surface),
    ``m_kg`` mass, ``Ixx/Iyy/Izz`` rigid-body inertia about the CB (kg m^2), ``Kdiff`` roll moment per
    u^2 (ds_port - ds_starboard) (kg/rad), thrust ``T0..T3`` (N per rps^k; ``T2`` multiplies n|n|),
    propeller torque ``Q2`` (N m per n|n|), ``minv`` the inverse mass matrix row-major (36 floats).
    """

    W_N: float
    B_N: float
    zg_m: float
    diameter_m: float
    m_kg: float
    Ixx: float
    Iyy: float
    Izz: float
    Xuu: float
    Xwq: float
    Xqq: float
    Xvr: float
    Xrr: float
    Yvv: float
    Yrr: float
    Yuv: float
    Yur: float
    Ywp: float
    Ypq: float
    Yuudr: float
    Zww: float
    Zqq: float
    Zuw: float
    Zuq: float
    Zvp: float
    Zrp: float
    Zuuds: float
    Kpp: float
    Kdiff: float
    Mww: float
    Mqq: float
    Muw: float
    Muq: float
    Mvp: float
    Mrp: float
    Muuds: float
    Nvv: float
    Nrr: float
    Nuv: float
    Nur: float
    Nwp: float
    Npq: float
    Nuudr: float
    T0: float
    T1: float
    T2: float
    T3: float
    Q2: float
    minv: tuple[float, ...]
    mass_matrix: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class ActuatorParams:
    """Actuator limits in radians / rev/s (converted once from the TOML's degrees)."""

    fin_limit_rad: float
    fin_rate_radps: float
    propeller_min_rps: float
    propeller_max_rps: float
    propeller_time_constant_s: float


@dataclass(frozen=True, slots=True)
class SensorProfile:
    """One sensor profile in SI/radians: rates (Hz) and 1-sigma noise."""

    ahrs_rate_hz: float
    ahrs_attitude_std_rad: float
    ahrs_yaw_std_rad: float
    ahrs_rate_std_radps: float
    depth_rate_hz: float
    depth_std_m: float
    dvl_rate_hz: float
    dvl_std_mps: float
    fix_rate_hz: float
    fix_std_m: float
    dvl_scale_bias_std: float = 0.0
    dvl_offset_bias_std_mps: float = 0.0


@dataclass(frozen=True, slots=True)
class VehicleParams:
    """Everything the simulator needs, derived once from a :class:`VehicleConfig`.

    Attributes:
        config: the TOML as read.
        hull: Myring hull geometry; ``hull_props`` its integrated properties.
        volume_m3, mass_kg, weight_n, buoyancy_n: nabla, m, W, B (fully submerged).
        inertia_kgm2: (Ixx, Iyy, Izz) about the CB.
        x_cb_from_nose_m, x_fin_m: CB position from the nose; fin post position from the CB (negative aft).
        fin_lift_kgpm: F = rho C_L_alpha S_fin of one fin pair.
        coeffs: the dynamics constants; ``actuators`` limits in rad; ``step_s`` default RK4 step.
        sensor_profiles: name -> profile (``basin``, ``sea``).
        turning_table: ((rudder_rad, diameter_m), ...) as recorded in the TOML.
    """

    config: VehicleConfig
    hull: MyringHull
    hull_props: HullProperties
    volume_m3: float
    mass_kg: float
    weight_n: float
    buoyancy_n: float
    inertia_kgm2: tuple[float, float, float]
    x_cb_from_nose_m: float
    x_fin_m: float
    fin_lift_kgpm: float
    coeffs: Coefficients
    actuators: ActuatorParams
    step_s: float
    control_period_s: float
    nominal_rps: float
    sensor_profiles: dict[str, SensorProfile]
    turning_table: tuple[tuple[float, float], ...]

    def with_config(self, **sections: Any) -> VehicleParams:
        """A new :class:`VehicleParams` with some TOML sections replaced (e.g. ``fins=FinConfig(...)``)."""
        return derive_params(dataclasses.replace(self.config, **sections))


def _sensor_profile(cfg: SensorProfileConfig) -> SensorProfile:
    d2r = math.radians
    return SensorProfile(
        ahrs_rate_hz=cfg.ahrs_rate_hz,
        ahrs_attitude_std_rad=d2r(cfg.ahrs_attitude_std_deg),
        ahrs_yaw_std_rad=d2r(cfg.ahrs_yaw_std_deg),
        ahrs_rate_std_radps=d2r(cfg.ahrs_rate_std_degps),
        depth_rate_hz=cfg.depth_rate_hz,
        depth_std_m=cfg.depth_std_m,
        dvl_rate_hz=cfg.dvl_rate_hz,
        dvl_std_mps=cfg.dvl_std_mps,
        fix_rate_hz=cfg.fix_rate_hz,
        fix_std_m=cfg.fix_std_m,
        dvl_scale_bias_std=cfg.dvl_scale_bias_std,
        dvl_offset_bias_std_mps=cfg.dvl_offset_bias_std_mps,
    )


def scaled_coefficients(cfg: VehicleConfig, fin_lift_kgpm: float, x_fin_m: float) -> dict[str, float]:
    """ISiMI100 coefficients: REMUS hull parts scaled by (l / L_remus)^k plus the ISiMI100 fin parts."""
    remus = cfg.remus
    ratio = cfg.hull.l_m / remus.L_m
    remus_fin = fin_parts(remus.Yuudr, remus.x_fin_m)
    isimi_fin = fin_parts(fin_lift_kgpm, x_fin_m)
    out: dict[str, float] = {}
    for name, k in SCALE_EXPONENT.items():
        hull_part = getattr(remus, name) - remus_fin.get(name, 0.0)
        out[name] = hull_part * ratio**k + isimi_fin.get(name, 0.0)
    for name in ("Yuudr", "Nuudr", "Zuuds", "Muuds"):
        out[name] = isimi_fin[name]
    return out


def rate_crossflow_damping(
    hull: MyringHull,
    x_cb_from_nose_m: float,
    rho_kgpm3: float,
    cfg: CrossflowConfig,
    fin_area_m2: float,
    x_fin_m: float,
) -> float:
    """Mqq = Nrr (kg m^2/rad^2) by Prestero's cross-flow formula (2001, sec. 3.4.2), axisymmetric hull.

    N_rr = -1/2 rho c_dc int 2 R(x) |x|^3 dx - 2 (1/2 rho S_fin c_df) |x_fin|^3: the hull's cross-flow drag
    under the local cross velocity r x, plus the two fins' flat-plate drag (x from the CB).
    """
    x = np.linspace(0.0, hull.body_length_m, 4001)
    r = np.array([hull.radius_m(float(xi)) for xi in x])
    integrand = 2.0 * r * np.abs(x - x_cb_from_nose_m) ** 3
    integral = float(np.sum(0.5 * (integrand[1:] + integrand[:-1]) * np.diff(x)))
    half_rho = 0.5 * rho_kgpm3
    return -half_rho * cfg.hull_cd * integral - 2.0 * half_rho * fin_area_m2 * cfg.fin_cd * abs(x_fin_m) ** 3


def derive_params(cfg: VehicleConfig) -> VehicleParams:
    """Compute the derived model (hull, mass, inertia, coefficients, inverse mass matrix) from ``cfg``."""
    env, hc = cfg.environment, cfg.hull
    hull = MyringHull(
        nose_length_m=hc.a_m,
        mid_length_m=hc.b_m,
        tail_length_m=hc.c_m,
        diameter_m=hc.d_m,
        nose_exponent=hc.myring_n,
        tail_half_angle_rad=math.radians(hc.tail_half_angle_deg),
    )
    props = hull_properties(hull)
    buoyancy = env.rho_kgpm3 * env.g_mps2 * props.volume_m3
    weight = (1.0 - cfg.mass.buoyancy_margin_fraction) * buoyancy
    mass = weight / env.g_mps2
    ixx, iyy, izz = props.solid_inertia_kgm2(mass)
    ixx *= cfg.mass.roll_inertia_factor
    zg = cfg.mass.zg_m
    x_fin = (hull.body_length_m - cfg.fins.x_from_tail_point_m) - props.x_cb_from_nose_m
    x_fin = -x_fin  # aft of the CB: negative
    fin_lift = env.rho_kgpm3 * cfg.fins.lift_slope_per_rad * cfg.fins.area_m2
    c = scaled_coefficients(cfg, fin_lift, x_fin)
    c["Mqq"] = c["Nrr"] = rate_crossflow_damping(
        hull, props.x_cb_from_nose_m, env.rho_kgpm3, cfg.crossflow, cfg.fins.area_m2, x_fin
    )

    # Roll arm of a stern plane's centre of pressure: hull radius at the fin post + half the span.
    span = math.sqrt(cfg.fins.aspect_ratio * cfg.fins.area_m2)
    y_fin = hull.radius_m(hull.body_length_m - cfg.fins.x_from_tail_point_m) + 0.5 * span
    kdiff = 0.5 * fin_lift * y_fin  # K = (F/2) y_f u^2 (ds_port - ds_stbd)

    # Mass matrix M = M_RB + M_A (Prestero eq. 3.40, x_g = y_g = 0), rows X Y Z K M N, columns u v w p q r.
    mz = mass * zg
    mm = np.array(
        [
            [mass - c["Xudot"], 0.0, 0.0, 0.0, mz, 0.0],
            [0.0, mass - c["Yvdot"], 0.0, -mz, 0.0, -c["Yrdot"]],
            [0.0, 0.0, mass - c["Zwdot"], 0.0, -c["Zqdot"], 0.0],
            [0.0, -mz, 0.0, ixx - c["Kpdot"], 0.0, 0.0],
            [mz, 0.0, -c["Mwdot"], 0.0, iyy - c["Mqdot"], 0.0],
            [0.0, -c["Nvdot"], 0.0, 0.0, 0.0, izz - c["Nrdot"]],
        ]
    )
    minv = np.linalg.inv(mm)

    half_rho = 0.5 * env.rho_kgpm3
    pr = cfg.propulsion
    l2 = half_rho * hc.l_m**2
    coeffs = Coefficients(
        W_N=weight,
        B_N=buoyancy,
        zg_m=zg,
        diameter_m=hc.d_m,
        m_kg=mass,
        Ixx=ixx,
        Iyy=iyy,
        Izz=izz,
        Xuu=c["Xuu"],
        Xwq=c["Xwq"],
        Xqq=c["Xqq"],
        Xvr=c["Xvr"],
        Xrr=c["Xrr"],
        Yvv=c["Yvv"],
        Yrr=c["Yrr"],
        Yuv=c["Yuv"],
        Yur=c["Yur"],
        Ywp=c["Ywp"],
        Ypq=c["Ypq"],
        Yuudr=c["Yuudr"],
        Zww=c["Zww"],
        Zqq=c["Zqq"],
        Zuw=c["Zuw"],
        Zuq=c["Zuq"],
        Zvp=c["Zvp"],
        Zrp=c["Zrp"],
        Zuuds=c["Zuuds"],
        Kpp=c["Kpp"],
        Kdiff=kdiff,
        Mww=c["Mww"],
        Mqq=c["Mqq"],
        Muw=c["Muw"],
        Muq=c["Muq"],
        Mvp=c["Mvp"],
        Mrp=c["Mrp"],
        Muuds=c["Muuds"],
        Nvv=c["Nvv"],
        Nrr=c["Nrr"],
        Nuv=c["Nuv"],
        Nur=c["Nur"],
        Nwp=c["Nwp"],
        Npq=c["Npq"],
        Nuudr=c["Nuudr"],
        T0=l2 * pr.a_x,
        T1=l2 * pr.b_x,
        T2=l2 * pr.c_x,
        T3=l2 * pr.d_x,
        Q2=half_rho * hc.l_m**3 * pr.k_q,
        minv=tuple(float(v) for v in minv.ravel()),
        mass_matrix=tuple(float(v) for v in mm.ravel()),
    )
    act = cfg.actuators
    actuators = ActuatorParams(
        fin_limit_rad=math.radians(act.fin_limit_deg),
        fin_rate_radps=math.radians(act.fin_rate_degps),
        propeller_min_rps=act.propeller_min_rps,
        propeller_max_rps=act.propeller_max_rps,
        propeller_time_constant_s=act.propeller_time_constant_s,
    )
    table = tuple(
        (math.radians(d), dia) for d, dia in zip(cfg.turning.rudder_deg, cfg.turning.diameter_m, strict=True)
    )
    return VehicleParams(
        config=cfg,
        hull=hull,
        hull_props=props,
        volume_m3=props.volume_m3,
        mass_kg=mass,
        weight_n=weight,
        buoyancy_n=buoyancy,
        inertia_kgm2=(ixx, iyy, izz),
        x_cb_from_nose_m=props.x_cb_from_nose_m,
        x_fin_m=x_fin,
        fin_lift_kgpm=fin_lift,
        coeffs=coeffs,
        actuators=actuators,
        step_s=cfg.integration.step_s,
        control_period_s=cfg.integration.control_period_s,
        nominal_rps=pr.nominal_rps,
        sensor_profiles={
            "basin": _sensor_profile(cfg.sensors.basin),
            "sea": _sensor_profile(cfg.sensors.sea),
        },
        turning_table=table,
    )


def load_config(path: str | Path | None = None) -> VehicleConfig:
    """Read and check the vehicle TOML (default: the packaged ``isimi100.toml``)."""
    p = Path(path) if path is not None else DEFAULT_PARAMS_PATH
    return from_table(VehicleConfig, load_toml(p), p.name)


def load_params(path: str | Path | None = None) -> VehicleParams:
    """Read the vehicle TOML and derive the model; raises :class:`ConfigError` on any bad value."""
    return derive_params(load_config(path))


def describe(params: VehicleParams) -> str:
    """A human-readable listing of the derived parameters (for the parameter file's reviewers)."""
    lines = [
        f"volume_m3 = {params.volume_m3:.6f}",
        f"x_cb_from_nose_m = {params.x_cb_from_nose_m:.4f}",
        f"mass_kg = {params.mass_kg:.3f}  weight_n = {params.weight_n:.2f}",
        f"buoyancy_n = {params.buoyancy_n:.2f}",
        "inertia_kgm2 (Ixx, Iyy, Izz) = ({:.4f}, {:.4f}, {:.4f})".format(*params.inertia_kgm2),
        f"x_fin_m = {params.x_fin_m:.4f}  fin_lift_kgpm = {params.fin_lift_kgpm:.3f}",
    ]
    for f in dataclasses.fields(Coefficients):
        value = getattr(params.coeffs, f.name)
        if isinstance(value, float):
            lines.append(f"{f.name} = {value:.6g}")
    return "\n".join(lines)


__all__ = [
    "DEFAULT_PARAMS_PATH",
    "ActuatorParams",
    "Coefficients",
    "ConfigError",
    "SensorProfile",
    "VehicleConfig",
    "VehicleParams",
    "derive_params",
    "describe",
    "load_config",
    "load_params",
]

if __name__ == "__main__":  # pragma: no cover - a reviewer's listing
    import sys

    sys.stdout.write(describe(load_params(sys.argv[1] if len(sys.argv) > 1 else None)) + "\n")
