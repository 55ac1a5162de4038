"""A vehicle-side process that hosts only the MAVLink endpoint with a fake loop (for tests and benches).

``python -m onboard.adapters.mavlink.standalone --endpoint udpin:127.0.0.1:0 --state-dir DIR`` prints
one JSON line
``{"ports": [...], "pid": N}`` on stdout once the sockets are bound, then runs until SIGTERM / SIGINT.
The fake loop applies the endpoint's events like the real mission state machine would and "drives" towards
each goal in a straight line at ``--speed-mps`` so that telemetry, MISSION_CURRENT and MISSION_ITEM_REACHED
move. It is no model of the vehicle.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import threading
import time
from dataclasses import replace

from auv_common.config import ConfigError, load_toml
from onboard.adapters.mavlink import api
from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink
from onboard.core.mission.model import Mission


class FakeLoop:
    """A stand-in for the control loop: applies events, moves a point towards the goals, publishes."""

    def __init__(self, link: VehicleLink, speed_mps: float = 2.0) -> None:
        self.link = link
        self.speed_mps = speed_mps
        self.mission = Mission(goals=())
        self.snap = VehicleSnapshot(x_m=0.0, y_m=0.0, depth_m=0.0, roll_rad=0.0, pitch_rad=0.0, yaw_rad=0.0)
        self.params: dict[str, float] = {}

    def tick(self, t_s: float, dt_s: float) -> None:
        s = self.snap
        for ev in self.link.take_events():
            if isinstance(ev, api.MissionReplaced):
                self.mission = ev.mission
                s = replace(s, current_goal=min(s.current_goal, max(len(ev.mission.goals) - 1, 0)))
            elif isinstance(ev, api.Arm):
                s = replace(s, state="ARMED")
            elif isinstance(ev, api.Disarm):
                s = replace(s, state="IDLE")
            elif isinstance(ev, api.StartMission):
                first = s.current_goal if ev.first_index is None else ev.first_index
                s = replace(s, state="RUNNING", current_goal=first, goals_reached=0)
            elif isinstance(ev, api.Hold):
                s = replace(s, state="HOLD")
            elif isinstance(ev, api.Resume):
                s = replace(s, state="RUNNING")
            elif isinstance(ev, api.Abort):
                s = replace(s, state="ABORT", propeller_rps=0.0)
            elif isinstance(ev, api.SetCurrent):
                s = replace(s, current_goal=ev.index)
            elif isinstance(ev, api.ParamChanged):
                self.params[ev.name] = ev.value
        if s.state == "RUNNING" and s.current_goal < len(self.mission.goals):
            g = self.mission.goals[s.current_goal]
            dx, dy, dz = g.x_m - s.x_m, g.y_m - s.y_m, g.depth_m - s.depth_m
            dist = math.sqrt(dx * dx + dy * dy + dz * dz)
            step = self.speed_mps * dt_s
            yaw = math.atan2(dy, dx) if math.hypot(dx, dy) > 1e-6 else s.yaw_rad
            if dist <= step:
                nxt = s.current_goal + 1
                s = replace(s, x_m=g.x_m, y_m=g.y_m, depth_m=g.depth_m, goals_reached=s.goals_reached + 1)
                s = (
                    replace(s, current_goal=nxt)
                    if nxt < len(self.mission.goals)
                    else replace(s, state="COMPLETE")
                )
            else:
                k = step / dist
                s = replace(
                    s,
                    x_m=s.x_m + k * dx,
                    y_m=s.y_m + k * dy,
                    depth_m=s.depth_m + k * dz,
                    yaw_rad=yaw,
                    u_mps=self.speed_mps,
                    goal_distance_m=dist,
                    cross_track_m=0.0,
                    along_track_m=0.0,
                    yaw_error_rad=0.0,
                    rudder_rad=0.0,
                    stern_port_rad=0.0,
                    stern_starboard_rad=0.0,
                    propeller_rps=10.0,
                )
        elif s.state == "ABORT" and s.depth_m > 0.0:
            s = replace(s, depth_m=max(0.0, s.depth_m - 0.3 * dt_s))
        self.snap = replace(s, t_s=t_s)
        self.link.publish(self.snap)

    def run(self, stop: threading.Event, rate_hz: float = 20.0) -> None:
        period = 1.0 / rate_hz
        t0 = time.monotonic()
        nxt = t0
        while not stop.is_set():
            self.tick(time.monotonic() - t0, period)
            nxt += period
            delay = nxt - time.monotonic()
            if delay > 0:
                stop.wait(delay)
            else:
                self.snap = replace(self.snap, overruns=self.snap.overruns + 1)
                nxt = time.monotonic()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m onboard.adapters.mavlink.standalone", description=__doc__)
    ap.add_argument("--config", help="TOML file with a [mavlink] table")
    ap.add_argument("--endpoint", action="append", help="endpoint spec (repeatable), overrides the config")
    ap.add_argument("--state-dir", help="state directory (overrides the config)")
    ap.add_argument("--signing-key", help="signing key file (overrides the config)")
    ap.add_argument("--speed-mps", type=float, default=2.0)
    ap.add_argument("--rate-hz", type=float, default=20.0)
    args = ap.parse_args(argv)
    try:
        table = load_toml(args.config).get("mavlink", {}) if args.config else {}
        if args.endpoint:
            table["endpoints"] = args.endpoint
        if args.state_dir:
            table["state_dir"] = args.state_dir
        if args.signing_key:
            table["signing_key_file"] = args.signing_key
        config = MavlinkConfig.from_table(table)
    except ConfigError as exc:
        sys.stderr.write(f"error: {exc}\n")
        return 2
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    link = VehicleLink(config)
    link.start()
    try:
        sys.stdout.write(json.dumps({"ports": link.ports, "pid": os.getpid()}) + "\n")
        sys.stdout.flush()
        FakeLoop(link, args.speed_mps).run(stop, args.rate_hz)
    finally:
        link.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
