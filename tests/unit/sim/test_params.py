"""Parameter file: strict loading, the REMUS scaling, fin decomposition and the stated choices."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from hil_sim.model.dynamics import derivatives
from hil_sim.model.hull import MyringHull
from hil_sim.model.params import (
    DEFAULT_PARAMS_PATH,
    ConfigError,
    CrossflowConfig,
    fin_parts,
    load_params,
    rate_crossflow_damping,
)


def test_unknown_key_is_rejected(tmp_path: Path) -> None:
    text = DEFAULT_PARAMS_PATH.read_text().replace("[fins]\n", "[fins]\nbogus = 1.0\n")
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match="bogus"):
        load_params(p)


def test_out_of_range_value_is_rejected(tmp_path: Path) -> None:
    text = DEFAULT_PARAMS_PATH.read_text().replace("fin_limit_deg = 20.0", "fin_limit_deg = 90.0")
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ConfigError, match="fin_limit_deg"):
        load_params(p)


def test_every_section_has_a_source_line() -> None:
    lines = DEFAULT_PARAMS_PATH.read_text().splitlines()
    for i, line in enumerate(lines):
        if line.startswith("[") and not line.startswith("[meta]"):
            block = "\n".join(lines[max(0, i - 30) : i])
            assert "source" in block, line


def test_remus_fin_parts_match_published_combined_terms(params) -> None:
    # GIVEN Prestero's fin lift F = Yuudr at x_fin WHEN rebuilding the fin parts THEN Nuudr matches and
    # the added-mass parts left over are the published ones (Yur_a = Xudot, Nur_a = Yrdot, Zuq_a = -Xudot,
    # Muq_a = -Zqdot)
    r = params.config.remus
    f = fin_parts(r.Yuudr, r.x_fin_m)
    assert f["Nuudr"] == pytest.approx(-6.15, abs=0.01)
    assert r.Yur - f["Yur"] == pytest.approx(r.Xudot, abs=0.02)
    assert r.Nur - f["Nur"] == pytest.approx(r.Yrdot, abs=0.02)
    assert r.Zuq - f["Zuq"] == pytest.approx(-r.Xudot, abs=0.02)
    assert r.Muq - f["Muq"] == pytest.approx(-r.Zqdot, abs=0.02)


def test_scaling_keeps_cruise_speed_of_remus(params) -> None:
    c = params.coeffs
    u = math.sqrt(c.T2 * 25.0**2 / -c.Xuu)
    assert u == pytest.approx(math.sqrt(3.87 / 1.62), rel=0.01)  # REMUS 1.54 m/s at 1500 rpm


def test_crossflow_formula_is_far_below_published_remus_mqq_nrr(params) -> None:
    # the stated reason for recomputing Mqq = Nrr: Prestero's own formula gives ~-11 for REMUS
    remus = MyringHull(0.191, 0.654, 0.541, 0.191, 2.0, 0.436)
    value = rate_crossflow_damping(remus, 0.611, 1030.0, CrossflowConfig(), 0.00665, -0.638)
    assert -20.0 < value < -5.0
    assert params.coeffs.Mqq == params.coeffs.Nrr < 0.0


def _sway_yaw_eigenvalues(p) -> np.ndarray:
    s0 = np.array([0, 0, 5, 0, 0, 0, 1.546, 0, 0, 0, 0, 0.0])
    u = (0.0, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0)
    idx = [7, 11]
    jac = np.zeros((2, 2))
    for j, k in enumerate(idx):
        e = np.zeros(12)
        e[k] = 1e-6
        plus = np.array(derivatives(tuple(s0 + e), u, p.coeffs))
        minus = np.array(derivatives(tuple(s0 - e), u, p.coeffs))
        jac[:, j] = (plus - minus)[idx] / 2e-6
    return np.linalg.eigvals(jac)


def test_fin_size_makes_sway_yaw_stable_and_remus_size_would_not(params) -> None:
    assert np.max(_sway_yaw_eigenvalues(params).real) < -0.5
    small = params.with_config(fins=dataclasses.replace(params.config.fins, area_m2=0.0094))
    assert np.max(_sway_yaw_eigenvalues(small).real) > 0.0


def test_mass_matrix_is_symmetric_positive_definite(params) -> None:
    mm = np.array(params.coeffs.mass_matrix).reshape(6, 6)
    assert np.allclose(mm, mm.T)
    assert np.all(np.linalg.eigvalsh(mm) > 0.0)
    assert np.allclose(np.array(params.coeffs.minv).reshape(6, 6) @ mm, np.eye(6), atol=1e-12)


def test_a_subnormal_integration_step_is_refused_with_a_reason(tmp_path: Path) -> None:
    """GIVEN an integration step_s inside its range (0, 0.2] but so small that control_period_s / step_s
    overflows THEN the file is refused with the rule's reason (before: an OverflowError traceback)."""
    p = tmp_path / "tiny_step.toml"
    p.write_text(DEFAULT_PARAMS_PATH.read_text().replace("step_s = 0.05\n", "step_s = 5e-324\n", 1))
    with pytest.raises(ConfigError, match=r"integration: step_s must divide control_period_s"):
        load_params(p)
