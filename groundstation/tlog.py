"""Read a .tlog (8-byte big-endian microsecond timestamp + raw MAVLink packet, repeated)."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink


def read_tlog(path: str | Path) -> Iterator[tuple[float, mavlink.MAVLink_message]]:
    """(unix time s, message) for every decodable packet; damaged records are skipped."""
    data = Path(path).read_bytes()
    parser = mavlink.MAVLink(None)
    i, n = 0, len(data)
    while i + 8 < n:
        (usec,) = struct.unpack(">Q", data[i : i + 8])
        j = i + 8
        magic = data[j]
        if magic == 0xFD and j + 3 <= n:
            length = 10 + data[j + 1] + 2 + (13 if data[j + 2] & 1 else 0)
        elif magic == 0xFE and j + 2 <= n:
            length = 6 + data[j + 1] + 2
        else:
            i += 1  # resynchronise
            continue
        frame = bytearray(data[j : j + length])
        try:
            msg = parser.decode(frame)
        except Exception:
            i += 1
            continue
        i = j + length
        if msg.get_type() not in ("BAD_DATA", "UNKNOWN"):
            yield usec / 1e6, msg
