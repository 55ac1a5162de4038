"""A goal's acceptance radius in the ground station's files (issue 24 item 1): QGroundControl's waypoint
"Acceptance radius" (a ``.plan`` SimpleItem's params[1]) and a WPL line's param2 are the goal's radius_m;
YAML downloads write it; each format reads back what it wrote."""

from __future__ import annotations

import json
import math
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from auv_common import mission_items as enc
from groundstation import mission_files as mf

REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT


def _qgc_plan(acceptance_m: float) -> dict:
    """A QGC plan of one waypoint 2 m down with its "Acceptance radius" set (as QGC writes it)."""
    item = {"autoContinue": True, "command": 16, "doJumpId": 1, "frame": REL, "type": "SimpleItem",
            "params": [0, acceptance_m, 0, None, 35.1001, 129.0401, -2]}  # fmt: skip
    mission = {"version": 2, "firmwareType": 0, "plannedHomePosition": [35.1, 129.04, 0], "items": [item]}
    return {"fileType": "Plan", "version": 1, "mission": mission}


def test_a_qgc_acceptance_radius_is_the_goals_radius(tmp_path: Path) -> None:
    p = tmp_path / "m.plan"
    p.write_text(json.dumps(_qgc_plan(3.5)))
    (item,), _ = mf.load(p)
    assert item.param2 == 3.5 and enc.radius_of_item(item) == 3.5
    # and a plan written back carries it where QGC reads it
    written = json.loads(mf.to_plan([item], []))
    assert written["mission"]["items"][0]["params"][1] == 3.5


def test_wpl_and_yaml_keep_the_radius(tmp_path: Path) -> None:
    goals = [mf.goal_item(20.0, 5.0, 2.0, 90.0, radius_m=3.0), mf.goal_item(30.0, -5.0, 3.0, None)]
    for fmt in ("wpl", "yaml", "plan"):
        f = tmp_path / f"m.{fmt}"
        f.write_text(mf.dump(fmt, goals, []))
        back, _ = mf.load(f)
        assert [it.param2 for it in back] == [3.0, 0.0], fmt
    text = mf.to_yaml(goals, [])
    assert "radius_m: 3.0" in text and text.count("radius_m") == 1  # 0 = the default: left out


def test_qgc_zero_and_older_nan_are_the_default() -> None:
    zero = mf.goal_item(1.0, 2.0, 1.0, None)
    nan = enc.MissionItem(zero.frame, zero.command, 0.0, math.nan, 0.0, math.nan, zero.x, zero.y, zero.z)
    assert "radius_m" not in mf.to_yaml([zero, nan], [])
