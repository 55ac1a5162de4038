"""A second sender on the CAN bus (issue 12, item 3): valid CRC and alive counter.

- FIN_CMD and PROP_CMD at 50 Hz (within the bench's rate check: 4x the 20 Hz cycle) while the firmware is
  not armed: the bench's actuator node obeys ARMED
  commands only while the onboard's own heartbeat says it is live, so nothing moves; an impostor that also
  forges that heartbeat is what the E2E profile cannot stop (docs/bus-contract.md: what E2E protects against).
- DEPTH = 25 m at 200 Hz next to the bench's genuine DEPTH: two interleaved counter streams on one id, seen
  as a conflicting sender at the genuine sensor's next frame; the id is then distrusted, so the impostor's
  value is taken for at most that first sensor period.
- One captured DEPTH frame sent again at 200 Hz, byte for byte (its counter stands still): a receiver that
  checks rates drops what is over 4x the DBC's 20 Hz undecoded (``over_rate``) and distrusts the id; the
  replay is taken at most once, as its first frame, and nothing of the id after the first sensor period
  until it stops (the sensor goes stale: the onboard's navigation failsafe); then the genuine sensor is taken
  again."""

from __future__ import annotations

import csv
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from hil_sim.scenario import free_port
from onboard.protocol import messages as m
from onboard.protocol.bus import BusConfig, open_bus
from onboard.protocol.codec import Codec, FrameReceiver
from onboard.protocol.port import BusPort
from tests.e2e.procs import processes
from tests.waiting import wait_until

pytestmark = pytest.mark.e2e


def _impostor(
    channel: str, seconds: float, heartbeat: m.MissionStateCode | None, period_s: float = 0.02
) -> None:
    bus = open_bus(BusConfig(interface="remote", channel=channel), timeout_s=15.0)
    port = BusPort(bus, time.monotonic, [], Codec())
    try:
        t_end = time.monotonic() + seconds
        k = 0
        while time.monotonic() < t_end:
            if heartbeat is not None and k % 10 == 0:
                port.send(m.OnboardHeartbeat(heartbeat, 1.0))
            port.send(m.FinCmd(0.3, 0.0, 0.0))
            # SAFE for the first 0.1 s, as the onboard does: it clears the actuators' failsafe, latched by
            # their watchdog when the bench ran 5 periods before the first command (any node may send it)
            safe = k * period_s < 0.1
            port.send(m.PropCmd(0.0, m.ActuatorMode.SAFE) if safe else m.PropCmd(30.0, m.ActuatorMode.ARMED))
            k += 1
            time.sleep(period_s)
    finally:
        port.close()


def _fly(
    tmp_path: Path, heartbeat: m.MissionStateCode | None, period_s: float = 0.02
) -> tuple[float, float, int]:
    """Max propeller rps, max |rudder| and the control periods the impostor's 30 rps was followed."""
    channel = f"ws://127.0.0.1:{free_port()}/"
    truth = tmp_path / f"truth-{heartbeat}-{period_s}.csv"
    with processes() as procs:
        cmd = [sys.executable, "-m", "hil_sim", "run", "--channel", channel, "--truth-log", str(truth)]
        bench = subprocess.Popen(
            [*cmd, "--duration", "6"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
        )
        procs.append(bench)
        _impostor(channel, 3.0, heartbeat, period_s)
        bench.wait(timeout=30)
    rows = list(csv.DictReader(truth.open()))
    obeyed = sum(float(r["propeller_cmd_rps"]) > 0.0 for r in rows)
    return (
        max(float(r["propeller_rps"]) for r in rows),
        max(abs(float(r["rudder_rad"])) for r in rows),
        obeyed,
    )


def test_an_impostors_commands_move_nothing_while_the_firmware_is_not_armed(tmp_path: Path) -> None:
    # WHEN the impostor commands 30 rps and 0.3 rad of rudder with no onboard heartbeat, or an IDLE one
    # THEN the propeller and the rudder stay where they are (before: 30 rps and 0.3 rad within 81 periods)
    assert _fly(tmp_path, None) == (0.0, 0.0, 0)
    assert _fly(tmp_path, m.MissionStateCode.IDLE) == (0.0, 0.0, 0)
    # and one that forges a RUNNING heartbeat too is obeyed: the limit of E2E on a shared bus
    rps, rudder, obeyed = _fly(tmp_path, m.MissionStateCode.RUNNING)
    assert rps > 20.0 and rudder > 0.25 and obeyed > 40
    # unless it sends far above the commands' rate: the bench then drops it and distrusts the ids after its
    # first burst, and its actuator watchdog ends what that burst commanded
    _, _, obeyed_fast = _fly(tmp_path, m.MissionStateCode.RUNNING, period_s=0.002)
    assert obeyed_fast <= 10, obeyed_fast


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
            before: list[float] = []  # the genuine depth, heard before the attack
            wait_until(
                lambda: before.extend(d.depth_m for d in listen.drain()) or len(before) >= 5,
                20.0,
                "5 genuine DEPTH frames",
            )
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


REPLAY_HZ = 200.0
DRAIN_S = 0.005  # the listener takes frames as they come; the hub delivers them within a few ms


def _take(
    bus: can.BusABC,
    rx: FrameReceiver,
    t_end: float,
    events: list[tuple[float, bytes, bool]],
    replay: tuple[can.BusABC, bytes] | None = None,
) -> int:
    """Receive DEPTH frames until ``t_end`` (monotonic) through ``rx``, noting (time, bytes, taken); with
    ``replay``, send its frame every 1 / REPLAY_HZ meanwhile. Returns the frames replayed."""
    sent = 0
    next_send = time.monotonic()
    depth_id = rx.codec.frame_id(m.DepthMeas)
    while (now := time.monotonic()) < t_end:
        if replay is not None and now >= next_send:
            replay[0].send(can.Message(arbitration_id=depth_id, data=replay[1], is_extended_id=False))
            sent += 1
            next_send = max(next_send + 1.0 / REPLAY_HZ, now)
        frame = bus.recv(max(0.0, min(0.01, next_send - now)) if replay is not None else 0.01)
        if frame is None or frame.arbitration_id != depth_id or frame.is_error_frame:
            continue
        t, data = time.monotonic(), bytes(frame.data)
        events.append((t, data, rx.receive(frame.arbitration_id, data, t) is not None))
    return sent


def test_a_depth_frame_replayed_at_200_hz_is_taken_at_most_once_then_the_id_is_distrusted() -> None:
    # GIVEN the bench (its depth sensor at 20 Hz on the hub) and a listener that checks rates, as the onboard
    channel = f"ws://127.0.0.1:{free_port()}/"
    codec = Codec()
    depth_id = codec.frame_id(m.DepthMeas)
    cycle_s = codec.cycle_time_s(depth_id)
    assert cycle_s is not None
    rx = FrameReceiver(codec, frozenset({depth_id}))
    rx.check_rates(receive_period_s=DRAIN_S)
    with processes() as procs:
        cmd = [sys.executable, "-m", "hil_sim", "run", "--channel", channel, "--duration", "12"]
        procs.append(subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        listen = open_bus(BusConfig(interface="remote", channel=channel), timeout_s=15.0)
        attacker = open_bus(BusConfig(interface="remote", channel=channel), timeout_s=15.0)
        try:
            before: list[tuple[float, bytes, bool]] = []
            _take(listen, rx, time.monotonic() + 1.0, before)
            rejected_before = dict(rx.rejected)
            # one frame of the genuine sensor as recorded off the bus, 15 frames old: its counter is the one
            # the listener expects next, the worst case (a copy can pass the counter check once)
            assert len(before) >= 16, before
            captured = before[-16][1]
            # WHEN the attacker sends it again, byte for byte, at 200 Hz for 2 s
            attack: list[tuple[float, bytes, bool]] = []
            t0 = time.monotonic()
            sent = _take(listen, rx, t0 + 2.0, attack, replay=(attacker, captured))
            t1 = time.monotonic()
            after: list[tuple[float, bytes, bool]] = []
            _take(listen, rx, t1 + 2.5, after)
        finally:
            attacker.shutdown()
            listen.shutdown()
    rejected = dict(rx.rejected)
    # THEN the genuine depth was taken before, with nothing refused
    assert sum(taken for _, _, taken in before) >= 10 and rejected_before == {}, rejected_before
    # AND the replayed frame is taken at most once: as the first of its copies to arrive (its counter may
    # happen to be the next one), within the first sensor period
    copies = [(t - t0, taken) for t, data, taken in attack if data == captured]
    assert len(copies) > 0.5 * sent
    taken_copies = [i for i, (_, taken) in enumerate(copies) if taken]
    assert taken_copies in ([], [0]), copies[:5]
    assert all(t < cycle_s + 0.05 for t, taken in copies if taken)
    # AND nothing of the id is taken while it lasts (after the conflict or the rate shows it: within a few
    # sensor periods): distrusted, the sensor goes stale rather than mixing a replayed and a genuine value
    assert not [t - t0 for t, _, taken in attack if taken and t - t0 > 0.3]
    # AND it is counted: over the rate (dropped undecoded), and the copies that passed, by the counter check
    assert rejected.get("over_rate", 0) > 0.25 * sent, (sent, rejected)
    refused = sum(rejected.get(r, 0) for r in ("over_rate", "repeated_counter", "jumping_counter"))
    assert refused + rejected.get("conflicting_sender", 0) >= len(copies) - 1, (sent, rejected)
    # AND once it stops, the genuine sensor is taken again (after a quiet second and 32 frames in step)
    back = [t - t1 for t, _, taken in after if taken]
    assert back and back[0] < 2.2, (back[:3], rejected)
