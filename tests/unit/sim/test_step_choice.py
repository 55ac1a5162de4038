"""The integration step at any control rate (issue 21 row 14) and the actuator timeout in periods (row 13).

The params file's ``step_s`` is the largest accurate step; the bench runs at whatever control rate it is
configured for, so the step it integrates with is the largest one <= ``step_s`` that divides the period.
Before: ``make_setup`` raised "step_s=0.05 does not divide control_period_s=0.01" at 100 Hz.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from hil_sim.bench_program import timeout_periods
from hil_sim.model.params import load_params
from hil_sim.model.sim import dividing_step_s, make_setup


@pytest.mark.parametrize(
    ("rate_hz", "step_s", "substeps"),
    [
        (20.0, 0.05, 1),
        (1.0, 0.05, 20),
        (100.0, 0.01, 1),
        (200.0, 0.005, 1),
        (30.0, 1 / 30, 1),
        (7.0, 1 / 21, 3),
    ],
)
def test_the_packaged_model_runs_at_every_rate(rate_hz: float, step_s: float, substeps: int) -> None:
    # GIVEN the packaged model (step_s 0.05 s) WHEN set up for this control rate
    setup = make_setup(load_params(), control_period_s=1.0 / rate_hz)
    # THEN the step is the largest <= 0.05 s that divides the period
    assert setup.step_s == pytest.approx(step_s) and setup.substeps == substeps


@given(
    st.floats(1.0, 200.0, allow_nan=False),
    st.floats(0.001, 0.2, allow_nan=False),
)
def test_the_step_is_the_largest_that_divides(rate_hz: float, max_step_s: float) -> None:
    period = 1.0 / rate_hz
    h = dividing_step_s(max_step_s, period)
    n = round(period / h)
    assert h <= max_step_s * (1 + 1e-9)  # no larger than the accurate step
    assert n >= 1 and abs(n * h - period) <= 1e-9 * period  # divides the period
    assert n == 1 or period / (n - 1) > max_step_s  # one fewer step would be too long


def test_an_explicit_step_must_still_divide() -> None:
    with pytest.raises(ValueError, match="does not divide"):
        make_setup(load_params(), step_s=0.03)


@pytest.mark.parametrize(
    ("timeout_s", "rate_hz", "periods"),
    [(0.5, 20.0, 10), (0.5, 100.0, 50), (0.5, 200.0, 100), (0.5, 1.0, 1), (0.3, 30.0, 9), (0.05, 100.0, 5)],
)
def test_timeout_in_whole_periods_rounded_up(timeout_s: float, rate_hz: float, periods: int) -> None:
    assert timeout_periods(timeout_s, 1.0 / rate_hz) == periods
    assert periods / rate_hz >= timeout_s - 1e-9 or periods == 1
