"""Pure encode/decode between the typed messages and (arbitration id, 8 data bytes), on cantools.

The DBC file ``isimi100.dbc`` beside this module is the single source of truth for every frame.

- :meth:`Codec.encode` raises :class:`EncodeError` for a non-finite or out-of-range value (cantools strict
  mode; saturation is the controller's job, the codec never clamps).
- :meth:`Codec.decode` raises :class:`FrameError` with a ``reason`` for a frame it cannot accept.
- :class:`FrameReceiver` adds the stateful checks (alive counter per id; once
  :meth:`FrameReceiver.check_rates` is called, a rate limit per id from the DBC's nominal cycle times) and
  counts every rejection by reason.
- :meth:`Codec.cycle_time_s`: an id's nominal cycle time, the DBC's ``GenMsgCycleTime`` (its one owner).

Each message is compiled once, when the codec loads the DBC (:class:`CompiledMessage`: shifts, masks,
scales, ranges and the CRC start per id), so a frame costs one pass over a tuple; the bytes are cantools'
to the bit (the tests compare every message with ``Message.encode`` / ``Message.decode``). A message the
compiled form does not cover (float or big-endian signals, multiplexing) takes cantools' general path.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections import Counter
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path
from typing import Any, Final

import cantools
import cantools.database
from cantools.database.conversion import BaseConversion, IdentityConversion, LinearConversion

from auv_common.token_bucket import TokenBucket
from onboard.protocol.e2e import (
    CRC_BYTE_INDEX,
    CRC_TABLE,
    CounterCheck,
    TxCounters,
    data_id_crc_state,
    frame_crc,
)
from onboard.protocol.messages import ALL_MESSAGE_TYPES, BusMessage, Sync

DBC_PATH: Final = Path(__file__).with_name("isimi100.dbc")
FRAME_LENGTH: Final = 8
E2E_SIGNALS: Final = ("e2e_counter", "e2e_crc")

REJECTION_REASONS: Final = (
    "unknown_id",
    "wrong_length",
    "wrong_crc",
    "repeated_counter",
    "jumping_counter",
    "conflicting_sender",
    "non_finite",
    "out_of_range",
    "over_rate",
)

#: The rate check (:meth:`FrameReceiver.check_rates`), a token bucket per id: an id may deliver RATE_FACTOR
#: times the rate of its DBC cycle time, with bursts of RATE_BURST_FRAMES frames on top of what the receiver's
#: own drain interval P bunches together (burst B + P / T for a cycle T).
#:
#: Why it never drops a genuine sender: a sender of period T whose frames reach the receiver late by at most
#: J (its own jitter, a stall it catches up on by sending its queue, the hub, the receiver's drain interval,
#: a stall of the receiver's process) delivers at most 1 + (L + J) / T frames in any L seconds of receive
#: time; the bucket passes B + P / T + L * K / T. With K >= 1 every such sender passes while
#: J <= (B - 1) T + P: with B = 8, 350 ms late plus the drain interval for the 20 Hz frames, 7 s for the
#: heartbeats (tests/unit/protocol/test_rate_limit.py: hypothesis over jitter, stalls, losses and drain
#: intervals). K = 4: the genuine senders reach 2x their cycle's rate at most (lock-step before the start
#: offers every sensor each control period: the DVL at 20 Hz for its 10 Hz), so a second sender shows once
#: the id carries 4x its rate. J <= 9 T keeps the conflict check's left-stream window sound
#: (:data:`onboard.protocol.e2e.LEFT_STREAM_CYCLES`): B - 1 + P / T <= 9, so B = 8 with P up to one cycle.
RATE_FACTOR: Final = 4.0
RATE_BURST_FRAMES: Final = 8.0


class ProtocolError(Exception):
    """Base class of the bus-contract errors."""


class EncodeError(ProtocolError, ValueError):
    """A message that cannot be put on the bus (NaN, out of the DBC range, wrong type).

    ``message_name`` is the DBC name of the message ("" if it is not a bus message), ``signal`` the
    offending signal ("" if not one in particular).
    """

    def __init__(self, message: str, message_name: str = "", signal: str = "") -> None:
        super().__init__(message)
        self.message_name = message_name
        self.signal = signal


class FrameError(ProtocolError):
    """A received frame that is rejected; ``reason`` is one of :data:`REJECTION_REASONS`."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True)
class _Spec:
    """Pre-computed facts of one message type."""

    cls: type[BusMessage]
    dbc: Any  # cantools Message
    frame_id: int
    fields: tuple[str, ...]  # dataclass fields that are DBC signals (no t_sample_s)
    converters: tuple[Any, ...]  # per field: the callable that turns a decoded number into the field type
    ranges: tuple[tuple[float, float], ...]
    cycle_s: float | None  # the DBC's GenMsgCycleTime in s; None: an event frame (no nominal rate)
    #: the message compiled to its bit layout (None: cantools' general path encodes and decodes it)
    compiled: CompiledMessage | None = None


class _Refused(Exception):
    """Raised inside a compiled encoder for a value it does not take: :meth:`Codec.encode` then finds out
    why, once, on its checking path (which raises the :class:`EncodeError` with the reason)."""


class CompiledMessage:
    """One DBC message compiled, once, into the arithmetic of its frame: per signal its attribute, the
    accepted range, cantools' scale and offset, bit shift, mask and sign bit; the alive counter's shift; the
    CRC register after the data id. :meth:`encode` and :meth:`decode` then do a frame in one pass over a
    tuple (no dict per call, no bitstruct): the raw value of a signal is cantools' own arithmetic,
    ``round((value - offset) / scale)`` out and ``raw * scale + offset`` back with the same scale and offset
    objects, so the bytes and numbers are exactly those of ``Message.encode`` / ``Message.decode``
    (tests/unit/protocol/test_codec.py checks every message against cantools).

    Built by :meth:`compile` for an ordinary frame: little-endian integer signals (identity or linear
    conversions, value tables only as names for numbers), 8 bytes, the E2E counter and the CRC in byte 7,
    no multiplexing. Anything else stays on cantools' general path.
    """

    __slots__ = ("cls", "counter_shift", "crc_state", "decode_fields", "encode_fields", "t_index")

    def __init__(
        self,
        cls: type[BusMessage],
        encode_fields: tuple[tuple[str, float, float, Any, Any, int, int, int, int], ...],
        decode_fields: tuple[tuple[int, int, int, Any, Any, float, float, Any], ...],
        counter_shift: int,
        crc_state: int,
        t_index: int,
    ) -> None:
        self.cls = cls
        # (attribute, lo, hi, offset, scale, shift, mask, raw lo, raw hi), in signal order
        self.encode_fields = encode_fields
        # (shift, mask, sign bit or 0, offset, scale, lo, hi, converter), in dataclass field order
        self.decode_fields = decode_fields
        self.counter_shift = counter_shift
        self.crc_state = crc_state  # data_id_crc_state(frame_id)
        self.t_index = t_index  # where t_sample_s goes among the constructor's positional arguments

    @classmethod
    def compile(cls, spec: _Spec) -> CompiledMessage | None:
        """The compiled form of ``spec``'s message, or None when it needs cantools' general path."""
        dbc_msg = spec.dbc
        if dbc_msg.is_container or dbc_msg.is_multiplexed() or dbc_msg.length != FRAME_LENGTH:
            return None
        signals = {sig.name: sig for sig in dbc_msg.signals}
        if set(signals) != {*spec.fields, *E2E_SIGNALS}:
            return None
        counter, crc = signals["e2e_counter"], signals["e2e_crc"]
        if (crc.start, crc.length, counter.length) != (8 * CRC_BYTE_INDEX, 8, 4):
            return None
        for sig in signals.values():
            numeric = _numeric_conversion(sig.conversion)
            if sig.byte_order != "little_endian" or sig.multiplexer_ids or numeric is None:
                return None
            if sig is not crc and sig.start + sig.length > 8 * CRC_BYTE_INDEX:
                return None  # a signal in the CRC byte
            if sig.length > 52:
                return None  # its raw values would not all be exact as floats
        names = [f.name for f in dataclasses.fields(spec.cls)]
        encode_fields, decode_fields = {}, {}
        for name, (lo, hi), conv in zip(spec.fields, spec.ranges, spec.converters, strict=True):
            sig = signals[name]
            offset, scale = _numeric_conversion(sig.conversion)  # type: ignore[misc]
            mask = (1 << sig.length) - 1
            sign = 1 << (sig.length - 1) if sig.is_signed else 0
            raw_lo, raw_hi = (-sign, sign - 1) if sign else (0, mask)
            encode_fields[name] = (name, lo, hi, offset, scale, sig.start, mask, raw_lo, raw_hi)
            decode_fields[name] = (sig.start, mask, sign, offset, scale, lo, hi, conv)
        return cls(
            spec.cls,
            tuple(encode_fields[sig.name] for sig in dbc_msg.signals if sig.name in encode_fields),
            tuple(decode_fields[name] for name in names if name != "t_sample_s"),
            counter.start,
            data_id_crc_state(spec.frame_id),
            names.index("t_sample_s"),
        )

    def encode(self, msg: Any, counter: int) -> bytes:
        """The 8 bytes of ``msg`` with alive counter ``counter`` and its CRC. Raises :class:`_Refused` for
        a value that is not a number, not finite, outside its range or its bits."""
        packed = (counter & 0xF) << self.counter_shift
        for attr, lo, hi, offset, scale, shift, mask, raw_lo, raw_hi in self.encode_fields:
            number = float(getattr(msg, attr))  # a TypeError / ValueError: not a number
            if not lo <= number <= hi:  # NaN fails here too
                raise _Refused(attr)
            raw = round((number - offset) / scale)
            if not raw_lo <= raw <= raw_hi:
                raise _Refused(attr)
            packed |= (raw & mask) << shift
        crc = self.crc_state
        for byte in packed.to_bytes(CRC_BYTE_INDEX, "little"):
            crc = CRC_TABLE[crc ^ byte]
        return (packed | (crc ^ 0xFF) << (8 * CRC_BYTE_INDEX)).to_bytes(FRAME_LENGTH, "little")

    def decode(self, data: bytes | bytearray, t_rx_s: float) -> tuple[BusMessage, int]:
        """The message of an 8-byte frame and its alive counter; raises :class:`FrameError` (``wrong_crc``,
        ``out_of_range``). Its numbers are finite by construction (integer raw values, finite scales)."""
        crc = self.crc_state
        for byte in data[:CRC_BYTE_INDEX]:
            crc = CRC_TABLE[crc ^ byte]
        if crc ^ 0xFF != data[CRC_BYTE_INDEX]:
            raise FrameError("wrong_crc", f"{self.cls.DBC_NAME}: CRC mismatch")
        packed = int.from_bytes(data, "little")
        args: list[Any] = []
        for shift, mask, sign, offset, scale, lo, hi, conv in self.decode_fields:
            raw = (packed >> shift) & mask
            if raw & sign:
                raw -= mask + 1
            value = raw * scale + offset
            if not lo <= value <= hi:
                raise self._out_of_range(len(args), value, "outside")
            try:
                args.append(conv(value))
            except ValueError:
                raise self._out_of_range(len(args), value, "not a valid value") from None
        args.insert(self.t_index, t_rx_s)
        return self.cls(*args), (packed >> self.counter_shift) & 0xF

    def _out_of_range(self, index: int, value: float, what: str) -> FrameError:
        name = [f.name for f in dataclasses.fields(self.cls) if f.name != "t_sample_s"][index]
        lo, hi = self.decode_fields[index][5:7]
        where = f"outside [{lo}, {hi}]" if what == "outside" else what
        return FrameError("out_of_range", f"{self.cls.DBC_NAME}.{name} = {float(value)} {where}")


def _numeric_conversion(conversion: Any) -> tuple[Any, Any] | None:
    """(offset, scale) of a conversion the compiled path reproduces exactly: identity (0, 1) or linear,
    integer raw values; a value table names numbers only (decoded without choices). None for others."""
    if conversion.is_float:
        return None
    if conversion.choices is not None:
        conversion = BaseConversion.factory(scale=conversion.scale, offset=conversion.offset)
    if isinstance(conversion, IdentityConversion):
        return 0, 1
    if isinstance(conversion, LinearConversion):
        return conversion.offset, conversion.scale
    return None  # e.g. LinearIntegerConversion: its divmod rounding is cantools' own


def _converter(annotation: Any) -> Any:
    if annotation is bool:
        return bool
    if annotation is int:
        return int
    if isinstance(annotation, type) and issubclass(annotation, IntEnum):
        return annotation
    return float


class Codec:
    """Encoder/decoder for the ISiMI100 DBC. Pure: no state except the loaded database."""

    def __init__(self, dbc_path: str | Path = DBC_PATH) -> None:
        db = cantools.database.load_file(str(dbc_path), strict=True)
        if not isinstance(db, cantools.database.can.Database):
            raise ProtocolError(f"{dbc_path} is not a CAN database")
        self.db = db
        self._by_cls: dict[type[BusMessage], _Spec] = {}
        self._by_id: dict[int, _Spec] = {}
        for cls in ALL_MESSAGE_TYPES:
            dbc_msg = self.db.get_message_by_name(cls.DBC_NAME)
            hints = typing.get_type_hints(cls)
            names = tuple(f.name for f in dataclasses.fields(cls) if f.name != "t_sample_s")
            signals = {s.name: s for s in dbc_msg.signals}
            missing = set(names) ^ (set(signals) - set(E2E_SIGNALS))
            if missing:
                raise ProtocolError(f"{cls.__name__} and DBC {cls.DBC_NAME} disagree on {sorted(missing)}")
            spec = _Spec(
                cls=cls,
                dbc=dbc_msg,
                frame_id=dbc_msg.frame_id,
                fields=names,
                converters=tuple(_converter(hints[n]) for n in names),
                # Decoded values carry float error from the scale: allow a thousandth of a step.
                ranges=tuple(
                    (
                        float(signals[n].minimum or 0.0) - 1e-3 * float(signals[n].scale),
                        float(signals[n].maximum or 0.0) + 1e-3 * float(signals[n].scale),
                    )
                    for n in names
                ),
                cycle_s=dbc_msg.cycle_time / 1000.0 if dbc_msg.cycle_time else None,
            )
            spec = dataclasses.replace(spec, compiled=CompiledMessage.compile(spec))
            self._by_cls[cls] = spec
            self._by_id[spec.frame_id] = spec

    def frame_id(self, cls: type[BusMessage]) -> int:
        """The CAN arbitration id of a message type."""
        return self._by_cls[cls].frame_id

    @property
    def frame_ids(self) -> tuple[int, ...]:
        return tuple(sorted(self._by_id))

    def cycle_time_s(self, frame_id: int) -> float | None:
        """The nominal cycle time of an id (s), the DBC's ``GenMsgCycleTime``: the period its genuine sender
        keeps (the control period for commands, SYNC and status, the fastest sensor profile's period for
        the sensors, 1 s for the heartbeats). None for an event frame or an unknown id."""
        spec = self._by_id.get(frame_id)
        return spec.cycle_s if spec is not None else None

    @property
    def control_cycle_s(self) -> float:
        """The bus contract's control period (SYNC's cycle time; commands and status follow it)."""
        return self.cycle_time_s(self.frame_id(Sync)) or 0.0

    def rates_checkable(self, loop_period_s: float) -> bool:
        """Whether a receiver in a loop of ``loop_period_s`` may check rates: not in one faster than the
        contract's control period (the frames that follow the loop would then exceed their cycles)."""
        return loop_period_s >= self.control_cycle_s - 1e-9

    def encode(self, msg: BusMessage, counter: int) -> tuple[int, bytes]:
        """Encode ``msg`` with alive counter ``counter`` (0..15); returns (arbitration_id, 8 bytes).

        Raises :class:`EncodeError` for a non-finite or out-of-range field.
        """
        spec = self._by_cls.get(type(msg))
        if spec is None:
            raise EncodeError(f"not a bus message: {msg!r}")
        compiled = spec.compiled
        if compiled is not None:
            try:
                return spec.frame_id, compiled.encode(msg, counter)
            except (_Refused, TypeError, ValueError, OverflowError):
                pass  # the checks below say why
        values = self._checked_values(spec, msg)
        values["e2e_counter"] = counter & 0xF
        values["e2e_crc"] = 0
        dbc_name = spec.cls.DBC_NAME
        try:
            data = bytearray(spec.dbc.encode(values, scaling=True, strict=False))
        except (cantools.database.EncodeError, ValueError, OverflowError) as exc:
            raise EncodeError(f"{dbc_name}: {exc}", dbc_name) from None
        data[CRC_BYTE_INDEX] = frame_crc(spec.frame_id, bytes(data))
        return spec.frame_id, bytes(data)

    @staticmethod
    def _checked_values(spec: _Spec, msg: BusMessage) -> dict[str, float | int]:
        """The DBC values of ``msg`` for cantools; raises :class:`EncodeError` with the reason for a value
        that is not a number, not finite or outside the DBC range (cantools' strict checks, with clearer
        messages)."""
        dbc_name = spec.cls.DBC_NAME
        values: dict[str, float | int] = {}
        for name, (lo, hi) in zip(spec.fields, spec.ranges, strict=True):
            value = getattr(msg, name)
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise EncodeError(f"{dbc_name}.{name} is not a number ({value!r})", dbc_name, name) from None
            if not math.isfinite(number):
                raise EncodeError(
                    f"{dbc_name}.{name} is not finite ({value!r}); refusing to encode", dbc_name, name
                )
            if not lo <= number <= hi:
                raise EncodeError(
                    f"{dbc_name}.{name} = {number!r} is outside the DBC range [{lo}, {hi}]; "
                    "saturate before encoding",
                    dbc_name,
                    name,
                )
            values[name] = int(value) if isinstance(value, bool | int) else number
        return values

    def decode(self, frame_id: int, data: bytes | bytearray, t_rx_s: float) -> BusMessage:
        """Decode one frame (stateless checks: id, length, CRC, finiteness, DBC range).

        ``t_rx_s`` becomes the message's ``t_sample_s``. Raises :class:`FrameError`.
        """
        msg, _counter = self.decode_with_counter(frame_id, data, t_rx_s)
        return msg

    def decode_with_counter(
        self, frame_id: int, data: bytes | bytearray, t_rx_s: float
    ) -> tuple[BusMessage, int]:
        """Like :meth:`decode`, and also return the frame's alive counter."""
        spec = self._by_id.get(frame_id)
        if spec is None:
            raise FrameError("unknown_id", f"unknown arbitration id 0x{frame_id:03X}")
        if len(data) != FRAME_LENGTH:
            raise FrameError(
                "wrong_length", f"{spec.cls.DBC_NAME}: {len(data)} bytes, expected {FRAME_LENGTH}"
            )
        if spec.compiled is not None:
            return spec.compiled.decode(data, t_rx_s)
        if frame_crc(frame_id, data) != data[CRC_BYTE_INDEX]:
            raise FrameError("wrong_crc", f"{spec.cls.DBC_NAME}: CRC mismatch")
        raw = spec.dbc.decode(bytes(data), decode_choices=False, scaling=True)
        kwargs: dict[str, Any] = {}
        for name, conv, (lo, hi) in zip(spec.fields, spec.converters, spec.ranges, strict=True):
            number = float(raw[name])
            if not math.isfinite(number):
                raise FrameError("non_finite", f"{spec.cls.DBC_NAME}.{name} is not finite")
            if not lo <= number <= hi:
                raise FrameError(
                    "out_of_range", f"{spec.cls.DBC_NAME}.{name} = {number} outside [{lo}, {hi}]"
                )
            try:
                kwargs[name] = conv(raw[name]) if conv is not float else number
            except ValueError:
                raise FrameError(
                    "out_of_range", f"{spec.cls.DBC_NAME}.{name} = {number} not a valid value"
                ) from None
        return spec.cls(**kwargs, t_sample_s=t_rx_s), int(raw["e2e_counter"])


@dataclass
class FrameSender:
    """Stateful encoder: adds the next alive counter for each id.

    A counter value is used up only by a frame that was produced: a message that fails to encode raises
    :class:`EncodeError` and leaves the counter where it was, so the next good frame continues the sequence
    and the receiver sees no jump. A sender that can still fail after encoding (a bus write) calls
    :meth:`encode` with ``commit=False`` and :meth:`commit` once the frame is really out.
    """

    codec: Codec
    counters: TxCounters = field(default_factory=TxCounters)

    def encode(self, msg: BusMessage, commit: bool = True) -> tuple[int, bytes]:
        """(arbitration id, 8 bytes) of ``msg`` with its id's next alive counter; raises EncodeError."""
        spec = self.codec._by_cls.get(type(msg))
        if spec is None:
            raise EncodeError(f"not a bus message: {msg!r}")
        frame_id = spec.frame_id
        frame = self.codec.encode(msg, self.counters.peek(frame_id))
        if commit:
            self.counters.advance(frame_id)
        return frame

    def commit(self, frame_id: int) -> None:
        """Use up the counter value of the frame last encoded with ``commit=False`` for ``frame_id``."""
        self.counters.advance(frame_id)


@dataclass
class FrameReceiver:
    """Stateful receiver: (rate check), decode, check the alive counter per id, count rejections by reason.

    ``accept_ids`` limits which ids this node listens to (others are ignored, not counted as errors);
    ``max_counter_delta`` is the largest accepted counter step (1: a lost frame costs the next one).

    The rate check is off until :meth:`check_rates`: it needs a receive clock in which the senders keep
    their nominal rates (the monotonic clock in real time; in lock-step the tick clock, tick x control
    period, which also runs before the start while the simulated time stands still). A receiver on the wall
    clock while a lock-step simulation runs faster, or on a constant clock, leaves it off.
    """

    codec: Codec
    accept_ids: frozenset[int] | None = None
    max_counter_delta: int = 1
    rejected: Counter[str] = field(default_factory=Counter)
    accepted: int = 0
    last_error: str = ""
    #: 0: no rate check; else the factor K of :meth:`check_rates`
    rate_factor: float = 0.0
    rate_burst_frames: float = RATE_BURST_FRAMES
    receive_period_s: float = 0.0
    _counters: dict[int, CounterCheck] = field(default_factory=dict)
    _buckets: dict[int, TokenBucket | None] = field(default_factory=dict)

    def check_rates(
        self,
        receive_period_s: float = 0.0,
        factor: float = RATE_FACTOR,
        burst_frames: float = RATE_BURST_FRAMES,
    ) -> None:
        """Drop (and count as ``over_rate``) the frames of an id beyond ``factor`` times the rate of its DBC
        cycle time, with bursts of ``burst_frames`` frames; before decoding, so a flood costs no CRC or
        decode. ``receive_period_s``: the receiver's drain interval, whose frames arrive at one receive time
        (the control period for a loop that drains once per tick, and in lock-step). Ids without a cycle
        time (event frames) are not rate-checked.

        A frame over the rate also puts its id's :class:`CounterCheck` into distrust, as a conflicting
        sender: a genuine sender stays within the rate, so frames above it mean a second sender (a replay,
        an impostor) or a babbling node, and neither may be taken for the genuine one.
        """
        if factor < 1.0 or burst_frames < 1.0 or receive_period_s < 0.0:
            raise ValueError(
                f"rate check: factor {factor} and burst {burst_frames} must be >= 1, "
                f"receive period {receive_period_s} >= 0"
            )
        self.rate_factor, self.rate_burst_frames = factor, burst_frames
        self.receive_period_s = receive_period_s
        self._buckets.clear()

    def new_session(self) -> None:
        """Forget every sender's alive counter and rate measurement (a bus reopened: a restarted peer starts
        its counters anew); the rejection counts are kept."""
        self._counters.clear()
        self._buckets.clear()

    def receive(
        self, frame_id: int, data: bytes | bytearray, t_rx_s: float, t_bus_s: float | None = None
    ) -> BusMessage | None:
        """Return the decoded message, or None if the frame is ignored or rejected (and counted).

        ``t_bus_s``: the bus's own arrival time of the frame (python-can's timestamp), for the rate check
        when given: frames keep their spacing however late the receiver reads them (a stall of this process
        then bunches nothing)."""
        if self.accept_ids is not None and frame_id not in self.accept_ids:
            return None
        t_rate_s = t_rx_s if t_bus_s is None else t_bus_s
        if self.rate_factor and not self._within_rate(frame_id, t_rate_s):
            # Dropped undecoded: its CRC is unchecked, so its counter is no evidence and does not move the
            # counter check (a frame that was never verified must not resynchronise the receiver). The drop
            # itself is the evidence: the id is distrusted as for a conflicting sender, until one stream
            # alone has come in step and QUIET_S passed without a conflict or an over-rate frame.
            self.rejected["over_rate"] += 1
            self.last_error = f"0x{frame_id:03X}: over_rate"
            self._check(frame_id).distrust(t_rx_s)
            return None
        try:
            msg, counter = self.codec.decode_with_counter(frame_id, data, t_rx_s)
        except FrameError as exc:
            self.rejected[exc.reason] += 1
            self.last_error = str(exc)
            return None
        reason = self._check(frame_id).check(counter, t_rx_s)
        if reason is not None:
            self.rejected[reason] += 1
            self.last_error = f"{type(msg).DBC_NAME}: {reason}"
            return None
        self.accepted += 1
        return msg

    def _check(self, frame_id: int) -> CounterCheck:
        check = self._counters.get(frame_id)
        if check is None:
            check = self._counters[frame_id] = CounterCheck(
                self.max_counter_delta, cycle_s=self.codec.cycle_time_s(frame_id)
            )
        return check

    def _within_rate(self, frame_id: int, t_rx_s: float) -> bool:
        try:
            bucket = self._buckets[frame_id]
        except KeyError:
            cycle_s = self.codec.cycle_time_s(frame_id)
            bucket = None
            if cycle_s is not None:
                burst = self.rate_burst_frames + self.receive_period_s / cycle_s
                bucket = TokenBucket(self.rate_factor / cycle_s, burst)
            self._buckets[frame_id] = bucket
        return bucket is None or bucket.take(t_rx_s)

    @property
    def rejected_total(self) -> int:
        return sum(self.rejected.values())


#: The command frames whose signal ranges bound the onboard configuration (:func:`command_ranges`).
COMMAND_MESSAGES: Final = ("FIN_CMD", "PROP_CMD")


def command_ranges(dbc_path: str | Path = DBC_PATH) -> dict[str, tuple[float, float]]:
    """The DBC (minimum, maximum) of every physical signal of FIN_CMD and PROP_CMD, keyed
    ``"MESSAGE.signal"`` (e.g. ``"FIN_CMD.rudder_rad"``), in the signal's own SI unit (rad, rev/s).

    The E2E signals and enumerations without a unit (``PROP_CMD.mode``) are left out. The core turns these
    into :class:`onboard.core.params.BusLimits`, so no configured limit can command an unencodable frame.
    """
    db = cantools.database.load_file(str(dbc_path), strict=True)
    if not isinstance(db, cantools.database.can.Database):
        raise ProtocolError(f"{dbc_path} is not a CAN database")
    ranges: dict[str, tuple[float, float]] = {}
    for message in COMMAND_MESSAGES:
        for sig in db.get_message_by_name(message).signals:
            if sig.name in E2E_SIGNALS or not sig.unit:
                continue
            if sig.minimum is None or sig.maximum is None:
                raise ProtocolError(f"{message}.{sig.name} has no range in {dbc_path}")
            ranges[f"{message}.{sig.name}"] = (float(sig.minimum), float(sig.maximum))
    return ranges
