"""The bus contract: every message round-trips, every frame is classic CAN, every rejection is counted."""

from __future__ import annotations

import dataclasses
import math
import typing
from enum import IntEnum

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from onboard.protocol.codec import (
    FRAME_LENGTH,
    REJECTION_REASONS,
    Codec,
    EncodeError,
    FrameError,
    FrameReceiver,
    FrameSender,
)
from onboard.protocol.e2e import crc8_sae_j1850, frame_crc
from onboard.protocol.messages import (
    ALL_MESSAGE_TYPES,
    ActuatorMode,
    FinCmd,
    PositionFix,
    PropCmd,
    Sync,
)

CODEC = Codec()


def _strategy_for(cls: type) -> st.SearchStrategy:
    """Values over each signal's DBC range, for the dataclass of one message."""
    dbc = CODEC.db.get_message_by_name(cls.DBC_NAME)
    signals = {s.name: s for s in dbc.signals}
    hints = typing.get_type_hints(cls)
    fields = {}
    for f in dataclasses.fields(cls):
        if f.name == "t_sample_s":
            continue
        sig = signals[f.name]
        ann = hints[f.name]
        if ann is bool:
            fields[f.name] = st.booleans()
        elif isinstance(ann, type) and issubclass(ann, IntEnum):
            fields[f.name] = st.sampled_from(list(ann))
        elif ann is int:
            fields[f.name] = st.integers(int(sig.minimum), int(sig.maximum))
        else:
            fields[f.name] = st.floats(float(sig.minimum), float(sig.maximum), allow_nan=False)
    return st.builds(cls, **fields)


def test_dbc_names_and_ids_follow_the_contract() -> None:
    # GIVEN the DBC WHEN listing its messages THEN commands end in _CMD and have the lowest ids,
    # every frame is classic CAN (<= 8 bytes) and carries an E2E counter and CRC.
    msgs = CODEC.db.messages
    cmd_ids = [m.frame_id for m in msgs if m.name.endswith("_CMD")]
    other_ids = [m.frame_id for m in msgs if not m.name.endswith("_CMD")]
    assert cmd_ids and max(cmd_ids) < min(other_ids)
    for m in msgs:
        assert m.length <= 8 and not m.is_extended_frame and not m.is_fd
        names = [s.name for s in m.signals]
        assert any("counter" in n for n in names) and any("crc" in n for n in names)


@pytest.mark.parametrize("cls", ALL_MESSAGE_TYPES, ids=lambda c: c.DBC_NAME)
def test_round_trip_every_message(cls: type) -> None:
    @settings(max_examples=60, deadline=None)
    @given(msg=_strategy_for(cls), counter=st.integers(0, 15))
    def check(msg: typing.Any, counter: int) -> None:
        frame_id, data = CODEC.encode(msg, counter)
        assert len(data) == FRAME_LENGTH
        back, got_counter = CODEC.decode_with_counter(frame_id, data, 1.5)
        assert got_counter == counter and back.t_sample_s == 1.5
        dbc = CODEC.db.get_message_by_name(cls.DBC_NAME)
        for sig in dbc.signals:
            if sig.name.startswith("e2e_"):
                continue
            want, got = getattr(msg, sig.name), getattr(back, sig.name)
            assert type(got) is type(want) or isinstance(want, float)
            assert math.isclose(float(got), float(want), abs_tol=sig.scale / 2 + 1e-12)

    check()


@pytest.mark.parametrize(
    "msg",
    [
        FinCmd(float("nan"), 0.0, 0.0),
        FinCmd(0.0, float("inf"), 0.0),
        FinCmd(0.6, 0.0, 0.0),
        FinCmd(0.0, 0.0, -0.6),
        PropCmd(41.0, ActuatorMode.ARMED),
        PositionFix(9000.0, 0.0),
        Sync(-1, 0.0),
    ],
)
def test_encoding_nan_or_out_of_range_raises_a_clear_error(msg: typing.Any) -> None:
    with pytest.raises(EncodeError, match=r"not finite|outside the DBC range"):
        CODEC.encode(msg, 0)


def test_crc_is_the_sae_j1850_check_value_and_covers_the_id() -> None:
    assert crc8_sae_j1850(b"123456789") == 0x4B
    payload = bytes(range(7)) + b"\x00"
    assert frame_crc(0x10, payload) != frame_crc(0x11, payload)


def _frames(n: int, msg: typing.Any = None) -> list[tuple[int, bytes]]:
    sender = FrameSender(CODEC)
    msg = msg or FinCmd(0.1, 0.0, -0.1)
    return [sender.encode(msg) for _ in range(n)]


def test_receiver_accepts_a_clean_stream_across_the_counter_wrap() -> None:
    rx = FrameReceiver(CODEC)
    for fid, data in _frames(40):
        assert rx.receive(fid, data, 0.0) is not None
    assert rx.accepted == 40 and rx.rejected_total == 0


def _reject(reason: str) -> FrameReceiver:
    rx = FrameReceiver(CODEC)
    if reason == "over_rate":
        rx.check_rates(burst_frames=1.0)  # one frame at a time: a second one at the same instant is over
    frames = _frames(4)
    fid, data = frames[0]
    assert rx.receive(fid, data, 0.0) is not None
    if reason == "unknown_id":
        rx.receive(0x7FF, data, 0.0)
    elif reason == "wrong_length":
        rx.receive(fid, data[:7], 0.0)
    elif reason == "wrong_crc":
        bad = bytearray(frames[1][1])
        bad[0] ^= 0x01
        rx.receive(fid, bytes(bad), 0.0)
    elif reason == "repeated_counter":
        rx.receive(fid, data, 0.0)
    elif reason == "jumping_counter":
        rx.receive(*frames[3], 0.0)
    elif reason == "out_of_range":
        # A raw int16 of 0x7FFF is 3.2767 rad: inside the bit field, outside the DBC range; valid CRC.
        bad = bytearray(frames[1][1])
        bad[0:2] = (0x7FFF).to_bytes(2, "little", signed=True)
        bad[7] = frame_crc(fid, bad)
        rx.receive(fid, bytes(bad), 0.0)
    elif reason == "non_finite":
        rx.codec = _NanCodec()
        rx.receive(*frames[1], 0.0)
    elif reason == "over_rate":
        rx.receive(*frames[1], 0.0)
    return rx


class _NanCodec(Codec):
    """A codec whose DBC decode yields NaN, to exercise the non-finite check (ints cannot be NaN)."""

    def __init__(self) -> None:
        super().__init__()
        spec = self._by_id[0x10]
        real = spec.dbc

        class _Dbc:
            def decode(self, data: bytes, **kw: typing.Any) -> dict[str, typing.Any]:
                out = dict(real.decode(data, **kw))
                out["rudder_rad"] = float("nan")
                return out

        object.__setattr__(spec, "dbc", _Dbc())
        object.__setattr__(spec, "compiled", None)  # the general path, where a float signal could be NaN


@pytest.mark.parametrize("reason", [r for r in REJECTION_REASONS if r != "conflicting_sender"])
def test_each_rejection_reason_is_counted_separately(reason: str) -> None:
    rx = _reject(reason)
    assert dict(rx.rejected) == {reason: 1}
    assert rx.accepted == 1


def test_after_a_jump_the_receiver_resynchronises() -> None:
    rx = FrameReceiver(CODEC)
    frames = _frames(6)
    rx.receive(*frames[0], 0.0)
    assert rx.receive(*frames[2], 0.0) is None  # frame 1 lost: jump rejected
    assert rx.receive(*frames[3], 0.0) is not None  # back in step
    assert rx.rejected["jumping_counter"] == 1


def test_listen_ids_ignore_other_frames_without_counting() -> None:
    fin_id = CODEC.frame_id(FinCmd)
    rx = FrameReceiver(CODEC, accept_ids=frozenset({fin_id + 1}))
    assert rx.receive(*_frames(1)[0], 0.0) is None
    assert rx.rejected_total == 0 and rx.accepted == 0


class _GeneralCodec(Codec):
    """The codec without its compiled messages: cantools' general path for every frame (the reference)."""

    def __init__(self) -> None:
        super().__init__()
        for spec in self._by_id.values():
            object.__setattr__(spec, "compiled", None)


GENERAL = _GeneralCodec()


def _outcome(call: typing.Callable[[], typing.Any]) -> typing.Any:
    """What ``call`` returns, or the class, reason and text of the protocol error it raises."""
    try:
        return call()
    except (EncodeError, FrameError) as exc:
        return type(exc).__name__, getattr(exc, "reason", ""), str(exc)


def test_every_message_of_the_dbc_is_compiled() -> None:
    # GIVEN the DBC THEN every message takes the compiled path (none falls back to cantools per call)
    assert all(CODEC._by_cls[cls].compiled is not None for cls in ALL_MESSAGE_TYPES)
    assert len(ALL_MESSAGE_TYPES) == len(CODEC.db.messages)


@pytest.mark.parametrize("cls", ALL_MESSAGE_TYPES, ids=lambda c: c.DBC_NAME)
def test_compiled_encoder_and_decoder_give_exactly_the_bytes_and_values_of_cantools(cls: type) -> None:
    # GIVEN values across each signal's DBC range WHEN the compiled codec encodes and decodes them
    # THEN the bytes are cantools' (Message.encode, the CRC byte the E2E CRC of cantools' bytes) and the
    # numbers back are cantools' (Message.decode), to the bit
    dbc = CODEC.db.get_message_by_name(cls.DBC_NAME)

    @settings(max_examples=80, deadline=None)
    @given(msg=_strategy_for(cls), counter=st.integers(0, 15))
    def check(msg: typing.Any, counter: int) -> None:
        frame_id, data = CODEC.encode(msg, counter)
        values = {s.name: getattr(msg, s.name) for s in dbc.signals if not s.name.startswith("e2e_")}
        values = {k: (int(v) if isinstance(v, bool | int) else float(v)) for k, v in values.items()}
        reference = bytearray(dbc.encode({**values, "e2e_counter": counter, "e2e_crc": 0}, strict=False))
        reference[7] = frame_crc(frame_id, reference)
        assert data == bytes(reference)
        back, got_counter = CODEC.decode_with_counter(frame_id, data, 2.5)
        want = dbc.decode(data, decode_choices=False)
        assert got_counter == want["e2e_counter"] == counter and back.t_sample_s == 2.5
        for name, value in want.items():
            if not name.startswith("e2e_"):
                got = getattr(back, name)
                assert got == value and (type(got) is float) == isinstance(value, float), name

    check()


@pytest.mark.parametrize("cls", ALL_MESSAGE_TYPES, ids=lambda c: c.DBC_NAME)
def test_compiled_decoder_takes_and_refuses_any_payload_as_cantools_does(cls: type) -> None:
    # GIVEN any 7 payload bytes with a valid CRC (values inside and outside the DBC ranges, invalid enum
    # values) and some with a wrong one THEN the compiled decoder gives the general path's message or error
    frame_id = CODEC.frame_id(cls)

    @settings(max_examples=150, deadline=None)
    @given(payload=st.binary(min_size=7, max_size=7), corrupt=st.integers(0, 255))
    def check(payload: bytes, corrupt: int) -> None:
        data = payload + bytes((frame_crc(frame_id, payload + b"\x00") ^ (corrupt if corrupt < 8 else 0),))
        compiled = _outcome(lambda: CODEC.decode_with_counter(frame_id, data, 0.5))
        assert compiled == _outcome(lambda: GENERAL.decode_with_counter(frame_id, data, 0.5))

    check()


_ANY_NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**40), 2**40),
    st.booleans(),
    st.just("3"),
    st.none(),
)


@pytest.mark.parametrize("cls", ALL_MESSAGE_TYPES, ids=lambda c: c.DBC_NAME)
def test_compiled_encoder_takes_and_refuses_any_value_as_the_checked_path_does(cls: type) -> None:
    # GIVEN any value in any field (NaN, infinities, out of range, wrong types) THEN the compiled encoder
    # gives the general path's frame, or its EncodeError with the same reason
    names = [f.name for f in dataclasses.fields(cls) if f.name != "t_sample_s"]

    @settings(max_examples=150, deadline=None)
    @given(msg=_strategy_for(cls), field=st.sampled_from(names), value=_ANY_NUMBER)
    def check(msg: typing.Any, field: str, value: typing.Any) -> None:
        odd = dataclasses.replace(msg, **{field: value})
        compiled = _outcome(lambda: CODEC.encode(odd, 3))
        assert compiled == _outcome(lambda: GENERAL.encode(odd, 3))

    check()


def test_an_encode_failure_does_not_use_up_an_alive_counter_value() -> None:
    # GIVEN a stream of good frames WHEN one message fails to encode in the middle THEN the next good frame
    # carries the next counter: the receiver accepts every frame, with no "jumping_counter" rejection.
    sender = FrameSender(CODEC)
    rx = FrameReceiver(CODEC)
    fid = CODEC.frame_id(FinCmd)
    for _ in range(3):
        assert rx.receive(*sender.encode(FinCmd(0.1, 0.0, 0.0)), 0.0) is not None
    before = sender.counters.peek(fid)
    with pytest.raises(EncodeError) as err:
        sender.encode(FinCmd(math.radians(45.0), 0.0, 0.0))
    assert (err.value.message_name, err.value.signal) == ("FIN_CMD", "rudder_rad")
    assert sender.counters.peek(fid) == before
    for _ in range(20):  # across the wrap too
        assert rx.receive(*sender.encode(FinCmd(0.1, 0.0, 0.0)), 0.0) is not None
    assert rx.rejected_total == 0 and rx.accepted == 23


def test_an_uncommitted_frame_keeps_its_counter_for_the_next_one() -> None:
    # a frame the bus refused (encode(commit=False) without commit) is encoded again with the same counter
    sender = FrameSender(CODEC)
    fid, first = sender.encode(FinCmd(0.1, 0.0, 0.0), commit=False)
    again = sender.encode(FinCmd(0.1, 0.0, 0.0), commit=False)
    assert again == (fid, first)
    sender.commit(fid)
    assert sender.counters.peek(fid) == 1


def test_a_second_sender_on_one_id_is_a_conflict_and_the_id_is_distrusted_until_one_stream_is_alone() -> None:
    # GIVEN the genuine sender and an impostor with its own counter (valid CRC) on FIN_CMD, interleaved
    genuine, impostor = FrameSender(CODEC), FrameSender(CODEC)
    for _ in range(7):
        impostor.encode(FinCmd(0.3, 0.0, 0.0))  # its counter runs 7 ahead
    rx = FrameReceiver(CODEC)
    got = [rx.receive(*genuine.encode(FinCmd(0.1, 0.0, 0.0)), 0.0)]
    for _ in range(20):
        got.append(rx.receive(*impostor.encode(FinCmd(0.3, 0.0, 0.0)), 0.0))
        got.append(rx.receive(*genuine.encode(FinCmd(0.1, 0.0, 0.0)), 0.0))
    # THEN after the first jump every frame is refused as a conflicting sender: neither stream gets through
    assert got[0] is not None and all(m is None for m in got[1:])
    assert rx.rejected["jumping_counter"] == 1 and rx.rejected["conflicting_sender"] == 39
    # WHEN the impostor goes quiet THEN 32 frames in step are not enough within a second of the last conflict
    # (a fast impostor sends that many between two frames of a slow sensor)
    soon = [rx.receive(*genuine.encode(FinCmd(0.1, 0.0, 0.0)), 0.5) for _ in range(40)]
    assert all(m is None for m in soon)
    # and once a second passed without a conflict the genuine stream is trusted again
    later = [rx.receive(*genuine.encode(FinCmd(0.1, 0.0, 0.0)), 1.5) for _ in range(3)]
    assert all(m is not None for m in later)


# Two single losses 15 frames apart bring the counter round to the one the first jump left behind; so does a
# loss of 8 frames right after one of 7 (before: both claimed a conflict; the id was distrusted for a second).
_FIFTEEN_APART = [i in (5, 20) for i in range(40)]
_TWO_BURSTS = [5 <= i < 13 or 14 <= i < 21 for i in range(40)]


@settings(max_examples=300, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=200))
@example(_FIFTEEN_APART)
@example(_TWO_BURSTS)
def test_lost_frames_alone_are_never_a_conflict(lost: list[bool]) -> None:
    # GIVEN one sender at its DBC cycle whose frames are lost at random (never reordered: CAN keeps the order)
    sender, rx = FrameSender(CODEC), FrameReceiver(CODEC)
    cycle_s = CODEC.cycle_time_s(CODEC.frame_id(FinCmd))
    assert cycle_s is not None
    for i, drop in enumerate(lost):
        frame = sender.encode(FinCmd(0.1, 0.0, 0.0))
        if not drop:
            rx.receive(*frame, i * cycle_s)
    # THEN a loss costs at most the next frame, as before, and no conflict is ever claimed
    assert rx.rejected["conflicting_sender"] == 0
