"""A state change reaches the ground station at once, not at the next 1 Hz beat: in the same poll of the
link as the loop's snapshot, MISSION_ITEM_REACHED for the goals just reached, then HEARTBEAT and
MISSION_CURRENT (MAVSDK's is_mission_finished and QGroundControl read the end of a mission there). The
e2e test with the real MAVSDK checks what a user sees; this one checks the order and the "at once" without
a clock (the link's clock does not move)."""

from __future__ import annotations

from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.core.mission.state import MissionState

from .linkkit import Captured
from .test_mission_protocol import wp

GOALS3 = (wp(10.0, 0.0, 1.0), wp(20.0, 0.0, 1.0), wp(30.0, 0.0, 1.0))


def test_the_last_goal_reached_and_complete_are_sent_in_the_same_poll_in_that_order(tmp_path: Path) -> None:
    # GIVEN a link with a 3-goal mission, RUNNING on its last goal, its periodic streams just sent
    c = Captured(tmp_path, items=GOALS3)
    c.link.publish(VehicleSnapshot(state=MissionState.RUNNING, armed=True, current_goal=2, goals_reached=2))
    c.poll()
    c.poll()
    c.out.clear()
    # WHEN the loop reports the last goal reached and the mission COMPLETE, and the link polls with no time
    # passed (no periodic stream is due)
    c.link.publish(VehicleSnapshot(state=MissionState.COMPLETE, armed=True, current_goal=2, goals_reached=3))
    c.poll()
    # THEN the goal, then the state it led to: HEARTBEAT and MISSION_CURRENT with mission_state COMPLETE
    kinds = [m.get_type() for m in c.out]
    assert kinds == ["MISSION_ITEM_REACHED", "HEARTBEAT", "MISSION_CURRENT"], kinds
    reached, _hb, current = c.out
    assert reached.seq == 2
    assert current.mission_state == mavlink.MISSION_STATE_COMPLETE and current.total == 3
    # AND nothing more at the next poll at the same time: sent once
    c.out.clear()
    c.poll()
    assert c.out == []
