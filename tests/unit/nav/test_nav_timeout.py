"""Navigation staleness has one timeout, the operator's FS_NAV_TMO_S (``[failsafe] nav_timeout_s``): it
decides when attitude and depth are too old, for the estimator's conditions, the vehicle's readiness and
the abort (issue 22, item 2: with attitude 2 s old the vehicle aborted whether FS_NAV_TMO_S was 1 or 5)."""

from __future__ import annotations

import pytest

from auv_common.config import ConfigError, from_table
from onboard.core import commands as c
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionState
from onboard.core.nav import NavCondition
from onboard.core.nav.estimator import NavParams
from onboard.core.params import BusLimits
from onboard.core.plans import compute_plan
from onboard.protocol import messages as m
from onboard.protocol.codec import command_ranges

DT = 0.05
BUS = BusLimits.from_ranges(command_ranges())


def _sensors(t_s: float, attitude_t_s: float) -> dict[type, object]:
    """Every sensor fresh at ``t_s`` except the attitude (and its rates), last sampled at ``attitude_t_s``."""
    msgs = [
        m.AhrsAttitude(0.0, 0.0, 0.0, attitude_t_s),
        m.AhrsRates(0.0, 0.0, 0.0, attitude_t_s),
        m.DepthMeas(1.0, t_s),
        m.DvlVelocity(1.0, 0.0, 0.0, True, t_s),
        m.PositionFix(t_s, 0.0, t_s),
    ]
    return {type(msg): msg for msg in msgs}


def _running(fs_nav_tmo_s: float) -> Autopilot:
    """A vehicle RUNNING a 50 m leg, FS_NAV_TMO_S set the way a ground station sets it (the one judge)."""
    ap = Autopilot(CoreConfig(), bus_limits=BUS)
    verdict = ap.handle(c.SetParam("FS_NAV_TMO_S", fs_nav_tmo_s))
    assert verdict.accepted and ap.config.failsafe.nav_timeout_s == fs_nav_tmo_s
    assert ap.replace_mission(Mission((Goal(50.0, 0.0, 1.0, 0.0),))).accepted
    ap.step(_sensors(0.0, 0.0), 0.0, DT)
    assert ap.handle(c.Arm()).accepted and ap.handle(c.Start()).accepted
    req = ap.take_plan_request()
    assert req is not None
    ap.plan_done(req.request_id, compute_plan(req))
    return ap


def _fly_with_attitude_frozen_at(ap: Autopilot, freeze_s: float, until_s: float) -> list[tuple[float, str]]:
    """Tick from ``freeze_s`` to ``until_s`` with the attitude frames stopped at ``freeze_s``; returns the
    (attitude age, state) of each tick."""
    seen = []
    k = 1
    while (t_s := freeze_s + k * DT) <= until_s + 1e-9:
        out = ap.step(_sensors(t_s, freeze_s), t_s, DT)
        seen.append((round(t_s - freeze_s, 3), out.status.state.name))
        k += 1
    return seen


def _first_abort_age_s(seen: list[tuple[float, str]]) -> float | None:
    return next((age for age, state in seen if state == "ABORT"), None)


@pytest.mark.parametrize(("fs_nav_tmo_s", "abort_after_s"), [(1.0, 1.0), (5.0, 5.0)])
def test_fs_nav_tmo_s_alone_decides_when_a_stale_attitude_aborts(
    fs_nav_tmo_s: float, abort_after_s: float
) -> None:
    # GIVEN a vehicle RUNNING with FS_NAV_TMO_S set by the operator
    ap = _running(fs_nav_tmo_s)
    for k in range(1, 11):
        assert ap.step(_sensors(k * DT, k * DT), k * DT, DT).status.state is MissionState.RUNNING
    # WHEN the attitude frames stop (every other sensor keeps sending) for 7 s
    seen = _fly_with_attitude_frozen_at(ap, 10 * DT, 10 * DT + 7.0)
    # THEN it runs on while the attitude is at most FS_NAV_TMO_S old and aborts on the first tick beyond it:
    # FS_NAV_TMO_S 1 -> ABORT by 2 s; 5 -> still RUNNING at 2 s, ABORT after 5 s
    assert _first_abort_age_s(seen) == pytest.approx(abort_after_s + DT)
    assert all(state == "RUNNING" for age, state in seen if age <= abort_after_s)
    assert "navigation stale" in ap.status.reason and "attitude age" in ap.status.reason
    running_at_2_s = dict(seen)[2.0] == "RUNNING"
    assert running_at_2_s is (fs_nav_tmo_s > 2.0)


def test_the_estimator_marks_attitude_stale_by_the_same_timeout() -> None:
    # GIVEN FS_NAV_TMO_S 5 and the attitude 2 s old
    ap = _running(5.0)
    ap.step(_sensors(0.05, 0.05), 0.05, DT)
    out = ap.step(_sensors(2.05, 0.05), 2.05, DT)
    # THEN the navigation is valid (not AHRS_STALE) and START would still be allowed
    assert not out.nav.conditions & NavCondition.AHRS_STALE and out.nav.valid
    assert ap.ready == (True, "")
    # and beyond 5 s it is AHRS_STALE, not valid, and the vehicle says why it is not ready
    out = ap.step(_sensors(5.2, 0.05), 5.2, DT)
    assert out.nav.conditions & NavCondition.AHRS_STALE and not out.nav.valid
    assert not ap.ready[0]


@pytest.mark.parametrize("key", ["ahrs_timeout_s", "depth_timeout_s"])
def test_a_config_with_the_removed_nav_timeouts_is_refused_with_the_reason(key: str) -> None:
    # GIVEN an old onboard.toml that still sets [nav] ahrs_timeout_s / depth_timeout_s
    # THEN it is refused in one line that names the key and the one timeout now in force
    with pytest.raises(ConfigError, match=rf"{key} was removed.*\[failsafe\] nav_timeout_s \(FS_NAV_TMO_S\)"):
        from_table(NavParams, {key: 0.5}, "onboard.toml [nav]")
