"""MAVLink FTP's client side over a :class:`~groundstation.link.Link`, read only: list a directory, read a
file, its CRC-32 (the packets: :mod:`auv_common.mavlink_ftp`)."""

from __future__ import annotations

import struct
import time
from collections.abc import Callable

from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from groundstation.link import Link, LinkError
from groundstation.messages import Msg


class FtpClient:
    """Reads the files of the vehicle the link talks to (its ``target``)."""

    def __init__(self, link: Link) -> None:
        self.link = link
        self._seq = 0

    def request(
        self,
        opcode: int,
        *,
        session: int = 0,
        offset: int = 0,
        size: int = 0,
        data: bytes = b"",
        on_other: Callable[[Msg], None] | None = None,
        resend_s: float = 0.5,
        retries: int = 6,
    ) -> ftp.Packet:
        """One FTP request, re-sent with the same sequence number until its reply (ACK or NAK) comes.
        Messages that are not its reply go to ``on_other``."""
        link = self.link
        self._seq = (self._seq + 1) & 0xFFFF
        req = ftp.Packet(self._seq, session, opcode, size or len(data), 0, 0, offset, data)
        ts, tc = link.target
        msg = mavlink.MAVLink_file_transfer_protocol_message(0, ts, tc, req.encode())
        for _ in range(retries):
            link.send(msg)
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = link.recv(left)
                if m is None:
                    continue
                if m.get_type() != "FILE_TRANSFER_PROTOCOL" or not (link.from_vehicle(m) and link.to_us(m)):
                    if on_other is not None:
                        on_other(m)
                    continue
                reply = ftp.Packet.decode(m.payload)
                if reply.seq == (req.seq + 1) & 0xFFFF and reply.req_opcode == opcode:
                    return reply
        raise LinkError(f"no FTP answer from the vehicle after {retries} tries{link.signing_note()}")

    def read_file(
        self,
        path: str,
        on_other: Callable[[Msg], None] | None = None,
        *,
        progress: Callable[[int, int], None] | None = None,
    ) -> bytes:
        """A file of the vehicle over MAVLink FTP (OpenFileRO, ReadFile, TerminateSession). Raises
        :class:`LinkError` for a missing file ("no such file on the vehicle: PATH") or no answer. Messages
        that are not FTP replies go to ``on_other``; ``progress(done, size)`` after each chunk."""
        opened = self.request(ftp.OPEN_RO, data=path.encode(), on_other=on_other)
        if opened.opcode == ftp.NAK:
            code = opened.data[0] if opened.data else 0
            if code == ftp.FILE_NOT_FOUND:
                raise LinkError(f"no such file on the vehicle: {path}")
            raise LinkError(f"the vehicle cannot open {path} (FTP error {code})")
        if len(opened.data) < 4:
            raise LinkError(f"the vehicle's answer to opening {path} has no size")
        size = struct.unpack("<I", opened.data[:4])[0]
        out = bytearray()
        try:
            while len(out) < size:
                r = self.request(
                    ftp.READ, session=opened.session, offset=len(out), size=ftp.DATA_MAX, on_other=on_other
                )
                if r.opcode == ftp.NAK or not r.data:
                    break  # EOF (the file is shorter than it was at the open) or an error: what we have
                out += r.data
                if progress is not None:
                    progress(len(out), size)
        finally:
            try:  # the vehicle closes an idle session itself: a lost TERMINATE costs no download
                self.request(ftp.TERMINATE, session=opened.session, on_other=on_other, retries=2)
            except LinkError:
                pass
        if len(out) < size:
            raise LinkError(f"{path}: read {len(out)} of {size} bytes")
        return bytes(out)

    def file_crc32(self, path: str, on_other: Callable[[Msg], None] | None = None) -> int | None:
        """CalcFileCRC32 of a vehicle file over MAVLink FTP (zlib's CRC-32 of its bytes); None when the
        vehicle cannot compute one. Raises LinkError for a missing file or no answer."""
        r = self.request(ftp.CRC32, data=path.encode(), on_other=on_other)
        if r.opcode == ftp.NAK:
            code = r.data[0] if r.data else 0
            if code == ftp.FILE_NOT_FOUND:
                raise LinkError(f"no such file on the vehicle: {path}")
            return None
        return int(struct.unpack("<I", r.data[:4])[0]) if len(r.data) >= 4 else None

    def list_dir(
        self, path: str, on_other: Callable[[Msg], None] | None = None
    ) -> list[tuple[str, str, int]]:
        """(kind "F" / "D", name, size) of each entry of a vehicle directory over MAVLink FTP."""
        entries: list[tuple[str, str, int]] = []
        while True:
            r = self.request(ftp.LIST, offset=len(entries), data=path.encode(), on_other=on_other)
            if r.opcode == ftp.NAK:
                code = r.data[0] if r.data else 0
                if code == ftp.EOF:
                    return entries
                if code == ftp.FILE_NOT_FOUND:
                    raise LinkError(f"no such directory on the vehicle: {path}")
                raise LinkError(f"the vehicle cannot list {path} (FTP error {code})")
            got = [e for e in r.data.split(b"\0") if e]
            if not got:
                return entries
            for e in got:
                text = e.decode("utf-8", "replace")
                name, _, size = text[1:].partition("\t")
                entries.append((text[0], name, int(size) if size.isdigit() else 0))
