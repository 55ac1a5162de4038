"""The ``campaign`` benchmark section: registered with auv-bench, and its pure helpers (no benchmark runs)."""

from __future__ import annotations

import math

import pytest

from auv_bench.__main__ import PACKAGES, SECTIONS
from auv_campaign import bench, bench_campaign
from auv_campaign.bench_campaign import (
    GOAL,
    START,
    bench_scenario,
    mission_runs,
    per_minute,
    rest_split,
    tick_split,
)


def test_registered_with_auv_bench() -> None:
    assert "campaign" in SECTIONS
    assert "auv_campaign.bench" in PACKAGES
    assert bench.SECTIONS == {"campaign": "auv_campaign.bench_campaign"}
    assert callable(bench_campaign.run)


def test_mission_runs_one_per_seed_all_different() -> None:
    runs = mission_runs(range(3, 7))
    assert [r.seed for r in runs] == [3, 4, 5, 6]
    assert len({r.run_id for r in runs}) == 4
    for r in runs:
        assert r.mission.start == START
        assert r.mission.goals == (GOAL,)
        assert r.mission.obstacles == ()
        assert r.current_speed_mps == 0.0
        assert r.profile == "basin"
    # about 30 s at 1 m/s
    assert 25.0 <= math.hypot(GOAL[0] - START[0], GOAL[1] - START[1]) <= 30.0


def test_bench_scenario_is_the_same_mission() -> None:
    sc = bench_scenario()
    assert sc.start == (START[0], START[1], START[3])
    assert sc.goal == (GOAL[0], GOAL[1], GOAL[3])
    assert START[2] == GOAL[2] == 1.0  # the scenario flies at 1 m depth


def test_per_minute() -> None:
    assert per_minute(10, 30.0) == pytest.approx(20.0)
    assert math.isnan(per_minute(3, 0.0))


def test_tick_split_sums_to_the_tick() -> None:
    t = {"drive_s": 0.4, "onboard_core_s": 0.05, "simulator_s": 0.1, "ticks": 1000.0}
    s = tick_split(t)
    assert s["tick_total_us"] == pytest.approx(400.0)
    assert s["tick_onboard_core_us"] == pytest.approx(50.0)
    assert s["tick_simulator_us"] == pytest.approx(100.0)
    assert s["tick_frames_us"] == pytest.approx(250.0)
    fractions = [s[k] for k in s if k.endswith("_fraction")]
    assert len(fractions) == 3
    assert sum(fractions) == pytest.approx(1.0)
    assert s["tick_frames_fraction"] == pytest.approx(0.625)


def test_tick_split_without_ticks() -> None:
    with pytest.raises(ValueError):
        tick_split({"drive_s": 0.0, "ticks": 0.0})


def test_rest_split() -> None:
    t = {"drive_s": 0.4, "onboard_core_s": 0.05, "simulator_s": 0.1, "ticks": 1000.0,
         "codec_e2e_s": 0.1, "bus_s": 0.12, "bus_sends": 10_500.0}  # fmt: skip
    s = rest_split(t)
    assert s["tick_rest_codec_e2e_us"] == pytest.approx(100.0)
    assert s["tick_rest_bus_us"] == pytest.approx(120.0)
    assert s["tick_rest_other_us"] == pytest.approx(30.0)
    assert s["frames_per_tick"] == pytest.approx(10.5)
