"""Vehicle variants: each scale group changes exactly its values, a set one value; errors name the key."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from auv_common.config import ConfigError
from hil_sim.model.params import VehicleConfig, VehicleParams, derive_params, load_config
from hil_sim.model.variants import SCALE_GROUPS, vary_config, vehicle_params


@pytest.fixture(scope="module")
def cfg() -> VehicleConfig:
    return load_config()


def _flat(cfg: Any, prefix: str = "") -> dict[str, Any]:
    """Every leaf value of the config by its dotted key path."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(cfg):
        value = getattr(cfg, f.name)
        key = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(value):
            out.update(_flat(value, key + "."))
        else:
            out[key] = value
    return out


EXPECTED: dict[str, dict[str, int]] = {
    "fin_lift": {"fins.lift_slope_per_rad": 1},
    "added_mass": {
        f"remus.{k}": 1
        for k in (
            *("Xudot", "Yvdot", "Yrdot", "Zwdot", "Zqdot", "Kpdot", "Mwdot", "Mqdot", "Nvdot", "Nrdot"),
            *("Xwq", "Xqq", "Xvr", "Xrr", "Ywp", "Ypq", "Zvp", "Zrp", "Mvp", "Mrp", "Nwp", "Npq"),
        )
    },
    "damping": {
        **{
            f"remus.{k}": 1
            for k in ("Xuu", "Yvv", "Yrr", "Zww", "Zqq", "Kpp", "Mww", "Nvv", "Yuv", "Zuw", "Muw", "Nuv")
        },
        "crossflow.hull_cd": 1,
        "crossflow.fin_cd": 1,
    },
    "actuator_time": {"actuators.propeller_time_constant_s": 1, "actuators.fin_rate_degps": -1},
}


def test_groups_are_documented() -> None:
    assert set(SCALE_GROUPS) == set(EXPECTED)
    import hil_sim.model.variants as module

    for group in SCALE_GROUPS:
        assert f"``{group}``" in (module.__doc__ or "")


@pytest.mark.parametrize("group", sorted(EXPECTED))
def test_each_group_scales_exactly_its_values(cfg: VehicleConfig, group: str) -> None:
    factor = 1.25
    before, after = _flat(cfg), _flat(vary_config(cfg, {group: factor}))
    changed = {k for k in before if before[k] != after[k]}
    assert changed == set(EXPECTED[group])
    for key, power in EXPECTED[group].items():
        assert after[key] == pytest.approx(before[key] * factor**power, rel=1e-12)


#: Prestero (2001): the pure added-mass coupling terms of [remus] as combinations of the *dot terms.
COUPLING: dict[str, dict[str, float]] = {
    "Xwq": {"Zwdot": 1.0},
    "Xqq": {"Zqdot": 1.0},
    "Xvr": {"Yvdot": -1.0},
    "Xrr": {"Yrdot": -1.0},
    "Ywp": {"Zwdot": -1.0},
    "Ypq": {"Zqdot": -1.0},
    "Zvp": {"Yvdot": 1.0},
    "Zrp": {"Yrdot": 1.0},
    "Mvp": {"Yrdot": -1.0},
    "Mrp": {"Kpdot": 1.0, "Nrdot": -1.0},
    "Nwp": {"Zqdot": 1.0},
    "Npq": {"Kpdot": -1.0, "Mqdot": 1.0},
}
#: The TOML's Mrp, Npq (+-4.86, Prestero's table) are 1 % off Kpdot - Nrdot = 4.81; the others are exact.
COUPLING_REL = {"Mrp": 0.011, "Npq": 0.011}


@pytest.mark.parametrize("factor", [1.0, 0.75, 1.25])
def test_added_mass_coupling_follows_the_dot_terms(cfg: VehicleConfig, factor: float) -> None:
    remus = vary_config(cfg, {"added_mass": factor}).remus
    assert set(COUPLING) == {k.removeprefix("remus.") for k in EXPECTED["added_mass"]} - {
        "Xudot", "Yvdot", "Yrdot", "Zwdot", "Zqdot", "Kpdot", "Mwdot", "Mqdot", "Nvdot", "Nrdot"
    }  # fmt: skip
    for term, combination in COUPLING.items():
        expected = sum(sign * getattr(remus, dot) for dot, sign in combination.items())
        assert getattr(remus, term) == pytest.approx(expected, rel=COUPLING_REL.get(term, 1e-12)), term


def test_combined_coupling_terms_keep_their_values(cfg: VehicleConfig) -> None:
    """Yur, Zuq, Muq, Nur, Muw, Nuv mix added mass with hull lift, the Munk moment or fin terms."""
    heavy = vary_config(cfg, {"added_mass": 1.25}).remus
    for term in ("Yur", "Zuq", "Muq", "Nur", "Muw", "Nuv"):
        assert getattr(heavy, term) == getattr(cfg.remus, term), term
    assert "Yur" in SCALE_GROUPS["added_mass"]  # named as left out


def test_actuator_time_is_slower(cfg: VehicleConfig) -> None:
    slow = vary_config(cfg, {"actuator_time": 1.3})
    assert slow.actuators.propeller_time_constant_s == pytest.approx(0.4 * 1.3)
    assert slow.actuators.fin_rate_degps == pytest.approx(40.0 / 1.3)


def test_identity_equals_the_packaged_params() -> None:
    base = derive_params(load_config())
    for variant in (vehicle_params(), vehicle_params({}, {})):
        assert variant.config == base.config
        assert variant.coeffs == base.coeffs
        assert variant.actuators == base.actuators


def test_identity_config_is_unchanged(cfg: VehicleConfig) -> None:
    assert vary_config(cfg) == cfg
    assert vary_config(cfg, {}, {}) == cfg


def test_a_set_changes_one_value(cfg: VehicleConfig) -> None:
    for key, value, expected in (
        ("fins.area_m2", 0.035, 0.035),
        ("actuators.fin_limit_deg", 18, 18.0),  # int -> float as the TOML reader does
        ("sensors.sea.fix_std_m", 1.5, 1.5),
        ("actuators.command_timeout_s", 1, 1.0),
    ):
        before, after = _flat(cfg), _flat(vary_config(cfg, sets={key: value}))
        assert {k for k in before if before[k] != after[k]} == {key}
        assert after[key] == expected
        assert type(after[key]) is type(before[key])


def test_sets_then_scale(cfg: VehicleConfig) -> None:
    v = vary_config(cfg, {"fin_lift": 0.5}, {"fins.lift_slope_per_rad": 2.0})
    assert v.fins.lift_slope_per_rad == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("scale", "sets", "pattern"),
    [
        (
            {"fin_lif": 0.7},
            None,
            r"^vehicle\.scale\.fin_lif: unknown group \(known: actuator_time, added_mass, ",
        ),
        ({"fin_lift": 0.0}, None, r"^vehicle\.scale\.fin_lift: .*> 0"),
        ({"fin_lift": -1.0}, None, r"^vehicle\.scale\.fin_lift: "),
        ({"damping": math.inf}, None, r"^vehicle\.scale\.damping: .*finite"),
        ({"damping": math.nan}, None, r"^vehicle\.scale\.damping: "),
        ({"added_mass": "1.2"}, None, r"^vehicle\.scale\.added_mass: expected a number"),
        ({"added_mass": True}, None, r"^vehicle\.scale\.added_mass: expected a number"),
        ({"damping": 2.0}, None, r"^vehicle\.scale\.damping: \[crossflow\]: hull_cd must be in \[0, 2\]"),
        ({"fin_lift": 10.0}, None, r"^vehicle\.scale\.fin_lift: \[fins\]: lift_slope_per_rad"),
        (None, {"fins.area_m3": 0.03}, r"^vehicle\.set\.fins\.area_m3: unknown key 'area_m3' in fins"),
        (None, {"finz.area_m2": 0.03}, r"^vehicle\.set\.finz\.area_m2: unknown key 'finz'"),
        (None, {"fins": 0.03}, r"^vehicle\.set\.fins: expected section\.key"),
        (None, {"sensors.sea": 1.0}, r"^vehicle\.set\.sensors\.sea: is a table"),
        (None, {"fins.area_m2.x": 1.0}, r"^vehicle\.set\.fins\.area_m2\.x: fins\.area_m2 is a value"),
        (None, {"fins.area_m2": "big"}, r"^vehicle\.set\.fins\.area_m2: expected a number, got 'big'$"),
        (None, {"fins.area_m2": 0.5}, r"^vehicle\.set\.fins\.area_m2: area_m2 must be in \(0, 0\.1\) m\^2"),
        (None, {"sensors.sea.fix_std_m": -1.0}, r"^vehicle\.set\.sensors\.sea\.fix_std_m: "),
        (
            None,
            {"actuators.command_timeout_s": 0.0},
            r"^vehicle\.set\.actuators\.command_timeout_s: .*\(0, 10\]",
        ),
        ({"fin_lift": 1.0}, [("fins.area_m2", 1)], r"^vehicle\.set: expected a mapping"),
    ],
)
def test_errors_name_the_key(
    cfg: VehicleConfig, scale: dict[str, Any] | None, sets: dict[str, Any] | None, pattern: str
) -> None:
    with pytest.raises(ConfigError, match=pattern) as info:
        vary_config(cfg, scale, sets)
    assert "\n" not in str(info.value)


def test_where_prefixes_the_message(cfg: VehicleConfig) -> None:
    with pytest.raises(ConfigError, match=r"^sweep\.vehicle\[1\]\.scale\.bogus: unknown group"):
        vary_config(cfg, {"bogus": 1.0}, where="sweep.vehicle[1]")


def test_weaker_fins_derive() -> None:
    base: VehicleParams = vehicle_params()
    weak = vehicle_params({"fin_lift": 0.7})
    assert weak.fin_lift_kgpm == pytest.approx(0.7 * base.fin_lift_kgpm)
    assert weak.fin_lift_kgpm < base.fin_lift_kgpm
    assert abs(weak.coeffs.Yuudr) < abs(base.coeffs.Yuudr)
    assert weak.mass_kg == pytest.approx(base.mass_kg)


def test_heavier_added_mass_changes_the_mass_matrix() -> None:
    base, heavy = vehicle_params(), vehicle_params({"added_mass": 1.25, "damping": 1.25})
    assert heavy.coeffs.mass_matrix[7] > base.coeffs.mass_matrix[7]  # m - Yvdot grows
    assert abs(heavy.coeffs.Nrr) > abs(base.coeffs.Nrr)  # cross-flow damping grows with the cd
    assert abs(heavy.coeffs.Xuu) == pytest.approx(1.25 * abs(base.coeffs.Xuu))
    for term in ("Xwq", "Ywp", "Zvp", "Mrp", "Npq"):  # the coupling follows the added mass
        assert getattr(heavy.coeffs, term) == pytest.approx(1.25 * getattr(base.coeffs, term), rel=1e-12)
    assert heavy.coeffs.Yur == pytest.approx(base.coeffs.Yur, rel=1e-12)  # combined: left alone
