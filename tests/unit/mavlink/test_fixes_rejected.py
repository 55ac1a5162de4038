"""The fixes the navigation refused reach the operator (issue 24 item 3): the tick record's
``fixes_rejected`` (the innovation gate's count since boot) rides the snapshot to a NAMED_VALUE_INT
``FIX_REJ`` on the SYS_STATUS stream's rate, so a ground station sees a 20 m jump refused, not only the
STATUSTEXT of a repeated refusal."""

from __future__ import annotations

from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink import bridge
from onboard.adapters.mavlink.api import VehicleSnapshot

from .linkkit import Captured


def _named(out: list[mavlink.MAVLink_message]) -> dict[str, int]:
    return {
        m.name.rstrip("\x00") if isinstance(m.name, str) else m.name.decode().rstrip("\x00"): m.value
        for m in out
        if m.get_msgId() == mavlink.MAVLINK_MSG_ID_NAMED_VALUE_INT
    }


def test_the_refused_fixes_count_is_sent_as_named_value_int_fix_rej(tmp_path: Path) -> None:
    # GIVEN a link whose loop reports 3 refused fixes
    c = Captured(tmp_path)
    c.link.publish(VehicleSnapshot(fixes_rejected=3))
    # WHEN its streams run for a little more than a second
    for _ in range(12):
        c.poll(0.1)
    # THEN a ground station reads FIX_REJ = 3
    assert _named(c.out).get("FIX_REJ") == 3
    # and the count comes from the tick record under its own name (the snapshot's fields from the record)
    assert "fixes_rejected" in bridge._FROM_RECORD
