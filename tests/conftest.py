"""The suite's tiers and its per-process isolation.

Tiers (``-m unit``, ``-m integration``, ``-m e2e``; ``make check`` runs the unit tier): every test has
exactly one. The directory gives it (``tests/unit``, ``tests/integration``, ``tests/e2e``) unless the test or
its module names a tier itself: a file under ``unit/`` whose test starts a subprocess or an optuna study is
marked ``integration`` there, a test under ``integration/`` that runs the firmware and the bench as processes
``e2e``. Two tiers on one test is a usage error, so a tier cannot be claimed twice by accident.

Isolation (``make test`` runs the suite in parallel with pytest-xdist): tests already take free ports, their
own bus channels and tmp dirs; what a program falls back to when a test names no directory, the per-user
state and data directories (``$XDG_STATE_HOME``, ``$XDG_DATA_HOME``), is a temporary directory of this
pytest process (one per xdist worker), inherited by the programs the tests start.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest

TIERS = ("unit", "integration", "e2e")
_TESTS = Path(__file__).resolve().parent
_private_home: str | None = None


def pytest_configure(config: pytest.Config) -> None:
    global _private_home
    _private_home = tempfile.mkdtemp(prefix="auv-tests-home-")
    for var, sub in (("XDG_STATE_HOME", "state"), ("XDG_DATA_HOME", "share")):
        os.environ[var] = os.path.join(_private_home, sub)


def pytest_unconfigure(config: pytest.Config) -> None:
    if _private_home is not None:
        shutil.rmtree(_private_home, ignore_errors=True)


def tier_of_path(path: Path) -> str | None:
    """The tier a test file's directory gives it (``tests/<tier>/...``), or None outside the tiers."""
    try:
        parts = path.resolve().relative_to(_TESTS).parts
    except ValueError:
        return None
    return parts[0] if parts and parts[0] in TIERS else None


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    for item in items:
        named = {m.name for m in item.iter_markers() if m.name in TIERS}
        if len(named) > 1:
            raise pytest.UsageError(f"{item.nodeid}: more than one tier {sorted(named)}; a test has one")
        if named:
            continue
        tier = tier_of_path(Path(item.path))
        if tier is None:
            raise pytest.UsageError(
                f"{item.nodeid}: no tier (not under tests/{'|'.join(TIERS)}, none marked)"
            )
        item.add_marker(tier)
