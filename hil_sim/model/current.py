"""Ocean current: a constant NED vector with an optional first-order Gauss-Markov variation (seeded)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil_sim.model.params import CurrentConfig


@dataclass(frozen=True, slots=True)
class CurrentParams:
    """Mean current in NED (m/s) and its variation: 1-sigma (m/s) per axis and time constant (s)."""

    north_mps: float = 0.0
    east_mps: float = 0.0
    down_mps: float = 0.0
    variation_std_mps: float = 0.0
    variation_period_s: float = 300.0  # the Gauss-Markov time constant

    @classmethod
    def from_config(cls, cfg: CurrentConfig) -> CurrentParams:
        """From the ``[current]`` TOML section."""
        return cls(cfg.north_mps, cfg.east_mps, cfg.down_mps, cfg.variation_std_mps, cfg.variation_period_s)

    @property
    def mean_ned_mps(self) -> tuple[float, float, float]:
        """The mean current (north, east, down) in m/s."""
        return (self.north_mps, self.east_mps, self.down_mps)


def current_after(
    current_ned_mps: tuple[float, float, float],
    params: CurrentParams,
    dt_s: float,
    rng: np.random.Generator,
) -> tuple[float, float, float]:
    """The current ``dt_s`` later: exact discretisation of a Gauss-Markov process about the mean.

    c_k+1 = mean + a (c_k - mean) + sigma sqrt(1 - a^2) w_k, a = exp(-dt/T). With zero variation the mean is
    returned and ``rng`` is not touched (so adding a still-water run does not shift other random streams).
    """
    mean = params.mean_ned_mps
    if params.variation_std_mps <= 0.0 or dt_s <= 0.0:
        return mean
    a = math.exp(-dt_s / params.variation_period_s)
    s = params.variation_std_mps * math.sqrt(1.0 - a * a)
    w = rng.standard_normal(3)
    return (
        mean[0] + a * (current_ned_mps[0] - mean[0]) + s * float(w[0]),
        mean[1] + a * (current_ned_mps[1] - mean[1]) + s * float(w[1]),
        mean[2] + a * (current_ned_mps[2] - mean[2]) + s * float(w[2]),
    )
