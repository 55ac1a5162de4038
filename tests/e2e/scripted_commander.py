"""A scripted commander process for the lock-step bench tests (stands in for the onboard until it flies).

    python tests/e2e/scripted_commander.py --channel ws://127.0.0.1:PORT/ --ticks 400

Connects to the bench hub with :mod:`onboard.protocol`, sends an ONBOARD_HEARTBEAT(RUNNING) (again once per
simulated second), then answers every SYNC with FIN_CMD, PROP_CMD(ARMED) and a SYNC_ACK echoing the tick,
until it has answered ``--ticks`` distinct ticks (or ``--timeout`` wall seconds pass). It prints one JSON
line with what it did.

The command is a pure function of the tick counted from the first SYNC answered (the tick the bench starts
on; the absolute tick number depends on how long the commander took to connect) and of the sensor frames
that arrived with that SYNC: a scheduled rudder sweep plus a small depth / heading hold on the measured
values. The feedback makes the truth depend on the sensor noise, so a different bench seed gives a
different run, while the same seed must give the same run bit for bit. No wall clock is read for the
commands.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass

from onboard.protocol.bus import BusConfig, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.messages import (
    ActuatorMode,
    AhrsAttitude,
    DepthMeas,
    FinCmd,
    MissionStateCode,
    OnboardHeartbeat,
    PropCmd,
    Sync,
    SyncAck,
)
from onboard.protocol.port import BusPort

FIN_LIMIT_RAD = 0.35  # inside the DBC range (+-0.5236) and the actuator limit
PROPELLER_RPS = 20.0
DEPTH_GAIN_RAD_PER_M = 0.5  # stern per metre of depth error (+stern = nose down)
YAW_GAIN = 0.4  # rudder per radian of heading error (+rudder turns to port, i.e. reduces yaw)
HEARTBEAT_EVERY_TICKS = 20


@dataclass
class Measured:
    """The latest sensor values the commander has seen (None until the first frame)."""

    depth_m: float | None = None
    yaw_rad: float | None = None


def command_for(k: int, meas: Measured, depth_ref_m: float, yaw_ref_rad: float) -> tuple[FinCmd, PropCmd]:
    """The commands for the k-th answered tick (k = 0 on the bench's start tick). Pure."""
    rudder = 0.15 * math.sin(2.0 * math.pi * k / 160.0)  # an 8 s sweep at 20 Hz
    stern = 0.0
    if meas.depth_m is not None:
        stern = DEPTH_GAIN_RAD_PER_M * (depth_ref_m - meas.depth_m)
    if meas.yaw_rad is not None:
        err = math.remainder(meas.yaw_rad - yaw_ref_rad, 2.0 * math.pi)
        rudder += YAW_GAIN * err
    rudder = max(-FIN_LIMIT_RAD, min(FIN_LIMIT_RAD, rudder))
    stern = max(-FIN_LIMIT_RAD, min(FIN_LIMIT_RAD, stern))
    return FinCmd(rudder, stern, stern), PropCmd(PROPELLER_RPS, ActuatorMode.ARMED)


def run(port: BusPort, ticks: int, deadline: float, depth_ref_m: float, yaw_ref_rad: float) -> dict:
    meas = Measured()
    first_tick: int | None = None
    answered: set[int] = set()
    port.send(OnboardHeartbeat(MissionStateCode.RUNNING, 0.0))
    while len(answered) < ticks and time.monotonic() < deadline:
        msg = port.recv(0.1)
        # Sensor frames count only once the first SYNC is answered: whether the commander heard the bench's
        # pre-start frames depends on when it connected (a race), and the run must not.
        if isinstance(msg, DepthMeas) and first_tick is not None:
            meas.depth_m = msg.depth_m
        elif isinstance(msg, AhrsAttitude) and first_tick is not None:
            meas.yaw_rad = msg.yaw_rad
        elif isinstance(msg, Sync):
            if first_tick is None:
                first_tick = msg.tick
            k = msg.tick - first_tick
            if k > 0 and k % HEARTBEAT_EVERY_TICKS == 0 and msg.tick not in answered:
                port.send(OnboardHeartbeat(MissionStateCode.RUNNING, min(msg.sim_time_s, 167772.0)))
            fin, prop = command_for(k, meas, depth_ref_m, yaw_ref_rad)
            port.send(fin)
            port.send(prop)
            port.send(SyncAck(msg.tick))
            answered.add(msg.tick)
    return {"answered": len(answered), "first_tick": first_tick}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--channel", required=True, help="bench hub URL ws://127.0.0.1:PORT/")
    parser.add_argument("--ticks", type=int, required=True, help="distinct SYNC ticks to answer")
    parser.add_argument("--depth", type=float, default=1.0, help="depth to hold (m)")
    parser.add_argument("--yaw-deg", type=float, default=0.0, help="heading to hold (deg)")
    parser.add_argument("--timeout", type=float, default=60.0, help="give up after this many wall seconds")
    args = parser.parse_args(argv)
    codec = Codec()
    bus = open_bus(BusConfig(interface="remote", channel=args.channel), timeout_s=15.0)
    listen = [codec.frame_id(c) for c in (Sync, DepthMeas, AhrsAttitude)]
    port = BusPort(bus, time.monotonic, listen_ids=listen, codec=codec)
    result: dict = {}
    try:
        result = run(
            port, args.ticks, time.monotonic() + args.timeout, args.depth, math.radians(args.yaw_deg)
        )
    except (OSError, ConnectionError) as exc:  # the bench closed the hub under us
        result = {"error": str(exc)}
    finally:
        port.close()
    result["rejected"] = dict(port.receiver.rejected)
    print(json.dumps(result), flush=True)
    return 0 if result.get("answered") == args.ticks else 1


if __name__ == "__main__":
    sys.exit(main())
