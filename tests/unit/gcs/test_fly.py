"""``auv-gcs fly``'s watch: how a started mission ends, from the vehicle's messages (a scripted client)."""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink
from rich.console import Console

from groundstation import fly
from groundstation.messages import StatusText

ARMED_FLAG = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
MANUAL, AUTO, POSHOLD, SURFACE = 19, 3, 16, 9


def hb(mode: int, armed: bool = True, status: int = mavlink.MAV_STATE_ACTIVE) -> Any:
    base = ARMED_FLAG if armed else mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SUBMARINE, 0, base, mode, status, 3)


def nav(dist_m: int) -> Any:
    return mavlink.MAVLink_nav_controller_output_message(0, 0, 0, 0, dist_m, 0.1, 0, 0.05)


class Script:
    """A client that hands out scripted messages (each ``None`` is a quiet 0.1 s) and the texts given."""

    def __init__(self, *steps: Any) -> None:
        self.steps = deque(steps)
        self.texts: deque[StatusText] = deque()

    def recv(self, timeout_s: float) -> Any:
        step = self.steps.popleft() if self.steps else None
        if isinstance(step, str):  # a text of the vehicle, as the assembler gives it
            self.texts.append(StatusText(mavlink.MAV_SEVERITY_WARNING, step, time.monotonic()))
            return None
        if step is None:
            time.sleep(min(timeout_s, 0.01))
        return step

    def from_vehicle(self, m: Any) -> bool:
        return True

    def texts_since(self, t_s: float) -> list[StatusText]:
        return [t for t in self.texts if t.t_s >= t_s]


def watch(script: Script, goals: int = 1) -> tuple[int, dict[str, Any]]:
    return fly.watch(script, goals, Console(quiet=True), as_json=True, emit=lambda d: None)  # type: ignore[arg-type]


def test_complete_is_exit_0_with_the_goals_reached() -> None:
    code, data = watch(
        Script(hb(AUTO), nav(12), mavlink.MAVLink_mission_item_reached_message(0), hb(SURFACE, False))
    )
    assert code == fly.EXIT_OK and data["state"] == "COMPLETE" and data["reached"] == 1 and data["ok"]


def test_an_abort_while_running_is_exit_1_with_the_vehicles_reason() -> None:
    script = Script(
        hb(AUTO), "abort: RUNNING -> ABORT: depth limit", hb(SURFACE, False, mavlink.MAV_STATE_CRITICAL)
    )
    code, data = watch(script)
    assert code == fly.EXIT_REFUSED and data["state"] == "ABORT"
    assert data["reason"] == "abort: RUNNING -> ABORT: depth limit"


def test_a_hold_before_running_is_the_end_not_a_wait() -> None:
    # the START was accepted, but the first leg could not be planned: the vehicle holds with the reason
    script = Script(hb(MANUAL), "start: ARMED -> HOLD: leg 0 cannot be planned", hb(POSHOLD))
    code, data = watch(script)
    assert (
        code == fly.EXIT_REFUSED and data["state"] == "HOLD" and "leg 0 cannot be planned" in data["reason"]
    )


def test_a_vehicle_that_never_runs_or_goes_silent_ends_the_watch(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fly, "START_WAIT_S", 0.2)
    code, data = watch(Script(hb(MANUAL), *[None] * 100))
    assert code == fly.EXIT_REFUSED and data["reason"] == "the mission did not start"
    monkeypatch.setattr(fly, "LINK_LOST_S", 0.2)
    code, data = watch(Script(hb(AUTO), *[None] * 100))
    assert code == fly.EXIT_ERROR and data["reason"] == "no heartbeat for 0.2 s"


def test_the_distance_to_go_is_from_the_position_when_the_goal_is_local() -> None:
    view = fly.FlightView(2, goal_xy_m=[(10.0, 0.0), None])
    view.feed(mavlink.MAVLink_local_position_ned_message(0, 3.7, 0.0, 1.0, 1.0, 0.0, 0.0))
    view.feed(nav(6))
    assert view.distance_m == pytest.approx(6.3) and "6.3 m to go" in view.line()
    assert view.eta_s == pytest.approx(6.3)
    view.feed(mavlink.MAVLink_mission_current_message(1, 2, mavlink.MISSION_STATE_ACTIVE, 1))
    view.feed(nav(42))  # a global goal: NAV_CONTROLLER_OUTPUT's whole metres, said as such
    assert view.distance_m == 42.0 and "42 m to go" in view.line()


def test_a_heartbeat_from_before_a_resume_is_not_the_end() -> None:
    # fly on a held vehicle: the START resumes it, but a HEARTBEAT sent before the tick still says HOLD
    code, data = watch(Script(hb(POSHOLD), None, hb(AUTO), hb(SURFACE, False)))
    assert code == fly.EXIT_OK and data["state"] == "COMPLETE"
