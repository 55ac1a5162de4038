"""Sensor models: AHRS, depth, DVL and position fix, each with its own rate and seeded white noise.

Truth stays in :class:`hil_sim.model.dynamics.BodyState`; measurements are new frozen objects carrying
``t_sample_s``, the simulation time of the truth they were computed from. Sample instants are integer
multiples of the sensor period, rounded to whole integration steps (so the effective rate is at most
1/step_s and the schedule is exact, with no floating-point drift).

Noise: zero-mean Gaussian, 1-sigma from the profile, drawn from the caller's ``numpy.random.Generator`` in a
fixed order (AHRS, depth, DVL, fix), so a seed reproduces a run bit for bit.

Bias: the DVL also carries a bias, as a real bottom-track DVL does (a scale-factor error of 0.2-0.5 % of
speed and a small offset): drawn once per run from the run's seed (:func:`dvl_bias`, its own stream, so the
white noise above is drawn exactly as without it), constant over the run. The profile's
``dvl_scale_bias_std`` / ``dvl_offset_bias_std_mps`` are the bench's truth; the onboard's ``[nav]``
``initial_bias_sigma_mps`` states it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hil_sim.model.dynamics import BodyState
from hil_sim.model.params import SensorProfile
from onboard.protocol.conventions import wrap_pi


@dataclass(frozen=True, slots=True)
class AhrsMeasurement:
    """Attitude (rad; yaw wrapped to (-pi, pi]) and body rates p, q, r (rad/s) at ``t_sample_s``."""

    t_sample_s: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    roll_rate_radps: float
    pitch_rate_radps: float
    yaw_rate_radps: float


@dataclass(frozen=True, slots=True)
class DepthMeasurement:
    """Depth of the CB below the surface (m, NED z) at ``t_sample_s``."""

    t_sample_s: float
    depth_m: float


@dataclass(frozen=True, slots=True)
class DvlMeasurement:
    """Body-frame velocity over ground (m/s; bottom track) at ``t_sample_s``."""

    t_sample_s: float
    u_mps: float
    v_mps: float
    w_mps: float


@dataclass(frozen=True, slots=True)
class PositionFix:
    """Horizontal NED position (m) at ``t_sample_s`` (basin: image tracking; sea: acoustic LBL)."""

    t_sample_s: float
    x_m: float
    y_m: float
    std_m: float = 0.0  # the sensor's stated 1-sigma accuracy (its profile's fix_std_m)


Measurement = AhrsMeasurement | DepthMeasurement | DvlMeasurement | PositionFix


@dataclass(frozen=True, slots=True)
class SensorSchedule:
    """Sample periods and next due instants, in whole integration steps (order: AHRS, depth, DVL, fix)."""

    period_steps: tuple[int, int, int, int]
    next_due_step: tuple[int, int, int, int]


def make_schedule(profile: SensorProfile, step_s: float, start_step: int = 0) -> SensorSchedule:
    """A schedule whose first samples fall on ``start_step`` (and every period after it)."""
    rates = (profile.ahrs_rate_hz, profile.depth_rate_hz, profile.dvl_rate_hz, profile.fix_rate_hz)
    periods = tuple(max(1, round(1.0 / (rate * step_s))) for rate in rates)
    return SensorSchedule(periods, (start_step,) * 4)  # type: ignore[arg-type]


def due_mask(schedule: SensorSchedule, step_index: int) -> tuple[bool, bool, bool, bool]:
    """Which sensors sample at integration step ``step_index``."""
    d = schedule.next_due_step
    return (d[0] <= step_index, d[1] <= step_index, d[2] <= step_index, d[3] <= step_index)


def advance_schedule(schedule: SensorSchedule, step_index: int) -> SensorSchedule:
    """Move every due sensor's next instant past ``step_index`` (whole periods, phase kept)."""
    nxt = []
    for due, period in zip(schedule.next_due_step, schedule.period_steps, strict=True):
        if due <= step_index:
            due += period * ((step_index - due) // period + 1)
        nxt.append(due)
    return SensorSchedule(schedule.period_steps, tuple(nxt))  # type: ignore[arg-type]


#: Mixed with the run's seed to give the DVL bias its own stream ("DVL" in ASCII).
_DVL_BIAS_STREAM = 0x44564C
_dvl_bias_cache: dict[tuple[object, float, float], tuple[float, float, float, float]] = {}


def dvl_bias(profile: SensorProfile, rng: np.random.Generator) -> tuple[float, float, float, float]:
    """This run's DVL bias: (scale-factor error, u, v, w offsets in m/s), fixed for the run.

    Drawn from the run's seed (the seed sequence's first entropy word, the bench's seed: the pre-start
    generator ``[seed, 1]`` sees the same DVL), not from ``rng``'s stream, which it leaves untouched. A
    generator without a seed sequence, or a profile with both 1-sigmas 0, gives no bias.
    """
    if profile.dvl_scale_bias_std == 0.0 and profile.dvl_offset_bias_std_mps == 0.0:
        return (0.0, 0.0, 0.0, 0.0)
    seed_seq = getattr(rng.bit_generator, "seed_seq", None)
    entropy = getattr(seed_seq, "entropy", None)
    if entropy is None:
        return (0.0, 0.0, 0.0, 0.0)
    root = int(entropy if isinstance(entropy, int) else entropy[0])
    key = (root, profile.dvl_scale_bias_std, profile.dvl_offset_bias_std_mps)
    bias = _dvl_bias_cache.get(key)
    if bias is None:
        e = np.random.default_rng([root, _DVL_BIAS_STREAM]).standard_normal(4)
        so = profile.dvl_offset_bias_std_mps
        scale = profile.dvl_scale_bias_std * float(e[0])
        bias = (scale, so * float(e[1]), so * float(e[2]), so * float(e[3]))
        if len(_dvl_bias_cache) > 256:
            _dvl_bias_cache.clear()
        _dvl_bias_cache[key] = bias
    return bias


def sample(
    truth: BodyState,
    t_s: float,
    mask: tuple[bool, bool, bool, bool],
    profile: SensorProfile,
    rng: np.random.Generator,
) -> list[Measurement]:
    """Measurements of the sensors in ``mask`` from ``truth`` at ``t_s``, with noise drawn from ``rng``."""
    out: list[Measurement] = []
    if mask[0]:
        e = rng.standard_normal(6)
        sa, sy, sr = profile.ahrs_attitude_std_rad, profile.ahrs_yaw_std_rad, profile.ahrs_rate_std_radps
        out.append(
            AhrsMeasurement(
                t_s,
                truth.roll_rad + sa * float(e[0]),
                truth.pitch_rad + sa * float(e[1]),
                wrap_pi(truth.yaw_rad + sy * float(e[2])),
                truth.p_radps + sr * float(e[3]),
                truth.q_radps + sr * float(e[4]),
                truth.r_radps + sr * float(e[5]),
            )
        )
    if mask[1]:
        e = rng.standard_normal(1)
        out.append(DepthMeasurement(t_s, truth.z_m + profile.depth_std_m * float(e[0])))
    if mask[2]:
        e = rng.standard_normal(3)
        s = profile.dvl_std_mps
        scale, bu, bv, bw = dvl_bias(profile, rng)
        out.append(
            DvlMeasurement(
                t_s,
                (1.0 + scale) * truth.u_mps + bu + s * float(e[0]),
                (1.0 + scale) * truth.v_mps + bv + s * float(e[1]),
                (1.0 + scale) * truth.w_mps + bw + s * float(e[2]),
            )
        )
    if mask[3]:
        e = rng.standard_normal(2)
        s = profile.fix_std_m
        out.append(PositionFix(t_s, truth.x_m + s * float(e[0]), truth.y_m + s * float(e[1]), s))
    return out
