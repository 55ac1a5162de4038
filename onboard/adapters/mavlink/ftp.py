"""MAVLink FTP, read only: the vehicle's planned path and its flight logs for any ground station.

Spec: https://mavlink.io/en/services/ftp.html (FILE_TRANSFER_PROTOCOL, the 12-byte header then data). What
is served (:class:`FileTree`):

- ``@PATH/planned.json``: the path the autopilot flies now, made from the telemetry snapshot when it is
  opened: ``{"version", "kind" ("goal" | "loiter" | ""), "goal_index", "frame": "local_ned",
  "length_m", "points_m": [[x_m, y_m, depth_m], ...]}`` every 0.5 m or closer (``sample_evenly``).
  ``version`` counts the paths the link has seen (a new plan is a new number); no path: ``points_m`` [].
  ``@`` marks a virtual file, as in ArduPilot (``@PARAM``, ``@SYS``).
- ``logs/``: the flight logs in the state directory's ``logs`` folder (``*.mcap``), read as they are on disk
  (the one being written may grow after it was opened: a read sees the size at the open).

Opcodes: ResetSessions, TerminateSession, ListDirectory, OpenFileRO, ReadFile, BurstReadFile,
CalcFileCRC32 (zlib's CRC-32 of the whole file). The work a request costs is bounded: the path file is made
once per path, a log's CRC read once per version of it, and the replies of all bursts together stay under
:data:`TX_PACKETS_PER_S` (a burst beyond it is cut short: the reader asks again from where it ended).
Every write opcode is NAKed FileProtected; any other UnknownCommand.

At most :data:`MAX_SESSIONS` files are open at once (then NoSessionsAvailable). A session is its opener's,
and is closed after :data:`SESSION_IDLE_S` without a request: a reader stopped mid-transfer would otherwise
hold it until a reboot, since each ground station has ids of its own and none could reset it.

A request re-sent as it was (sequence number and content) gets the same reply again (its reply was lost),
so opening is not done twice; reads are answered anew (they are idempotent). MAVProxy starts every transfer
at sequence 0, so the sequence number alone does not tell a resend. Names are looked up in the tree, never
joined to a path: ``..`` or an absolute path is simply not found.

MAVProxy (``ftp list``, ``ftp get @PATH/planned.json``) and QGroundControl speak this protocol, as does
``groundstation.mavclient.MavClient.read_file``.
"""

from __future__ import annotations

import json
import logging
import struct
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from auv_common.mavlink_ftp import (
    ACK,
    BURST_READ,
    CRC32,
    DATA_MAX,
    EOF,
    FAIL,
    FILE_NOT_FOUND,
    FILE_PROTECTED,
    INVALID_SESSION,
    LIST,
    NAK,
    NO_SESSIONS,
    NONE,
    OPEN_RO,
    READ,
    RESET,
    TERMINATE,
    UNKNOWN_COMMAND,
    WRITE_OPS,
    Packet,
)  # fmt: skip
from auv_common.token_bucket import TokenBucket
from onboard.adapters.log_files import log_files
from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.peers import Sender
from onboard.adapters.mavlink.transport import Transport, addressed_to
from onboard.core.planner.path import sample_evenly

log = logging.getLogger(__name__)

MAX_SESSIONS = 4
MAX_REMEMBERED = 64  # stations whose last reply is kept for a resend
SESSION_IDLE_S = 5.0  # a session with no request for this long is closed (its reader is gone)
BURST_PACKETS = 64  # data packets per BurstReadFile request (15 kB); the reader asks again for the rest
TX_PACKETS_PER_S = 2000.0  # every station's FTP replies together (500 kB/s): a burst beyond it is cut short
PATH_FILE = "@PATH/planned.json"
LOG_DIR = "logs"


def path_document(snapshot: VehicleSnapshot, version: int) -> bytes:
    """``@PATH/planned.json`` for a snapshot (see the module docstring)."""
    p = snapshot.path
    points: list[list[float]] = []
    length_m = 0.0
    if p is not None:
        length_m = p.length_m
        for sample in sample_evenly(p):
            points.append([round(sample.x_m, 3), round(sample.y_m, 3), round(sample.depth_m, 3)])
    doc = {
        "version": version,
        "kind": snapshot.path_kind if p is not None else "",
        "goal_index": snapshot.path_goal_index if p is not None else -1,
        "frame": "local_ned",
        "length_m": round(length_m, 3),
        "points_m": points,
    }
    return json.dumps(doc, separators=(",", ":")).encode()


_UNSEEN = object()


class FileTree:
    """What is served: the virtual path file and the logs folder (a real directory, read only)."""

    def __init__(self, snapshot: Callable[[], VehicleSnapshot], log_dir: Path) -> None:
        self._snapshot = snapshot
        self.log_dir = log_dir
        self._path_obj: object = _UNSEEN
        self._version = 0
        self._path_doc = b""
        self._crcs: dict[tuple[str, int, int], int] = {}  # a log's CRC by (name, size, mtime): read once

    def _path_bytes(self) -> bytes:
        """The path file, made once per path (a request costs no re-sampling)."""
        s = self._snapshot()
        if s.path is not self._path_obj:
            self._path_obj = s.path
            self._version += 1
            self._path_doc = path_document(s, self._version)
        return self._path_doc

    def _logs(self) -> dict[str, Path]:
        """The flight logs, oldest first, by the one naming rule (other files are not served)."""
        return {p.name: p for p in log_files(self.log_dir)}

    def listing(self, path: str) -> list[bytes] | None:
        """Directory entries (``F<name>\\t<size>`` / ``D<name>``), None if no such directory."""
        key = path.strip("/")
        if key == "":
            return [b"D@PATH", b"D" + LOG_DIR.encode()]
        if key == "@PATH":
            return [f"F{PATH_FILE.split('/')[1]}\t{len(self._path_bytes())}".encode()]
        if key == LOG_DIR:
            out = []
            for name, p in self._logs().items():
                try:
                    out.append(f"F{name}\t{p.stat().st_size}".encode())
                except OSError:
                    continue
            return out
        return None

    def open(self, path: str) -> _OpenFile | None:
        key = path.strip("/")
        if key == PATH_FILE:
            return _OpenFile(data=self._path_bytes())
        folder, _, name = key.rpartition("/")
        if folder == LOG_DIR:
            p = self._logs().get(name)
            if p is not None:
                try:
                    st = p.stat()
                except OSError:
                    return None
                return _OpenFile(file=p, size=st.st_size, crc_key=(name, st.st_size, st.st_mtime_ns))
        return None

    def crc32(self, f: _OpenFile) -> int:
        """CalcFileCRC32 of an opened file; a log's is read once per version of it (a request repeated
        does not re-read megabytes)."""
        if f.crc_key is None:
            return f.crc32()
        crc = self._crcs.get(f.crc_key)
        if crc is None:
            if len(self._crcs) > 64:
                self._crcs.clear()
            crc = self._crcs[f.crc_key] = f.crc32()
        return crc


@dataclass
class _OpenFile:
    data: bytes | None = None
    file: Path | None = None
    size: int = 0
    owner: tuple[int, int] = (0, 0)
    used_s: float = 0.0
    crc_key: tuple[str, int, int] | None = None

    def __post_init__(self) -> None:
        if self.data is not None:
            self.size = len(self.data)

    def read(self, offset: int, n: int) -> bytes:
        n = max(0, min(n, self.size - offset))
        if self.data is not None:
            return self.data[offset : offset + n]
        assert self.file is not None
        with self.file.open("rb") as f:
            f.seek(offset)
            return f.read(n)

    def crc32(self) -> int:
        crc, offset = 0, 0
        while offset < self.size:
            chunk = self.read(offset, 1 << 16)
            if not chunk:
                break
            crc = zlib.crc32(chunk, crc)
            offset += len(chunk)
        return crc


@dataclass
class FtpService:
    """FILE_TRANSFER_PROTOCOL requests in, replies to their sender's link (I/O thread)."""

    transport: Transport
    tree: FileTree
    system_id: int
    component_id: int
    clock: Callable[[], float] = time.monotonic
    sessions: dict[int, _OpenFile] = field(default_factory=dict)
    _last: dict[tuple[int, int], tuple[Packet, list[bytes]]] = field(default_factory=dict)
    served: int = 0
    tx: TokenBucket = field(default_factory=lambda: TokenBucket(TX_PACKETS_PER_S, 2 * BURST_PACKETS))

    def handle(self, msg: mavlink.MAVLink_message, sender: Sender) -> None:
        if not addressed_to(msg, self.system_id, self.component_id):
            return
        try:
            req = Packet.decode(msg.payload)
        except struct.error:
            return
        who = (sender.system_id, sender.component_id)
        now = self.clock()
        for sid in [s for s, f in self.sessions.items() if now - f.used_s > SESSION_IDLE_S]:
            del self.sessions[sid]  # its reader was stopped mid-transfer, or lost its TERMINATE
        last = self._last.get(who)
        if last is not None and last[0] == req and req.opcode not in (READ, BURST_READ):
            # the same request again (same sequence number and content): its reply was lost. Reads are
            # answered anew (they are idempotent, and a burst must spend the reply budget again)
            replies = last[1]
        else:
            try:
                replies = [p.encode() for p in self._answer(req, who)]
            except OSError as exc:  # a log removed or unreadable under our feet
                log.warning("ftp: %s", exc)
                replies = [self._nak(req, FAIL).encode()]
            if req.opcode not in (READ, BURST_READ):  # only what a resend must not redo is kept
                self._last.pop(who, None)
                self._last[who] = (req, replies)
                while len(self._last) > MAX_REMEMBERED:  # one per station; spoofed ids cannot grow it
                    del self._last[next(iter(self._last))]
        for raw in replies:
            self.served += 1
            self.transport.reply(
                mavlink.MAVLink_file_transfer_protocol_message(0, sender.system_id, sender.component_id, raw),
                sender,
            )

    def _ack(self, req: Packet, data: bytes = b"", **kw: int) -> Packet:
        fields = {"session": req.session, "offset": req.offset, "burst_complete": 0, **kw}
        return Packet(
            req.seq + 1, fields["session"], ACK, len(data), req.opcode, fields["burst_complete"],
            fields["offset"], data,
        )  # fmt: skip

    @staticmethod
    def _nak(req: Packet, error: int) -> Packet:
        return Packet(req.seq + 1, req.session, NAK, 1, req.opcode, 0, 0, bytes([error]))

    def _answer(self, req: Packet, who: tuple[int, int]) -> list[Packet]:
        op = req.opcode
        if op == NONE:
            return [self._ack(req)]
        if op == RESET:
            for sid in [s for s, f in self.sessions.items() if f.owner == who]:
                del self.sessions[sid]
            return [self._ack(req)]
        if op == TERMINATE:
            f = self.sessions.get(req.session)
            if f is None or f.owner != who:
                return [self._nak(req, INVALID_SESSION)]
            del self.sessions[req.session]
            return [self._ack(req)]
        if op == LIST:
            entries = self.tree.listing(_text(req.data))
            if entries is None:
                return [self._nak(req, FILE_NOT_FOUND)]
            if req.offset >= len(entries):
                return [self._nak(req, EOF)]
            out = b""
            for e in entries[req.offset :]:
                if len(out) + len(e) + 1 > DATA_MAX:
                    break
                out += e + b"\0"
            return [self._ack(req, out)]
        if op in (OPEN_RO, CRC32):
            f = self.tree.open(_text(req.data))
            if f is None:
                return [self._nak(req, FILE_NOT_FOUND)]
            if op == CRC32:
                return [self._ack(req, struct.pack("<I", self.tree.crc32(f)))]
            if len(self.sessions) >= MAX_SESSIONS:
                return [self._nak(req, NO_SESSIONS)]
            # the opener's own number when free (MAVProxy picks one and routes the replies by it, as
            # ArduPilot answers in the request's session), else the first free one
            sid = (
                req.session if req.session not in self.sessions else min(set(range(256)) - set(self.sessions))
            )
            f.owner, f.used_s = who, self.clock()
            self.sessions[sid] = f
            return [self._ack(req, struct.pack("<I", f.size), session=sid)]
        if op in (READ, BURST_READ):
            f = self.sessions.get(req.session)
            if f is None or f.owner != who:
                return [self._nak(req, INVALID_SESSION)]
            f.used_s = self.clock()
            if req.offset >= f.size:
                return [self._nak(req, EOF)]
            if op == READ:
                return [self._ack(req, f.read(req.offset, min(req.size or DATA_MAX, DATA_MAX)))]
            burst: list[Packet] = []
            offset = req.offset
            now = self.clock()
            # the first packet always (one per request, which the receive share bounds); more while the
            # reply budget lasts
            while offset < f.size and len(burst) < BURST_PACKETS and (not burst or self.tx.take(now)):
                chunk = f.read(offset, DATA_MAX)
                if not chunk:
                    break
                burst.append(
                    Packet(req.seq + 1 + len(burst), req.session, ACK, len(chunk), op, 0, offset, chunk)
                )
                offset += len(chunk)
            if not burst:  # the file shrank since it was opened
                return [self._nak(req, EOF)]
            end = burst[-1]
            burst[-1] = Packet(end.seq, end.session, ACK, end.size, op, 1, end.offset, end.data)
            return burst
        if op in WRITE_OPS:
            return [self._nak(req, FILE_PROTECTED)]
        return [self._nak(req, UNKNOWN_COMMAND)]


def _text(data: bytes) -> str:
    return data.split(b"\0", 1)[0].decode("utf-8", "replace")
