"""Shared fixtures for the simulator core tests."""

from __future__ import annotations

import pytest

from hil_sim.model.params import VehicleParams, load_params


@pytest.fixture(scope="session")
def params() -> VehicleParams:
    """The packaged ISiMI100 parameters (derived once per session)."""
    return load_params()
