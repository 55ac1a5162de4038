"""A bus peer process for the bus demo, the two-process test and the CAN benchmark.

``python -m onboard.bench.busdemo echo --channel ws://127.0.0.1:PORT/`` connects to the bench hub and
answers every SYNC with FIN_CMD, PROP_CMD and a SYNC_ACK echoing the tick (what the onboard does in
lock-step), until it has answered ``--count`` SYNCs or ``--timeout`` passes. It prints one JSON line with
what it received and rejected.

``... record --channel URL --count N`` stamps the monotonic arrival time of each SYNC tick and prints them
as JSON (the CAN benchmark's one-way latency; the monotonic clock is shared by processes on one machine).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

from onboard.protocol.bus import BusConfig, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.messages import ActuatorMode, FinCmd, PropCmd, Sync, SyncAck
from onboard.protocol.port import BusPort


def _echo(port: BusPort, count: int, deadline: float) -> dict[str, object]:
    answered = 0
    while answered < count and time.monotonic() < deadline:
        msg = port.recv(0.1)
        if not isinstance(msg, Sync):
            continue
        # A deterministic command derived from the tick, so the host can check what arrives.
        rudder = 0.2 * math.sin(0.1 * msg.tick)
        port.send(FinCmd(rudder, -rudder, rudder, t_sample_s=msg.sim_time_s))
        port.send(PropCmd(20.0, ActuatorMode.ARMED, t_sample_s=msg.sim_time_s))
        port.send(SyncAck(msg.tick, t_sample_s=msg.sim_time_s))
        answered += 1
    return {"answered": answered}


def _record(port: BusPort, count: int, deadline: float) -> dict[str, object]:
    arrivals: dict[int, float] = {}
    while len(arrivals) < count and time.monotonic() < deadline:
        msg = port.recv(0.1)
        if isinstance(msg, Sync):
            arrivals[msg.tick] = msg.t_sample_s
    return {"arrivals": arrivals}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m onboard.bench.busdemo", description=__doc__)
    parser.add_argument("role", choices=["echo", "record"])
    parser.add_argument("--channel", required=True, help="bench hub URL ws://127.0.0.1:PORT/")
    parser.add_argument("--count", type=int, default=100)
    parser.add_argument("--timeout", type=float, default=30.0, help="give up after this many seconds")
    args = parser.parse_args(argv)
    codec = Codec()
    bus = open_bus(BusConfig(interface="remote", channel=args.channel), timeout_s=10.0)
    port = BusPort(bus, time.monotonic, listen_ids=[codec.frame_id(Sync)], codec=codec)
    print(json.dumps({"ready": True}), flush=True)
    deadline = time.monotonic() + args.timeout
    try:
        result = (_echo if args.role == "echo" else _record)(port, args.count, deadline)
    finally:
        port.close()
    result["rejected"] = dict(port.receiver.rejected)
    result["accepted"] = port.receiver.accepted
    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
