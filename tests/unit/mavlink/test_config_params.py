"""[mavlink] configuration and atomic persistence (the parameter service: test_services.py)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from auv_common.config import ConfigError
from onboard.adapters.mavlink.config import MavlinkConfig, load_signing_key
from onboard.adapters.mavlink.mission_protocol import TYPE_MISSION, MissionItem
from onboard.adapters.mavlink.storage import load_plan
from onboard.app.store import StateStore


def test_defaults_and_table() -> None:
    c = MavlinkConfig.from_table({"endpoints": ["udpin:127.0.0.1:0", "tcpin:0.0.0.0:5760"]})
    assert c.endpoints == ("udpin:127.0.0.1:0", "tcpin:0.0.0.0:5760")
    assert MavlinkConfig().gcs_loss_action == "continue" and MavlinkConfig().component_id == 1


@pytest.mark.parametrize(
    "table",
    [
        {"no_such_key": 1},
        {"endpoints": ["serial:/dev/ttyS0:57600"]},
        {"endpoints": ["udpout:127.0.0.1:0"]},
        {"gcs_loss_action": "panic"},
        {"system_id": 0},
        {"max_depth_m": 10.0},  # the validator owns the limits: no longer a [mavlink] key
        {"command_timeout_s": 0.0},
        {"validate_timeout_s": -1.0},
        {"item_timeout_s": 6.0},
        {"heartbeat_rate_hz": "fast"},
    ],
)
def test_bad_config_raises_config_error(table: dict) -> None:
    with pytest.raises(ConfigError):
        MavlinkConfig.from_table(table)


def test_signing_key_file_hex_or_raw(tmp_path: Path) -> None:
    (tmp_path / "hex").write_text("ab" * 32 + "\n")
    (tmp_path / "raw").write_bytes(bytes(range(32)))
    (tmp_path / "bad").write_text("nope")
    assert load_signing_key(tmp_path / "hex") == b"\xab" * 32
    assert load_signing_key(tmp_path / "raw") == bytes(range(32))
    with pytest.raises(ConfigError):
        load_signing_key(tmp_path / "bad")


def test_state_store_round_trip_with_nan(tmp_path: Path) -> None:
    s = StateStore(tmp_path / "state")
    items = (MissionItem(1, 16, 0.0, math.nan, 0.0, math.nan, 10000, -20000, 3.0),)
    s.save_plan("mission", items)
    loaded = load_plan(s, TYPE_MISSION)
    assert loaded is not None and loaded[0].key() == items[0].key()
    s.save_params({"LIM_RPS": 12.0})
    assert s.load_params() == {"LIM_RPS": 12.0}
    assert not list((tmp_path / "state").glob(".*tmp"))
    (tmp_path / "state" / "fence.json").write_text("{broken")
    assert load_plan(s, 1) is None
