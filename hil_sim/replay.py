"""``auv-hil replay FILE``: play a recorded ``.blf``/``.asc`` frame log back onto the bench bus.

The bench hosts the hub as usual (``--channel``, default the bench hub), then sends every frame of the log
with its recorded timing (scaled by ``--speed``) using python-can's ``LogReader`` and ``MessageSync``.
``--ids`` limits the replay to some arbitration ids (e.g. only the sensor frames, to drive a firmware
under test with a recorded sea run).
"""

from __future__ import annotations

import argparse
import logging
import sys
import threading

import can

from auv_common.config import ConfigError
from onboard.protocol.bus import DEFAULT_HUB_CHANNEL, DEFAULT_REMOTE_CHANNEL, BenchHub

log = logging.getLogger("hil_sim.replay")


def replay(
    path: str, bus: can.BusABC, speed: float, ids: frozenset[int] | None, stop: threading.Event
) -> int:
    """Send the frames of ``path`` on ``bus`` with their recorded spacing / ``speed``; returns the count."""
    sent = 0
    reader = can.LogReader(path)
    for msg in can.MessageSync(reader, timestamps=True, gap=0.0, skip=3600.0 / speed):
        if stop.is_set():
            break
        if ids is not None and msg.arbitration_id not in ids:
            continue
        bus.send(
            can.Message(arbitration_id=msg.arbitration_id, data=msg.data, is_extended_id=msg.is_extended_id)
        )
        sent += 1
    return sent


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="auv-hil replay", description=__doc__)
    parser.add_argument("file", help="a .blf or .asc frame log (auv-hil run --record / [bus] record)")
    parser.add_argument("--channel", default=DEFAULT_REMOTE_CHANNEL, help="bench hub to host and play onto")
    parser.add_argument("--speed", type=float, default=1.0, help="playback speed factor (default 1)")
    parser.add_argument(
        "--ids", help="comma-separated arbitration ids to replay, e.g. 0x40,0x41 (default all)"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        if not args.file.endswith((".blf", ".asc")):
            raise ConfigError(f"{args.file}: expected a .blf or .asc log")
        if args.speed <= 0:
            raise ConfigError("--speed must be > 0")
        ids = frozenset(int(v, 0) for v in args.ids.split(",")) if args.ids else None
        hub = BenchHub(args.channel, DEFAULT_HUB_CHANNEL, listen_ids=())  # it only sends
    except (ConfigError, ValueError, OSError) as exc:
        print(f"auv-hil replay: {exc}", file=sys.stderr)
        return 2
    bus = hub.bus
    try:
        sent = replay(args.file, bus, args.speed, ids, threading.Event())
    finally:
        bus.shutdown()
        hub.close()
    log.info("replayed %d frames from %s", sent, args.file)
    return 0
