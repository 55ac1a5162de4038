"""``auv-hil replay FILE``: play a recorded ``.blf``/``.asc``/``.log`` frame log back onto the bench bus.

The bench hosts the hub as usual (``--channel``, default the bench hub), then sends every frame of the log
(python-can's ``LogReader``) with its recorded spacing divided by ``--speed`` (20: twenty times faster),
with a progress bar. The pacing is done here: python-can's ``MessageSync`` has no speed factor.
``--ids`` limits the replay to some arbitration ids (e.g. only the sensor frames, to drive a firmware
under test with a recorded sea run).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import threading
import time
from collections.abc import Callable

import can

from auv_common.config import ConfigError
from onboard.protocol.bus import DEFAULT_HUB_CHANNEL, DEFAULT_REMOTE_CHANNEL, FRAME_LOG_SUFFIXES, BenchHub

log = logging.getLogger("hil_sim.replay")


def replay(
    path: str,
    bus: can.BusABC,
    speed: float,
    ids: frozenset[int] | None,
    stop: threading.Event,
    on_frame: Callable[[int, int], None] | None = None,
) -> int:
    """Send the frames of ``path`` on ``bus`` with their recorded spacing / ``speed``; returns the count.
    ``on_frame(done, total)`` after each frame of the log (sent or filtered out)."""
    frames = list(can.LogReader(path))
    sent = 0
    t0_log = frames[0].timestamp if frames else 0.0
    t0 = time.monotonic()
    for k, msg in enumerate(frames, 1):
        delay = t0 + (msg.timestamp - t0_log) / speed - time.monotonic()
        if delay > 0.0 and stop.wait(delay):
            break
        if stop.is_set():
            break
        if ids is None or msg.arbitration_id in ids:
            frame = can.Message(
                arbitration_id=msg.arbitration_id, data=msg.data, is_extended_id=msg.is_extended_id
            )
            bus.send(frame)
            sent += 1
        if on_frame is not None:
            on_frame(k, len(frames))
    return sent


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="auv-hil replay", description=__doc__)
    parser.add_argument(
        "file", help="a .blf, .asc or candump .log frame log (auv-hil run --record / [bus] record)"
    )
    parser.add_argument("--channel", default=DEFAULT_REMOTE_CHANNEL, help="bench hub to host and play onto")
    parser.add_argument("--speed", type=float, default=1.0, help="playback speed factor (default 1)")
    parser.add_argument(
        "--ids", help="comma-separated arbitration ids to replay, e.g. 0x40,0x41 (default all)"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    try:
        if not args.file.endswith(FRAME_LOG_SUFFIXES):
            raise ConfigError(f"{args.file}: expected a .blf, .asc or .log frame log")
        if not os.path.isfile(args.file):
            raise ConfigError(f"{args.file}: no such file")
        if args.speed <= 0:
            raise ConfigError("--speed must be > 0")
        ids = frozenset(int(v, 0) for v in args.ids.split(",")) if args.ids else None
        hub = BenchHub(args.channel, DEFAULT_HUB_CHANNEL, listen_ids=())  # it only sends
    except (ConfigError, ValueError, OSError) as exc:
        print(f"auv-hil replay: {exc}", file=sys.stderr)
        return 2
    bus = hub.bus
    from rich.progress import Progress

    try:
        with Progress(transient=True) as progress:
            task = progress.add_task(f"replaying {args.file} at x{args.speed:g}", total=None)
            sent = replay(
                args.file,
                bus,
                args.speed,
                ids,
                threading.Event(),
                lambda done, total: progress.update(task, completed=done, total=total),
            )
    finally:
        bus.shutdown()
        hub.close()
    log.info("replayed %d frames from %s", sent, args.file)
    return 0
