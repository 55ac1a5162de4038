"""The "live" states are defined once (issue 22, item 2: three definitions): ``state.LIVE_STATES``, the bus
contract's set the actuator node applies; "active" (the failsafes apply) and the actuators' truth derive
from it."""

from __future__ import annotations

import pytest

from onboard.core.mission.state import ACTIVE_STATES, LIVE_STATES, MissionState, MissionStatus, actuators_live
from onboard.protocol.messages import LIVE_MISSION_STATES

S = MissionState


def test_one_set_the_core_and_the_bus_contract_share() -> None:
    assert LIVE_STATES is LIVE_MISSION_STATES
    assert {S.ARMED, S.RUNNING, S.HOLD, S.COMPLETE} == LIVE_STATES
    assert ACTIVE_STATES == LIVE_STATES - {S.ARMED}


@pytest.mark.parametrize("state", list(S))
def test_live_active_and_the_actuators_agree_in_every_state(state: MissionState) -> None:
    status = MissionStatus(state)
    assert status.live is (state in LIVE_STATES)
    assert status.active is (status.live and state is not S.ARMED)
    # the actuators move only in a live state; in COMPLETE only while loitering
    assert actuators_live(state, loitering=True) is status.live
    assert actuators_live(state, loitering=False) is (status.live and state is not S.COMPLETE)
