"""Issue 21 row 6: the operator's terminal shows the wire's words as text, never as markup or escapes.

A stranger sends PARAM_SETs whose names are rich markup (``[/]``, ``[link=...]``, ``[bold]``), terminal
escape sequences (an SGR colour, an OSC 8 hyperlink) and a run of control bytes; the REAL vehicle (the
standalone process: the real link and core over a simple plant) answers each with the STATUSTEXT "unknown
parameter NAME". The stranger shares the operator's link (it sends from the operator's own address, so the
answer reaches the operator also when refusals go to the asking link only). ``auv-gcs fly``, ``monitor``,
``params`` run as processes, on a pipe and on a pseudo-terminal (rich renders markup and hyperlinks there):
each shows the literal text with the control characters removed, no escape byte of the wire's, no traceback,
and fly flies on (Ctrl-C: HOLD sent, exit 130). ``logs`` is fed by a vehicle whose FTP listing carries the
names (the real vehicle serves only names of its own rule); the map's page gets the texts without control
characters and writes every text with ``textContent``.

A PARAM_SET's name is at most 16 characters, so each hostile string is one name; the 50-character run of
control bytes goes through the log listing (and the unit tests of :mod:`groundstation.text`).
"""

from __future__ import annotations

import fcntl
import json
import os
import pty
import re
import signal
import socket
import struct
import subprocess
import sys
import termios
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from groundstation.bench_upload import start_vehicle, stop_vehicle
from hil_sim.scenario import free_udp_port

CONTROL_RUN = "<" + "".join(map(chr, [*range(1, 10), 11, 12, 13, 14, 0x7F])) + ">"  # 16: a name's most
#: (name sent, what the operator must read after "unknown parameter ")
HOSTILE = [
    ("[/]", "[/]"),
    ("[link=http://x]x", "[link=http://x]x"),
    ("[bold]word[/]", "[bold]word[/]"),
    ("\x1b[31mred", "[31mred"),
    ("\x1b]8;;http://x\x1b\\", "]8;;http://x\\"),
    (CONTROL_RUN, "<>"),
]
WIRE_ESCAPES = ("\x1b[31mred", "\x1b]8;;http://x")  # the wire's own sequences: never on the operator's screen
#: Far enough that the flight is still under way when the operator's Ctrl-C comes, however slowly a loaded
#: machine feeds the stranger's names (at 60 m the vehicle sometimes completed first).
MISSION = "goals:\n  - {x_m: 200.0, y_m: 0.0, depth_m: 1.0}\n"


class Run:
    """A process whose output (stdout and stderr) is collected as it comes, on a pipe or a pseudo-terminal
    (200 columns, TERM xterm-256color: rich renders styles, markup and hyperlinks)."""

    def __init__(self, cmd: list[str], *, tty: bool) -> None:
        env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "200", "PYTHONUNBUFFERED": "1"}
        env.pop("NO_COLOR", None)
        self._buf = bytearray()
        self._lock = threading.Lock()
        if tty:
            master, slave = pty.openpty()
            fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 200, 0, 0))
            self.proc = subprocess.Popen(cmd, stdin=slave, stdout=slave, stderr=slave, env=env)
            os.close(slave)
            self._fd = master
        else:
            self.proc = subprocess.Popen(
                cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env
            )
            assert self.proc.stdout is not None
            self._fd = self.proc.stdout.fileno()
        self._tty = tty
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        while True:
            try:
                chunk = os.read(self._fd, 65536)
            except OSError:  # a pty's master reads EIO once the child has gone
                break
            if not chunk:
                break
            with self._lock:
                self._buf += chunk

    @property
    def raw(self) -> str:
        with self._lock:
            return self._buf.decode("utf-8", "replace")

    def wait_for(self, pred: Callable[[str], bool], timeout_s: float, what: str) -> None:
        t_end = time.monotonic() + timeout_s
        while not pred(self.raw):
            if self.proc.poll() is not None:
                self._reader.join(5.0)  # the rest of its output: the reader ends at the end of it
                if pred(self.raw):
                    return
                raise AssertionError(f"exited {self.proc.returncode} before {what}:\n{self.raw[-3000:]}")
            if time.monotonic() > t_end:
                raise AssertionError(f"no {what} within {timeout_s:g} s:\n{self.raw[-3000:]}")
            time.sleep(0.05)

    def finish(self, timeout_s: float) -> int:
        try:
            code = self.proc.wait(timeout_s)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait(5.0)
            self._reader.join(5.0)
            if self._tty:
                os.close(self._fd)
        return code

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(5.0)


def shown(screen: str) -> str:
    """What a terminal shows of ``screen``, near enough: rich's own CSI sequences (colours, cursor moves) and
    carriage returns dropped, so a text split by a redraw reads whole. The wire's ESC bytes were checked
    before this."""
    return re.sub(r"\x1b\[[0-9;?]*[A-Za-z]|\r", "", screen)


def stranger_says(gcs_port: int, vehicle_port: int, name: str) -> None:
    """A stranger's PARAM_SET named ``name`` (system 77), sent from the operator's own address: a socket
    bound beside the operator's (SO_REUSEADDR), closed at once so the vehicle's answer goes to the
    operator's socket."""
    mav = mavlink.MAVLink(None, 77, 1)
    msg = mavlink.MAVLink_param_set_message(1, 1, name.encode("latin-1"), 1.0, mavlink.MAV_PARAM_TYPE_REAL32)
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind(("127.0.0.1", gcs_port))
        s.sendto(msg.pack(mav), ("127.0.0.1", vehicle_port))
    finally:
        s.close()


def feed_until_shown(run: Run, gcs_port: int, vehicle_port: int, timeout_s: float = 60.0) -> None:
    """Each hostile name, again every second until the operator's output shows its text (a datagram of the
    vehicle that came while the stranger's socket was bound went to the stranger)."""
    t_end = time.monotonic() + timeout_s
    for name, literal in HOSTILE:
        while f"unknown parameter {literal}" not in shown(run.raw):
            assert run.proc.poll() is None, f"auv-gcs exited {run.proc.returncode}:\n{run.raw[-3000:]}"
            assert time.monotonic() < t_end, f"never shown: {literal!r}\n{run.raw[-3000:]}"
            stranger_says(gcs_port, vehicle_port, name)
            deadline = time.monotonic() + 1.0
            while time.monotonic() < deadline and f"unknown parameter {literal}" not in shown(run.raw):
                if run.proc.poll() is not None:
                    run._reader.join(5.0)  # the rest of its output
                    break
                time.sleep(0.05)


def assert_text_only(out: str, *, tty: bool) -> None:
    """The wire's words as text: no traceback, none of the wire's escape sequences; on a pipe no ESC at all
    (rich writes none there), on a terminal no hyperlink (OSC 8) either."""
    assert "Traceback" not in out and "MarkupError" not in out, out[-3000:]
    for seq in WIRE_ESCAPES:
        assert seq not in out, out[-3000:]
    if tty:
        assert "\x1b]8;" not in out, out[-3000:]
    else:
        assert "\x1b" not in out, out[-3000:]


def gcs(url: str, tmp_path: Path, *args: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "groundstation",
        "--connect",
        url,
        "--tlog-dir",
        str(tmp_path / "tlogs"),
        *args,
    ]


@pytest.fixture
def vehicle_to_gcs(tmp_path: Path) -> Iterator[tuple[int, int]]:
    """The real vehicle sending to a ground station's port (``udpout``): (its port, the vehicle's)."""
    gcs_port = free_udp_port()
    proc, vehicle_port = start_vehicle(
        tmp_path / "state", endpoint=f"udpout:127.0.0.1:{gcs_port}", time_scale=2.0
    )
    try:
        yield gcs_port, vehicle_port
    finally:
        stop_vehicle(proc)


@pytest.mark.parametrize("tty", [False, True], ids=["pipe", "tty"])
def test_fly_shows_a_strangers_markup_as_text_flies_on_and_holds(
    vehicle_to_gcs: tuple[int, int], tmp_path: Path, tty: bool
) -> None:
    gcs_port, vehicle_port = vehicle_to_gcs
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION)
    # GIVEN the operator flying a mission with `auv-gcs fly`
    run = Run(
        gcs(f"udpin:127.0.0.1:{gcs_port}", tmp_path, "fly", str(mission), "--ready-timeout", "60"), tty=tty
    )
    try:
        run.wait_for(lambda s: "start: MAV_RESULT_ACCEPTED" in s, 90.0, "the start")
        # WHEN a stranger's hostile names come back from the vehicle as its texts
        feed_until_shown(run, gcs_port, vehicle_port)
        assert run.proc.poll() is None, run.raw[-3000:]  # THEN fly flies on
        run.proc.send_signal(signal.SIGINT)  # and the operator's Ctrl-C still holds the vehicle
        code = run.finish(60.0)
    finally:
        run.stop()
    out = run.raw
    assert_text_only(out, tty=tty)
    assert code == 130, out[-3000:]
    assert "interrupted: HOLD sent, the vehicle answered MAV_RESULT_ACCEPTED" in shown(out), out[-3000:]


def test_monitor_on_a_terminal_shows_the_texts_as_text(
    vehicle_to_gcs: tuple[int, int], tmp_path: Path
) -> None:
    gcs_port, vehicle_port = vehicle_to_gcs
    run = Run(gcs(f"udpin:127.0.0.1:{gcs_port}", tmp_path, "monitor", "--duration", "600"), tty=True)
    try:
        run.wait_for(lambda s: "state" in shown(s) and "IDLE" in shown(s), 60.0, "the vehicle's state")
        feed_until_shown(run, gcs_port, vehicle_port)
        assert run.proc.poll() is None, run.raw[-3000:]
        run.proc.send_signal(signal.SIGINT)
        code = run.finish(60.0)
    finally:
        run.stop()
    assert_text_only(run.raw, tty=True)
    assert code in (0, 130), run.raw[-3000:]


# `get` reads the whole list for each name (about 3 s a name): on a terminal only, where markup bites
@pytest.mark.parametrize(
    ("action", "tty"), [("get", True), ("set", False), ("set", True)], ids=["get-tty", "set-pipe", "set-tty"]
)
def test_params_of_a_hostile_name_is_one_plain_refusal(
    vehicle_to_gcs: tuple[int, int], tmp_path: Path, action: str, tty: bool
) -> None:
    """The operator's own command with a hostile name: the vehicle's "unknown parameter NAME" comes back."""
    gcs_port, _vehicle_port = vehicle_to_gcs
    for name, literal in HOSTILE:
        args = ["params", action, name, *(["1"] if action == "set" else [])]
        run = Run(gcs(f"udpin:127.0.0.1:{gcs_port}", tmp_path, "--timeout", "20", *args), tty=tty)
        try:
            code = run.finish(60.0)
        finally:
            run.stop()
        assert_text_only(run.raw, tty=tty)
        assert code == 1, (name, run.raw)
        assert f"no such parameter {literal}" in shown(run.raw), (name, run.raw)


def test_map_page_gets_the_texts_without_control_characters(
    vehicle_to_gcs: tuple[int, int], tmp_path: Path
) -> None:
    """``auv-gcs map``: the texts the page lists come without control characters (the page writes them with
    ``textContent``, never as HTML: checked in its script)."""
    import asyncio

    import aiohttp

    from hil_sim.scenario import free_port

    gcs_port, vehicle_port = vehicle_to_gcs
    http_port = free_port()
    texts: list[str] = []
    stop = threading.Event()

    async def collect() -> None:
        async with aiohttp.ClientSession() as session:
            async with session.ws_connect(f"http://127.0.0.1:{http_port}/ws") as ws:
                while not stop.is_set():
                    try:
                        m = await ws.receive(timeout=0.5)
                    except TimeoutError:
                        continue
                    if m.type != aiohttp.WSMsgType.TEXT:
                        break
                    tel = json.loads(m.data).get("telemetry") or {}
                    texts.extend(t["text"] for t in tel.get("texts") or [])

    class Page:  # what feed_until_shown reads: the texts the page was sent, one a line
        def __init__(self, run: Run) -> None:
            self.proc = run.proc

        @property
        def raw(self) -> str:
            return "\n".join(list(texts))

    run = Run(gcs(f"udpin:127.0.0.1:{gcs_port}", tmp_path, "map", "--port", str(http_port)), tty=False)
    collector = threading.Thread(target=lambda: asyncio.run(collect()), daemon=True)
    try:
        run.wait_for(lambda s: "map on http://" in s, 30.0, "the map's address")
        collector.start()
        feed_until_shown(Page(run), gcs_port, vehicle_port)  # type: ignore[arg-type]
    finally:
        stop.set()
        collector.join(5.0)
        run.proc.send_signal(signal.SIGTERM)
        code = run.finish(60.0)
    assert code == 0, run.raw
    assert_text_only(run.raw, tty=False)
    assert not [t for t in texts if re.search(r"[\x00-\x1f\x7f-\x9f]", t)], texts
    script = (Path(__file__).parents[2] / "groundstation" / "map" / "static" / "map.js").read_text()
    assert not re.search(r"innerHTML|outerHTML|insertAdjacentHTML|document\.write", script)


#: The log names of a vehicle that lists what it likes (the real one serves only names of its own rule):
#: markup, escape sequences and a 50-character run of control bytes; the newest (the last) has a "/".
LOG_NAMES = [
    "[bold]word[/bold].mcap",
    "[link=http://x]x[/link].mcap",
    "\x1b[31mred\x1b]8;;http://x\x1b\\.mcap",
    "<" + "".join(chr(c) for c in [*range(1, 9), *range(10, 32), 0x7F, *range(0x80, 0x93)]) + ">.mcap",
    "flight-[/].mcap",
]
LOG_LITERALS = ["[bold]word[/bold].mcap", "[link=http://x]x[/link].mcap", "[31mred]8;;http://x\\.mcap",
                "<>.mcap", "flight-[/].mcap"]  # fmt: skip


class ListingVehicle:
    """A MAVLink vehicle (system 1) on a UDP port that answers HEARTBEAT requests and FTP: LIST of ``logs``
    with :data:`LOG_NAMES`, OpenFileRO with "file not found"."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.1)
        self.port = self.sock.getsockname()[1]
        self.mav = mavlink.MAVLink(None, 1, 1)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self) -> ListingVehicle:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.sock.close()

    def _send(self, msg: Any, addr: Any) -> None:
        self.sock.sendto(msg.pack(self.mav), addr)

    def _run(self) -> None:
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        while not self._stop.is_set():
            try:
                data, addr = self.sock.recvfrom(65535)
            except (TimeoutError, OSError):
                continue
            for m in parser.parse_buffer(data) or []:
                if m.get_type() in ("HEARTBEAT", "COMMAND_LONG"):
                    hb = mavlink.MAVLink_heartbeat_message(12, 3, 0, 19, 3, 3)
                    self._send(hb, addr)
                elif m.get_type() == "FILE_TRANSFER_PROTOCOL":
                    self._ftp(ftp.Packet.decode(m.payload), m.get_srcSystem(), m.get_srcComponent(), addr)

    def _ftp(self, req: ftp.Packet, sys_id: int, comp_id: int, addr: Any) -> None:
        def reply(opcode: int, data: bytes) -> None:
            p = ftp.Packet(
                (req.seq + 1) & 0xFFFF, req.session, opcode, len(data), req.opcode, 0, req.offset, data
            )
            self._send(mavlink.MAVLink_file_transfer_protocol_message(0, sys_id, comp_id, p.encode()), addr)

        if req.opcode == ftp.LIST and req.offset < len(LOG_NAMES):
            reply(ftp.ACK, b"F" + LOG_NAMES[req.offset].encode() + b"\t1000\0")
        elif req.opcode == ftp.LIST:
            reply(ftp.NAK, bytes([ftp.EOF]))
        elif req.opcode == ftp.OPEN_RO:
            reply(ftp.NAK, bytes([ftp.FILE_NOT_FOUND]))
        else:
            reply(ftp.ACK, b"")


@pytest.mark.parametrize("tty", [False, True], ids=["pipe", "tty"])
def test_logs_shows_the_vehicles_file_names_as_text(tmp_path: Path, tty: bool) -> None:
    with ListingVehicle() as v:
        url = f"udpout:127.0.0.1:{v.port}"
        listing = Run(gcs(url, tmp_path, "logs"), tty=tty)
        code = listing.finish(60.0)
        assert_text_only(listing.raw, tty=tty)
        assert code == 0, listing.raw
        for literal in LOG_LITERALS:
            assert literal in shown(listing.raw), (literal, listing.raw)
        get = Run(gcs(url, tmp_path, "logs", "get", "-o", str(tmp_path)), tty=tty)
        code = get.finish(60.0)
        assert_text_only(get.raw, tty=tty)
        assert code == 2, get.raw
        assert "the vehicle listed a log name that is a path: 'flight-[/].mcap'" in shown(get.raw), get.raw
