"""The time-varying current (issue 24 item 4): the vehicle file's ``current: {variation_std_mps,
variation_period_s}`` (a campaign sets it as ``vehicle: [{set: {current: {...}}}]``) moves the truth's
current, seeded, over about ``variation_period_s``; the truth log records it."""

from __future__ import annotations

import itertools
import statistics
from pathlib import Path

import pytest

from auv_common.config import ConfigError
from hil_sim.bench_program import TRUTH_COLUMNS, Bench, BenchConfig, HilConfig, WaterCurrentConfig
from hil_sim.model.params import load_params
from hil_sim.model.variants import vehicle_params

PACKAGED = Path(__file__).parents[3] / "hil_sim" / "params" / "isimi100.toml"

COL = {c: i for i, c in enumerate(TRUTH_COLUMNS)}


def _east_currents(std_mps: float, period_s: float, seed: int = 3, periods: int = 400) -> list[float]:
    """The truth log's current_east_mps over ``periods`` control periods in a 0.5 m/s current towards east."""
    hil = HilConfig(bench=BenchConfig(seed=seed), current=WaterCurrentConfig(0.5, 90.0))
    sets = {"current.variation_std_mps": std_mps, "current.variation_period_s": period_s}
    bench = Bench(hil, vehicle_params({}, sets))
    out = []
    for _ in range(periods):
        cmd = bench.period(True)
        out.append(bench.truth_row(cmd, "RUNNING")[COL["current_east_mps"]])
    return out


def test_the_truth_current_varies_about_its_mean_over_about_its_period() -> None:
    # GIVEN a 0.3 m/s variation with a 1 s and a 1000 s period (same seed)
    fast, slow = _east_currents(0.3, 1.0), _east_currents(0.3, 1000.0)
    # THEN the truth log's current moves about the 0.5 m/s mean: by about its std over 20 periods of 1 s ...
    assert 0.1 < statistics.pstdev(fast) < 0.6 and abs(statistics.fmean(fast) - 0.5) < 0.2

    # ... and hardly in 20 s when the period is 1000 s (step-to-step changes 10 x smaller and more)
    def steps(c: list[float]) -> float:
        return statistics.fmean(abs(b - a) for a, b in itertools.pairwise(c))

    assert steps(fast) > 10.0 * steps(slow) > 0.0
    # AND it is seeded: the same seed the same current, and no variation a constant one
    assert fast == _east_currents(0.3, 1.0) and fast != _east_currents(0.3, 1.0, seed=4)
    assert all(c == pytest.approx(0.5, abs=1e-12) for c in _east_currents(0.0, 1.0, periods=20))


def test_the_old_key_says_what_it_became(tmp_path: Path) -> None:
    # a vehicle file of before the rename ([bench] params) is refused with the new name
    text = PACKAGED.read_text().replace("variation_period_s = 300.0", "variation_time_constant_s = 300.0")
    (tmp_path / "old.toml").write_text(text)
    with pytest.raises(
        ConfigError, match=r"variation_time_constant_s was removed: renamed variation_period_s"
    ):
        load_params(tmp_path / "old.toml")
    # and a campaign's vehicle.set names the keys it knows
    with pytest.raises(ConfigError, match=r"unknown key 'variation_time_constant_s' .*variation_period_s"):
        vehicle_params({}, {"current.variation_time_constant_s": 60.0})
