"""Two real processes exchange protected frames through the bench hub (python-can-remote on 127.0.0.1)."""

from __future__ import annotations

import pytest

from hil_sim.busdemo import run_bus_demo

pytestmark = pytest.mark.e2e


def test_two_processes_exchange_protected_frames_through_the_hub() -> None:
    # GIVEN a hub on a free port and a peer process WHEN the bench sends 100 SYNCs at 100 Hz
    result = run_bus_demo(count=100, rate_hz=100.0, timeout_s=30.0)
    # THEN every SYNC is answered with FIN_CMD, PROP_CMD and SYNC_ACK, and nothing is rejected either way
    assert result.syncs_sent == 100
    assert result.answers_complete == 100
    assert result.rejected == {}
    assert result.peer["answered"] == 100 and result.peer["rejected"] == {}
