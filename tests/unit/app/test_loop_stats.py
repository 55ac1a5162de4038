"""LoopStats is the one owner of the overrun count, the lateness the overrun failsafe judges and the load
(issue 22, item 2: the control loop and the stand-alone vehicle each counted overruns their own way; the load
was never measured)."""

from __future__ import annotations

import math

import pytest

from onboard.app.loop import LoopStats


def test_overruns_and_the_lateness_of_a_run_of_them_are_counted_once_per_tick() -> None:
    # GIVEN a 0.1 s period  WHEN ticks end on time, then three late in a row, then on time again
    stats = LoopStats()
    late = [
        stats.end_tick(0.05, 0.1),  # on time
        stats.end_tick(0.25, 0.2),  # misses the deadline at 0.2
        stats.end_tick(0.32, 0.3),  # still behind
        stats.end_tick(0.45, 0.4),
        stats.end_tick(0.48, 0.5),  # back on time
    ]
    # THEN each late tick is one overrun, the lateness runs from the first deadline missed, and on time resets
    assert late == pytest.approx([0.0, 0.05, 0.12, 0.25, 0.0])
    assert stats.overruns == 3 and stats.max_consecutive_overruns == 3 and stats.consecutive_overruns == 0
    assert stats.max_late_s == pytest.approx(0.25) and stats.late_since_s is None


def test_the_load_is_the_busy_share_of_the_period() -> None:
    stats = LoopStats()
    assert math.isnan(stats.load)  # before the first tick: unknown (SYS_STATUS says 0)
    stats.note_busy(0.005, 0.05)
    assert stats.load == pytest.approx(0.1)
