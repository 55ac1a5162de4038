"""The vehicle's state store (onboard.app.store) cannot brick the vehicle: a bad file is moved aside,
announced and not loaded (a stored plan's items checked as an upload is: onboard.adapters.mavlink.storage)."""

from __future__ import annotations

import json
import logging
import math
import os
import stat
from pathlib import Path
from typing import Any

import pytest

from auv_common.config import ConfigError
from onboard.adapters.mavlink.mission_protocol import TYPE_FENCE, TYPE_MISSION, MissionItem
from onboard.adapters.mavlink.storage import load_plan, mission_key
from onboard.app.store import PARAMS_FILE, PROGRESS_FILE, StateDirError, StateStore

WP = MissionItem(1, 16, 0.0, math.nan, 0.0, math.nan, 100_000, -20_000, 3.0)  # LOCAL_NED waypoint
FENCE = MissionItem(1, 5004, 2.0, 0.0, 0.0, 0.0, 50_000, 50_000, 0.0)  # circle exclusion, radius 2 m


def write(path: Path, content: Any) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(content if isinstance(content, str) else json.dumps(content))


def plan_file(*items: dict[str, Any]) -> dict[str, Any]:
    return {"version": 1, "items": list(items)}


def asides(directory: Path, name: str) -> list[Path]:
    return sorted(directory.glob(f"{name}.invalid-*"))


def test_good_files_round_trip(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    store.save_plan("mission", (WP,))
    store.save_plan("fence", (FENCE,))
    store.save_params({"LIM_RPS": 12.0})
    again = StateStore(tmp_path)
    mission, fence = load_plan(again, TYPE_MISSION), load_plan(again, TYPE_FENCE)
    assert mission is not None and [i.key() for i in mission] == [WP.key()]
    assert fence == (FENCE,)
    assert again.load_params() == {"LIM_RPS": 12.0}
    assert again.quarantined() == [] and not list(tmp_path.glob("*.invalid-*"))


def test_nothing_stored_is_not_a_problem(tmp_path: Path) -> None:
    store = StateStore(tmp_path / "absent")
    assert load_plan(store, TYPE_MISSION) is None and store.load_params() == {}
    assert store.load_progress("k") is None and store.quarantined() == []


@pytest.mark.parametrize(
    ("name", "mission_type", "content", "why"),
    [
        ("mission.json", TYPE_MISSION, '{"version": 1, "items": [{"frame": 1', "not valid JSON"),
        ("mission.json", TYPE_MISSION, "[1, 2]", "expected a JSON object"),
        ("mission.json", TYPE_MISSION, {"version": 1, "items": 3}, "'items' must be a JSON array"),
        (
            "mission.json",
            TYPE_MISSION,
            plan_file(WP.to_json(), {**WP.to_json(), "z": None}),
            "item 1: depth is not a finite number: nan",
        ),
        (
            "mission.json",
            TYPE_MISSION,
            plan_file({**WP.to_json(), "frame": 99}),
            "item 0: frame 99 unsupported",
        ),
        (
            "mission.json",
            TYPE_MISSION,
            plan_file({**WP.to_json(), "x": "1"}),
            "item 0: x '1' is not an integer",
        ),
        ("mission.json", TYPE_MISSION, plan_file({**WP.to_json(), "command": 17}), "command 17 unsupported"),
        ("mission.json", TYPE_MISSION, '{"version": 1, "items": [{"z": NaN}]}', "not valid JSON"),
        (
            "fence.json",
            TYPE_FENCE,
            plan_file({**FENCE.to_json(), "param1": -2.0}),
            "item 0: radius -2 m must be positive",
        ),
    ],
)
def test_an_invalid_plan_file_is_moved_aside_and_announced(
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    name: str,
    mission_type: int,
    content: Any,
    why: str,
) -> None:
    write(tmp_path / name, content)
    store = StateStore(tmp_path)
    with caplog.at_level(logging.ERROR, logger="onboard.app.store"):
        assert load_plan(store, mission_type) is None
    assert not (tmp_path / name).exists()
    (aside,) = asides(tmp_path, name)
    assert aside.read_text() == (content if isinstance(content, str) else json.dumps(content))  # kept as is
    (line,) = store.quarantined()
    assert line.startswith(f"{name} was invalid (") and why in line and line.endswith(aside.name)
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1 and why in errors[0].getMessage()
    # the next boot finds nothing (and says nothing more)
    again = StateStore(tmp_path)
    assert load_plan(again, mission_type) is None and again.quarantined() == []


def test_fence_radius_minus_two_names_the_item(tmp_path: Path) -> None:
    write(
        tmp_path / "fence.json",
        plan_file(FENCE.to_json(), FENCE.to_json(), {**FENCE.to_json(), "param1": -2}),
    )
    store = StateStore(tmp_path)
    assert load_plan(store, TYPE_FENCE) is None
    assert "(item 2: radius -2 m must be positive)" in store.quarantined()[0]


@pytest.mark.parametrize(
    ("content", "why"),
    [
        ({"version": 1, "params": {"LIM_RPS": "12"}}, "LIM_RPS = '12' is not a finite number"),
        ({"version": 1, "params": {"LIM_RPS": True}}, "is not a finite number"),
        ({"version": 1, "params": {"A_VERY_LONG_PARAMETER_NAME": 1.0}}, "is not 1..16 characters"),
        ({"version": 2, "params": {}}, "version 2"),
        ("not json", "not valid JSON"),
    ],
)
def test_an_invalid_params_file_is_moved_aside(tmp_path: Path, content: Any, why: str) -> None:
    write(tmp_path / PARAMS_FILE, content)
    store = StateStore(tmp_path)
    assert store.load_params() == {}
    assert len(asides(tmp_path, PARAMS_FILE)) == 1 and not (tmp_path / PARAMS_FILE).exists()
    (line,) = store.quarantined()
    assert why in line


def test_two_quarantines_in_the_same_second_keep_both_files(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    for _ in range(2):
        write(tmp_path / PARAMS_FILE, "{")
        assert store.load_params() == {}
    assert len(asides(tmp_path, PARAMS_FILE)) == 2 and len(store.quarantined()) == 2


def test_progress_round_trip_and_mission_key(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    key = mission_key((WP,))
    assert key == mission_key((MissionItem(**WP.__dict__),))  # stable, NaN included
    store.save_progress(3, key)
    assert StateStore(tmp_path).load_progress(key) == 3
    # progress of another mission is never applied (and that file is not invalid: it stays)
    other = mission_key((WP, WP))
    assert other != key
    assert StateStore(tmp_path).load_progress(other) is None
    assert (tmp_path / PROGRESS_FILE).exists() and not asides(tmp_path, PROGRESS_FILE)
    with pytest.raises(ValueError, match="goal_index"):
        store.save_progress(-1, key)


@pytest.mark.parametrize(
    "content",
    [
        {"version": 1, "mission_key": "k", "goal_index": -1},
        {"version": 1, "mission_key": "k", "goal_index": 1.5},
        {"version": 1, "mission_key": 7, "goal_index": 1},
        '{"version": 1, "mission_key": "k", "goal_',
    ],
)
def test_an_invalid_progress_file_is_moved_aside(tmp_path: Path, content: Any) -> None:
    write(tmp_path / PROGRESS_FILE, content)
    store = StateStore(tmp_path)
    assert store.load_progress("k") is None
    assert len(asides(tmp_path, PROGRESS_FILE)) == 1 and len(store.quarantined()) == 1


def test_quarantine_is_public_for_whole_mission_refusals(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    store.save_plan("mission", (WP,))
    line = store.quarantine("mission.json", "goal 0: depth 30 m is below the failsafe depth limit 20 m")
    assert "goal 0: depth 30 m" in line and store.quarantined() == [line]
    assert load_plan(store, TYPE_MISSION) is None


def test_a_state_directory_that_cannot_be_created(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(
        StateDirError, match=r"^state directory .*/file/state cannot be created: Not a directory$"
    ):
        StateStore(blocker / "state").check_writable()
    with pytest.raises(StateDirError, match="is not a directory"):
        StateStore(blocker).check_writable()


def test_a_writable_state_directory_passes_and_leaves_nothing(tmp_path: Path) -> None:
    StateStore(tmp_path / "new").check_writable()
    assert (tmp_path / "new").is_dir() and list((tmp_path / "new").iterdir()) == []


def test_an_unwritable_state_directory(tmp_path: Path) -> None:
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o500)
    try:
        if os.access(d, os.W_OK):
            pytest.skip("chmod does not take write access away here (running as root)")
        with pytest.raises(StateDirError) as err:
            StateStore(d).check_writable()
        assert str(err.value) == f"state directory {d} is not writable: Permission denied"
    finally:
        d.chmod(0o700)


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("params.json", '{"version": 1, "params": {"PD_KP5": 1' + "0" * 400 + "}}"),
        ("mission.json", '{"version": 1, "items": [{"frame": 1, "command": 16, "x": 1' + "0" * 400 + "}]}"),
        ("progress.json", "[" * 100_000 + "]" * 100_000),
    ],
)
def test_absurd_numbers_or_nesting_make_invalid_files_not_a_crash(
    tmp_path: Path, name: str, text: str
) -> None:
    (tmp_path / name).write_text(text)
    store = StateStore(tmp_path)
    assert store.load_params() == {}
    assert load_plan(store, TYPE_MISSION) is None
    assert store.load_progress("key") is None
    assert len(store.quarantined()) == 1 and name in store.quarantined()[0]
    assert not (tmp_path / name).exists()


def test_the_signing_timestamp_round_trips_and_a_bad_file_is_set_aside(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    assert store.load_signing_timestamp() == 0
    store.save_signing_timestamp(123_456_789_012)
    assert StateStore(tmp_path).load_signing_timestamp() == 123_456_789_012
    (tmp_path / "signing.json").write_text('{"version": 1, "timestamp": -5}')
    bad = StateStore(tmp_path)
    assert bad.load_signing_timestamp() == 0 and bad.quarantined()


def test_a_signing_key_is_owner_only_from_its_creation_and_round_trips(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    old_umask = os.umask(0)  # even with no umask at all
    try:
        store.save_signing_key(bytes(range(32)))
    finally:
        os.umask(old_umask)
    path = tmp_path / "signing_key.json"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert store.load_signing_key() == (True, bytes(range(32)))
    store.save_signing_key(None)
    assert store.load_signing_key() == (True, None)  # off, by a SETUP_SIGNING


@pytest.mark.parametrize("content", ["{not json", '{"version": 1, "key": "abcd"}', '{"version": 1}'])
def test_a_signing_key_file_that_cannot_be_used_fails_closed(tmp_path: Path, content: str) -> None:
    (tmp_path / "signing_key.json").write_text(content)
    store = StateStore(tmp_path)
    set_, key = store.load_signing_key()
    # THEN signing stays on with a key nobody holds (never off), also at the next boot, and the file is set
    # aside and announced
    assert set_ and key is not None and len(key) == 32
    assert len(store.quarantined()) == 1 and StateStore(tmp_path).load_signing_key() == (True, key)


def test_open_removes_what_killed_writers_left_but_never_its_own(tmp_path: Path) -> None:
    # issue 21 row 17: a kill -9 in write_json_atomic or the probe leaves its temporary file for ever
    own = f".params.json.{os.getpid()}.tmp"
    for name in (".progress.json.12.tmp", ".write-probe.13", own, ".other.json.14.tmp", "x.tmp"):
        (tmp_path / name).write_text("{")
    store = StateStore(tmp_path)
    assert store.open() == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([own, ".other.json.14.tmp", "x.tmp"])


def test_a_failed_save_is_the_storage_problem_until_a_probe_or_save_works(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    store = StateStore(blocker)  # a "directory" that is a file: nothing can be saved
    assert "is not a directory" in store.open()
    with pytest.raises(StateDirError, match="is not writable"):
        store.save_params({"PD_KP5": -0.5})
    assert store.problem().startswith(f"state directory {blocker} is not writable")
    assert store.reprobe(0.0) and store.reprobe(0.1)  # still broken; probed at most every PROBE_PERIOD_S
    blocker.unlink()
    assert store.reprobe(0.2) != ""  # not yet due
    assert store.reprobe(100.0) == ""  # the next probe finds it writable (created)
    store.save_params({"PD_KP5": -0.5})
    assert store.load_params() == {"PD_KP5": -0.5}


# ---- the [store] table (issue 22 item 4: the store is the vehicle's, not MAVLink's) -------------------
def test_the_store_table_and_its_default_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from onboard.app.config import config_from_dict, load_config
    from onboard.app.store import StoreConfig

    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "xdg"))
    assert load_config().store == StoreConfig()  # the packaged onboard.toml says the defaults
    assert StoreConfig().resolved_dir() == tmp_path / "xdg" / "isimi100"
    cfg = config_from_dict({"store": {"dir": str(tmp_path / "s"), "probe_period_s": 0.5}}, "x")
    store = StateStore.of(cfg.store)
    assert store.dir == tmp_path / "s" and store.probe_period_s == 0.5


def test_mavlink_state_dir_in_a_config_file_is_refused_naming_store_dir() -> None:
    from onboard.app.config import config_from_dict

    with pytest.raises(ConfigError) as err:
        config_from_dict({"mavlink": {"state_dir": "/var/lib/auv"}}, "onboard.toml")
    (line,) = str(err.value).splitlines()
    assert "state_dir was removed" in line and "[store] dir (store.dir)" in line


def test_the_state_dir_option_sets_store_dir(tmp_path: Path) -> None:
    from onboard.app.runtime import build_config

    state = tmp_path / 'a "quoted" dir'
    cfg = build_config(None, [f"store.dir={json.dumps(str(state))}"])
    assert StateStore.of(cfg.store).dir == state


def test_progress_is_written_when_it_changes_and_retried_with_back_off(tmp_path: Path) -> None:
    # GIVEN a store whose directory is a file (a disk that cannot be written), then becomes writable
    blocker = tmp_path / "state"
    blocker.write_text("")
    store = StateStore(blocker)
    store.open()
    # WHEN the progress changes: the failure is said once, the retries back off
    failed = store.keep_progress(1, "k", 0.0)
    assert failed is not None and failed[0] is False and "goal 1) not saved, retrying" in failed[1]
    assert store.keep_progress(1, "k", 0.5) is None  # within the back-off: not tried, not said again
    blocker.unlink()
    assert store.keep_progress(1, "k", 0.6) is None  # still backing off (the store has not probed yet)
    # THEN once due it is saved and said; the same value again is not written
    assert store.keep_progress(1, "k", 1.5) == (True, "mission progress (goal 1) saved")
    assert StateStore(blocker).load_progress("k") == 1
    (blocker / PROGRESS_FILE).unlink()
    assert store.keep_progress(1, "k", 2.0) is None and not (blocker / PROGRESS_FILE).exists()
    assert store.keep_progress(2, "k", 2.0) is None and StateStore(blocker).load_progress("k") == 2
