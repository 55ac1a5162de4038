"""Faults in the bench (issue 24 item 4): each kind seen where the onboard would see it, on the bus.

The bench runs ``run_bench`` in lock-step on a ``virtual`` bus (helpers of test_bench_program.py); the test
plays the onboard (RUNNING heartbeat, rudder 0.1 rad, propeller 20 rev/s every period) and keeps every frame
the bench publishes. Each faulted run is compared with its fault-free twin (same seed): the faults draw no
random numbers, so the two differ only by the fault.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from hil_sim.bench_program import BenchResult, HilConfig
from hil_sim.model import faults as fm
from onboard.protocol import messages as m
from tests.integration import test_bench_program as tb

SIM_S = 4.0  # simulated seconds per run
START_S, DURATION_S = 1.0, 1.5  # every windowed fault here: [1.0, 2.5) s


@dataclass
class Flight:
    #: everything the bench published after the start, in order, with the simulated time of the SYNC it came
    #: before (the end of the period its sensors sampled: the integration step is the control period, so
    #: that is each sample's time; a received frame's own ``t_sample_s`` is the receiver's clock)
    frames: list[tuple[float, m.BusMessage]]
    truth: list[dict[str, float]]
    result: BenchResult

    def of(self, cls: type) -> list[tuple[float, Any]]:
        """(simulated s, the frame with its receive stamp zeroed, so two runs compare) of one type."""
        return [(t, dataclasses.replace(f, t_sample_s=0.0)) for t, f in self.frames if isinstance(f, cls)]


def _fly(tmp_path: Path, name: str, faults: tuple[fm.Fault, ...] = (), profile: str = "basin") -> Flight:
    log_path = tmp_path / f"{name}.csv"
    cfg = tb._config(
        tb._channel(f"fault-{name}"), truth_log=str(log_path), duration_s=SIM_S, sensor_profile=profile
    )
    frames: list[tuple[float, m.BusMessage]] = []
    with tb.bench_and_onboard(cfg, faults) as (bench, onboard):
        tick = tb.start(onboard)
        frames += [(tick.sync.sim_time_s, f) for f in tick.before]
        while True:
            onboard.answer(tick, state=m.MissionStateCode.RUNNING)
            try:
                tick = onboard.next_tick(timeout_s=2.0)
            except TimeoutError:
                break  # the bench ended the run (its duration)
            frames += [(tick.sync.sim_time_s, f) for f in tick.before]
        result = bench.join()
    with log_path.open(newline="") as f:
        truth = [{k: float(v) for k, v in r.items() if k != "onboard_state"} for r in csv.DictReader(f)]
    return Flight(frames, truth, result)


def _window(t: float) -> bool:
    return START_S <= t < START_S + DURATION_S


@pytest.fixture(scope="module")
def twin(tmp_path_factory: pytest.TempPathFactory) -> Flight:
    """The fault-free run every faulted one is compared with."""
    return _fly(tmp_path_factory.mktemp("twin"), "twin")


def _events(flight: Flight) -> list[tuple[float, str, str]]:
    return [(e["t_s"], e["event"], e["fault"]) for e in flight.result.fault_events]


def test_dvl_dropout_sends_no_dvl_frame_in_its_window(tmp_path: Path, twin: Flight) -> None:
    # GIVEN a DVL dropout from 1.0 s for 1.5 s WHEN the run is flown
    run = _fly(tmp_path, "dvl", (fm.DvlDropout(START_S, DURATION_S),))
    # THEN no DVL frame is sampled in the window, the twin's frames outside it, the rest of the bus unchanged
    dvl = run.of(m.DvlVelocity)
    assert dvl and not [t for t, _ in dvl if _window(t)]
    assert dvl == [(t, f) for t, f in twin.of(m.DvlVelocity) if not _window(t)]
    assert run.of(m.AhrsAttitude) == twin.of(m.AhrsAttitude) and run.of(m.PositionFix) == twin.of(
        m.PositionFix
    )
    # AND the truth log and the result record its start and end
    name = "dvl_dropout(start_s=1, duration_s=1.5)"
    assert _events(run) == [(1.0, "start", name), (2.5, "end", name)]
    assert run.result.faults == [name]
    assert all(r["fault_dvl_dropout"] == (1.0 if _window(r["t_s"]) else 0.0) for r in run.truth)


def test_fix_outage_sends_no_position_fix_in_its_window(tmp_path: Path, twin: Flight) -> None:
    run = _fly(tmp_path, "fix", (fm.FixOutage(START_S, DURATION_S),))
    fixes = run.of(m.PositionFix)
    assert fixes and not [t for t, _ in fixes if _window(t)]
    assert fixes == [(t, f) for t, f in twin.of(m.PositionFix) if not _window(t)]
    assert run.of(m.DvlVelocity) == twin.of(m.DvlVelocity)
    assert [r["fault_fix_outage"] for r in run.truth].count(1.0) == round(DURATION_S * tb.RATE_HZ)


def test_compass_bias_shifts_the_heading_on_the_bus_not_the_truth(tmp_path: Path, twin: Flight) -> None:
    run = _fly(tmp_path, "compass", (fm.CompassBias(START_S, bias_deg=8.0),))
    # THEN the AHRS heading is the twin's + 8 deg from the start, the same before
    pairs = list(zip(run.of(m.AhrsAttitude), twin.of(m.AhrsAttitude), strict=True))
    assert len(pairs) > 60
    for (t, got), (_, ref) in pairs:
        shift = math.degrees(math.remainder(got.yaw_rad - ref.yaw_rad, 2 * math.pi))
        assert shift == pytest.approx(8.0 if t >= START_S else 0.0, abs=0.01)  # the frame's resolution
    # AND the truth is the twin's (the onboard in this test does not steer on the heading)
    assert [r["yaw_deg"] for r in run.truth] == [r["yaw_deg"] for r in twin.truth]
    assert run.truth[-1]["fault_compass_bias"] == 1.0


def test_a_stuck_depth_sensor_repeats_one_reading_while_the_truth_moves(tmp_path: Path, twin: Flight) -> None:
    run = _fly(tmp_path, "depth", (fm.DepthStuck(START_S),))
    stuck = [f.depth_m for t, f in run.of(m.DepthMeas) if t >= START_S]
    twin_depths = [f.depth_m for t, f in twin.of(m.DepthMeas) if t >= START_S]
    assert len(stuck) > 20 and set(stuck) == {twin_depths[0]}  # the reading at the start, then frozen
    assert len(set(twin_depths)) > 10
    before = [(t, f) for t, f in twin.of(m.DepthMeas) if t < START_S]
    assert [(t, f) for t, f in run.of(m.DepthMeas) if t < START_S] == before


def test_a_stuck_rudder_is_what_fin_status_reports_whatever_is_commanded(
    tmp_path: Path, twin: Flight
) -> None:
    # GIVEN the rudder stuck at -6 deg from 1.0 s while the onboard commands +0.1 rad (5.7 deg)
    run = _fly(tmp_path, "fin", (fm.FinStuck(START_S, fin="rudder", angle_deg=-6.0),))
    # THEN FIN_STATUS and the truth reach -6 deg (at the fin's slew rate) and stay; the command is unchanged
    late = [f.rudder_rad for t, f in run.of(m.FinStatus) if t >= START_S + 0.5]
    assert late and all(r == pytest.approx(math.radians(-6.0), abs=2e-3) for r in late)  # frame resolution
    assert max(f.rudder_rad for _, f in twin.of(m.FinStatus)) == pytest.approx(0.1, abs=2e-3)
    last = run.truth[-1]
    assert last["rudder_rad"] == pytest.approx(math.radians(-6.0)) and last[
        "rudder_cmd_rad"
    ] == pytest.approx(0.1)
    assert last["fault_fin_stuck"] == 1.0
    # AND the vehicle turns the other way than its twin
    assert (run.truth[-1]["yaw_deg"] - 30.0) * (twin.truth[-1]["yaw_deg"] - 30.0) < 0.0


def test_thrust_loss_slows_the_vehicle_at_the_same_propeller_speed(tmp_path: Path, twin: Flight) -> None:
    run = _fly(tmp_path, "thrust", (fm.ThrustLoss(START_S, fraction=0.5),))
    # THEN PROP_STATUS reports the twin's propeller speed, and the truth's speed falls behind the twin's
    assert run.of(m.PropStatus) == twin.of(m.PropStatus)
    u = {r["t_s"]: r["u_mps"] for r in run.truth}
    u_twin = {r["t_s"]: r["u_mps"] for r in twin.truth}
    assert all(u[t] == u_twin[t] for t in u if t <= START_S)
    assert u[SIM_S] < 0.9 * u_twin[SIM_S]
    assert run.truth[-1]["fault_thrust_loss"] == 1.0 and run.truth[0]["fault_thrust_loss"] == 0.0


def test_auv_hil_run_takes_repeatable_faults_and_refuses_a_bad_one_in_one_line(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import hil_sim.bench_program as bp

    # GIVEN two --fault options WHEN auv-hil run starts THEN the bench gets both, parsed
    got: dict[str, object] = {}

    def fake_run_bench(cfg: HilConfig, stop: object, faults: tuple[fm.Fault, ...] = ()) -> BenchResult:
        got["faults"] = faults
        return BenchResult()

    monkeypatch.setattr(bp, "run_bench", fake_run_bench)
    monkeypatch.setattr(bp.signal, "signal", lambda *_: None)  # the test process keeps its own handlers
    argv = [
        "--fault",
        "kind=dvl_dropout,start_s=10,duration_s=20",
        "--fault",
        "kind=thrust_loss,start_s=5,fraction=0.5",
    ]
    assert bp.run_main(argv) == 0
    assert got["faults"] == (fm.DvlDropout(10.0, 20.0), fm.ThrustLoss(5.0, fraction=0.5))
    # AND a bad one is one line naming the key, exit 2, before the bench starts
    got.clear()
    assert bp.run_main(["--fault", "kind=fin_stuck,fin=aileron,start_s=1,angle_deg=3"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "auv-hil: --fault 'kind=fin_stuck,fin=aileron,start_s=1,angle_deg=3': fin: must be one of rudder, "
        "stern_port, stern_starboard, got 'aileron'"
    ]
    assert not got
