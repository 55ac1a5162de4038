"""Benchmark ``links``: the two links under contention and under floods, over real processes only.

Every figure is measured, none is asserted; each has a reference measured in the same run (a ratio where it
makes sense). Only public entry points are used: the standalone vehicle as the ``mission_upload`` section
starts it (:func:`groundstation.bench_upload.start_vehicle`), ``python -m hil_sim run`` (the bench, hosting
the CAN hub) and ``python -m onboard run`` as programs, :class:`~groundstation.mavclient.MavClient` for
MAVLink and python-can's ``RemoteBus`` for the hub. Helpers (ground stations, flooders) are processes of
this module (``python -m groundstation.bench_links worker KIND ...``): each says ``{"ready": ...}`` on
stdout, then acts on ``go`` / ``stop`` lines from stdin and answers one JSON line.

1. Concurrent uploads (``upload100_*``). A 100-goal mission uploaded by one ground station (``1gcs``, R
   rounds), then by three at once (``3gcs``: three processes, each its own MavClient and system id, released
   at the same instant, each uploading its own mission). The vehicle takes one transfer at a time and
   answers the others MAV_MISSION_DENIED; ``MavClient.upload`` returns that refusal as it is (it does not
   retry), so the ground-station worker here retries: after a DENIED it waits a back-off (50 ms, doubling
   to at most 0.8 s, each wait drawn in 0.5-1.5 times that) and uploads again, until ACCEPTED or 30 s.
   Figures: the median time of one upload (the accepted transfer itself, ``MavClient.upload``'s
   ``elapsed_s``), the median time from the release to a GCS's acceptance (retries included), the time until
   all three were accepted (median over rounds), its ratio to the one-GCS upload (3.0 would be three
   uploads back to back with no gap), and the DENIED answers per round.
2. MAVLink flood (``mav_*``). One genuine ground station (system 251) sends up to N PARAM_REQUEST_READ (by
   index, cycling through the table), one at a time, spaced over a window, each waiting at most 1 s for its
   PARAM_VALUE (no retry), and counts the vehicle's HEARTBEATs meanwhile: % answered within 1 s, median
   latency of the answered ones, HEARTBEAT rate (Hz). First without a flood (``ref``), then while a flooder
   process sends garbage datagrams (random bytes, and MAVLink 2 HEARTBEAT frames with one bit flipped so the
   CRC fails) from 16 other source ports to the vehicle's UDP port as fast as one Python process can
   (``flood``; its achieved rate in datagrams/s). Under a flood that starves the vehicle, each request costs
   its 1 s timeout, so the flood window is capped: fewer than N may be sent (``mav_flood_requests``).
3. CAN flood (``can_*``). ``hil_sim run`` in real time (hosting the hub) and ``onboard run`` (20 Hz, the
   paper's straight line as a start-up mission, ``--autostart``, MAVLink on) as processes, as
   tests/e2e/test_can_impostor.py and the scenario runner start them. Once the vehicle's HEARTBEAT says
   RUNNING, a window of W s and 1 s more: without a flood (``ref``), and in a second, fresh run while a
   third process floods the hub with unknown-id frames (standard ids 0x100-0x6FF, random data; none is in
   the DBC) through its own RemoteBus as fast as it can for the W s (``flood``; its rate in frames/s; the
   second after it counts too, as frames queued in the hub still arrive then). From the onboard's per-tick
   telemetry CSV (``--set loop.telemetry_csv``; each row carries the loop's overrun count) over the window:
   overruns, the longest run of consecutive overruns, ticks and ticks per second, the longest gap between
   two ticks. The bench's actuator watchdog: the times of its warning ``actuator failsafe: no valid
   command`` in the ``hil_sim run`` log (its lines begin with the local time) within the window, and when
   it first fired after the flood began; ``run_*``: the whole run's counts from the programs'
   ``--summary-json`` (the watchdog may also fire once at start-up, before the onboard is on the hub).
   ``running_at_end`` is 1 when the onboard's last tick of the window was still RUNNING (it aborts when the
   actuator node reports its failsafe).

Sizes (full / ``--quick``): 7 / 3 one-GCS uploads and 5 / 2 three-GCS rounds; N = 50 / 20 requests over
8 / 3 s without and at most 15 / 5 s with the flood; W = 10 / 3 s for CAN. About 65 s / 30 s in all
(``links_wall_s``). ``run(quick)`` returns the flat figures;
``python -m groundstation.bench_links [--quick] [--json]`` prints them.
"""

from __future__ import annotations

import contextlib
import csv
import datetime
import itertools
import json
import math
import queue
import random
import select
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from pymavlink.dialects.v20 import common as mavlink

from auv_common.cli import run_one_section
from auv_common.process import stop_process
from groundstation.bench_upload import start_vehicle, stop_vehicle
from groundstation.mavclient import MavClient
from groundstation.messages import state_from_heartbeat
from groundstation.mission_client import Item
from groundstation.mission_files import goal_item

GENUINE_SYSTEM_ID = 251
UPLOAD_GOALS = 100
REQUEST_TIMEOUT_S = 1.0
UDP_FLOOD_SOURCES = 16
#: standard CAN ids absent from onboard/protocol/isimi100.dbc (it uses 0x010-0x044 and 0x701-0x703)
CAN_FLOOD_IDS = (0x100, 0x6FF)
#: the paper's straight line (as ``make demo`` and the e2e tests): start pose and the one goal
CAN_START = "-13.0,0.0,1.0,0.0"
#: the CAN figures are over the flood and this long after it (the same for the reference)
CAN_TAIL_S = 1.0
#: the bench's warning when its actuator watchdog fires (``hil_sim run``'s log)
WATCHDOG_FIRED = "actuator failsafe: no valid command"
CAN_MISSION = "goals:\n  - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"


# --- processes ----------------------------------------------------------------------------------------
def _free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _drain(stream: IO[str] | None) -> None:
    """Read a child's pipe to its end in a daemon thread (a full pipe would block the child)."""
    if stream is not None:
        threading.Thread(target=lambda: stream.read(), daemon=True).start()


class Worker:
    """A helper process of this module: one JSON line when ready, then ``go`` / ``stop`` lines, answers."""

    def __init__(self, *args: str) -> None:
        self.name = " ".join(args)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "groundstation.bench_links", "worker", *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        self._lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self._lines.put(line)
        self._lines.put("")  # the worker ended

    def answer(self, timeout_s: float) -> dict[str, Any]:
        """The worker's next JSON line (a RuntimeError if it ended or took longer than ``timeout_s``)."""
        try:
            line = self._lines.get(timeout=timeout_s)
        except queue.Empty:
            line = ""
        if not line:
            raise RuntimeError(f"worker {self.name!r} gave no answer within {timeout_s:.0f} s")
        result: dict[str, Any] = json.loads(line)
        return result

    def say(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def stop(self) -> None:
        with contextlib.suppress(OSError):
            self.say("quit")
        stop_process(self.proc, 3.0)


@contextlib.contextmanager
def _workers() -> Iterator[list[Worker]]:
    started: list[Worker] = []
    try:
        yield started
    finally:
        for w in reversed(started):
            w.stop()


def _stdin_says() -> str | None:
    """A line from stdin if one is waiting (no wait), else None; EOF reads as ``quit``."""
    ready, _, _ = select.select([sys.stdin], [], [], 0.0)
    if not ready:
        return None
    return sys.stdin.readline().strip() or "quit"


def _say(obj: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(obj) + "\n")
    sys.stdout.flush()


# --- 1. concurrent uploads ---------------------------------------------------------------------------
def _mission(n: int, k: int) -> list[Item]:
    # goals 1 rad apart on a 10 m circle, depth alternating 1 / 1.5 m (every leg flyable, as bench_upload);
    # k turns the circle, so every upload is a different mission
    return [
        goal_item(10.0 * math.cos(i + 0.1 * k), 10.0 * math.sin(i + 0.1 * k), 1.0 + 0.5 * (i % 2), None)
        for i in range(n)
    ]


def _connect(c: MavClient, tries: int = 10) -> None:
    for _ in range(tries):
        try:
            c.wait_heartbeat(1.0)
            return
        except Exception:
            continue
    raise RuntimeError("no vehicle heartbeat")


def _upload_until_accepted(
    c: MavClient,
    items: list[Item],
    rng: random.Random,
    budget_s: float,
    t0: float,
) -> dict[str, Any]:
    """Upload until ACCEPTED (times from ``t0``): after a DENIED wait the back-off (50 ms doubling to 0.8 s,
    x 0.5-1.5)."""
    attempts = denied = other = 0
    backoff = 0.05
    while True:
        attempts += 1
        r = c.upload(items, timeout_s=8.0)
        if r.ok:
            return {"ok": True, "t_accept_s": time.monotonic() - t0, "upload_s": r.elapsed_s,
                    "attempts": attempts, "denied": denied, "other": other}  # fmt: skip
        if r.result == mavlink.MAV_MISSION_DENIED:
            denied += 1
        else:
            other += 1  # a timeout or a cancel: try again too (a refusal of the mission itself would repeat)
        if time.monotonic() - t0 > budget_s:
            return {"ok": False, "t_accept_s": math.nan, "upload_s": math.nan, "attempts": attempts,
                    "denied": denied, "other": other, "last": r.result_name}  # fmt: skip
        time.sleep(backoff * rng.uniform(0.5, 1.5))
        backoff = min(backoff * 2.0, 0.8)


def _gcs_worker(port: int, system_id: int) -> None:
    """A ground station: on ``go T K`` (T monotonic) upload mission K from T until accepted, answer."""
    rng = random.Random(system_id)
    with MavClient(f"udpout:127.0.0.1:{port}", system_id=system_id) as c:
        _connect(c)
        _say({"ready": True})
        for line in sys.stdin:
            words = line.split()
            if not words or words[0] != "go":
                break
            t_go, k = float(words[1]), int(words[2])
            time.sleep(max(0.0, t_go - time.monotonic()))
            _say(_upload_until_accepted(c, _mission(UPLOAD_GOALS, k), rng, 30.0, t_go))


def _upload_rounds(port: int, n_gcs: int, rounds: int, k0: int) -> list[list[dict[str, Any]]]:
    out = []
    with _workers() as ws:
        for i in range(n_gcs):
            ws.append(Worker("gcs", str(port), str(240 + i)))
        for w in ws:
            w.answer(30.0)
        for r in range(rounds):
            t_go = time.monotonic() + 0.2
            for i, w in enumerate(ws):
                w.say(f"go {t_go} {k0 + r * n_gcs + i}")
            out.append([w.answer(60.0) for w in ws])
            time.sleep(0.2)
    return out


def _uploads(port: int, quick: bool) -> dict[str, float]:
    rounds1, rounds3 = (3, 2) if quick else (7, 5)
    single = [res[0] for res in _upload_rounds(port, 1, rounds1, 0)]
    multi = _upload_rounds(port, 3, rounds3, 1000)
    t1 = _median([x["upload_s"] for x in single if x["ok"]])
    flat = [x for res in multi for x in res]
    per_upload = _median([x["upload_s"] for x in flat if x["ok"]])
    all_accepted = _median(
        [max(x["t_accept_s"] for x in res) if all(x["ok"] for x in res) else math.nan for res in multi]
    )
    return {
        "upload100_1gcs_median_s": t1,
        "upload100_1gcs_ok": float(sum(x["ok"] for x in single)),
        "upload100_1gcs_tries": float(len(single)),
        "upload100_3gcs_per_upload_median_s": per_upload,
        "upload100_3gcs_per_upload_ratio": per_upload / t1,
        "upload100_3gcs_time_to_accept_median_s": _median([x["t_accept_s"] for x in flat if x["ok"]]),
        "upload100_3gcs_all_accepted_median_s": all_accepted,
        "upload100_3gcs_all_accepted_ratio": all_accepted / t1,
        "upload100_3gcs_denied_per_round": sum(x["denied"] for x in flat) / len(multi),
        "upload100_3gcs_other_failures": float(sum(x["other"] for x in flat)),
        "upload100_3gcs_ok": float(sum(x["ok"] for x in flat)),
        "upload100_3gcs_tries": float(len(flat)),
    }


# --- 2. MAVLink flood ---------------------------------------------------------------------------------
def garbage_datagrams(rng: random.Random, n: int) -> list[bytes]:
    """Random bytes, and MAVLink 2 HEARTBEAT frames with one bit flipped (the CRC fails), half each."""
    mav = mavlink.MAVLink(None, 66, 1)
    out = []
    for k in range(n):
        if k % 2:
            out.append(rng.randbytes(rng.randint(1, 280)))
        else:
            frame = bytearray(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav))
            bit = rng.randrange(8, 8 * len(frame))  # any bit after the magic byte
            frame[bit // 8] ^= 1 << (bit % 8)
            out.append(bytes(frame))
    return out


def _udp_flood_worker(port: int, sources: int) -> None:
    """On ``go``: garbage to 127.0.0.1:``port`` from ``sources`` sockets, flat out, until ``stop``."""
    datagrams = garbage_datagrams(random.Random(7), 512)
    socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(sources)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
        s.setblocking(False)
    addr = ("127.0.0.1", port)
    _say({"ready": True})
    if sys.stdin.readline().strip() != "go":
        return
    sent = errors = i = 0
    t0 = time.monotonic()
    while True:
        for _ in range(2048):
            try:
                socks[i % sources].sendto(datagrams[i & 511], addr)
                sent += 1
            except OSError:  # a full send buffer (EAGAIN / ENOBUFS): that one is lost
                errors += 1
            i += 1
        if _stdin_says() is not None:
            break
    t1 = time.monotonic()
    _say({"sent": sent, "errors": errors, "t0": t0, "t1": t1, "rate": sent / (t1 - t0)})


def _request_phase(c: MavClient, n: int, count: int, window_s: float, cap_s: float) -> dict[str, float]:
    """Up to ``n`` PARAM_REQUEST_READ spaced over ``window_s`` (none sent after ``cap_s``), each waiting at
    most 1 s for its PARAM_VALUE; the vehicle's HEARTBEATs counted over the whole phase."""
    ts, tc = c.target
    t0 = time.monotonic()
    heartbeats = sent = 0
    latencies: list[float] = []

    def pump(until: float, idx: int | None = None, t_sent: float = 0.0) -> bool:
        nonlocal heartbeats
        while (left := until - time.monotonic()) > 0:
            m = c.recv(left)
            if m is None or (m.get_srcSystem(), m.get_srcComponent()) != c.target:
                continue
            kind = m.get_type()
            if kind == "HEARTBEAT" and m.type != mavlink.MAV_TYPE_GCS:
                heartbeats += 1
            elif kind == "PARAM_VALUE" and idx is not None and m.param_index == idx:
                latencies.append(time.monotonic() - t_sent)
                return True
        return False

    while sent < n and time.monotonic() - t0 < cap_s:
        pump(t0 + sent * window_s / n)
        idx = sent % count
        c.drop_stale(("PARAM_VALUE",))  # a late answer to an earlier request is not this one's
        c.send(mavlink.MAVLink_param_request_read_message(ts, tc, b"", idx))
        t_sent = time.monotonic()
        sent += 1
        pump(t_sent + REQUEST_TIMEOUT_S, idx, t_sent)
    pump(t0 + window_s)
    duration = time.monotonic() - t0
    return {
        "requests": float(sent),
        "answered_pct": 100.0 * len(latencies) / sent if sent else math.nan,
        "latency_median_ms": 1e3 * _median(latencies),
        "latency_max_ms": 1e3 * max(latencies) if latencies else math.nan,
        "heartbeat_hz": heartbeats / duration,
        "phase_s": duration,
    }


def _mavlink_flood(port: int, quick: bool) -> dict[str, float]:
    n, ref_s, flood_s = (20, 3.0, 5.0) if quick else (50, 8.0, 15.0)
    out: dict[str, float] = {}
    with MavClient(f"udpout:127.0.0.1:{port}", system_id=GENUINE_SYSTEM_ID) as c, _workers() as ws:
        ws.append(Worker("udp-flood", str(port), str(UDP_FLOOD_SOURCES)))
        _connect(c)
        ts, tc = c.target
        c.send(mavlink.MAVLink_param_request_read_message(ts, tc, b"", 0))
        count = 0
        t_end = time.monotonic() + 5.0
        while not count and time.monotonic() < t_end:
            m = c.recv(0.5)
            if m is not None and m.get_type() == "PARAM_VALUE":
                count = int(m.param_count)
        if not count:
            raise RuntimeError("the vehicle did not answer PARAM_REQUEST_READ")
        ref = _request_phase(c, n, count, ref_s, ref_s)
        ws[0].answer(30.0)
        ws[0].say("go")
        time.sleep(0.3)  # the flood under way
        flood = _request_phase(c, n, count, flood_s, flood_s)
        ws[0].say("stop")
        rate = ws[0].answer(10.0)
    for tag, res in (("ref", ref), ("flood", flood)):
        for k, v in res.items():
            out[f"mav_{tag}_{k}"] = v
    out["mav_flood_rate_dgram_per_s"] = float(rate["rate"])
    out["mav_flood_send_errors"] = float(rate["errors"])
    out["mav_flood_sources"] = float(UDP_FLOOD_SOURCES)
    out["mav_flood_answered_ratio"] = flood["answered_pct"] / ref["answered_pct"]
    out["mav_flood_latency_ratio"] = flood["latency_median_ms"] / ref["latency_median_ms"]
    out["mav_flood_heartbeat_ratio"] = flood["heartbeat_hz"] / ref["heartbeat_hz"]
    return out


# --- 3. CAN flood -------------------------------------------------------------------------------------
def _can_flood_worker(channel: str) -> None:
    """Connect to the hub (retrying); on ``go`` send unknown-id frames as fast as possible until ``stop``."""
    import can

    t_end = time.monotonic() + 30.0
    while True:
        try:
            # a sender only: a filter nothing passes, so the hub forwards nothing to this client
            bus = can.Bus(
                interface="remote",
                channel=channel,
                can_filters=[{"can_id": 0, "can_mask": 0x1FFFFFFF, "extended": True}],
            )
            break
        except Exception:
            if time.monotonic() > t_end:
                raise
            time.sleep(0.1)
    rng = random.Random(11)
    frames = [
        can.Message(arbitration_id=rng.randint(*CAN_FLOOD_IDS), data=rng.randbytes(8), is_extended_id=False)
        for _ in range(256)
    ]
    _say({"ready": True})
    if sys.stdin.readline().strip() != "go":
        bus.shutdown()
        return
    sent = i = 0
    t0 = time.monotonic()
    while True:
        for _ in range(256):
            bus.send(frames[i & 255])
            i += 1
        sent += 256
        if _stdin_says() is not None:
            break
    t1 = time.monotonic()
    _say({"sent": sent, "t0": t0, "t1": t1, "rate": sent / (t1 - t0)})
    try:
        bus.shutdown()
    except Exception:  # the hub reset the connection: closed all the same
        can.BusABC.shutdown(bus)


def _tick_figures(rows: list[dict[str, str]], t_a: float, t_b: float) -> dict[str, float]:
    """Overruns, the longest run of them, ticks, rate and the longest gap of the ticks in [t_a, t_b].

    A row is written at its tick with the overruns counted before it; whether tick k overran shows in row
    k + 1, so the row after the window is read too."""
    idx = [i for i, r in enumerate(rows) if t_a <= float(r["t_s"]) <= t_b]
    if len(idx) < 2:
        nan = math.nan
        return {"running_at_end": nan, "ticks": float(len(idx)), "overruns": nan,
                "max_consecutive_overruns": nan, "tick_rate_hz": nan, "max_tick_gap_ms": nan}  # fmt: skip
    last = min(idx[-1] + 1, len(rows) - 1)
    ov = [int(rows[i]["overruns"]) for i in range(idx[0], last + 1)]
    run = longest = 0
    for a, b in itertools.pairwise(ov):
        run = run + 1 if b > a else 0
        longest = max(longest, run)
    ts = [float(rows[i]["t_s"]) for i in idx]
    return {
        "running_at_end": float(rows[idx[-1]]["state"] == "RUNNING"),
        "ticks": float(len(idx)),
        "overruns": float(ov[-1] - ov[0]),
        "max_consecutive_overruns": float(longest),
        "tick_rate_hz": len(idx) / (t_b - t_a),
        "max_tick_gap_ms": 1e3 * max(b - a for a, b in itertools.pairwise(ts)),
    }


def _can_run(work: Path, flood: bool, window_s: float) -> dict[str, float]:
    work.mkdir(parents=True)
    channel = f"ws://127.0.0.1:{_free_port(socket.SOCK_STREAM)}/"
    mav_port = _free_port(socket.SOCK_DGRAM)
    (work / "mission.yaml").write_text(CAN_MISSION)
    hil_cmd = [
        sys.executable, "-m", "hil_sim", "run", "--mode=realtime", f"--channel={channel}",
        f"--start={CAN_START}", "--profile=basin", "--duration=300",
        f"--summary-json={work / 'hil.json'}",
    ]  # fmt: skip
    onboard_cmd = [
        sys.executable, "-m", "onboard", "run",
        "--set", f'bus.channel="{channel}"',
        "--set", f'mavlink.endpoints=["udpin:127.0.0.1:{mav_port}"]',
        "--set", f'loop.telemetry_csv="{work / "telemetry.csv"}"',
        "--state-dir", str(work / "state"),
        "--mission", str(work / "mission.yaml"), "--autostart",
        "--summary-json", str(work / "onboard.json"),
    ]  # fmt: skip
    out: dict[str, float] = {}
    procs: list[subprocess.Popen[str]] = []
    wall = time.time() - time.monotonic()  # the logs' clock from ours
    logs = [work / "hil.log", work / "onboard.log"]
    with open(logs[0], "w") as hil_log, open(logs[1], "w") as onboard_log, _workers() as ws:
        try:
            for cmd, log in ((hil_cmd, hil_log), (onboard_cmd, onboard_log)):
                procs.append(subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, text=True))
            if flood:
                ws.append(Worker("can-flood", channel))
            with MavClient(f"udpout:127.0.0.1:{mav_port}", system_id=GENUINE_SYSTEM_ID) as c:
                _connect(c, tries=20)
                state = _wait_state(c, "RUNNING", 20.0)
                if state != "RUNNING":
                    raise RuntimeError(f"the vehicle did not start its mission (state {state})")
                if flood:
                    ws[0].answer(30.0)
                    ws[0].say("go")
                t_a = time.monotonic()
                _wait_state(c, None, window_s, state)
                t_b = time.monotonic()
                if flood:
                    ws[0].say("stop")
                    res = ws[0].answer(20.0)
                    out["rate_frames_per_s"] = float(res["rate"])
                    out["flood_s"] = float(res["t1"]) - float(res["t0"])
                    t_a, t_b = float(res["t0"]), float(res["t1"])
                # and a second after it: frames queued in the hub still come after the flood ends
                _wait_state(c, None, t_b + CAN_TAIL_S - time.monotonic(), state)
                t_b += CAN_TAIL_S
        finally:
            # the onboard first (it writes its summary and telemetry at exit), then the bench
            for p in reversed(procs):
                stop_process(p, 10.0)
    rows = list(csv.DictReader((work / "telemetry.csv").open()))
    out.update(_tick_figures(rows, t_a, t_b))
    onboard, hil = _summary(work / "onboard.json"), _summary(work / "hil.json")
    fired = _log_times(logs[0], WATCHDOG_FIRED)
    in_window = [t - wall - t_a for t in fired if wall + t_a <= t <= wall + t_b]
    out["watchdog_fired_in_window"] = float(len(in_window))
    out["watchdog_first_fired_after_s"] = in_window[0] if in_window else math.nan
    out["run_watchdog_timeouts"] = float(hil.get("failsafe_timeouts", math.nan))
    out["run_overruns"] = float(onboard.get("overruns", math.nan))
    out["run_frames_rejected"] = float(sum(onboard.get("frames_rejected", {}).values()))
    out["window_s"] = t_b - t_a
    return out


def _summary(path: Path) -> dict[str, Any]:
    """A program's ``--summary-json`` ({} if it wrote none: it was killed)."""
    with contextlib.suppress(OSError, ValueError):
        data: dict[str, Any] = json.loads(path.read_text())
        return data
    return {}


def _log_times(path: Path, text: str) -> list[float]:
    """The times (s since the epoch) of a program's log lines containing ``text`` (its logging format
    begins with ``%(asctime)s``: local time, milliseconds after a comma)."""
    times = []
    for line in path.read_text(errors="replace").splitlines():
        if text in line:
            with contextlib.suppress(ValueError):
                stamp = datetime.datetime.strptime(line[:23], "%Y-%m-%d %H:%M:%S,%f")
                times.append(stamp.timestamp())
    return times


def _wait_state(c: MavClient, want: str | None, timeout_s: float, state: str = "") -> str:
    """Read the vehicle's HEARTBEATs for ``timeout_s`` (until state ``want`` if given); the last state."""
    t_end = time.monotonic() + timeout_s
    while (left := t_end - time.monotonic()) > 0:
        m = c.recv(left)
        if m is not None and m.get_type() == "HEARTBEAT" and m.type != mavlink.MAV_TYPE_GCS:
            state = state_from_heartbeat(m)
            if state == want:
                break
    return state


def _can_flood(quick: bool) -> dict[str, float]:
    window_s = 3.0 if quick else 10.0
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as d:
        ref = _can_run(Path(d) / "ref", False, window_s)
        flood = _can_run(Path(d) / "flood", True, window_s)
    for tag, res in (("ref", ref), ("flood", flood)):
        for k, v in res.items():
            if not (tag == "ref" and k == "rate_frames_per_s"):
                out[f"can_{tag}_{k}"] = v
    out["can_flood_tick_rate_ratio"] = flood["tick_rate_hz"] / ref["tick_rate_hz"]
    out["can_flood_max_tick_gap_ratio"] = flood["max_tick_gap_ms"] / ref["max_tick_gap_ms"]
    return out


# --- the section --------------------------------------------------------------------------------------
def _median(values: list[float]) -> float:
    return statistics.median(values) if values else math.nan


def run(quick: bool = False) -> dict[str, float]:
    """The ``links`` figures (see the module's docstring); measured, not asserted."""
    t0 = time.monotonic()
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as d:
        proc, port = start_vehicle(Path(d))
        _drain(proc.stdout)
        _drain(proc.stderr)
        try:
            out.update(_uploads(port, quick))
            out.update(_mavlink_flood(port, quick))
        finally:
            stop_vehicle(proc)
    out.update(_can_flood(quick))
    out["links_wall_s"] = time.monotonic() - t0
    return out


def _worker(argv: list[str]) -> int:
    kind, *args = argv
    if kind == "gcs":
        _gcs_worker(int(args[0]), int(args[1]))
    elif kind == "udp-flood":
        _udp_flood_worker(int(args[0]), int(args[1]))
    elif kind == "can-flood":
        _can_flood_worker(args[0])
    else:
        raise SystemExit(f"unknown worker {kind!r}")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["worker"]:
        return _worker(argv[1:])
    return run_one_section("python -m groundstation.bench_links", run, argv)


if __name__ == "__main__":
    raise SystemExit(main())
