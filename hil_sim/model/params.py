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
from typing import Any

import numpy as np

from auv_common.config import ConfigError, from_table, load_toml, require
from hil_sim.model.hull import HullProperties, MyringHull, hull_properties

DEFAULT_PARAMS_PATH = Path(__file__).resolve().parent.parent / "params" / "isimi100.toml"


# ----------------------------------------------------------------------------------------------------
# TOML sections


@dataclass(frozen=True)
class MetaConfig:
    """Free-text description and source of the parameter set."""

    vehicle: str = ""
    source: str = ""


@dataclass(frozen=True)
class EnvironmentConfig:
    """Water density (kg/m^3) and gravity (m/s^2)."""

    rho_kgpm3: float = 1030.0
    g_mps2: float = 9.81

    def __post_init__(self) -> None:
        require(900.0 < self.rho_kgpm3 < 1100.0, f"rho_kgpm3 out of range: {self.rho_kgpm3}")
        require(9.7 < self.g_mps2 < 9.9, f"g_mps2 out of range: {self.g_mps2}")


@dataclass(frozen=True)
class HullConfig:
    """Paper Table 1 (metres) plus the Myring exponent and tail half-angle we chose (see the TOML)."""

    a_m: float
    b_m: float
    c_m: float
    d_m: float
    a_offset_m: float
    c_offset_m: float
    lf_m: float
    l_m: float
    myring_n: float = 2.0
    tail_half_angle_deg: float = 25.0

    def __post_init__(self) -> None:
        for name in ("a_m", "b_m", "c_m", "d_m", "lf_m", "l_m"):
            require(getattr(self, name) > 0.0, f"{name} must be > 0")
        require(
            abs(self.a_m + self.b_m + self.c_m - self.lf_m) < 1e-6,
            "a_m + b_m + c_m must equal lf_m (Table 1)",
        )
        require(abs(self.lf_m + self.c_offset_m - self.l_m) < 1e-6, "lf_m + c_offset_m must equal l_m")
        require(1.0 <= self.myring_n <= 4.0, f"myring_n out of range [1, 4]: {self.myring_n}")
        require(5.0 <= self.tail_half_angle_deg <= 40.0, "tail_half_angle_deg out of range [5, 40]")


@dataclass(frozen=True)
class MassConfig:
    """Buoyancy margin (B - W)/B, CG below CB (m), roll-inertia correction factor."""

    buoyancy_margin_fraction: float = 0.01
    zg_m: float = 0.0205
    roll_inertia_factor: float = 1.0

    def __post_init__(self) -> None:
        require(
            -0.05 <= self.buoyancy_margin_fraction <= 0.1,
            f"buoyancy_margin_fraction out of range: {self.buoyancy_margin_fraction}",
        )
        require(0.0 <= self.zg_m < 0.1, f"zg_m out of range [0, 0.1): {self.zg_m}")
        require(0.5 <= self.roll_inertia_factor <= 3.0, "roll_inertia_factor out of range [0.5, 3]")


@dataclass(frozen=True)
class RemusConfig:
    """Prestero's REMUS 100 coefficients (dimensional SI, origin at the CB, L_m = 1.33 m), yaml names."""

    L_m: float
    Sfin_m2: float
    x_fin_m: float
    Xudot: float
    Yvdot: float
    Yrdot: float
    Zwdot: float
    Zqdot: float
    Kpdot: float
    Mwdot: float
    Mqdot: float
    Nvdot: float
    Nrdot: float
    Xuu: float
    Yvv: float
    Yrr: float
    Zww: float
    Zqq: float
    Kpp: float
    Mww: float
    Nvv: float
    Yuv: float
    Zuw: float
    Muw: float
    Nuv: float
    Xwq: float
    Xqq: float
    Xvr: float
    Xrr: float
    Yur: float
    Ywp: float
    Ypq: float
    Zuq: float
    Zvp: float
    Zrp: float
    Muq: float
    Mvp: float
    Mrp: float
    Nur: float
    Nwp: float
    Npq: float
    Yuudr: float


@dataclass(frozen=True)
class FinConfig:
    """One fin's planform area (m^2), effective lift slope per fin pair (1/rad), position, aspect ratio."""

    area_m2: float
    lift_slope_per_rad: float = 1.407
    x_from_tail_point_m: float = 0.12
    aspect_ratio: float = 1.1

    def __post_init__(self) -> None:
        require(0.0 < self.area_m2 < 0.1, f"area_m2 out of range (0, 0.1): {self.area_m2}")
        require(0.1 < self.lift_slope_per_rad < 7.0, "lift_slope_per_rad out of range (0.1, 7)")
        require(0.0 <= self.x_from_tail_point_m < 0.5, "x_from_tail_point_m out of range [0, 0.5)")
        require(0.2 < self.aspect_ratio < 5.0, "aspect_ratio out of range (0.2, 5)")


@dataclass(frozen=True)
class CrossflowConfig:
    """Cross-flow drag coefficients of Prestero's Mqq/Nrr formula: hull (cylinder) and fin (flat plate)."""

    hull_cd: float = 1.1
    fin_cd: float = 0.56

    def __post_init__(self) -> None:
        require(0.0 <= self.hull_cd <= 2.0, f"hull_cd out of range [0, 2]: {self.hull_cd}")
        require(0.0 <= self.fin_cd <= 2.0, f"fin_cd out of range [0, 2]: {self.fin_cd}")


@dataclass(frozen=True)
class PropulsionConfig:
    """Paper eq. 7 thrust primes (a_x..d_x, n in rev/s), torque prime k_q, nominal propeller speed (rev/s)."""

    a_x: float = 0.0
    b_x: float = 0.0
    c_x: float = 6.8029e-06
    d_x: float = 0.0
    k_q: float = -7.3053e-07
    nominal_rps: float = 25.0

    def __post_init__(self) -> None:
        require(0.0 < self.nominal_rps <= 100.0, f"nominal_rps out of range (0, 100]: {self.nominal_rps}")


@dataclass(frozen=True)
class ActuatorConfig:
    """Fin angle/rate limits (deg, deg/s), propeller range (rev/s) and lag (s), and the actuator node's
    command timeout (s): no valid command for that long latches its failsafe. In seconds, not control
    periods, so one value means the same at every control rate (the bench counts it in whole periods, rounded
    up)."""

    fin_limit_deg: float = 20.0
    fin_rate_degps: float = 40.0
    propeller_min_rps: float = -10.0
    propeller_max_rps: float = 30.0
    propeller_time_constant_s: float = 0.4
    command_timeout_s: float = 0.5

    def __post_init__(self) -> None:
        require(0.0 < self.fin_limit_deg <= 45.0, f"fin_limit_deg out of range (0, 45]: {self.fin_limit_deg}")
        require(0.0 < self.fin_rate_degps <= 1000.0, "fin_rate_degps out of range (0, 1000]")
        require(self.propeller_min_rps <= 0.0 < self.propeller_max_rps, "need propeller_min_rps <= 0 < max")
        require(self.propeller_time_constant_s > 0.0, "propeller_time_constant_s must be > 0")
        require(
            0.0 < self.command_timeout_s <= 10.0,
            f"command_timeout_s out of range (0, 10]: {self.command_timeout_s}",
        )


@dataclass(frozen=True)
class IntegrationConfig:
    """RK4 step (s) and the default control period (s) it divides. ``step_s`` is also the largest step the
    bench uses at another control rate (:func:`hil_sim.model.sim.dividing_step_s`)."""

    step_s: float = 0.05
    control_period_s: float = 0.05

    def __post_init__(self) -> None:
        require(0.0 < self.step_s <= 0.2, f"step_s out of range (0, 0.2]: {self.step_s}")
        require(0.0 < self.control_period_s <= 1.0, "control_period_s out of range (0, 1]")
        ratio = self.control_period_s / self.step_s
        require(abs(ratio - round(ratio)) < 1e-9, "step_s must divide control_period_s")


@dataclass(frozen=True)
class CurrentConfig:
    """Ocean current in NED (m/s) and its optional Gauss-Markov variation (std m/s, time constant s)."""

    north_mps: float = 0.0
    east_mps: float = 0.0
    down_mps: float = 0.0
    variation_std_mps: float = 0.0
    variation_time_constant_s: float = 300.0

    def __post_init__(self) -> None:
        require(math.hypot(self.north_mps, self.east_mps, self.down_mps) <= 5.0, "current above 5 m/s")
        require(self.variation_std_mps >= 0.0, "variation_std_mps must be >= 0")
        require(self.variation_time_constant_s > 0.0, "variation_time_constant_s must be > 0")


@dataclass(frozen=True)
class SensorProfileConfig:
    """Rates (Hz) and 1-sigma white noise of the four sensors; degrees only here."""

    ahrs_rate_hz: float = 20.0
    ahrs_attitude_std_deg: float = 0.1
    ahrs_yaw_std_deg: float = 0.5
    ahrs_rate_std_degps: float = 0.1
    depth_rate_hz: float = 20.0
    depth_std_m: float = 0.005
    dvl_rate_hz: float = 10.0
    dvl_std_mps: float = 0.005
    fix_rate_hz: float = 20.0
    fix_std_m: float = 0.003

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if f.name.endswith("_hz"):
                require(0.0 < value <= 1000.0, f"{f.name} out of range (0, 1000]: {value}")
            else:
                require(value >= 0.0, f"{f.name} must be >= 0: {value}")


@dataclass(frozen=True)
class SensorsConfig:
    """The two sensor profiles: ``basin`` (the paper's tank) and ``sea``."""

    basin: SensorProfileConfig = SensorProfileConfig()
    sea: SensorProfileConfig = SensorProfileConfig()


@dataclass(frozen=True)
class TurningConfig:
    """Recorded steady turning diameters (m) at ``propeller_rps`` for each rudder angle (deg): port (+rudder),
    starboard, and the wider of the two (``diameter_m``, for the planner)."""

    propeller_rps: float = 25.0
    rudder_deg: tuple[float, ...] = ()
    diameter_port_m: tuple[float, ...] = ()
    diameter_starboard_m: tuple[float, ...] = ()
    diameter_m: tuple[float, ...] = ()

    def __post_init__(self) -> None:
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

# Power k of L in the scale rho/2 L^k for each coefficient (forces; moments one more), Prestero / SNAME.
SCALE_EXPONENT: dict[str, int] = {
    "Xudot": 3, "Yvdot": 3, "Yrdot": 4, "Zwdot": 3, "Zqdot": 4, "Kpdot": 5, "Mwdot": 4, "Mqdot": 5,
    "Nvdot": 4, "Nrdot": 5,
    "Xuu": 2, "Yvv": 2, "Yrr": 4, "Zww": 2, "Zqq": 4, "Kpp": 5, "Mww": 3, "Nvv": 3,
    "Yuv": 2, "Zuw": 2, "Muw": 3, "Nuv": 3,
    "Xwq": 3, "Xqq": 4, "Xvr": 3, "Xrr": 4, "Yur": 3, "Ywp": 3, "Ypq": 4, "Zuq": 3, "Zvp": 3, "Zrp": 4,
    "Muq": 4, "Mvp": 4, "Mrp": 5, "Nur": 4, "Nwp": 4, "Npq": 5,
}  # fmt: skip


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
