"""The bench's parameters declared once (issue 22, item 3): the declaration beside the default is what the
bench's loaders check (bench.toml, the vehicle file) and what ``docs/bench-parameters.md`` shows."""

from __future__ import annotations

import math
import subprocess
import sys
from typing import Any

import pytest

from auv_common.config import ConfigError, declared, declared_bounds, from_table, load_toml
from hil_sim.bench_program import load_hil_config
from hil_sim.model.params import DEFAULT_PARAMS_PATH, VehicleConfig, load_config
from hil_sim.params_doc import PAGE_PATH, _tables, page


def test_the_committed_bench_parameter_page_is_the_generated_one() -> None:
    """GIVEN the declarations in the code and the packaged files WHEN the page is generated THEN
    docs/bench-parameters.md is that text (regenerate: ``python -m hil_sim.params_doc >
    docs/bench-parameters.md``)."""
    assert PAGE_PATH.is_file(), (
        f"{PAGE_PATH} is missing: python -m hil_sim.params_doc > docs/bench-parameters.md"
    )
    assert PAGE_PATH.read_text(encoding="utf-8") == page(), (
        "docs/bench-parameters.md is out of date: python -m hil_sim.params_doc > docs/bench-parameters.md"
    )


@pytest.mark.integration  # a process of its own: not make check's unit tier
def test_the_generator_prints_the_page() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "hil_sim.params_doc"], capture_output=True, text=True, check=True, timeout=120
    )
    assert run.stdout == page()


def test_the_page_lists_every_key_of_both_files_once_with_its_unit() -> None:
    text = page()
    rows = 0
    for config in (load_hil_config(None), load_config()):
        for path, table in _tables(config):
            for key, meta in declared(type(table)):
                found = [line for line in text.splitlines() if line.startswith(f"| `{path}.{key}` |")]
                assert len(found) == 1, f"{path}.{key}"
                cells = [c.strip() for c in found[0].strip("|").split(" | ")]
                assert cells[1] == (meta.unit or "-") and cells[-1] == meta.desc.replace("|", "\\|"), cells
                rows += 1
    assert rows == text.count("\n| `")


def _bench_load(path: str, key: str, value: float) -> None:
    load_hil_config(None, {path: {key: value}})


def _vehicle_load(path: str, key: str, value: float) -> None:
    data = load_toml(DEFAULT_PARAMS_PATH)
    node = data
    for part in path.split("."):
        node = node.setdefault(part, {})
    node[key] = value
    from_table(VehicleConfig, data, "isimi100.toml")


@pytest.mark.parametrize(
    ("config", "load"),
    [(load_hil_config(None), _bench_load), (load_config(), _vehicle_load)],
    ids=["bench", "vehicle"],
)
def test_the_loaders_check_every_declared_range(config: Any, load: Any) -> None:
    """GIVEN any declared key with a finite bound WHEN the file sets it just outside THEN loading stops with
    one line naming the key and the range; at the bound (next to it, for an open end) it loads, unless a rule
    across keys (e.g. a_m + b_m + c_m = lf_m) refuses the pair."""
    checked = 0
    for path, table in _tables(config):
        for key, meta in declared(type(table)):
            lo, hi = declared_bounds(table, key)
            for bound, outside, is_open in (
                (lo, lo - max(1e-3, abs(lo) * 1e-3), meta.min_open),
                (hi, hi + max(1e-3, abs(hi) * 1e-3), meta.max_open),
            ):
                if not math.isfinite(bound):
                    continue
                value: float = bound
                if is_open:  # the bound itself is outside, the value next to it inside
                    value, outside = math.nextafter(bound, hi if bound == lo else lo), bound
                if isinstance(getattr(table, key), int):
                    value, outside = int(bound), int(bound) + (1 if bound == hi else -1)
                try:
                    load(path, key, value)
                except ConfigError as exc:
                    assert f"{key} must be" not in str(exc), str(exc)
                with pytest.raises(ConfigError) as info:
                    load(path, key, outside)
                message = str(info.value)
                assert "\n" not in message and f"{key} must be" in message, message
                assert path.split(".")[0] in message, message
                checked += 1
            assert meta.desc, key
    assert checked >= 10
