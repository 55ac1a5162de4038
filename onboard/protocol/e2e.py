"""End-to-end protection of CAN frames, AUTOSAR E2E style (profile-1-like).

Every frame of the ISiMI100 bus carries a 4-bit alive counter and, in its last byte, a CRC-8 (SAE J1850:
polynomial 0x1D, initial value 0xFF, final XOR 0xFF) computed over the 16-bit data id (the CAN message id,
low byte first) followed by payload bytes 0..6. The counter catches lost, repeated and replayed frames; the
CRC catches corruption and frames that were meant for another id.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

CRC_BYTE_INDEX = 7
COUNTER_MODULO = 16


def _make_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1D) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        table.append(crc)
    return tuple(table)


#: The CRC-8 of every byte value (one table lookup per byte instead of eight shifts).
CRC_TABLE: tuple[int, ...] = _make_table()


def crc8_sae_j1850(data: bytes, crc: int = 0xFF) -> int:
    """CRC-8 SAE J1850 of ``data`` (initial value ``crc``, final XOR 0xFF). check("123456789") = 0x4B."""
    for b in data:
        crc = CRC_TABLE[crc ^ b]
    return crc ^ 0xFF


def data_id_crc_state(frame_id: int) -> int:
    """The CRC register after the data id (the CAN id, 2 bytes little-endian), before any payload byte:
    the start value of every frame of ``frame_id`` (the codec computes it once per id)."""
    crc = 0xFF
    for b in (frame_id & 0xFF, (frame_id >> 8) & 0xFF):
        crc = CRC_TABLE[crc ^ b]
    return crc


def frame_crc(frame_id: int, payload: bytes | bytearray) -> int:
    """The E2E CRC of a frame: over the data id (2 bytes, little-endian) and payload bytes 0..6."""
    return crc8_sae_j1850(bytes(payload[:CRC_BYTE_INDEX]), data_id_crc_state(frame_id))


#: After two interleaved counter streams were seen on one id, the distrust ends once this many frames came in
#: step from one stream alone (two laps of the 4-bit counter) and no conflict was seen for QUIET_S seconds
#: (a fast impostor sends many frames in step between two of a slow genuine sensor).
QUIET_FRAMES = 2 * COUNTER_MODULO
QUIET_S = 1.0
#: A frame continues the stream left behind at the last jump only if it comes sooner than this many nominal
#: cycles after that stream's last frame: later, one sender whose counter went round a lap (16 frames, some
#: of them lost) would look the same.
LEFT_STREAM_CYCLES = COUNTER_MODULO // 2


@dataclass
class CounterCheck:
    """Receiver-side alive-counter state for one message id.

    ``max_delta`` is the largest accepted counter step (1 = no frame may be lost). A repeated counter
    (step 0) or a jump (step > max_delta) rejects the frame; after a jump the receiver re-synchronises on the
    new counter, so one lost frame costs one more rejected frame, not a permanent lock-out.

    A second sender on the same id (valid CRC, its own counter) shows as two interleaved streams: a frame
    that jumps from the last counter but continues the one before the last jump. That is counted as a
    conflicting sender, and the id is then distrusted: every frame is rejected (``conflicting_sender``: a
    sensor goes stale, a command stream stops, so the actuators' watchdog fires: the node's ABORT) until
    :data:`QUIET_FRAMES` frames in a row come in step from one stream alone and :data:`QUIET_S` passed
    without a conflict (``t_s``: the receive time). The receiver also calls :meth:`distrust` for a frame
    over the id's rate (:meth:`onboard.protocol.codec.FrameReceiver.check_rates`).

    ``cycle_s``, the id's nominal cycle time: the left-behind stream is only claimed within
    :data:`LEFT_STREAM_CYCLES` cycles of its last frame, so lost frames of one sender are never a conflict
    (two losses 15 frames apart, or a burst of losses, bring its counter round to the one it left): that
    takes 17 frames, and a sender whose frames are at most COUNTER_MODULO + 1 - LEFT_STREAM_CYCLES = 9 cycles
    late cannot have sent them within 8 cycles (the rate check's tolerance, 7 cycles plus the drain interval,
    is within that). With no cycle time, or a receive clock that stands still, any continuation is claimed.
    """

    max_delta: int = 1
    last: int | None = None
    before_jump: int | None = None  # the counter the last jump left behind
    quiet_needed: int = 0  # > 0: distrusted, this many clean frames to go
    conflicts: int = 0
    conflict_t_s: float = -math.inf  # when the last conflict (or over-rate frame) was seen
    cycle_s: float | None = None
    last_t_s: float = -math.inf  # when ``last`` was taken
    before_jump_t_s: float = -math.inf  # when ``before_jump`` was taken

    def check(self, counter: int, t_s: float = 0.0) -> str | None:
        """Return None if the counter is acceptable, else the rejection reason; update the state."""
        if self.last is None:
            self.last, self.last_t_s = counter, t_s
            return None
        delta = (counter - self.last) % COUNTER_MODULO
        if delta == 0:
            return "repeated_counter" if not self.quiet_needed else self._distrusted(clean=False)
        if delta > self.max_delta:
            prior, prior_t_s = self.before_jump, self.before_jump_t_s
            self.before_jump, self.before_jump_t_s = self.last, self.last_t_s
            self.last, self.last_t_s = counter, t_s
            recent = self.cycle_s is None or t_s - prior_t_s < LEFT_STREAM_CYCLES * self.cycle_s
            if prior is not None and recent and 0 < (counter - prior) % COUNTER_MODULO <= self.max_delta:
                self.conflicts += 1  # it continues the stream the previous jump left: two senders
                self.quiet_needed, self.conflict_t_s = QUIET_FRAMES, t_s
                return "conflicting_sender"
            return "jumping_counter" if not self.quiet_needed else self._distrusted(clean=False)
        self.last, self.last_t_s = counter, t_s
        if self.quiet_needed > 1 or (self.quiet_needed == 1 and t_s - self.conflict_t_s < QUIET_S):
            return self._distrusted(clean=True)
        self.quiet_needed = 0
        return None

    def distrust(self, t_s: float) -> None:
        """Evidence of a second sender other than the counters (a frame over the id's rate): distrusted as
        after a conflict, and the quiet time starts again at ``t_s``; the counter state is not moved."""
        self.quiet_needed = QUIET_FRAMES
        self.conflict_t_s = max(self.conflict_t_s, t_s)

    def _distrusted(self, clean: bool) -> str:
        self.quiet_needed = max(self.quiet_needed - 1, 1) if clean else QUIET_FRAMES
        return "conflicting_sender"


@dataclass
class TxCounters:
    """Sender-side alive counters, one per message id, starting at 0 and wrapping at 16.

    A value belongs to a frame that was actually produced: :meth:`peek` the value, build the frame, then
    :meth:`advance`. A frame that could not be built (an encode error) must not use one up, or the receiver
    sees a jump (``jumping_counter``) in the next good frame.
    """

    next_by_id: dict[int, int] = field(default_factory=dict)

    def peek(self, frame_id: int) -> int:
        """The counter the next frame of ``frame_id`` carries (not used up)."""
        return self.next_by_id.get(frame_id, 0)

    def advance(self, frame_id: int) -> None:
        """Use up the current value of ``frame_id`` (its frame was produced)."""
        self.next_by_id[frame_id] = (self.peek(frame_id) + 1) % COUNTER_MODULO

    def next(self, frame_id: int) -> int:
        """:meth:`peek` and :meth:`advance` at once, for a frame that cannot fail any more."""
        value = self.peek(frame_id)
        self.advance(frame_id)
        return value
