"""Flooders for the e2e tests, each run as a process of its own: ``python -m tests.e2e.flood KIND ...``.

- ``can URL SECONDS RATE``: standard-id 0x7F0 frames (an id no node listens to) through the hub at up to
  RATE frames/s (0: as fast as one process can).
- ``mavlink HOST PORT SECONDS RATE``: random bytes and bit-flipped MAVLink 2 heartbeats, from 64 source
  ports, to a vehicle's UDP port at up to RATE datagrams/s.

Each prints one JSON line at the end: ``{"sent": N, "seconds": S, "rate": N/S}``.
"""

from __future__ import annotations

import json
import random
import socket
import sys
import time


def _paced(seconds: float, rate: float, send_batch: object) -> tuple[int, float]:
    """Call ``send_batch()`` (100 sends) until ``seconds`` pass, at most ``rate`` sends/s (0: no limit)."""
    t0 = time.monotonic()
    sent = 0
    while (now := time.monotonic()) < t0 + seconds:
        if rate > 0 and sent > (now - t0) * rate:
            time.sleep(0.001)
            continue
        send_batch()  # type: ignore[operator]
        sent += 100
    return sent, time.monotonic() - t0


def flood_can(url: str, seconds: float, rate: float) -> tuple[int, float]:
    import can

    from onboard.protocol.bus import BusConfig, open_bus

    bus = open_bus(BusConfig(interface="remote", channel=url), timeout_s=15.0, listen_ids=())  # sends only
    frame = can.Message(arbitration_id=0x7F0, data=bytes(8), is_extended_id=False)

    def batch() -> None:
        for _ in range(100):
            bus.send(frame)

    try:
        return _paced(seconds, rate, batch)
    finally:
        try:
            bus.shutdown()
        except OSError:  # the hub went first (the bench's run ended): what was sent is still the answer
            pass


def flood_mavlink(host: str, port: int, seconds: float, rate: float) -> tuple[int, float]:
    from groundstation.bench_links import garbage_datagrams

    payloads = garbage_datagrams(random.Random(7), 64)
    socks = []
    for _ in range(64):
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", 0))
        s.setblocking(False)
        socks.append(s)
    dest = (host, port)
    k = 0

    def batch() -> None:
        nonlocal k
        for i in range(100):
            try:
                socks[(k + i) % 64].sendto(payloads[(k + 3 * i) % 64], dest)
            except BlockingIOError:
                pass
        k += 1

    try:
        return _paced(seconds, rate, batch)
    finally:
        for s in socks:
            s.close()


def main(argv: list[str]) -> int:
    kind, *rest = argv
    if kind == "can":
        sent, seconds = flood_can(rest[0], float(rest[1]), float(rest[2]))
    else:
        sent, seconds = flood_mavlink(rest[0], int(rest[1]), float(rest[2]), float(rest[3]))
    print(json.dumps({"sent": sent, "seconds": seconds, "rate": sent / seconds}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
