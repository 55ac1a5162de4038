"""A second sender on the CAN bus (issue 12, item 3): valid CRC and alive counter.

- FIN_CMD and PROP_CMD at 100 Hz while the firmware is not armed: the bench's actuator node obeys ARMED
  commands only while the onboard's own heartbeat says it is live, so nothing moves; an impostor that also
  forges that heartbeat is what the E2E profile cannot stop (README: what E2E protects against).
- DEPTH = 25 m at 200 Hz next to the bench's genuine DEPTH: two interleaved counter streams on one id, seen
  as a conflicting sender at the genuine sensor's next frame; the id is then distrusted, so the impostor's
  value is taken for at most that first sensor period."""

from __future__ import annotations

import csv
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hil_sim.scenario import free_port
from onboard.protocol import messages as m
from onboard.protocol.bus import BusConfig, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.port import BusPort
from tests.e2e.procs import processes

pytestmark = pytest.mark.e2e


def _impostor(channel: str, seconds: float, heartbeat: m.MissionStateCode | None) -> None:
    bus = open_bus(BusConfig(interface="remote", channel=channel), timeout_s=15.0)
    port = BusPort(bus, time.monotonic, [], Codec())
    try:
        t_end = time.monotonic() + seconds
        k = 0
        while time.monotonic() < t_end:
            if heartbeat is not None and k % 10 == 0:
                port.send(m.OnboardHeartbeat(heartbeat, 1.0))
            port.send(m.FinCmd(0.3, 0.0, 0.0))
            port.send(m.PropCmd(30.0, m.ActuatorMode.ARMED))
            k += 1
            time.sleep(0.01)
    finally:
        port.close()


def _fly(tmp_path: Path, heartbeat: m.MissionStateCode | None) -> tuple[float, float]:
    channel = f"ws://127.0.0.1:{free_port()}/"
    truth = tmp_path / f"truth-{heartbeat}.csv"
    with processes() as procs:
        cmd = [sys.executable, "-m", "hil_sim", "run", "--channel", channel, "--truth-log", str(truth)]
        bench = subprocess.Popen(
            [*cmd, "--duration", "6"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        procs.append(bench)
        _impostor(channel, 3.0, heartbeat)
        bench.wait(timeout=30)
    rows = list(csv.DictReader(truth.open()))
    return max(float(r["propeller_rps"]) for r in rows), max(abs(float(r["rudder_rad"])) for r in rows)


def test_an_impostors_commands_move_nothing_while_the_firmware_is_not_armed(tmp_path: Path) -> None:
    # WHEN the impostor commands 30 rps and 0.3 rad of rudder with no onboard heartbeat, or an IDLE one
    # THEN the propeller and the rudder stay where they are (before: 30 rps and 0.3 rad within 81 periods)
    assert _fly(tmp_path, None) == (0.0, 0.0)
    assert _fly(tmp_path, m.MissionStateCode.IDLE) == (0.0, 0.0)
    # and one that forges a RUNNING heartbeat too is obeyed: the limit of E2E on a shared bus
    rps, rudder = _fly(tmp_path, m.MissionStateCode.RUNNING)
    assert rps > 20.0 and rudder > 0.25


def test_an_impostor_interleaved_with_the_genuine_depth_sensor_is_a_conflict_not_a_depth(
    tmp_path: Path,
) -> None:
    # GIVEN the bench (its depth sensor on the hub) and a listener, as the onboard listens to DEPTH
    channel = f"ws://127.0.0.1:{free_port()}/"
    codec = Codec()
    with processes() as procs:
        cmd = [sys.executable, "-m", "hil_sim", "run", "--channel", channel, "--duration", "8"]
        procs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        listen = BusPort(
            open_bus(BusConfig(interface="remote", channel=channel), timeout_s=15.0),
            time.monotonic,
            [codec.frame_id(m.DepthMeas)],
            codec,
        )
        impostor = BusPort(
            open_bus(BusConfig(interface="remote", channel=channel), timeout_s=15.0), time.monotonic
        )
        try:
            time.sleep(1.0)
            before = [d.depth_m for d in listen.drain()]
            # WHEN an impostor sends DEPTH = 25 m at 200 Hz for 2 s, with its own valid counter
            taken: list[tuple[float, float]] = []  # (s since the attack began, depth) of each DEPTH taken
            t0 = time.monotonic()
            while time.monotonic() < t0 + 2.0:
                impostor.send(m.DepthMeas(25.0, 0.0))
                taken.extend((time.monotonic() - t0, d.depth_m) for d in listen.drain())
                time.sleep(0.005)
            time.sleep(0.2)
            taken.extend((time.monotonic() - t0, d.depth_m) for d in listen.drain())
            rejected = dict(listen.receiver.rejected)
        finally:
            impostor.close()
            listen.close()
    # THEN the genuine depth was heard before; the impostor's 25 m is taken only until the genuine sensor's
    # next frame shows the second stream (at most one sensor period), never after: the id is distrusted
    assert before and max(before) < 5.0
    fake = [t for t, d in taken if d > 20.0]
    assert len(fake) <= 40 and (not fake or max(fake) < 0.5), fake
    assert rejected.get("conflicting_sender", 0) > 10, rejected
