"""MAVLink FTP's payload (https://mavlink.io/en/services/ftp.html): the one codec of FILE_TRANSFER_PROTOCOL's
12-byte header and data, its opcodes and NAK error codes, for the vehicle's server and the ground station's
reader alike."""

from __future__ import annotations

import struct
from dataclasses import dataclass

HEADER = struct.Struct("<HBBBBBxI")  # seq, session, opcode, size, req_opcode, burst_complete, pad, offset
DATA_MAX = 251 - HEADER.size  # 239

# opcodes
NONE, TERMINATE, RESET, LIST, OPEN_RO, READ, CREATE, WRITE, REMOVE, MKDIR, RMDIR = range(11)
OPEN_WO, TRUNCATE, RENAME, CRC32, BURST_READ = 11, 12, 13, 14, 15
ACK, NAK = 128, 129
WRITE_OPS = frozenset({CREATE, WRITE, REMOVE, MKDIR, RMDIR, OPEN_WO, TRUNCATE, RENAME})
# NAK error codes
FAIL, FAIL_ERRNO, INVALID_SIZE, INVALID_SESSION, NO_SESSIONS, EOF, UNKNOWN_COMMAND = 1, 2, 3, 4, 5, 6, 7
FILE_EXISTS, FILE_PROTECTED, FILE_NOT_FOUND = 8, 9, 10


@dataclass(frozen=True)
class Packet:
    """One FTP payload, decoded."""

    seq: int
    session: int
    opcode: int
    size: int
    req_opcode: int
    burst_complete: int
    offset: int
    data: bytes

    @classmethod
    def decode(cls, payload: bytes | list[int]) -> Packet:
        raw = bytes(payload)
        seq, session, opcode, size, req, burst, offset = HEADER.unpack_from(raw)
        size = min(size, DATA_MAX)
        return cls(seq, session, opcode, size, req, burst, offset, raw[HEADER.size : HEADER.size + size])

    def encode(self) -> bytes:
        head = HEADER.pack(
            self.seq & 0xFFFF, self.session, self.opcode, len(self.data), self.req_opcode,
            self.burst_complete, self.offset,
        )  # fmt: skip
        return (head + self.data).ljust(251, b"\0")
