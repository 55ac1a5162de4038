"""The bench program (``hil_sim.bench_program.run_bench``) in one process, lock-step, ``virtual`` bus.

The bench runs in a thread on its own virtual bus; the test plays the onboard through a :class:`BusPort` on
the same virtual channel: it answers each SYNC (or not), sends commands (valid, corrupt or none) and reads
what the bench publishes before the next SYNC. Every wait has an explicit timeout; the bench thread is
stopped and joined in a ``finally``.
"""

from __future__ import annotations

import csv
import itertools
import threading
import time
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import can
import pytest
from can.interfaces.virtual import VirtualBus

from hil_sim.bench_program import (
    BenchConfig,
    BenchResult,
    EchoTimeout,
    HilConfig,
    InitialConfig,
    run_bench,
    timeout_periods,
)
from hil_sim.model.faults import Fault
from hil_sim.model.params import load_params
from onboard.protocol import messages as m
from onboard.protocol.bus import BusConfig
from onboard.protocol.codec import Codec
from onboard.protocol.port import BusPort

RATE_HZ = 20.0
PERIOD_S = 1.0 / RATE_HZ
WAIT_S = 5.0  # generous wall-clock limit for any one frame the bench owes us
_channels = itertools.count()


def _channel(name: str) -> str:
    """A virtual channel no other test (or earlier run of this one) uses."""
    return f"bench-it-{name}-{time.monotonic_ns()}-{next(_channels)}"


def _config(channel: str, **bench: object) -> HilConfig:
    return HilConfig(
        bus=BusConfig(interface="virtual", channel=channel),
        bench=BenchConfig(time_mode="lockstep", control_rate_hz=RATE_HZ, host_hub=False, **bench),  # type: ignore[arg-type]
        initial=InitialConfig(x_m=2.0, y_m=-3.0, depth_m=1.5, yaw_deg=30.0),
    )


@dataclass
class Tick:
    """One SYNC and what the bench published before it (the state after the previous period)."""

    sync: m.Sync
    before: list[m.BusMessage]

    def one(self, cls: type) -> m.BusMessage:
        found = [msg for msg in self.before if isinstance(msg, cls)]
        assert len(found) == 1, f"expected one {cls.__name__} before SYNC {self.sync.tick}, got {found}"
        return found[0]

    def count(self) -> Counter[str]:
        return Counter(type(msg).__name__ for msg in self.before)


class FakeOnboard:
    """The test's side of the bus: reads what the bench publishes, answers SYNCs."""

    def __init__(self, channel: str) -> None:
        self.codec = Codec()
        self.bus = VirtualBus(channel=channel, receive_own_messages=False)
        self.port = BusPort(self.bus, time.monotonic, None, self.codec)

    def next_tick(self, timeout_s: float = WAIT_S) -> Tick:
        """Collect frames until the next SYNC (a :class:`TimeoutError` if none comes in time)."""
        before: list[m.BusMessage] = []
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            msg = self.port.recv(min(left, 0.1))
            if isinstance(msg, m.Sync):
                return Tick(msg, before)
            if msg is not None:
                before.append(msg)
        raise TimeoutError(f"no SYNC from the bench within {timeout_s} s")

    def quiet_for(self, seconds: float) -> list[m.BusMessage]:
        """Everything received in ``seconds`` of wall time."""
        out: list[m.BusMessage] = []
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            msg = self.port.recv(min(left, 0.05))
            if msg is not None:
                out.append(msg)
        return out

    def answer(
        self,
        tick: Tick,
        rudder_rad: float | None = 0.1,
        propeller_rps: float = 20.0,
        mode: m.ActuatorMode = m.ActuatorMode.ARMED,
        state: m.MissionStateCode | None = None,
    ) -> None:
        """Optionally a heartbeat, then FIN_CMD + PROP_CMD (unless ``rudder_rad`` is None), then SYNC_ACK."""
        if state is not None:
            self.port.send(m.OnboardHeartbeat(state, 0.0))
        if rudder_rad is not None:
            self.port.send(m.FinCmd(rudder_rad, 0.0, 0.0))
            self.port.send(m.PropCmd(propeller_rps, mode))
        self.port.send(m.SyncAck(tick.sync.tick))

    def send_raw(self, frame_id: int, data: bytes) -> None:
        self.bus.send(can.Message(arbitration_id=frame_id, data=data, is_extended_id=False))

    def close(self) -> None:
        self.port.close()


@dataclass
class BenchThread:
    stop: threading.Event
    thread: threading.Thread
    outcome: dict[str, object] = field(default_factory=dict)

    def join(self, timeout_s: float = WAIT_S) -> BenchResult:
        """Wait for the bench to end by itself; its result (re-raises the bench's exception)."""
        self.thread.join(timeout_s)
        assert not self.thread.is_alive(), f"bench still running after {timeout_s} s"
        if "error" in self.outcome:
            raise self.outcome["error"]  # type: ignore[misc]
        result = self.outcome["result"]
        assert isinstance(result, BenchResult)
        return result

    def stop_and_join(self) -> BenchResult:
        self.stop.set()
        return self.join()


@contextmanager
def bench_and_onboard(
    cfg: HilConfig, faults: tuple[Fault, ...] = ()
) -> Iterator[tuple[BenchThread, FakeOnboard]]:
    """The bench in a thread on ``cfg.bus.channel`` (with ``faults`` injected) and the test's onboard on the
    same channel."""
    onboard = FakeOnboard(cfg.bus.channel)  # listening before the bench's first frame
    bench_bus = VirtualBus(channel=cfg.bus.channel, receive_own_messages=False)
    stop = threading.Event()
    bt = BenchThread(stop, threading.Thread(name="bench", daemon=True, target=lambda: None))

    def target() -> None:
        try:
            bt.outcome["result"] = run_bench(cfg, stop, bus_override=bench_bus, faults=faults)
        except BaseException as exc:  # handed to the test thread by BenchThread.join
            bt.outcome["error"] = exc

    bt.thread = threading.Thread(name="bench", daemon=True, target=target)
    bt.thread.start()
    try:
        yield bt, onboard
    finally:
        stop.set()
        bt.thread.join(WAIT_S)
        onboard.close()
        assert not bt.thread.is_alive(), "bench thread did not stop"


def start(onboard: FakeOnboard) -> Tick:
    """Answer the first SYNC with a RUNNING heartbeat and commands; the first SYNC of simulated time."""
    first = onboard.next_tick()
    onboard.answer(first, state=m.MissionStateCode.RUNNING)
    tick = onboard.next_tick()
    assert tick.sync.sim_time_s == pytest.approx(PERIOD_S, abs=1e-3), "simulated time did not start"
    return tick


def _timeout_periods(cfg: HilConfig) -> int:
    """The actuator node's command timeout in the control periods it counts."""
    timeout_s = cfg.bench.command_timeout_s or load_params().config.actuators.command_timeout_s
    return timeout_periods(timeout_s, 1.0 / cfg.bench.control_rate_hz)


def failsafe_flags(tick: Tick) -> tuple[bool, bool]:
    fin = tick.one(m.FinStatus)
    prop = tick.one(m.PropStatus)
    assert isinstance(fin, m.FinStatus) and isinstance(prop, m.PropStatus)
    return fin.failsafe, prop.failsafe


# --- (a) the actuator failsafe ---------------------------------------------------------------------------
def test_failsafe_fires_within_the_timeout_when_commands_stop_and_latches_until_safe() -> None:
    cfg = _config(_channel("failsafe"))
    timeout = _timeout_periods(cfg)
    with bench_and_onboard(cfg) as (bench, onboard):
        # GIVEN a running bench that follows ARMED commands
        tick = start(onboard)
        for _ in range(10):
            onboard.answer(tick, rudder_rad=0.1, propeller_rps=20.0)
            tick = onboard.next_tick()
        assert failsafe_flags(tick) == (False, False)
        prop = tick.one(m.PropStatus)
        assert isinstance(prop, m.PropStatus) and prop.armed and prop.propeller_rps > 5.0
        # WHEN the commands stop (the onboard still echoes SYNC)
        flags: list[tuple[bool, bool]] = []
        for _ in range(timeout + 3):
            onboard.answer(tick, rudder_rad=None)
            tick = onboard.next_tick()
            flags.append(failsafe_flags(tick))
        # THEN both status frames report the failsafe after exactly `timeout` periods without a command
        # (the status before SYNC k describes the state after period k-1)
        assert flags[: timeout - 1] == [(False, False)] * (timeout - 1)
        assert flags[timeout - 1 :] == [(True, True)] * 4
        # AND valid ARMED commands again do not clear it (latched): propeller spins down, fins go neutral
        for _ in range(25):
            onboard.answer(tick, rudder_rad=0.1, propeller_rps=20.0)
            tick = onboard.next_tick()
            assert failsafe_flags(tick) == (True, True)
        fin, prop = tick.one(m.FinStatus), tick.one(m.PropStatus)
        assert isinstance(fin, m.FinStatus) and isinstance(prop, m.PropStatus)
        assert fin.rudder_rad == pytest.approx(0.0, abs=1e-4)
        assert abs(prop.propeller_rps) < 0.5
        # WHEN the onboard sends a SAFE command THEN the failsafe clears on the next status
        onboard.answer(tick, rudder_rad=0.0, propeller_rps=0.0, mode=m.ActuatorMode.SAFE)
        tick = onboard.next_tick()
        assert failsafe_flags(tick) == (False, False)
        # AND ARMED commands are followed again
        for _ in range(10):
            onboard.answer(tick, rudder_rad=0.1, propeller_rps=20.0)
            tick = onboard.next_tick()
        prop = tick.one(m.PropStatus)
        assert isinstance(prop, m.PropStatus) and prop.propeller_rps > 5.0 and not prop.failsafe
        result = bench.stop_and_join()
    assert result.failsafe_timeouts == 1
    assert result.rejected == {}


def test_actuator_heartbeat_reports_the_latched_failsafe() -> None:
    cfg = _config(_channel("heartbeat"))
    with bench_and_onboard(cfg) as (bench, onboard):
        # GIVEN a running bench WHEN no command comes for 2 simulated seconds
        tick = start(onboard)
        health: list[m.NodeHealth] = []
        for _ in range(round(2.2 * RATE_HZ)):
            onboard.answer(tick, rudder_rad=None)
            tick = onboard.next_tick()
            health += [msg.node_state for msg in tick.before if isinstance(msg, m.ActuatorsHeartbeat)]
        bench.stop_and_join()
    # THEN the 1 Hz actuator heartbeats that follow the timeout say FAILSAFE
    assert len(health) >= 2
    assert health[-1] is m.NodeHealth.FAILSAFE


# --- (b) a corrupt command stream ---------------------------------------------------------------------------
def test_corrupt_commands_are_rejected_counted_and_trigger_the_failsafe() -> None:
    cfg = _config(_channel("corrupt"))
    timeout = _timeout_periods(cfg)
    codec = Codec()
    fin_id, prop_id = codec.frame_id(m.FinCmd), codec.frame_id(m.PropCmd)
    with bench_and_onboard(cfg) as (bench, onboard):
        tick = start(onboard)
        for _ in range(5):
            onboard.answer(tick)
            tick = onboard.next_tick()
        assert failsafe_flags(tick) == (False, False)
        counters = onboard.port.sender.counters.next_by_id
        # WHEN every command frame is corrupt: even ticks a flipped payload bit (CRC mismatch), odd ticks a
        # correct frame that repeats the last accepted alive counter
        flags: list[tuple[bool, bool]] = []
        bad_crc = repeated = 0
        for i in range(timeout + 3):
            for frame_id, msg in (
                (fin_id, m.FinCmd(0.2, 0.0, 0.0)),
                (prop_id, m.PropCmd(25.0, m.ActuatorMode.ARMED)),
            ):
                if i % 2 == 0:
                    _, data = codec.encode(msg, counters[frame_id])
                    onboard.send_raw(frame_id, bytes((data[0] ^ 0x01, *data[1:])))
                    bad_crc += 1
                else:
                    _, data = codec.encode(msg, (counters[frame_id] - 1) % 16)
                    onboard.send_raw(frame_id, data)
                    repeated += 1
            onboard.answer(tick, rudder_rad=None)
            tick = onboard.next_tick()
            flags.append(failsafe_flags(tick))
        # THEN none is taken: the failsafe fires after `timeout` periods, as if no command had come
        assert flags[: timeout - 1] == [(False, False)] * (timeout - 1)
        assert flags[timeout - 1 :] == [(True, True)] * 4
        # AND the bench counts each rejected frame (PROP_STATUS reports the running total)
        prop = tick.one(m.PropStatus)
        assert isinstance(prop, m.PropStatus)
        assert prop.rejected_frames == bad_crc + repeated
        # AND a valid stream after it is accepted again (the counters were not disturbed), still latched
        for _ in range(3):
            onboard.answer(tick)
            tick = onboard.next_tick()
        assert failsafe_flags(tick) == (True, True)
        result = bench.stop_and_join()
    assert result.rejected == {"wrong_crc": bad_crc, "repeated_counter": repeated}
    assert result.failsafe_timeouts == 1


# --- (c) lock-step -----------------------------------------------------------------------------------------
def test_simulated_time_waits_for_running_heartbeat_and_advances_one_period_per_ack() -> None:
    cfg = _config(_channel("lockstep"))
    with bench_and_onboard(cfg) as (bench, onboard):
        # GIVEN an onboard that echoes SYNC but is not RUNNING
        ticks = []
        for _ in range(6):
            tick = onboard.next_tick()
            ticks.append(tick.sync)
            onboard.answer(tick, rudder_rad=None, state=m.MissionStateCode.IDLE)
        # THEN ticks advance (paced by the wall clock) and simulated time stays at 0
        assert [s.tick for s in ticks] == list(range(6))
        assert all(s.sim_time_s == 0.0 for s in ticks)
        # WHEN the onboard does not answer tick 6 THEN the bench offers the same tick again, with no end
        # (before the start the onboard may simply not be there yet)
        tick = onboard.next_tick()
        reoffers = [msg for msg in onboard.quiet_for(1.2) if isinstance(msg, m.Sync)]
        assert tick.sync.tick == 6 and len(reoffers) >= 1
        assert {(s.tick, s.sim_time_s) for s in reoffers} == {(6, 0.0)}
        assert bench.thread.is_alive()
        # WHEN the heartbeat reports RUNNING THEN each ACK advances simulated time by exactly one period
        onboard.answer(tick, state=m.MissionStateCode.RUNNING)
        times = []
        for _ in range(10):
            tick = onboard.next_tick()
            times.append((tick.sync.tick, tick.sync.sim_time_s))
            onboard.answer(tick)
        assert [t for t, _ in times] == list(range(7, 17))
        assert [s for _, s in times] == pytest.approx([(i + 1) * PERIOD_S for i in range(10)], abs=1e-6)
        # AND an ACK echoing the wrong tick does not advance it (nothing more than the SYNC is offered)
        tick = onboard.next_tick()
        onboard.port.send(m.SyncAck(tick.sync.tick - 1))
        assert not [msg for msg in onboard.quiet_for(0.3) if isinstance(msg, m.Sync)]
        onboard.answer(tick)
        assert onboard.next_tick().sync.tick == tick.sync.tick + 1
        result = bench.stop_and_join()
    assert result.started and result.onboard_state == "RUNNING"
    assert result.sim_time_s == pytest.approx(12 * PERIOD_S)  # ticks 6..17 integrated


def test_missing_sync_ack_after_the_start_raises_echo_timeout() -> None:
    cfg = _config(_channel("echo"), echo_timeout_s=0.3)
    with bench_and_onboard(cfg) as (bench, onboard):
        # GIVEN a started run
        tick = start(onboard)
        for _ in range(3):
            onboard.answer(tick)
            tick = onboard.next_tick()
        # WHEN the onboard stops answering
        # THEN the bench ends the run on its own with a clear EchoTimeout naming the tick and the deadline
        # (the join's bound is only how long the test waits for it)
        with pytest.raises(EchoTimeout, match=r"no SYNC_ACK for tick 4 within 0\.3 s") as err:
            bench.join(timeout_s=30.0)
    assert "lock-step" in str(err.value)


def test_echo_timeout_fires_even_while_commands_keep_arriving() -> None:
    # GIVEN a started run with a short echo deadline
    cfg = _config(_channel("echo-flood"), echo_timeout_s=0.3)
    with bench_and_onboard(cfg) as (bench, onboard):
        tick = start(onboard)
        onboard.answer(tick)
        onboard.next_tick()
        # WHEN the onboard keeps commanding at 100 Hz but never echoes the SYNC (e.g. it runs in real time)
        t0 = time.monotonic()
        while bench.thread.is_alive() and time.monotonic() - t0 < 30.0:
            onboard.port.send(m.FinCmd(0.1, 0.0, 0.0))
            onboard.port.send(m.PropCmd(20.0, m.ActuatorMode.ARMED))
            time.sleep(0.01)
        # THEN the bench ended the run while the commands were still coming (they do not restart the
        # 0.3 s deadline: else it would run on), with EchoTimeout
        assert not bench.thread.is_alive()
        with pytest.raises(EchoTimeout, match="no SYNC_ACK for tick 2"):
            bench.join(timeout_s=1.0)


# --- (d) sensor rates -----------------------------------------------------------------------------------
@pytest.mark.parametrize("profile", ["basin", "sea"])
def test_sensor_frames_arrive_at_the_profile_rates(profile: str) -> None:
    cfg = _config(_channel(f"rates-{profile}"), sensor_profile=profile)
    rates = load_params(None).sensor_profiles[profile]
    sim_s = 10.0
    with bench_and_onboard(cfg) as (bench, onboard):
        # GIVEN a started run WHEN 10 simulated seconds are answered
        tick = start(onboard)
        counts: Counter[str] = tick.count()
        for _ in range(round(sim_s * RATE_HZ) - 1):
            onboard.answer(tick)
            tick = onboard.next_tick()
            counts += tick.count()
        assert tick.sync.sim_time_s == pytest.approx(sim_s, abs=1e-3)
        bench.stop_and_join()
    # THEN each sensor's frames per simulated second match the profile (one sample of slack for the phase)
    expected = {
        "AhrsAttitude": rates.ahrs_rate_hz,
        "AhrsRates": rates.ahrs_rate_hz,
        "DepthMeas": rates.depth_rate_hz,
        "DvlVelocity": rates.dvl_rate_hz,
        "PositionFix": rates.fix_rate_hz,
        "FinStatus": RATE_HZ,
        "PropStatus": RATE_HZ,
        "ActuatorsHeartbeat": 1.0,
        "SensorsHeartbeat": 1.0,
    }
    for name, rate_hz in expected.items():
        assert abs(counts[name] - rate_hz * sim_s) <= 1, f"{name}: {counts[name]} frames in {sim_s} s"


# --- (e) the truth log ----------------------------------------------------------------------------------
def test_truth_log_has_one_row_per_period_with_the_expected_columns(tmp_path: Path) -> None:
    log_path = tmp_path / "run" / "truth.csv"
    cfg = _config(_channel("truth"), truth_log=str(log_path), duration_s=1.0)
    with bench_and_onboard(cfg) as (bench, onboard):
        # GIVEN a 1 s run WHEN the onboard answers until the bench ends it
        tick = start(onboard)
        while bench.thread.is_alive():
            onboard.answer(tick)
            try:
                tick = onboard.next_tick(timeout_s=0.5)
            except TimeoutError:
                break
        result = bench.join()
    assert result.stop_reason.startswith("duration")
    # THEN the CSV has the columns the plots read and one row per simulated period, starting at the pose
    with log_path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows, "empty truth log"
    for column in ("t_s", "x_m", "y_m", "depth_m", "yaw_deg"):
        assert column in rows[0], f"missing column {column}"
    assert [float(r["t_s"]) for r in rows] == pytest.approx([(i + 1) * PERIOD_S for i in range(20)])
    assert float(rows[0]["x_m"]) == pytest.approx(2.0, abs=0.01)
    assert float(rows[0]["y_m"]) == pytest.approx(-3.0, abs=0.01)
    assert float(rows[0]["depth_m"]) == pytest.approx(1.5, abs=0.01)
    assert float(rows[0]["yaw_deg"]) == pytest.approx(30.0, abs=0.1)
    assert {r["onboard_state"] for r in rows} == {"RUNNING"}


def test_a_period_counts_as_commanded_only_with_both_command_frames() -> None:
    # GIVEN an armed actuator node that received both frames once
    from hil_sim.bench_program import ActuatorNode

    node = ActuatorNode(timeout_periods=3)
    node.take(m.OnboardHeartbeat(m.MissionStateCode.RUNNING, 1.0))
    node.take(m.FinCmd(0.1, 0.0, 0.0))
    node.take(m.PropCmd(20.0, m.ActuatorMode.ARMED))
    assert node.end_period().propeller_rps == 20.0 and node.armed
    # WHEN only PROP_CMD keeps coming (every FIN_CMD rejected by the E2E checks)
    for _ in range(3):
        node.take(m.PropCmd(20.0, m.ActuatorMode.ARMED))
        out = node.end_period()
    # THEN the watchdog fires: stale fins are not kept alive by a fresh propeller frame; no longer armed
    assert node.watchdog.failsafe and out.propeller_rps == 0.0 and out.rudder_rad == 0.0
    assert not node.armed


def test_armed_commands_move_nothing_unless_the_onboard_heartbeat_says_live() -> None:
    # GIVEN the actuator node and a second sender of valid FIN_CMD + PROP_CMD frames (30 rps, rudder 0.3)
    from hil_sim.bench_program import ActuatorNode

    node = ActuatorNode(timeout_periods=5, heartbeat_timeout_periods=3)

    def period() -> tuple[float, float]:
        node.take(m.FinCmd(0.3, 0.0, 0.0))
        node.take(m.PropCmd(30.0, m.ActuatorMode.ARMED))
        out = node.end_period()
        return out.propeller_rps, out.rudder_rad

    # WHEN no onboard heartbeat was ever heard, or it says IDLE (the firmware is disarmed)
    assert period() == (0.0, 0.0)
    node.take(m.OnboardHeartbeat(m.MissionStateCode.IDLE, 1.0))
    assert [period() for _ in range(10)] == [(0.0, 0.0)] * 10
    # THEN nothing moves, the watchdog stays fed (no failsafe), and the node counts the refused periods
    assert not node.watchdog.failsafe and not node.armed and node.refused_periods == 11
    # WHEN the onboard says RUNNING: obeyed; once its heartbeat is older than the timeout: neutral again
    node.take(m.OnboardHeartbeat(m.MissionStateCode.RUNNING, 2.0))
    assert period() == (30.0, 0.3) and node.armed
    assert [period() for _ in range(3)] == [(30.0, 0.3)] * 3
    assert period() == (0.0, 0.0) and not node.armed
