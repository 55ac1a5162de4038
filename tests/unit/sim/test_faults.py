"""The fault schedule (hil_sim/model/faults.py): the one parser, the windows, and what each kind does to the
measurements and the actuator command (pure; the bench tests are tests/integration/test_bench_faults.py)."""

from __future__ import annotations

import math

import pytest

from hil_sim.model import faults as fm
from hil_sim.model.actuators import ActuatorCommand
from hil_sim.model.params import load_params
from hil_sim.model.sensors import AhrsMeasurement, DepthMeasurement, DvlMeasurement, PositionFix

#: The issue's acceptance list (issue 24 item 4), as a campaign spec writes it.
ISSUE_LIST = [
    [],
    [{"kind": "dvl_dropout", "start_s": 10, "duration_s": 20}],
    [{"kind": "fix_outage", "start_s": 0, "duration_s": 90}],
    [{"kind": "compass_bias", "start_s": 5, "bias_deg": 8}],
    [{"kind": "depth_stuck", "start_s": 8}],
    [{"kind": "fin_stuck", "fin": "rudder", "start_s": 12, "angle_deg": 6}],
    [{"kind": "thrust_loss", "start_s": 10, "fraction": 0.5}],
]


def test_the_issue_list_parses_and_round_trips() -> None:
    for entry in ISSUE_LIST:
        faults = fm.parse_faults(entry)
        assert [fm.to_dict(f) for f in faults] == [{k: v for k, v in d.items()} for d in entry]
        assert fm.parse_faults([fm.to_dict(f) for f in faults]) == faults
    assert fm.describe(fm.parse_faults(ISSUE_LIST[1])) == "dvl_dropout(start_s=10, duration_s=20)"
    assert fm.describe(()) == "none" and fm.short_label(()) == "none"
    assert fm.short_label(fm.parse_faults(ISSUE_LIST[5] + ISSUE_LIST[6])) == "fin_stuck+thrust_loss"


def test_the_command_line_form_is_the_same_fault() -> None:
    assert fm.parse_fault_option("kind=fin_stuck,fin=rudder,start_s=12,angle_deg=6") == fm.parse_fault(
        ISSUE_LIST[5][0]
    )
    assert fm.parse_fault_option(" kind = dvl_dropout , start_s=10, duration_s=20") == fm.DvlDropout(
        10.0, 20.0
    )


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ([{"kind": "dvl_drop", "start_s": 1}], r"^\[0\].kind: must be one of dvl_dropout, "),
        ([{"start_s": 1}], r"^\[0\].kind: must be one of .* got none"),
        ([{"kind": "dvl_dropout"}], r"^\[0\].start_s: missing"),
        (
            [{"kind": "dvl_dropout", "start_s": 1, "bias_deg": 3}],
            r"^\[0\].bias_deg: unknown key for dvl_dropout",
        ),
        ([{"kind": "fin_stuck", "start_s": 1, "angle_deg": 3}], r"^\[0\].fin: missing"),
        (
            [{"kind": "fin_stuck", "start_s": 1, "fin": "aileron", "angle_deg": 3}],
            r"fin: must be one of rudder",
        ),
        (
            [{"kind": "fin_stuck", "start_s": 1, "fin": "rudder", "angle_deg": 40}],
            r"angle_deg: must be within",
        ),
        ([{}, {"kind": "thrust_loss", "start_s": 1, "fraction": 0}], r"^\[0\].kind"),
        ([{"kind": "thrust_loss", "start_s": 1, "fraction": 1.5}], r"^\[0\].fraction: must be in \(0, 1\]"),
        ([{"kind": "compass_bias", "start_s": 1, "bias_deg": 0}], r"bias_deg: must be non-zero"),
        ([{"kind": "depth_stuck", "start_s": -1}], r"start_s: must be >= 0"),
        ([{"kind": "depth_stuck", "start_s": 1, "duration_s": 0}], r"duration_s: must be > 0"),
        ([{"kind": "depth_stuck", "start_s": "soon"}], r"start_s: expected a number, got 'soon'"),
        ([{"kind": "depth_stuck", "start_s": True}], r"start_s: expected a number"),
        ([{"kind": "depth_stuck", "start_s": math.nan}], r"start_s: must be finite"),
        ([3], r"^\[0\]: expected a mapping"),
        ({"kind": "depth_stuck"}, r"^expected a list of faults"),
    ],
)
def test_a_bad_fault_is_refused_with_its_key_and_reason(data: object, message: str) -> None:
    with pytest.raises(fm.FaultError, match=message):
        fm.parse_faults(data)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("dvl_dropout", r"expected kind=KIND,KEY=VALUE"),
        ("kind=dvl_dropout,start_s=ten", r"start_s: expected a number, got 'ten'"),
        ("kind=dvl_dropout,start_s=1,start_s=2", r"start_s: given twice"),
    ],
)
def test_a_bad_command_line_fault_is_refused(text: str, message: str) -> None:
    with pytest.raises(fm.FaultError, match=message):
        fm.parse_fault_option(text)


def test_a_window_is_half_open_and_without_a_duration_lasts() -> None:
    f = fm.DvlDropout(10.0, 20.0)
    assert [f.active(t) for t in (9.999, 10.0, 29.999, 30.0)] == [False, True, True, False]
    assert fm.DepthStuck(8.0).active(1e6) and fm.DepthStuck(8.0).end_s == math.inf


def _sensors(t: float, depth_m: float = 1.0) -> list:
    return [
        AhrsMeasurement(t, 0.0, 0.0, math.radians(175.0), 0.0, 0.0, 0.0),
        DepthMeasurement(t, depth_m),
        DvlMeasurement(t, 1.0, 0.0, 0.0),
        PositionFix(t, 1.0, 2.0, 0.5),
    ]


def test_each_sensor_fault_acts_on_its_sensor_only_inside_its_window() -> None:
    faults = fm.parse_faults(
        [
            {"kind": "dvl_dropout", "start_s": 1, "duration_s": 1},
            {"kind": "fix_outage", "start_s": 1, "duration_s": 1},
            {"kind": "compass_bias", "start_s": 1, "duration_s": 1, "bias_deg": 8},
            {"kind": "depth_stuck", "start_s": 1, "duration_s": 1},
        ]
    )
    memory = fm.FaultMemory()
    before, memory = fm.apply_to_measurements(faults, _sensors(0.5, 1.0), memory)
    assert before == _sensors(0.5, 1.0)  # nothing before the window
    first, memory = fm.apply_to_measurements(faults, _sensors(1.0, 2.0), memory)
    later, memory = fm.apply_to_measurements(faults, _sensors(1.5, 3.0), memory)
    for out, t in ((first, 1.0), (later, 1.5)):
        assert [type(x).__name__ for x in out] == ["AhrsMeasurement", "DepthMeasurement"]  # DVL, fix dropped
        yaw_deg = math.degrees(out[0].yaw_rad)
        assert yaw_deg == pytest.approx(-177.0)  # 175 + 8, wrapped
        assert out[1] == DepthMeasurement(t, 2.0)  # the first reading in the window, repeated
    after, memory = fm.apply_to_measurements(faults, _sensors(2.0, 4.0), memory)
    assert after == _sensors(2.0, 4.0)


def test_a_stuck_fin_holds_its_angle_and_thrust_loss_scales_thrust_only() -> None:
    faults = fm.parse_faults(
        [
            {"kind": "fin_stuck", "fin": "stern_port", "start_s": 12, "angle_deg": 6},
            {"kind": "thrust_loss", "start_s": 10, "fraction": 0.5},
        ]
    )
    cmd = ActuatorCommand(0.1, 0.2, 0.3, 20.0)
    assert fm.apply_to_command(faults, cmd, 11.9) == cmd
    assert fm.apply_to_command(faults, cmd, 12.0) == ActuatorCommand(0.1, math.radians(6.0), 0.3, 20.0)
    assert fm.thrust_factor(faults, 9.9) == 1.0 and fm.thrust_factor(faults, 10.0) == 0.5
    coeffs = load_params().coeffs
    half = fm.thrust_scaled(coeffs, 0.5)
    assert (half.T0, half.T1, half.T2, half.T3) == tuple(
        0.5 * c for c in (coeffs.T0, coeffs.T1, coeffs.T2, coeffs.T3)
    )
    assert half.Q2 == coeffs.Q2 and half.Xuu == coeffs.Xuu
    assert fm.thrust_scaled(coeffs, 1.0) is coeffs


def test_truth_flags_and_events() -> None:
    faults = fm.parse_faults(ISSUE_LIST[1] + ISSUE_LIST[6])
    assert fm.TRUTH_COLUMNS[0] == "fault_dvl_dropout" and len(fm.TRUTH_COLUMNS) == len(fm.KINDS) == 6
    assert fm.truth_flags(faults, 15.0) == [1, 0, 0, 0, 0, 1]
    assert fm.truth_flags(faults, 35.0) == [0, 0, 0, 0, 0, 1]
    a, b = fm.active_indices(faults, 15.0), fm.active_indices(faults, 35.0)
    assert [(e.t_s, e.event, e.index) for e in fm.events_between(faults, frozenset(), a)] == [
        (10.0, "start", 0),
        (10.0, "start", 1),
    ]
    ends = fm.events_between(faults, a, b)
    assert [(e.t_s, e.event, e.index) for e in ends] == [(30.0, "end", 0)]
    assert ends[0].to_dict()["fault"] == "dvl_dropout(start_s=10, duration_s=20)"
