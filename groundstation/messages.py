"""The vehicle's words, decoded (pure: no socket, no clock): result and state names, the mission state a
HEARTBEAT says, whole STATUSTEXTs from their MAVLink 2 chunks, the sensor problems of a SYS_STATUS.

The link (:mod:`groundstation.link`), the clients, ``fly``, ``monitor``, ``plot`` and the map all read the
vehicle through these, so each rule has one owner here.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TypeAlias

from pymavlink.dialects.v20 import common as mavlink

#: A decoded MAVLink message (pymavlink has no type stubs: its fields are read by name).
Msg: TypeAlias = mavlink.MAVLink_message

MISSION_RESULT_NAMES = {
    v: k
    for k, v in vars(mavlink).items()
    if k.startswith("MAV_MISSION_") and isinstance(v, int) and "TYPE" not in k
}
MAV_RESULT_NAMES = {
    v: k for k, v in vars(mavlink).items() if k.startswith("MAV_RESULT_") and isinstance(v, int)
}
MAV_STATE_NAMES = {
    v: k for k, v in vars(mavlink).items() if k.startswith("MAV_STATE_") and isinstance(v, int)
}
#: The vehicle's HEARTBEAT custom_mode: ArduSub's mode numbers (pymavlink's ``mode_mapping_sub``).
ARDUSUB_MANUAL, ARDUSUB_AUTO, ARDUSUB_POSHOLD, ARDUSUB_CIRCLE, ARDUSUB_SURFACE = 19, 3, 16, 7, 9
#: HEARTBEAT system_status values meaning "not ready yet" (the vehicle reports BOOT until it could start).
NOT_READY_STATES = (mavlink.MAV_STATE_UNINIT, mavlink.MAV_STATE_BOOT)
STATUSTEXT_LEN = 50


@dataclass(frozen=True)
class StatusText:
    """One (reassembled) STATUSTEXT of the vehicle: MAV_SEVERITY, the text, when it arrived (monotonic s).

    ``complete`` is False for a chunked text whose last chunk never came (the chunks that did, in order)."""

    severity: int
    text: str
    t_s: float
    complete: bool = True


class StatusTextAssembler:
    """Reassembles STATUSTEXT chunks (MAVLink 2 ``id`` / ``chunk_seq``) into whole texts."""

    def __init__(self, max_age_s: float = 2.0) -> None:
        self.max_age_s = max_age_s
        self._parts: dict[tuple[int, int, int], tuple[int, float, dict[int, str]]] = {}

    def feed(self, msg: Msg, now_s: float) -> StatusText | None:
        """The completed text this message finishes (a single-message text at once), else None."""
        text = wire_string(msg.text)
        chunk_id = int(getattr(msg, "id", 0) or 0)
        if chunk_id == 0:
            return StatusText(int(msg.severity), text, now_s)
        key = (msg.get_srcSystem(), msg.get_srcComponent(), chunk_id)
        severity, _t, parts = self._parts.get(key, (int(msg.severity), now_s, {}))
        parts[int(getattr(msg, "chunk_seq", 0) or 0)] = text
        if len(text) < STATUSTEXT_LEN:  # the last chunk (it ends with a NUL)
            self._parts.pop(key, None)
            last = max(parts)
            complete = all(k in parts for k in range(last + 1))
            return StatusText(severity, "".join(parts[k] for k in sorted(parts)), now_s, complete)
        self._parts[key] = (severity, now_s, parts)
        return None

    def flush(self, now_s: float, older_than_s: float | None = None) -> list[StatusText]:
        """Texts whose last chunk did not come within ``older_than_s`` (default ``max_age_s``), incomplete."""
        age = self.max_age_s if older_than_s is None else older_than_s
        out = []
        for key, (severity, t, parts) in list(self._parts.items()):
            if now_s - t >= age:
                del self._parts[key]
                out.append(StatusText(severity, "".join(parts[k] for k in sorted(parts)), now_s, False))
        return out


def state_from_heartbeat(msg: Msg) -> str:
    """Mission state from the vehicle's HEARTBEAT: its ArduSub mode, SAFETY_ARMED and system_status (the
    vehicle's README, "Modes": MANUAL is IDLE or, armed, ARMED; AUTO RUNNING; POSHOLD HOLD; CIRCLE COMPLETE;
    SURFACE is ABORT when CRITICAL, else COMPLETE)."""
    mode = int(msg.custom_mode)
    if mode == ARDUSUB_MANUAL:
        return "ARMED" if msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED else "IDLE"
    if mode == ARDUSUB_SURFACE:
        return "ABORT" if msg.system_status >= mavlink.MAV_STATE_CRITICAL else "COMPLETE"
    named = {ARDUSUB_AUTO: "RUNNING", ARDUSUB_POSHOLD: "HOLD", ARDUSUB_CIRCLE: "COMPLETE"}
    return named.get(mode, f"?{mode}")


def sensor_problems(msg: Msg) -> str:
    """SYS_STATUS: the sensors present and enabled but not healthy, as one phrase ("" if none)."""
    bad = int(msg.onboard_control_sensors_present) & int(msg.onboard_control_sensors_enabled)
    bad &= ~int(msg.onboard_control_sensors_health)
    if not bad:
        return ""
    names = [
        entry.name.removeprefix("MAV_SYS_STATUS_SENSOR_").removeprefix("MAV_SYS_STATUS_")
        for bit, entry in mavlink.enums["MAV_SYS_STATUS_SENSOR"].items()
        if bit & bad and bit & (bit - 1) == 0
    ]
    return "not healthy: " + ", ".join(names) if names else f"sensor health 0x{bad:x}"


def pick_text(texts: Iterable[StatusText], t_s: float, *, warning_only: bool) -> StatusText | None:
    """The first text at or after ``t_s`` (of severity WARNING or worse if ``warning_only``)."""
    for t in texts:
        if t.t_s >= t_s and (not warning_only or t.severity <= mavlink.MAV_SEVERITY_WARNING):
            return t
    return None


def wire_string(raw: object) -> str:
    """A MAVLink char[] field as text: bytes decoded, cut at the first NUL (a STATUSTEXT, a param_id)."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).split("\x00", 1)[0]
