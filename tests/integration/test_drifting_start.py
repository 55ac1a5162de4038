"""The onboard knows the current at START (issue 23 item 4: drift from rest), bench and onboard in lock-step.

The bench starts the vehicle drifting with the water; while the onboard waits for START, simulated time
stands still and the DVL shows that drift, so the current estimate the first plan uses is the current. The
old bench held the vehicle at rest over ground before START: the estimate read 0 +- 0.06 m/s in 0.3-0.5 m/s.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from hil_sim.bench_program import BenchConfig, HilConfig, InitialConfig, WaterCurrentConfig
from hil_sim.scenario import DEPTH_M, SCENARIOS
from onboard.app.config import load_config
from onboard.core.autopilot import Autopilot
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionState
from tests.integration.closed_loop import run_lockstep

pytestmark = pytest.mark.slow

SPEED_MPS, TOWARDS_DEG = 0.4, 120.0


def test_the_current_estimate_at_start_is_the_current(tmp_path: Path) -> None:
    # GIVEN the paper's straight in 0.4 m/s towards 120 deg (across and against the start heading)
    sc = SCENARIOS["paper-straight"]
    hil = HilConfig(
        bench=BenchConfig(
            time_mode="lockstep", seed=3, duration_s=1.0, truth_log=str(tmp_path / "truth.csv")
        ),
        initial=InitialConfig(sc.start[0], sc.start[1], DEPTH_M, sc.start[2]),
        current=WaterCurrentConfig(SPEED_MPS, TOWARDS_DEG),
    )
    cfg = load_config()
    autopilot = Autopilot(cfg.core)
    autopilot.replace_mission(Mission((Goal(sc.goal[0], sc.goal[1], DEPTH_M, math.radians(sc.goal[2])),)))
    autopilot.request_autostart()
    at_start: list[Any] = []
    inner = autopilot.step

    def step(cache: dict[type, Any], now_s: float, dt_s: float) -> Any:
        record = inner(cache, now_s, dt_s)
        if not at_start and record.mission_state is MissionState.RUNNING:
            at_start.append(record.nav)
        return record

    autopilot.step = step  # type: ignore[method-assign]
    # WHEN the onboard starts the mission on the bench
    run_lockstep(autopilot, cfg.loop, hil, f"drifting-start-{id(tmp_path)}", 120.0, "drifting start")
    # THEN its current estimate at START is within 0.1 m/s of the water's
    assert at_start, "the mission never ran"
    nav = at_start[0]
    truth = (SPEED_MPS * math.cos(math.radians(TOWARDS_DEG)), SPEED_MPS * math.sin(math.radians(TOWARDS_DEG)))
    error = math.hypot(nav.current_north_mps - truth[0], nav.current_east_mps - truth[1])
    assert error <= 0.1, (nav.current_north_mps, nav.current_east_mps, truth)
