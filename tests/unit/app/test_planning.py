"""Planning never in the tick: the worker computes the plans the core asks for, off the control thread."""

from __future__ import annotations

import threading
from typing import Any

import pytest

from onboard.app import planning
from onboard.app.planning import PlanWorker
from onboard.core import commands as c
from onboard.core.autopilot import Autopilot
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.state import MissionState
from onboard.core.plans import compute_plan
from tests.unit.autopilot.test_autopilot import DT, core, sensors


@pytest.fixture
def gate(monkeypatch: pytest.MonkeyPatch) -> threading.Event:
    """The worker's planner waits for this event (a plan as slow as the test wants, no timing)."""
    release = threading.Event()

    def slow(request: Any) -> Any:
        release.wait(10.0)
        return compute_plan(request)

    monkeypatch.setattr(planning, "compute_plan", slow)
    return release


def armed(**mission: object) -> Autopilot:
    ap = Autopilot(core(**{"max_obstacles": 400, **mission}))  # the default capacity is 64
    # 400 obstacles far from the leg: what took 0.93 s inside a tick before
    fence = tuple(Obstacle(-100.0 - 3.0 * (i % 20), -30.0 + 3.0 * (i // 20), 1.0) for i in range(400))
    assert ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),), fence)).accepted
    ap.step(sensors(0.0), 0.0, DT)
    assert ap.handle(c.Arm()).accepted
    return ap


def test_in_real_time_the_tick_goes_on_still_while_the_plan_is_computed(gate: threading.Event) -> None:
    ap = armed()
    worker = PlanWorker(ap, lockstep=False)
    assert ap.handle(c.Start()).accepted
    t = 0.05
    for _ in range(5):  # the planner is blocked: every tick still runs, neutral, waiting
        worker.before_step()
        out = ap.step(sensors(t), t, DT)
        worker.after_step()
        assert out.status.state is MissionState.RUNNING and ap.plan_pending and out.propeller_rps == 0.0
        t += DT
    gate.set()
    for _ in range(200):
        worker.before_step()
        out = ap.step(sensors(t), t, DT)
        worker.after_step()
        t += DT
        if ap.path is not None:
            break
        threading.Event().wait(0.01)
    assert ap.path is not None and not ap.plan_pending and worker.plans == 1
    worker.close()


def test_in_lock_step_the_plan_is_awaited_before_the_step_so_runs_repeat(gate: threading.Event) -> None:
    gate.set()
    ap = armed()
    worker = PlanWorker(ap, lockstep=True)
    assert ap.handle(c.Start()).accepted  # asks for the plan from where the vehicle is
    worker.before_step()  # submits it and waits for it
    out = ap.step(sensors(0.05), 0.05, DT)
    assert ap.path is not None and out.propeller_rps > 0.0
    worker.close()


def test_a_plan_past_its_deadline_is_a_hold_with_a_reason_not_an_overrun(gate: threading.Event) -> None:
    ap = armed(plan_deadline_s=0.1)
    worker = PlanWorker(ap, lockstep=True)
    assert ap.handle(c.Start()).accepted
    worker.before_step()  # waits 0.1 s (wall) for the blocked planner, then gives up
    assert worker.late == 1
    ap.step(sensors(0.05), 0.05, DT)
    out = ap.step(sensors(0.2), 0.2, DT)
    assert out.status.state is MissionState.HOLD and "deadline" in out.status.reason
    gate.set()
    worker.close()
