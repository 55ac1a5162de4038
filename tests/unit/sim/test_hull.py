"""Myring hull geometry, volume and inertia (computed in code), and the free-surface immersion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hil_sim.model.hull import MyringHull, hull_properties, immersed_fraction

REMUS = MyringHull(0.191, 0.654, 0.541, 0.191, 2.0, 0.436)  # yaml geometry.myring_params (no offsets)


def test_remus_body_reproduces_published_volume_and_pitch_inertia() -> None:
    # GIVEN the REMUS Myring body WHEN integrated THEN volume and Iyy match Prestero's numbers
    props = hull_properties(REMUS)
    assert props.volume_m3 == pytest.approx(0.0317, rel=0.01)  # yaml note: 31.7 L
    _ixx, iyy, _izz = props.solid_inertia_kgm2(30.48)
    assert iyy == pytest.approx(3.45, rel=0.03)


def test_roll_inertia_factor_in_params_is_remus_ratio(params) -> None:
    ixx_homog, _, _ = hull_properties(REMUS).solid_inertia_kgm2(30.48)
    assert params.config.mass.roll_inertia_factor == pytest.approx(0.177 / ixx_homog, rel=0.005)


def test_isimi_hull_volume_and_mass(params) -> None:
    # a solid check: cylinder of the mid-section plus 2/3 of the nose cylinder plus the tail integral
    props = params.hull_props
    r2 = 0.1**2
    nose_mid = math.pi * r2 * (0.960 + 2.0 / 3.0 * 0.197)
    assert nose_mid < props.volume_m3 < nose_mid + math.pi * r2 * 0.398
    assert params.buoyancy_n > params.weight_n  # slightly positively buoyant
    assert (params.buoyancy_n - params.weight_n) / params.buoyancy_n == pytest.approx(0.01)
    assert 0.6 < params.x_cb_from_nose_m < 0.8


def test_tail_profile_is_monotone_and_ends_at_a_point(params) -> None:
    hull = params.hull
    xs = np.linspace(hull.nose_length_m, hull.body_length_m, 400)
    r = np.array([hull.radius_m(float(x)) for x in xs])
    assert np.all(np.diff(r) <= 1e-12)
    assert r[0] == pytest.approx(0.1)
    assert hull.radius_m(hull.body_length_m) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(
    ("depth_m", "expected"), [(1.0, 1.0), (0.1, 1.0), (0.0, 0.5), (-0.1, 0.0), (-1.0, 0.0)]
)
def test_immersed_fraction_limits(depth_m: float, expected: float) -> None:
    assert immersed_fraction(depth_m, 0.2) == pytest.approx(expected)


def test_immersed_fraction_is_continuous_and_monotone() -> None:
    zs = np.linspace(-0.12, 0.12, 2001)
    f = np.array([immersed_fraction(float(z), 0.2) for z in zs])
    assert np.all(np.diff(f) >= 0.0)
    assert np.max(np.abs(np.diff(f))) < 0.01
