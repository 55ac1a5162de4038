"""``auv-gcs monitor``: a live rich table of the vehicle's state, pose, errors, actuators and failsafes."""

from __future__ import annotations

import json
import math
import sys
import time
from typing import Any

from rich.console import Console
from rich.live import Live
from rich.table import Table

from groundstation.link import Link
from groundstation.messages import state_from_heartbeat
from groundstation.text import plain


def _fmt(v: Any, unit: str = "", digits: int = 2) -> str:
    if isinstance(v, float):
        return "-" if math.isnan(v) else f"{v:.{digits}f}{unit}"
    return f"{v}{unit}"


def _table(s: dict[str, Any]) -> Table:
    """The cells as rich Text: a cell's string (the vehicle's text) is never markup."""
    t = Table(title="ISiMI100", show_header=False)
    t.add_column("field")
    t.add_column("value")
    for key, value in s.items():
        t.add_row(plain(key), plain(value if isinstance(value, str) else _fmt(value)))
    return t


def monitor(client: Link, console: Console, duration_s: float = 0.0, *, as_json: bool = False) -> None:
    """Show telemetry until interrupted or for ``duration_s``; ``as_json``: one JSON line per second."""
    s: dict[str, Any] = {"state": "?", "goal": "-", "failsafe / text": ""}
    t_end = time.monotonic() + duration_s if duration_s > 0 else math.inf
    next_json = time.monotonic()
    live = None if as_json else Live(_table(s), console=console, refresh_per_second=4)
    if live is not None:
        live.start()
    try:
        while time.monotonic() < t_end:
            m = client.recv(0.25)
            if m is not None and (m.get_srcSystem(), m.get_srcComponent()) == client.target:
                k = m.get_type()
                if k == "HEARTBEAT":
                    s["state"] = state_from_heartbeat(m)
                    s["armed"] = "yes" if m.base_mode & 128 else "no"
                elif k == "LOCAL_POSITION_NED":
                    s["x north (m)"], s["y east (m)"], s["depth (m)"] = m.x, m.y, m.z
                elif k == "ATTITUDE":
                    s["roll (deg)"] = math.degrees(m.roll)
                    s["pitch (deg)"] = math.degrees(m.pitch)
                    s["yaw (deg)"] = math.degrees(m.yaw)
                elif k == "NAV_CONTROLLER_OUTPUT":
                    s["cross-track (m)"] = m.xtrack_error
                    s["depth error (m)"] = m.alt_error
                    s["yaw error (deg)"] = float(((m.target_bearing - m.nav_bearing + 180) % 360) - 180)
                    s["goal distance (m)"] = float(m.wp_dist)
                elif k == "ACTUATOR_OUTPUT_STATUS":
                    s["rudder (deg)"] = math.degrees(m.actuator[0])
                    s["stern port (deg)"] = math.degrees(m.actuator[1])
                    s["stern stbd (deg)"] = math.degrees(m.actuator[2])
                    s["propeller (rps)"] = m.actuator[3]
                elif k == "MISSION_CURRENT":
                    s["goal"] = f"{m.seq} / {m.total}"
                elif k == "SYS_STATUS":
                    s["loop overruns"] = m.errors_count1
                    s["link errors"] = m.errors_comm
                elif k == "STATUSTEXT" and client.texts:
                    s["failsafe / text"] = client.texts[-1].text  # reassembled from its chunks
            if live is not None:
                live.update(_table(s))
            elif time.monotonic() >= next_json:
                next_json += 1.0
                sys.stdout.write(json.dumps(dict(s), default=str) + "\n")
                sys.stdout.flush()
    finally:
        if live is not None:
            live.stop()
