"""The fixed-rate control loop: the only onboard code that owns time and the CAN bus.

One :meth:`ControlLoop.tick` does one iteration in a fixed order: take the bus frames into a latest-value
cache with arrival times; step the autopilot (staleness, mission, planning, guidance, PD, saturation: all
pure code in :mod:`onboard.core.autopilot`); encode and send the commands; record telemetry. Two time sources:

- real time (:meth:`run_realtime`): ticks scheduled against deadlines (``next += period``, never
  ``sleep(period)``), a hybrid wait (sleep until ``spin_s`` before the deadline, then spin), overruns and
  wake-up lateness counted (:meth:`LoopStats.end_tick`, the one overrun count: SYS_STATUS, the telemetry
  rows, the summary and the overrun failsafe's lateness all read it);
- lock-step (:meth:`run_lockstep`): exactly one tick per SYNC frame from the bench, ``now_s`` = the SYNC's
  simulated time; frames that arrived since the previous SYNC are stamped with it; the answer is the command
  frames and then a SYNC_ACK echoing the tick. No wall clock is read for control, so runs repeat exactly.
"""

from __future__ import annotations

import csv
import dataclasses
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol, overload

from auv_common.config import Bound, check_declared, param
from onboard.app.planning import PlanWorker
from onboard.protocol.messages import (
    ActuatorMode,
    BusMessage,
    FinCmd,
    MissionStateCode,
    OnboardHeartbeat,
    PropCmd,
    Sync,
    SyncAck,
)
from onboard.protocol.port import BusPort

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LoopConfig:
    """The ``[loop]`` table: the control loop's rate and clock, its heartbeat and its records."""

    rate_hz: float = param(20.0, unit="Hz", min=1.0, max=200.0, desc="control rate")
    time_source: Literal["monotonic", "lockstep"] = param(
        "monotonic", desc='"monotonic" (real time) or "lockstep" (one tick per SYNC frame from the bench)'
    )
    spin_s: float = param(
        0.0003, unit="s", min=0.0, max=Bound(lambda c: 0.5 / c.rate_hz, "half a period"),
        desc="the last part of each wait that is spun instead of slept (0 = sleep only)",
    )  # fmt: skip
    heartbeat_period_s: float = param(
        1.0, unit="s", min=0.0, min_open=True,
        desc="ONBOARD_HEARTBEAT period (also sent at once on every mission-state change)",
    )  # fmt: skip
    telemetry_csv: str = param("", desc='a per-tick CSV log ("" = off)')
    history: int = param(2000, min=1, desc="ticks kept in memory for tests and MAVLink")

    def __post_init__(self) -> None:
        check_declared(self)

    @property
    def period_s(self) -> float:
        return 1.0 / self.rate_hz


class AutopilotOutput(Protocol):
    """What the loop needs from one autopilot step."""

    @property
    def rudder_rad(self) -> float: ...
    @property
    def stern_port_rad(self) -> float: ...
    @property
    def stern_starboard_rad(self) -> float: ...
    @property
    def propeller_rps(self) -> float: ...
    @property
    def mode(self) -> ActuatorMode: ...
    @property
    def mission_state(self) -> MissionStateCode: ...
    def telemetry_row(self) -> dict[str, float | int | str]: ...


class Autopilot(Protocol):
    """The pure core the loop drives (see :mod:`onboard.core.autopilot`)."""

    def step(self, cache: dict[type, BusMessage], now_s: float, dt_s: float) -> AutopilotOutput: ...
    def note_loop_late(self, late_s: float) -> None: ...
    def note_encode_fault(self, message_name: str, reason: str) -> None: ...
    def note_bus(self, lost_reason: str) -> None: ...
    def before_step(self) -> None: ...


@dataclass
class LoopStats:
    """Counters and timings the loop keeps (the benchmark and telemetry read them).

    The one owner of the overrun count and of the loop's load: every loop that ticks against deadlines
    (:class:`ControlLoop`, the stand-alone vehicle) accounts each tick with :meth:`end_tick`.
    """

    ticks: int = 0
    overruns: int = 0
    consecutive_overruns: int = 0
    #: the longest run of overruns in a row so far
    max_consecutive_overruns: int = 0
    #: the longest time the loop was behind its schedule continuously (s): from the first deadline a run of
    #: overrunning ticks missed to the end of its last tick (what the overrun failsafe judges)
    max_late_s: float = 0.0
    missed_deadlines: int = 0
    encode_errors: int = 0
    #: frames not sent because they did not encode, by DBC message name
    encode_errors_by_message: dict[str, int] = field(default_factory=dict)
    #: frames not encodable in the current run of ticks with encode errors (0 = none; logged once per run)
    encode_burst: int = 0
    lateness_s: deque[float] = field(default_factory=lambda: deque(maxlen=100_000))
    compute_s: deque[float] = field(default_factory=lambda: deque(maxlen=100_000))
    #: the busy share of the latest tick's period (its work over the period; > 1 when it overran): MAVLink
    #: SYS_STATUS ``load`` in per mille; NaN before the first tick
    load: float = math.nan
    #: the first deadline missed by the current run of overruns (None: on time)
    late_since_s: float | None = None

    def note_busy(self, busy_s: float, period_s: float) -> None:
        """One tick's work took ``busy_s`` (s) of its ``period_s`` (s): the load."""
        self.load = busy_s / period_s

    def end_tick(self, end_s: float, deadline_s: float) -> float:
        """A tick ended at ``end_s`` (s), its next deadline at ``deadline_s``: an overrun if after it.

        Returns how long the loop has been behind its schedule continuously (s, 0 = on time): from the first
        deadline the current run of overruns missed to ``end_s`` (what the overrun failsafe judges)."""
        if end_s <= deadline_s:
            self.consecutive_overruns = 0
            self.late_since_s = None
            return 0.0
        self.overruns += 1
        self.consecutive_overruns += 1
        self.max_consecutive_overruns = max(self.max_consecutive_overruns, self.consecutive_overruns)
        if self.late_since_s is None:
            self.late_since_s = deadline_s
        late_s = end_s - self.late_since_s
        self.max_late_s = max(self.max_late_s, late_s)
        return late_s

    def note_encode_error(self, message_name: str) -> bool:
        """Count one frame that did not encode; True if it starts a burst (the one to log)."""
        self.encode_errors += 1
        self.encode_errors_by_message[message_name] = self.encode_errors_by_message.get(message_name, 0) + 1
        self.encode_burst += 1
        return self.encode_burst == 1


class TelemetryHistory(Sequence[dict[str, Any]]):
    """The telemetry rows of the last ``maxlen`` ticks, oldest first: ``{"t_s", "tick", **telemetry_row(),
    "overruns"}``.

    A read-only sequence of dicts. It keeps each tick's (immutable) autopilot output and builds the row
    only when it is read: building a row costs more than the rest of the bookkeeping of a tick, and most
    rows are never read.
    """

    def __init__(self, maxlen: int) -> None:
        self._ticks: deque[tuple[float, int, int, AutopilotOutput]] = deque(maxlen=maxlen)

    def record(self, now_s: float, tick: int, overruns: int, out: AutopilotOutput) -> None:
        """Keep one tick: its time (s), number, the overrun count at that tick and the output."""
        self._ticks.append((now_s, tick, overruns, out))

    @staticmethod
    def row(now_s: float, tick: int, overruns: int, out: AutopilotOutput) -> dict[str, Any]:
        row: dict[str, Any] = {"t_s": now_s, "tick": tick, **out.telemetry_row()}
        row["overruns"] = overruns
        return row

    def __len__(self) -> int:
        return len(self._ticks)

    @overload
    def __getitem__(self, index: int) -> dict[str, Any]: ...
    @overload
    def __getitem__(self, index: slice) -> list[dict[str, Any]]: ...
    def __getitem__(self, index: int | slice) -> dict[str, Any] | list[dict[str, Any]]:
        if isinstance(index, slice):
            return [self.row(*t) for t in list(self._ticks)[index]]
        return self.row(*self._ticks[index])

    def __iter__(self) -> Iterator[dict[str, Any]]:
        for t in list(self._ticks):  # a snapshot: the loop may append while a reader iterates
            yield self.row(*t)


class ControlLoop:
    """Drive an :class:`Autopilot` from a :class:`BusPort` at a fixed rate (see the module docstring)."""

    def __init__(
        self,
        port: BusPort,
        autopilot: Autopilot,
        config: LoopConfig,
        on_tick: Callable[[AutopilotOutput, float], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.port = port
        self.autopilot = autopilot
        self.config = config
        self.on_tick = on_tick
        self.clock = clock
        self.stats = LoopStats()
        self.cache: dict[type, BusMessage] = {}
        self.history = TelemetryHistory(config.history)
        self._last_state: MissionStateCode | None = None
        self._next_heartbeat_s = -1.0
        self._t0_s: float | None = None
        self._csv_file: Any = None
        self._csv: Any = None
        self._last_sync_tick = -1
        self._pending: list[BusMessage] = []  # lock-step: frames since the last SYNC
        self._last_tick_s = -math.inf
        self._bus_lost = ""  # the port's word on the bus the autopilot was last told
        # Called before each step (the links' commands reach the autopilot here, on the loop thread).
        self.before_tick: Callable[[float], None] | None = None
        self.plans = PlanWorker.for_autopilot(autopilot, config.time_source == "lockstep")

    # --- one iteration -------------------------------------------------------------------------
    def take(self, msgs: list[BusMessage], t_rx_s: float | None = None) -> None:
        """Put received messages into the latest-value cache (re-stamped with ``t_rx_s`` if given)."""
        for msg in msgs:
            if t_rx_s is not None:
                msg = dataclasses.replace(msg, t_sample_s=t_rx_s)
            self.cache[type(msg)] = msg

    def tick(self, now_s: float) -> AutopilotOutput:
        """One control iteration at time ``now_s`` (s, the loop's time base)."""
        t_compute = time.perf_counter()
        if self._t0_s is None:
            self._t0_s = now_s
        if self.port.lost != self._bus_lost:  # the bus lost or back (the port reconnects on its own)
            self._bus_lost = self.port.lost
            self.autopilot.note_bus(self._bus_lost)
        if self.before_tick is not None:
            self.before_tick(now_s)
        self.autopilot.before_step()
        if self.plans is not None:
            self.plans.before_step()
        out = self.autopilot.step(self.cache, now_s, self.config.period_s)
        if self.plans is not None:
            self.plans.after_step()
        # A command that does not encode (the autopilot saturates, so it is a bug) is not sent and not
        # replaced by a made-up one: the autopilot is told and aborts at the next tick (its abort command
        # always encodes). The frames that do encode go out; no alive-counter value is used up by a failure.
        faulty: list[tuple[str, str]] = []
        for cmd in (
            FinCmd(out.rudder_rad, out.stern_port_rad, out.stern_starboard_rad, now_s),
            PropCmd(out.propeller_rps, out.mode, now_s),
        ):
            try:
                self.port.send(cmd)
            except ValueError as exc:  # EncodeError
                faulty.append((type(cmd).DBC_NAME, str(exc)))
        for name, reason in faulty:
            first = self.stats.note_encode_error(name)
            if first:
                log.error("command not encodable, not sent (%s); the autopilot aborts", reason)
            self.autopilot.note_encode_fault(name, reason)
        if not faulty and self.stats.encode_burst:
            log.warning("commands encodable again after %d frame(s) not sent", self.stats.encode_burst)
            self.stats.encode_burst = 0
        # Also every tick while the time base stands still (lock-step before the start: the bench waits
        # for a RUNNING heartbeat, and one lost frame must not stall it).
        frozen = now_s <= self._last_tick_s
        self._last_tick_s = now_s
        if out.mission_state != self._last_state or now_s >= self._next_heartbeat_s or frozen:
            uptime = min(max(now_s - self._t0_s, 0.0), 167772.0)
            self.port.send(OnboardHeartbeat(out.mission_state, round(uptime, 2), now_s))
            self._next_heartbeat_s = now_s + self.config.heartbeat_period_s
            self._last_state = out.mission_state
        self.stats.ticks += 1
        self.stats.compute_s.append(time.perf_counter() - t_compute)
        self._record(out, now_s)
        if self.on_tick is not None:
            self.on_tick(out, now_s)
        self.stats.note_busy(time.perf_counter() - t_compute, self.config.period_s)
        return out

    def _record(self, out: AutopilotOutput, now_s: float) -> None:
        self.history.record(now_s, self.stats.ticks, self.stats.overruns, out)
        if self.config.telemetry_csv:
            row = TelemetryHistory.row(now_s, self.stats.ticks, self.stats.overruns, out)
            if self._csv is None:
                path = Path(self.config.telemetry_csv)
                path.parent.mkdir(parents=True, exist_ok=True)
                self._csv_file = path.open("w", newline="")
                self._csv = csv.DictWriter(self._csv_file, fieldnames=list(row), extrasaction="ignore")
                self._csv.writeheader()
            self._csv.writerow(row)

    # --- time sources --------------------------------------------------------------------------
    def _wait_until(self, deadline_s: float, stop: threading.Event) -> None:
        """Sleep until ``spin_s`` before the deadline, then spin (sleep alone wakes ~0.1-0.3 ms late)."""
        while True:
            remaining = deadline_s - self.clock()
            if remaining <= 0.0:
                return
            if remaining > self.config.spin_s:
                if stop.wait(remaining - self.config.spin_s):
                    return
            # spin the last fraction of a millisecond only: a spinning thread holds the GIL

    def run_realtime(self, stop: threading.Event) -> None:
        """Tick against deadlines on the monotonic clock until ``stop`` is set."""
        period = self.config.period_s
        next_s = self.clock()
        while not stop.is_set():
            self._wait_until(next_s, stop)
            if stop.is_set():
                break
            now = self.clock()
            self.stats.lateness_s.append(now - next_s)
            self.take(self.port.drain())
            self.tick(now)
            next_s += period
            late_s = self.stats.end_tick(self.clock(), next_s)
            self.autopilot.note_loop_late(late_s)
            if late_s > 0.0:
                while next_s < self.clock():  # skip the deadlines already missed, keep the phase
                    next_s += period
                    self.stats.missed_deadlines += 1

    def run_lockstep(self, stop: threading.Event, idle_timeout_s: float | None = None) -> None:
        """One tick per SYNC frame until ``stop`` is set (or no SYNC for ``idle_timeout_s``)."""
        if self.plans is not None:
            self.plans.lockstep = True  # a plan is awaited before the next step: runs repeat exactly
        last_sync = time.monotonic()
        while not stop.is_set():
            msg = self.port.recv(0.2)
            if msg is None:
                if idle_timeout_s is not None and time.monotonic() - last_sync > idle_timeout_s:
                    log.warning("no SYNC for %.1f s; leaving lock-step", idle_timeout_s)
                    return
                continue
            if isinstance(msg, Sync):
                last_sync = time.monotonic()
            self.feed(msg)

    def feed(self, msg: BusMessage) -> AutopilotOutput | None:
        """Lock-step: one received frame. A SYNC ticks (:meth:`step_sync`) with the frames that arrived since
        the previous one, stamped with its simulated time; any other frame waits for the next SYNC."""
        if not isinstance(msg, Sync):
            self._pending.append(msg)
            return None
        self.take(self._pending, msg.sim_time_s)
        self._pending.clear()
        return self.step_sync(msg)

    def step_sync(self, sync: Sync) -> AutopilotOutput | None:
        """Answer one SYNC: tick at its simulated time, send the commands, then echo the tick.

        A repeated SYNC (the bench offers the first tick again until someone answers) is echoed again
        without a second tick.
        """
        out = None
        if sync.tick != self._last_sync_tick:
            out = self.tick(sync.sim_time_s)
            self._last_sync_tick = sync.tick
        self.port.send(SyncAck(sync.tick, sync.sim_time_s))
        return out

    def close(self) -> None:
        if self.plans is not None:
            self.plans.close()
        if self._csv_file is not None:
            self._csv_file.close()
            self._csv_file = None
            self._csv = None
