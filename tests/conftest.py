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
import signal
import tempfile
from pathlib import Path
from typing import Any

import pytest

TIERS = ("unit", "integration", "e2e")

# The operator's Ctrl-C, as the tests send it (SIGINT to `auv-gcs fly`, `monitor`, a campaign), must reach the
# programs they start. A suite started in the background of a non-interactive shell (`make test &`, nohup)
# inherits SIGINT ignored, and an ignored signal stays ignored across exec: each program would then never
# see it. Handled here (a handler is reset to the default on exec), the programs get the default.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

#: Tests that must not run beside one another in parallel (``make test``: pytest-xdist ``--dist loadgroup``
#: runs a group on one worker, one test after the other): node id prefixes by group. The scheduler below reads
#: this table itself: xdist's ``xdist_group`` mark is lost with pytest 9.2 (pytest-xdist issue 1386).
GROUPS: dict[str, tuple[str, ...]] = {
    # The floods load the whole machine; the others judge in real time what a loaded machine delays
    # (the actuator watchdog and the loop's lateness under stalls, a replay's rate, each peer's budget).
    "real_time": (
        "tests/e2e/test_floods.py",
        "tests/e2e/test_loaded_watchdogs.py::test_firmware_stalls_shorter_than_the_timeout_do_not_abort_a_100_hz_mission",
        "tests/e2e/test_can_impostor.py",
        "tests/integration/mavlink/test_peer_isolation.py",
    ),
    # One flight and one browser for the module (module-scoped fixtures): its tests on one worker, not a
    # flight per worker.
    "map_browser": ("tests/e2e/test_map_browser.py",),
    # A Ray cluster each: Ray's own ports (the dashboard agent's, the client server's) are fixed.
    "ray": (
        "tests/integration/test_campaign.py::test_same_results_with_one_worker_two_workers_and_ray",
        "tests/integration/test_campaign.py::test_join_a_running_ray_cluster_by_its_address",
    ),
}
#: The order tests are handed to the workers in: the groups and the slow first, the many short unit tests
#: last, where they fill the workers' ends (a long test handed out last would run on alone).
_RANK = {"group": 0, "slow": 1, "e2e": 2, "integration": 3, "unit": 4}
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


def group_of(nodeid: str) -> str | None:
    """The :data:`GROUPS` group a test belongs to, or None."""
    for name, prefixes in GROUPS.items():
        for p in prefixes:
            if nodeid == p or nodeid.startswith((p + "::", p + "[")):
                return name
    return None


def _rank(item: pytest.Item) -> int:
    if group_of(item.nodeid) is not None:
        return _RANK["group"]
    if item.get_closest_marker("slow") is not None:
        return _RANK["slow"]
    return min(_RANK[t] for t in TIERS if item.get_closest_marker(t) is not None)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    """With ``--dist loadgroup``: pytest-xdist's load-scope scheduler, a scope per test except the
    :data:`GROUPS`, each one scope (one worker, its tests one after the other)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class GroupScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            group = group_of(nodeid)
            return f"group:{group}" if group is not None else nodeid

    return GroupScheduling(config, log)


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
    items.sort(key=_rank)  # stable: the order within a rank is the collection's
