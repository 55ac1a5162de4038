"""Each parameter declared once (issue 22, item 3): the declaration beside the default is what the config
loader checks, what the MAVLink table serves and what ``docs/parameters.md`` shows."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from typing import Any

import pytest

from auv_common.config import ConfigError, declared, declared_bounds
from onboard.app.config import OnboardConfig, config_from_dict
from onboard.app.params_doc import APP_TABLES, PAGE_PATH, page
from onboard.core.config import CoreConfig
from onboard.core.control.pd import ControlParams
from onboard.core.params import PARAM_NAMES, SECTIONS, BusLimits, param_table
from onboard.protocol.codec import command_ranges

BUS = BusLimits.from_ranges(command_ranges())


def _tables(node: Any, path: str = "") -> list[tuple[str, Any]]:
    """Every dataclass table under ``node`` with its dotted path (``node`` itself included)."""
    out = [(path, node)]
    for f in dataclasses.fields(node):
        value = getattr(node, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out += _tables(value, f"{path}.{f.name}" if path else f.name)
    return out


def test_the_committed_parameter_page_is_the_generated_one() -> None:
    """GIVEN the declarations in the code WHEN the page is generated THEN docs/parameters.md is that text
    (regenerate: ``python -m onboard.app.params_doc > docs/parameters.md``)."""
    assert PAGE_PATH.is_file(), (
        f"{PAGE_PATH} is missing: python -m onboard.app.params_doc > docs/parameters.md"
    )
    assert PAGE_PATH.read_text(encoding="utf-8") == page(), (
        "docs/parameters.md is out of date: python -m onboard.app.params_doc > docs/parameters.md"
    )


@pytest.mark.integration  # a process of its own: not make check's unit tier
def test_the_generator_prints_the_page() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "onboard.app.params_doc"],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    assert run.stdout == page()


def test_the_page_lists_every_parameter_once_with_its_key_unit_and_range() -> None:
    text = page()
    assert "<" not in text.replace("<profile>", "").replace("<=", "")  # plain Markdown, no HTML
    for spec in param_table(CoreConfig(), BUS):
        rows = [line for line in text.splitlines() if line.startswith(f"| `{spec.name}` |")]
        assert len(rows) == 1, spec.name
        cells = [c.strip() for c in rows[0].strip("|").split(" | ")]
        key = spec.path.replace(".improved.", ".<profile>.")
        assert cells[1] == f"`{key}`" and cells[2] == (spec.unit or "-"), cells
        assert cells[3].startswith(f"[{spec.min:g}, {spec.max:g}]") and cells[5] == spec.description, cells
    headers = [line for line in text.splitlines() if line.startswith("## ")]
    assert headers[len(SECTIONS) :] == [f"## `[{name}]`" for name, _ in APP_TABLES]
    assert len(headers) == len(SECTIONS) + len(APP_TABLES)
    assert "| - | `mavlink.tcp_evict_idle_s` | s | [0.5, 20] (max: tcp_idle_timeout_s) | 3 |" in text


def test_every_mavlink_declaration_is_in_the_table_and_the_table_reads_only_declarations() -> None:
    """No declared MAVLink name outside the table's sections (it would be served by no one), every
    profile declares the same names, and every parameter has a finite, closed range."""
    for profile in ("paper", "improved"):
        config = dataclasses.replace(CoreConfig(), control=ControlParams(profile=profile))
        declared_names = {
            meta.mavlink
            for path, table in _tables(config)
            for _, meta in declared(type(table))
            if meta.mavlink is not None and not (path.startswith("control.") and path.split(".")[1] != profile
                                                 and path != "control.limits")
        }  # fmt: skip
        table = param_table(config, BUS)
        assert {s.name for s in table} == declared_names == set(PARAM_NAMES)
        for s in table:
            assert math.isfinite(s.min) and math.isfinite(s.max) and s.min <= s.default <= s.max, s


def _sections(config: Any) -> list[tuple[str, Any]]:
    return [(p, t) for p, t in _tables(config) if p and declared(type(t))]


def _toml(path: str, key: str, value: float) -> dict[str, Any]:
    data: dict[str, Any] = {key: value}
    for part in reversed(path.split(".")):
        data = {part: data}
    return data


def test_the_config_loader_checks_every_declared_range() -> None:
    """GIVEN any declared key (the core's tables and [mavlink]) WHEN the file sets it just outside its
    declared range THEN start-up stops with one line naming the key and the range; at the bound it loads
    (unless another key's rule, e.g. upload_timeout_s > item_timeout_s, refuses the pair)."""
    checked = 0
    for path, table in _sections(OnboardConfig()):
        for key, meta in declared(type(table)):
            lo, hi = declared_bounds(table, key)
            for bound, outside, is_open in (
                (lo, lo - max(1e-3, abs(lo) * 1e-3), meta.min_open),
                (hi, hi + max(1e-3, abs(hi) * 1e-3), meta.max_open),
            ):
                if not math.isfinite(bound):
                    continue
                value: float = bound
                if is_open:  # an open end: the bound itself is outside, the value next to it inside
                    value, outside = math.nextafter(bound, hi if bound == lo else lo), bound
                if isinstance(getattr(table, key), int):
                    value, outside = int(bound), int(bound) + (1 if bound == hi else -1)
                try:
                    config_from_dict(_toml(path, key, value), "onboard.toml")
                except ConfigError as exc:
                    assert f"{key} must be" not in str(exc), str(exc)
                with pytest.raises(ConfigError) as info:
                    config_from_dict(_toml(path, key, outside), "onboard.toml")
                message = str(info.value)  # this key's rule, or another's that names it (rates <= max rate)
                assert "\n" not in message and key in message and "must be" in message, message
                assert f"{bound:g}" in message or f"{key} must be" not in message, message
                checked += 1
            assert meta.desc, key
    assert checked >= 80  # every finite bound of every declared key (the gains have an operator range only)


def test_the_table_reads_its_ranges_without_trying_values(monkeypatch: pytest.MonkeyPatch) -> None:
    """No bisection: the ranges are read from the declarations, no value is tried on a dataclass (a
    configuration never seen before, so no cache answers either)."""
    c = CoreConfig()
    limits = dataclasses.replace(c.control.limits, rudder_limit_deg=21.5, propeller_min_rps=2.0)
    improved = dataclasses.replace(c.control.improved, Kp1=2.5)
    config = dataclasses.replace(
        c,
        control=dataclasses.replace(c.control, limits=limits, improved=improved),
        planner=dataclasses.replace(c.planner, turning_radius_m=3.5, weight_yaw=0.5),
        guidance=dataclasses.replace(c.guidance, speed_mps=1.1, min_water_speed_mps=0.4),
        mission=dataclasses.replace(c.mission, arrival_radius_m=0.6),
        failsafe=dataclasses.replace(c.failsafe, max_depth_m=11.0),
    )

    def no_tries(*args: object, **kwargs: object) -> None:
        raise AssertionError("the parameter table tried a value on the configuration")

    monkeypatch.setattr(dataclasses, "replace", no_tries)
    table = {s.name: s for s in param_table(config, BUS)}
    assert (table["LIM_RUDDER_DEG"].default, table["LIM_RUDDER_DEG"].min) == (21.5, 1.0)
    assert table["LIM_RPS_MAX"].min == 3.0  # propeller_min_rps + 1, with the values in force
    assert table["PLN_W_D"].min == 0.0  # another weight carries the scale
    assert table["GDE_SPEED_MPS"].min == 0.4  # the steerage way
    assert table["PD_KP1"].default == 2.5 and table["MIS_ARRIVE_R_M"].default == 0.6
