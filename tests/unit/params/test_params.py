"""The parameter table (onboard.core.params): generated from the config, bounded by its rules and the DBC."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from auv_common.config import ConfigError
from onboard.app.config import config_from_dict, load_config
from onboard.core.config import CoreConfig
from onboard.core.control.actuators import PROPELLER_SPAN_MIN_RPS, ActuatorCommand, ActuatorLimits, saturate
from onboard.core.control.pd import ControlParams
from onboard.core.mission.params import ARRIVAL_RADIUS_MIN_M
from onboard.core.params import (
    PARAM_NAMES,
    BusLimits,
    ParamError,
    ParamSpec,
    apply_param,
    check_against_bus,
    float32,
    is_default,
    param_path,
    param_table,
    param_value,
)
from onboard.protocol.codec import Codec, EncodeError, command_ranges
from onboard.protocol.messages import ActuatorMode, FinCmd, PropCmd

BUS = BusLimits.from_ranges(command_ranges())
CODEC = Codec()
CONFIG = CoreConfig()


def _spec(name: str, config: CoreConfig = CONFIG) -> ParamSpec:
    return next(s for s in param_table(config, BUS) if s.name == name)


def _limits(config: CoreConfig) -> ActuatorLimits:
    return config.control.limits


def _own_reason(leaf: object, **changes: object) -> str:
    """The dataclass's own refusal message (read from the dataclass, not copied)."""
    with pytest.raises(ConfigError) as exc:
        dataclasses.replace(leaf, **changes)  # type: ignore[type-var]
    return str(exc.value)


def _encode_at_limits(limits: ActuatorLimits) -> None:
    """Saturate commands far beyond every limit (both signs, with roll) and encode them: never refused."""
    for sign in (1.0, -1.0):
        for roll in (0.0, 1.0, -1.0):
            desired = ActuatorCommand(sign * 10.0, sign * 10.0 - roll, sign * 10.0 + roll, sign * 1e3)
            out = saturate(desired, ActuatorCommand(0.0, 0.0, 0.0, 0.0), limits, 1e3)
            CODEC.encode(FinCmd(out.rudder_rad, out.stern_port_rad, out.stern_starboard_rad), 0)
            CODEC.encode(PropCmd(out.propeller_rps, ActuatorMode.ARMED), 0)
    CODEC.encode(FinCmd(limits.rudder_limit_rad, limits.stern_limit_rad, -limits.stern_limit_rad), 0)
    CODEC.encode(FinCmd(-limits.rudder_limit_rad, -limits.stern_limit_rad, limits.stern_limit_rad), 0)
    CODEC.encode(PropCmd(limits.propeller_max_rps, ActuatorMode.ARMED), 0)
    CODEC.encode(PropCmd(limits.propeller_min_rps, ActuatorMode.ARMED), 0)


# --- the table ----------------------------------------------------------------------------------------


def test_table_names_paths_defaults() -> None:
    table = param_table(CONFIG, BUS)
    assert [s.name for s in table] == list(PARAM_NAMES)
    assert len(set(PARAM_NAMES)) == len(PARAM_NAMES)
    for s in table:
        assert 1 <= len(s.name) <= 16
        assert s.default == param_value(CONFIG, s.name)  # defaults = the running config's values
        assert s.min <= s.default <= s.max and math.isfinite(s.min) and math.isfinite(s.max)
        assert s.description
    names = set(PARAM_NAMES)
    for kept in ("LIM_RUDDER_DEG", "LIM_STERN_DEG", "LIM_RPS_MAX", "PLN_W_D", "PLN_W_PSI", "PLN_W_DR"):
        assert kept in names
    assert {f"PD_K{k}{i}" for k in ("P", "D") for i in range(1, 9)} <= names
    assert _spec("PD_KP5").path == "control.improved.Kp5"
    assert _spec("LIM_RUDDER_DEG").path == "control.limits.rudder_limit_deg"


def test_gains_follow_the_active_profile() -> None:
    paper = dataclasses.replace(CONFIG, control=ControlParams(profile="paper"))
    assert param_path(paper, "PD_KP5") == "control.paper.Kp5"
    assert _spec("PD_KP5", paper).default == paper.control.paper.Kp5
    new = apply_param(paper, "PD_KP5", -1.5, BUS)
    assert new.control.paper.Kp5 == -1.5 and new.control.improved == paper.control.improved


def test_actuator_limit_ranges_are_within_the_dbc() -> None:
    rudder, stern, rps = _spec("LIM_RUDDER_DEG"), _spec("LIM_STERN_DEG"), _spec("LIM_RPS_MAX")
    assert math.radians(rudder.max) <= BUS.rudder_rad[1] and -math.radians(rudder.max) >= BUS.rudder_rad[0]
    assert math.radians(stern.max) <= BUS.stern_rad[1] and -math.radians(stern.max) >= BUS.stern_rad[0]
    assert BUS.propeller_rps[0] <= rps.min and rps.max <= BUS.propeller_rps[1]
    # the DBC is the tighter bound here (the dataclass allows 45 deg): the table says so
    assert rudder.max < 30.001 and stern.max < 30.001
    for s in (rudder, stern, rps):  # the bounds are exact float32 numbers, as a ground station sees them
        assert float32(s.max) == s.max and float32(s.min) == s.min


def test_bounds_come_from_the_dataclass_rules() -> None:
    # closed rule (mission arrival radius in [0.1, 50]) and an integer count (1..20), declared
    assert (_spec("MIS_ARRIVE_R_M").min, _spec("MIS_ARRIVE_R_M").max) == (ARRIVAL_RADIUS_MIN_M, 50.0)
    assert (_spec("MIS_MAX_TRIES").min, _spec("MIS_MAX_TRIES").max) == (1.0, 20.0)
    assert _spec("FS_ABORT_STN_DEG").max == 45.0
    assert _spec("PD_KP1").min == -100.0  # no rule in the config: the operator range


def test_bus_limits_from_ranges() -> None:
    assert BUS.rudder_rad == command_ranges()["FIN_CMD.rudder_rad"]
    assert set(command_ranges()) == {
        "FIN_CMD.rudder_rad",
        "FIN_CMD.stern_port_rad",
        "FIN_CMD.stern_starboard_rad",
        "PROP_CMD.propeller_rps",
    }
    narrow = {**command_ranges(), "FIN_CMD.stern_starboard_rad": (-0.3, 0.2)}
    assert BusLimits.from_ranges(narrow).stern_rad == (-0.3, 0.2)
    with pytest.raises(ConfigError):
        BusLimits.from_ranges({"FIN_CMD.rudder_rad": (-1.0, 1.0)})


# --- no value in range makes an unencodable command --------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_no_value_in_range_gives_an_unencodable_command(fr: float, fs: float, fp: float) -> None:
    config = CONFIG
    for name, f in (("LIM_RUDDER_DEG", fr), ("LIM_STERN_DEG", fs), ("LIM_RPS_MAX", fp)):
        spec = _spec(name, config)
        value = float32(spec.min + f * (spec.max - spec.min))  # what a ground station sends
        try:
            config = apply_param(config, name, value, BUS)
        except ParamError as exc:  # only the dataclass's open bound (0) may refuse a value in range
            assert value == spec.min, exc.reason
    _encode_at_limits(_limits(config))


def test_the_maximum_as_float32_is_accepted_and_encodable() -> None:
    config = CONFIG
    for name in ("LIM_RUDDER_DEG", "LIM_STERN_DEG", "LIM_RPS_MAX"):
        spec = _spec(name, config)
        config = apply_param(config, name, float32(spec.max), BUS)
        assert param_value(config, name) == spec.max
    _encode_at_limits(_limits(config))


def test_a_rudder_limit_beyond_the_dbc_is_refused_and_would_not_encode() -> None:
    with pytest.raises(ParamError, match="DBC FIN_CMD rudder"):
        apply_param(CONFIG, "LIM_RUDDER_DEG", 45.0, BUS)  # the dataclass accepts 45
    with pytest.raises(EncodeError):
        CODEC.encode(FinCmd(math.radians(45.0), 0.0, 0.0), 0)
    with pytest.raises(ParamError, match="DBC PROP_CMD"):
        apply_param(CONFIG, "LIM_RPS_MAX", 41.0, BUS)


def test_check_against_bus_refuses_configured_limits_beyond_the_dbc() -> None:
    check_against_bus(CONFIG, BUS)
    for changes in ({"rudder_limit_deg": 45.0}, {"stern_limit_deg": 31.0}, {"propeller_max_rps": 45.0}):
        limits = dataclasses.replace(CONFIG.control.limits, **changes)  # type: ignore[arg-type]
        bad = dataclasses.replace(CONFIG, control=dataclasses.replace(CONFIG.control, limits=limits))
        with pytest.raises(ConfigError, match="DBC") as exc:
            check_against_bus(bad, BUS)
        assert "\n" not in str(exc.value) and next(iter(changes)) in str(exc.value)
        with pytest.raises(ConfigError):
            param_table(bad, BUS)


# --- refusals -----------------------------------------------------------------------------------------


def test_the_config_rule_refusal_carries_the_configs_reason() -> None:
    spec = _spec("LIM_RPS_MAX")
    assert spec.min == PROPELLER_SPAN_MIN_RPS  # the cross-value rule: at least this above propeller_min_rps
    reason = _own_reason(CONFIG.control.limits, propeller_max_rps=0.5)
    with pytest.raises(ParamError) as exc:
        apply_param(CONFIG, "LIM_RPS_MAX", 0.5, BUS)
    assert reason in exc.value.reason and "LIM_RPS_MAX" in exc.value.reason
    with pytest.raises(ParamError) as exc:
        apply_param(CONFIG, "LIM_RUDDER_DEG", 0.0, BUS)
    assert _own_reason(CONFIG.control.limits, rudder_limit_deg=0.0) in exc.value.reason
    with pytest.raises(ParamError) as exc:
        apply_param(CONFIG, "MIS_ARRIVE_R_M", 60.0, BUS)  # beyond the closed bound: the config's reason
    assert _own_reason(CONFIG.mission, arrival_radius_m=60.0) in exc.value.reason


#: float32's smallest normal number: below it (and above 0) a float32 is subnormal.
FLOAT32_NORMAL_MIN = 2.0**-126


@pytest.mark.parametrize("config", [CONFIG, load_config().core], ids=["defaults", "onboard.toml"])
def test_every_parameter_whose_zero_is_refused_declares_a_meaningful_minimum(config: CoreConfig) -> None:
    """Issue 21 row 15: a parameter whose 0 is refused has a closed minimum > 0, not subnormal, in force in
    the configuration (the minimum is accepted, anything below it refused, 1.4e-45 and 1e-10 included)."""
    zero_refused = []
    for spec in param_table(config, BUS):
        try:
            apply_param(config, spec.name, 0.0, BUS)
        except ParamError:
            zero_refused.append(spec.name)
        else:
            continue
        assert spec.min > 0.0 and spec.min >= FLOAT32_NORMAL_MIN, (spec.name, spec.min)
        assert float32(spec.min) == spec.min or spec.min >= 1e-3, (spec.name, spec.min)
        assert param_value(apply_param(config, spec.name, spec.min, BUS), spec.name) == spec.min, spec.name
        for below in (1.4e-45, 1e-10, float32(spec.min) * (1 - 1e-6)):  # below it in float32 too
            with pytest.raises(ParamError) as exc:
                apply_param(config, spec.name, below, BUS)
            assert f"{spec.min:g}" in exc.value.reason or "whole number" in exc.value.reason, exc.value.reason
    assert {"LIM_RUDDER_DEG", "LIM_RPS_MAX", "FS_NAV_TMO_S"} <= set(zero_refused)
    # every bound in the table is closed: the maximum is accepted too
    for spec in param_table(config, BUS):
        assert param_value(apply_param(config, spec.name, spec.max, BUS), spec.name) == spec.max, spec.name


def test_a_configuration_value_below_a_declared_minimum_stops_start_up(tmp_path: Path) -> None:
    """The file and the parameter agree: the minimum lives beside the configuration's rule."""
    for table, key, value, words in (
        ("control.limits", "rudder_limit_deg", 1e-10, "rudder_limit_deg must be in [1, 45]"),
        ("control.limits", "propeller_max_rps", 0.5, "propeller_max_rps must be >= 1"),
        ("failsafe", "nav_timeout_s", 1.4e-45, "nav_timeout_s must be >= 0.05"),
        ("planner", "turning_radius_m", 1e-10, "turning_radius_m must be >= 0.5"),
    ):
        section, _, sub = table.partition(".")
        data: dict[str, object] = {section: {sub: {key: value}} if sub else {key: value}}
        with pytest.raises(ConfigError, match=re.escape(words)):
            config_from_dict(data, "onboard.toml")


@pytest.mark.parametrize(
    ("name", "value", "words"),
    [
        ("NO_SUCH", 1.0, "unknown parameter"),
        ("PD_KP1", math.nan, "not a finite number"),
        ("PD_KP1", math.inf, "not a finite number"),
        ("PD_KP1", 1e9, "above the maximum"),
        ("PD_KP1", -1e9, "below the minimum"),
        ("MIS_MAX_TRIES", 2.5, "whole number"),
    ],
)
def test_refusals(name: str, value: float, words: str) -> None:
    with pytest.raises(ParamError, match=words):
        apply_param(CONFIG, name, value, BUS)


def test_cross_value_rules_are_judged_on_the_whole_config() -> None:
    with pytest.raises(ParamError, match="weights"):
        apply_param(CONFIG, "PLN_W_D", 0.0, BUS)  # the only positive weight
    config = apply_param(CONFIG, "PLN_W_PSI", 1.0, BUS)
    config = apply_param(config, "PLN_W_D", 0.0, BUS)  # now allowed: 0 is in the table's range
    assert (config.planner.weight_distance, config.planner.weight_yaw) == (0.0, 1.0)


def test_accepted_values_and_counts() -> None:
    config = apply_param(CONFIG, "MIS_MAX_TRIES", 5.0, BUS)
    assert config.mission.max_tries == 5 and isinstance(config.mission.max_tries, int)
    config = apply_param(config, "LIM_RUDDER_DEG", 25.0, BUS)
    assert config.control.limits.rudder_limit_rad == pytest.approx(math.radians(25.0))
    assert param_value(config, "LIM_RUDDER_DEG") == 25.0 and CONFIG.control.limits.rudder_limit_deg == 20.0


# --- float32 ------------------------------------------------------------------------------------------


def test_float32_round_trip_at_every_bound() -> None:
    for spec in param_table(CONFIG, BUS):
        for bound in (spec.min, spec.max):
            try:
                config = apply_param(CONFIG, spec.name, float32(bound), BUS)
            except ParamError as exc:  # an open bound of the dataclass (e.g. > 0): its own reason
                assert "refused" in exc.reason, (spec.name, bound, exc.reason)
                continue
            assert param_value(config, spec.name) == bound, spec.name
        up = float32(spec.max) * (1 + 1e-6) + 1e-6  # beyond the bound in float32 too
        with pytest.raises(ParamError):
            apply_param(CONFIG, spec.name, up, BUS)


def test_float32_of_an_inexact_bound_and_of_the_value_in_force() -> None:
    planner = dataclasses.replace(CONFIG.planner, turning_radius_m=2.93)
    gains = dataclasses.replace(CONFIG.control.improved, Kp1=100.3)  # beyond the operator range: widens it
    control = dataclasses.replace(CONFIG.control, improved=gains)
    config = dataclasses.replace(CONFIG, planner=planner, control=control)
    spec = _spec("PLN_R_MIN_M", config)
    assert float32(spec.default) != spec.default  # 2.93 is not a float32 ...
    same = apply_param(config, "PLN_R_MIN_M", float32(spec.default), BUS)
    assert same.planner.turning_radius_m == 2.93  # ... its float32 means exactly it
    kp1 = _spec("PD_KP1", config)
    assert kp1.max == 100.3 and float32(100.3) > 100.3  # an inexact maximum, its float32 above it
    assert apply_param(config, "PD_KP1", float32(100.3), BUS).control.improved.Kp1 == 100.3


def test_is_default_compares_in_float32() -> None:
    spec = ParamSpec("PLN_R_MIN_M", 2.93, 0.0, 100.0, "m", "turning radius", "planner.turning_radius_m")
    assert is_default(spec, 2.93) and is_default(spec, float32(2.93))
    assert float32(2.93) != 2.93
    assert not is_default(spec, float32(2.93) * (1 + 1e-6))
    for s in param_table(CONFIG, BUS):
        assert is_default(s, float32(s.default))


# --- precedence at boot (onboard.app.runtime.resolve_config) -------------------------------------------


def _boot_file(tmp_path: Path, body: str) -> str:
    path = tmp_path / "onboard.toml"
    path.write_text(body)
    return str(path)


BODY = """
[control.limits]
rudder_limit_deg = 22.0
stern_limit_deg = 21.0
[failsafe]
max_depth_m = 12.0
[store]
dir = "STATE"
"""


def test_precedence_defaults_file_persisted_set(tmp_path: Path) -> None:
    from onboard.app.runtime import resolve_config

    path = _boot_file(tmp_path, BODY.replace("STATE", str(tmp_path / "state")))
    persisted = {
        "LIM_RUDDER_DEG": 25.0,  # persisted beats the file
        "LIM_STERN_DEG": 15.0,  # --set beats persisted
        "FS_MAX_DEPTH_M": 500.0,  # refused: dropped, never applied
        "GONE": 1.0,  # unknown: dropped
        "PLN_W_D": 0.0,  # refused alone, accepted with PLN_W_PSI (order does not matter)
        "PLN_W_PSI": 2.0,
    }
    sets = ["control.limits.stern_limit_deg=18", "guidance.speed_mps=1.2"]
    boot = resolve_config(path, sets, persisted, BUS)
    core = boot.config.core
    assert core.control.limits.rudder_limit_deg == 25.0
    assert core.control.limits.stern_limit_deg == 18.0
    assert core.failsafe.max_depth_m == 12.0
    assert core.guidance.speed_mps == 1.2
    assert (core.planner.weight_distance, core.planner.weight_yaw) == (0.0, 2.0)
    assert set(boot.dropped) == {"FS_MAX_DEPTH_M", "GONE"}
    assert boot.persisted == {"LIM_RUDDER_DEG": 25.0, "PLN_W_D": 0.0, "PLN_W_PSI": 2.0}
    # the table's defaults are the configured values (file + --set), not the persisted ones
    assert boot.configured.core.control.limits.rudder_limit_deg == 22.0
    assert _spec("LIM_RUDDER_DEG", boot.configured.core).default == 22.0
    lines = "\n".join(boot.log_lines)
    assert "control.limits.rudder_limit_deg = 25.0 (persisted, LIM_RUDDER_DEG)" in lines
    assert "control.limits.stern_limit_deg = 18.0 (--set, LIM_STERN_DEG)" in lines
    assert "failsafe.max_depth_m = 12.0 (file, FS_MAX_DEPTH_M)" in lines
    assert "guidance.speed_mps = 1.2 (--set, GDE_SPEED_MPS)" in lines
    assert "persisted LIM_STERN_DEG = 15 not applied" in lines
    assert "persisted FS_MAX_DEPTH_M = 500.0 dropped" in lines and "persisted GONE = 1.0 dropped" in lines
    assert "nav." not in lines  # packaged defaults are not logged


def test_a_file_limit_beyond_the_dbc_stops_start_up(tmp_path: Path) -> None:
    from onboard.app.runtime import resolve_config

    path = _boot_file(tmp_path, "[control.limits]\nrudder_limit_deg = 45.0\n")
    with pytest.raises(ConfigError, match="rudder_limit_deg"):
        resolve_config(path, [], {}, BUS)
    boot = resolve_config(path, ["control.limits.rudder_limit_deg=30"], {"LIM_RUDDER_DEG": 45.0}, BUS)
    assert boot.config.core.control.limits.rudder_limit_deg == 30.0 and not boot.dropped
