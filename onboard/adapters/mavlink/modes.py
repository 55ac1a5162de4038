"""The vehicle's modes on MAVLink: the one table of HEARTBEAT ``custom_mode`` and of DO_SET_MODE.

HEARTBEAT is MAV_TYPE_SUBMARINE with ArduSub's custom-mode numbers (ArduSub ``mode.h``; pymavlink's
``mode_mapping_sub``), so MAVProxy and other ground stations that know ArduSub show the mode by name.
The autopilot stays MAV_AUTOPILOT_GENERIC: this is not ArduPilot and does not claim its parameters.

=========  =============  ===========================================================================
mode       number         the vehicle's state (what it does)
=========  =============  ===========================================================================
MANUAL     19             IDLE (disarmed) and ARMED: propeller off, fins neutral, nothing steered
AUTO       3              RUNNING: flying the mission
POSHOLD    16             HOLD: the mission held, propeller off, fins neutral, still armed (a torpedo
                          cannot hold a position: it drifts; ArduSub's name is the closest there is)
CIRCLE     7              COMPLETE with the ``loiter`` end action: circling the last goal, armed
SURFACE    9              ABORT (MAV_STATE_CRITICAL) and COMPLETE with the ``surface`` end action
=========  =============  ===========================================================================

A ground station reads the state back from the mode, SAFETY_ARMED and ``system_status`` (MANUAL + armed is
ARMED; SURFACE + CRITICAL is ABORT, SURFACE otherwise COMPLETE). ``groundstation.mavclient`` does.

DO_SET_MODE (param1 with MAV_MODE_FLAG_CUSTOM_MODE_ENABLED) takes either layout:

- ArduSub (MAVProxy's ``mode NAME``, QGroundControl for ArduSub): param2 = the number above, param3 = 0:
  AUTO "mission", POSHOLD "loiter" (hold), SURFACE "surface" (abort), MANUAL "ready";
- PX4 (MAVSDK): param2 = main mode AUTO (4), param3 = sub mode MISSION 4, LOITER 3, RTL 5, READY 1.

ArduSub's GUIDED is 4, PX4's main mode AUTO is 4 too: param3 tells them apart (0 for ArduSub).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from onboard.core import commands as core
from onboard.core.commands import Verdict
from onboard.core.mission.state import MissionState

STABILIZE, ACRO, ALT_HOLD, AUTO, GUIDED, CIRCLE, SURFACE, POSHOLD, MANUAL = 0, 1, 2, 3, 4, 7, 9, 16, 19
#: ArduSub's mode names (the ones a ground station shows).
ARDUSUB_NAMES: dict[int, str] = {
    STABILIZE: "STABILIZE", ACRO: "ACRO", ALT_HOLD: "ALT_HOLD", AUTO: "AUTO", GUIDED: "GUIDED",
    CIRCLE: "CIRCLE", SURFACE: "SURFACE", POSHOLD: "POSHOLD", MANUAL: "MANUAL",
}  # fmt: skip

_S = MissionState
#: The one table: the mode a state is in (COMPLETE: by whether it loiters).
_STATE_MODE: dict[MissionState, int] = {
    _S.IDLE: MANUAL,
    _S.ARMED: MANUAL,
    _S.RUNNING: AUTO,
    _S.HOLD: POSHOLD,
    _S.ABORT: SURFACE,
    _S.COMPLETE: SURFACE,
}

#: The mode requests a ground station may make, ArduSub layout.
_ARDUSUB_REQUESTS: dict[int, core.ModeName] = {
    AUTO: "mission",
    POSHOLD: "loiter",
    SURFACE: "surface",
    MANUAL: "ready",
}
PX4_MAIN_AUTO = 4
PX4_SUB_READY, PX4_SUB_LOITER, PX4_SUB_MISSION, PX4_SUB_RTL = 1, 3, 4, 5
_PX4_REQUESTS: dict[int, core.ModeName] = {
    PX4_SUB_MISSION: "mission",
    PX4_SUB_LOITER: "loiter",
    PX4_SUB_RTL: "surface",
    PX4_SUB_READY: "ready",
}


def custom_mode(state: MissionState, loitering: bool) -> int:
    """HEARTBEAT ``custom_mode`` of a state (ArduSub's number); COMPLETE is CIRCLE while ``loitering`` (the
    snapshot's bit: not the armed bit, which is also set while the surface end action still brakes)."""
    if state is _S.COMPLETE and loitering:
        return CIRCLE
    return _STATE_MODE[state]


def mode_name(number: int) -> str:
    return ARDUSUB_NAMES.get(number, f"mode {number}")


def requested_mode(base: int, main: int, sub: int) -> core.ModeName | Verdict:
    """The mode a DO_SET_MODE asks for (param1 ``base``, param2 ``main``, param3 ``sub``), or why it is
    refused."""
    if not base & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        return core.denied("only custom modes (param1 with MAV_MODE_FLAG_CUSTOM_MODE_ENABLED)")
    if main == PX4_MAIN_AUTO and sub in _PX4_REQUESTS:
        return _PX4_REQUESTS[sub]
    if sub == 0 and main in _ARDUSUB_REQUESTS:
        return _ARDUSUB_REQUESTS[main]
    settable = ", ".join(ARDUSUB_NAMES[m] for m in _ARDUSUB_REQUESTS)
    if sub == 0 and main == CIRCLE:
        return core.denied(f"CIRCLE is the end of a mission with the loiter end action; modes: {settable}")
    return core.denied(f"{mode_name(main)} is not a mode of this vehicle (modes: {settable})")
