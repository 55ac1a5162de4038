"""The rate check of the receiver (issue 12, item 3): frames far above an id's nominal rate are counted as
``over_rate`` and dropped before decoding, the id is distrusted as for a conflicting sender, and a genuine
sender at its nominal rate (jitter, a stall it catches up on, the receiver's drain interval) is never dropped.
The nominal rates are the DBC's ``GenMsgCycleTime``."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hil_sim.model.params import load_params
from onboard.app.config import load_config
from onboard.protocol import messages as m
from onboard.protocol.codec import (
    DBC_PATH,
    RATE_BURST_FRAMES,
    RATE_FACTOR,
    Codec,
    FrameReceiver,
    FrameSender,
)
from onboard.protocol.e2e import QUIET_FRAMES, QUIET_S

CODEC = Codec()
DEPTH_ID = CODEC.frame_id(m.DepthMeas)

#: One message of each type with a nominal rate, as its sender would send it.
SAMPLES: tuple[m.BusMessage, ...] = (
    m.FinCmd(0.1, 0.0, -0.1),
    m.PropCmd(20.0, m.ActuatorMode.ARMED),
    m.Sync(7, 1.5),
    m.FinStatus(0.0, 0.0, 0.0, False, False),
    m.AhrsAttitude(0.0, 0.1, 1.0),
    m.DepthMeas(2.5),
    m.DvlVelocity(1.0, 0.0, 0.0, True),
    m.PositionFix(3.0, 4.0),
    m.SensorsHeartbeat(m.NodeHealth.OK, 12.0),
)


def _cycle(msg: m.BusMessage) -> float:
    cycle_s = CODEC.cycle_time_s(CODEC.frame_id(type(msg)))
    assert cycle_s is not None
    return cycle_s


def test_every_frame_has_its_nominal_cycle_time_in_the_dbc_and_the_senders_keep_it() -> None:
    # GIVEN the DBC WHEN reading each message's GenMsgCycleTime THEN the codec reports it, in s, for each id
    for msg in CODEC.db.messages:
        assert msg.cycle_time and CODEC.cycle_time_s(msg.frame_id) == msg.cycle_time / 1000.0
    assert CODEC.cycle_time_s(0x7FF) is None
    # AND the senders keep it: the onboard's loop (commands, SYNC_ACK; the bench's SYNC and status follow it)
    period_s = load_config().loop.period_s
    for cls in (m.FinCmd, m.PropCmd, m.SyncAck, m.Sync, m.FinStatus, m.PropStatus):
        assert CODEC.cycle_time_s(CODEC.frame_id(cls)) == pytest.approx(period_s)
    # the bench's sensors in every profile, at most at their DBC rate, and the heartbeats each second
    for name, profile in load_params().sensor_profiles.items():
        for cls, rate_hz in (
            (m.AhrsAttitude, profile.ahrs_rate_hz),
            (m.AhrsRates, profile.ahrs_rate_hz),
            (m.DepthMeas, profile.depth_rate_hz),
            (m.DvlVelocity, profile.dvl_rate_hz),
            (m.PositionFix, profile.fix_rate_hz),
        ):
            assert rate_hz * CODEC.cycle_time_s(CODEC.frame_id(cls)) <= 1.0 + 1e-9, (name, cls.DBC_NAME)
    for cls in (m.OnboardHeartbeat, m.ActuatorsHeartbeat, m.SensorsHeartbeat):
        assert CODEC.cycle_time_s(CODEC.frame_id(cls)) == 1.0


def _deliver(
    msg: m.BusMessage,
    period_s: float,
    lateness_s: list[float],
    drain_s: float,
    t0_s: float = 100.0,
    lost: frozenset[int] = frozenset(),
) -> FrameReceiver:
    """Frames of one sender every ``period_s``, each late by ``lateness_s[i]`` (in order: CAN and the hub keep
    a sender's order), taken by a receiver that drains every ``drain_s`` (0: at once)."""
    rx = FrameReceiver(CODEC)
    rx.check_rates(receive_period_s=drain_s)
    sender = FrameSender(CODEC)
    t_prev = -math.inf
    for i, late in enumerate(lateness_s):
        frame = sender.encode(msg)
        t = max(t_prev, t0_s + i * period_s + late)
        t_prev = t
        t_rx = math.ceil(t / drain_s) * drain_s if drain_s else t
        if i not in lost:
            rx.receive(*frame, t_rx)
    return rx


@st.composite
def _lateness(draw: st.DrawFn, n: int, max_late_s: float, period_s: float) -> list[float]:
    """Lateness of n frames up to ``max_late_s``: jitter, and stalls after which the sender sends its
    queue."""
    late = [draw(st.floats(0.0, 1.0)) * max_late_s for _ in range(n)]
    for _ in range(draw(st.integers(0, 3))):  # stalls: the frames due in it go out together at its end
        start = draw(st.integers(0, n - 1))
        length_s = draw(st.floats(0.0, 1.0)) * max_late_s
        end_s = start * period_s + length_s
        for i in range(start, n):
            if i * period_s >= end_s:
                break
            late[i] = max(late[i], end_s - i * period_s)
    return [min(x, max_late_s) for x in late]


@settings(max_examples=300, deadline=None)
@given(data=st.data())
def test_a_genuine_sender_at_its_rate_is_never_dropped(data: st.DataObject) -> None:
    # GIVEN one sender of any cyclic frame, at its DBC cycle or slower, whose frames come late by up to
    # (burst - 1) cycles (jitter; a stall after which it sends what it queued), some of them lost, taken by a
    # receiver that drains at once, every few ms, or once per control period (lock-step: at one tick time)
    msg = data.draw(st.sampled_from(SAMPLES), label="msg")
    cycle_s = _cycle(msg)
    period_s = cycle_s * data.draw(st.floats(1.0, 1.5), label="period / cycle")
    drain_s = data.draw(st.sampled_from([0.0, 0.005, 0.05, 0.1, 0.25]), label="drain_s")
    n = data.draw(st.integers(1, 300), label="n")
    late = data.draw(_lateness(n, (RATE_BURST_FRAMES - 1) * cycle_s, period_s), label="lateness")
    lost = frozenset(data.draw(st.lists(st.integers(0, n - 1), max_size=n // 4), label="lost"))
    rx = _deliver(msg, period_s, late, drain_s, lost=lost)
    # THEN none is dropped for rate, no conflict is claimed, each frame is taken but the first after a loss
    assert rx.rejected["over_rate"] == 0 and rx.rejected["conflicting_sender"] == 0, dict(rx.rejected)
    delivered = n - len(lost)
    assert rx.accepted + rx.rejected["jumping_counter"] == delivered
    assert rx.rejected["jumping_counter"] <= len(lost)


@settings(max_examples=100, deadline=None)
@given(
    msg=st.sampled_from(SAMPLES),
    speed=st.floats(1.0, 2.0),
    control_hz=st.sampled_from([5.0, 10.0, 20.0, 50.0]),
    n=st.integers(1, 400),
)
def test_lock_step_senders_up_to_twice_their_rate_pass(
    msg: m.BusMessage, speed: float, control_hz: float, n: int
) -> None:
    # GIVEN lock-step: a control period's frames arrive at its tick time; before the start the bench offers
    # every sensor in each period (DVL at 20 Hz, twice its cycle's rate)
    tick_s = 1.0 / control_hz
    rx = _deliver(msg, _cycle(msg) / speed, [0.0] * n, tick_s)
    # THEN none is dropped
    assert rx.accepted == n and rx.rejected_total == 0, dict(rx.rejected)


def _replay_attack(rate_hz: float, check_rates: bool, seconds: float = 2.0) -> dict[str, object]:
    """The bench's depth sensor (20 Hz) and one of its frames, captured, sent again at ``rate_hz`` from
    t = 1 s for ``seconds``; a receiver draining every 5 ms. Which values it takes, and when."""
    rx = FrameReceiver(CODEC, frozenset({DEPTH_ID}))
    if check_rates:
        rx.check_rates(receive_period_s=0.005)
    genuine = FrameSender(CODEC)
    cycle_s = _cycle(m.DepthMeas(0.0))
    events: list[tuple[float, str, tuple[int, bytes]]] = []
    for k in range(round(6.0 / cycle_s)):
        events.append((k * cycle_s + 0.0011, "genuine", genuine.encode(m.DepthMeas(1.0 + 0.001 * k))))
    captured = next(frame for t, _, frame in events if t > 0.8)
    n = round(seconds * rate_hz)
    events += [(1.0 + i / rate_hz, "replay", captured) for i in range(n)]
    events.sort(key=lambda e: e[0])
    taken: list[tuple[float, str]] = []
    for t, who, (fid, data) in events:
        t_rx = math.ceil(t / 0.005) * 0.005
        if rx.receive(fid, data, t_rx) is not None:
            taken.append((t, who))
    return {"taken": taken, "rejected": dict(rx.rejected), "replays": n}


def test_a_depth_frame_replayed_at_200_hz_is_taken_at_most_once_then_the_id_is_distrusted() -> None:
    # GIVEN the depth sensor at its 20 Hz and one of its frames replayed at 200 Hz from t = 1 s to 3 s
    out = _replay_attack(200.0, check_rates=True)
    taken, rejected = out["taken"], out["rejected"]
    assert isinstance(taken, list) and isinstance(rejected, dict)
    cycle_s = _cycle(m.DepthMeas(0.0))
    # THEN the replayed frame is taken at most once, within the first sensor period of the attack
    replays = [t for t, who in taken if who == "replay"]
    assert len(replays) <= 1 and all(t < 1.0 + cycle_s for t in replays), replays
    # AND nothing of the id is taken after the first sensor period while the attack lasts: distrusted, the
    # sensor goes stale (the onboard's failsafe), rather than a genuine and a replayed value mixed
    assert not [t for t, _ in taken if 1.0 + cycle_s <= t < 3.0]
    # AND every replayed frame but one is counted: over the rate, or refused by the counter check
    counted = sum(rejected.values())
    assert rejected["over_rate"] > 200 and counted >= int(out["replays"]) - 1, rejected  # type: ignore[call-overload]
    # AND once it stops, the genuine sensor is trusted again after a quiet second and 32 frames in step
    back = min(t for t, who in taken if t >= 3.0)
    assert back < 3.0 + max(QUIET_S, QUIET_FRAMES * cycle_s) + 2 * cycle_s, back


def test_without_the_rate_check_the_replay_is_refused_by_the_counter_check_alone() -> None:
    # the rate check is off by default (a receiver whose clock is not one where the senders keep their rates)
    out = _replay_attack(200.0, check_rates=False)
    rejected = out["rejected"]
    assert isinstance(rejected, dict) and "over_rate" not in rejected
    assert rejected.get("conflicting_sender", 0) > 0


def test_the_rate_check_is_before_decoding_and_skips_event_frames(tmp_path: Path) -> None:
    # GIVEN a flood of DEPTH frames with a wrong CRC at one instant
    rx = FrameReceiver(CODEC)
    rx.check_rates()
    fid, data = FrameSender(CODEC).encode(m.DepthMeas(1.0))
    bad = bytes(data[:7]) + bytes([data[7] ^ 0xFF])
    for _ in range(100):
        rx.receive(fid, bad, 5.0)
    # THEN the burst allowance reaches the CRC check, the rest is dropped undecoded as over the rate
    assert dict(rx.rejected) == {"wrong_crc": RATE_BURST_FRAMES, "over_rate": 100 - RATE_BURST_FRAMES}
    # AND an id without a cycle time (an event frame) is not rate-checked
    text = DBC_PATH.read_text()
    dbc = tmp_path / "event.dbc"
    dbc.write_text(re.sub(rf'BA_ "GenMsgCycleTime" BO_ {DEPTH_ID} \d+;\n', "", text))
    codec = Codec(dbc)
    assert codec.cycle_time_s(DEPTH_ID) is None
    rx = FrameReceiver(codec)
    rx.check_rates()
    sender = FrameSender(codec)
    for _ in range(100):
        assert rx.receive(*sender.encode(m.DepthMeas(1.0)), 5.0) is not None
    assert rx.rejected_total == 0


def test_a_flood_above_the_rate_is_distrusted_until_it_stops() -> None:
    # GIVEN one sender at RATE_FACTOR + 1 times its cycle's rate, alone on the id, for 2 s
    rx = FrameReceiver(CODEC)
    rx.check_rates()
    sender = FrameSender(CODEC)
    cycle_s = _cycle(m.DepthMeas(0.0))
    fast = cycle_s / (RATE_FACTOR + 1.0)
    got = [rx.receive(*sender.encode(m.DepthMeas(1.0)), i * fast) for i in range(round(2.0 / fast))]
    # THEN the frames over the rate are counted and the rest refused: a babbling node is no sensor
    assert rx.rejected["over_rate"] > 0
    first_drop = next(i for i, msg in enumerate(got) if msg is None)
    assert all(msg is None for msg in got[first_drop:])
    # AND back at its cycle it is trusted again once a quiet second and 32 frames in step have passed
    t0 = 2.0
    later = [rx.receive(*sender.encode(m.DepthMeas(1.0)), t0 + k * cycle_s) for k in range(60)]
    k_back = next(k for k, msg in enumerate(later) if msg is not None)
    assert k_back * cycle_s <= max(QUIET_S, QUIET_FRAMES * cycle_s) + 2 * cycle_s
    assert all(msg is not None for msg in later[k_back:])


def test_check_rates_refuses_nonsense() -> None:
    rx = FrameReceiver(CODEC)
    for kwargs in ({"factor": 0.5}, {"burst_frames": 0.0}, {"receive_period_s": -1.0}):
        with pytest.raises(ValueError, match="rate check"):
            rx.check_rates(**kwargs)  # type: ignore[arg-type]
    # the genuine senders reach twice their cycle's rate (lock-step, before the start)
    assert RATE_FACTOR >= 2.0


def test_on_the_bus_time_a_stalled_receiver_drops_nothing_a_fast_sender_is_still_over_rate() -> None:
    # GIVEN a port whose rate check reads the bus's arrival times (real time, as auv-onboard run)
    import can
    from can.interfaces.virtual import VirtualBus

    from onboard.protocol.port import BusPort

    channel = f"bus-time-{id(object())}"
    sender_bus = VirtualBus(channel=channel, preserve_timestamps=True)
    port = BusPort(VirtualBus(channel=channel), lambda: 100.0, [DEPTH_ID], CODEC)
    port.receiver.check_rates(receive_period_s=0.05)
    port.rates_on_bus_time = True
    tx = FrameSender(CODEC)

    def send(n: int, t0: float, period_s: float) -> None:
        for k in range(n):
            frame_id, data = tx.encode(m.DepthMeas(1.0 + 0.01 * k))
            frame = can.Message(
                arbitration_id=frame_id, data=data, is_extended_id=False, timestamp=t0 + k * period_s
            )
            sender_bus.send(frame)

    try:
        # WHEN 3 s of the genuine 20 Hz sensor are read in one go (the receiver stalled; its clock stands)
        send(60, 1000.0, 0.05)
        assert len(port.drain()) == 60 and port.receiver.rejected == {}
        # THEN nothing was dropped; and a sender at 10x the rate is over it, bus time or not
        send(60, 1003.0, 0.005)
        taken = port.drain()
        assert port.receiver.rejected["over_rate"] >= 20 and len(taken) < 20  # the burst, then none
    finally:
        port.close()
        sender_bus.shutdown()
