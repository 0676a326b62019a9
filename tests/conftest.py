"""Test-wide settings.

Before anything imports the planner, a stale build of its compiled modules is
set aside for their sources (``planner.native.use_sources_if_stale``), as the
programs do. Under CI the property tests use a fixed derandomised search, so that a run
is reproducible; locally hypothesis explores new examples every run.
"""

from __future__ import annotations

import os

import pytest

from planner.native import use_sources_if_stale

use_sources_if_stale()

from hypothesis import settings  # noqa: E402

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")


#: Test files that fly missions or time links in real time (a mock fleet at a
#: speed-up, MAVLink over sockets, a browser). Under pytest-xdist they all run on one
#: worker, one after another: two of them side by side on two cores starve each
#: other's event loops, and a mock vehicle at a speed-up of 20 flies on while its
#: station waits for the processor. The other tests share the second worker.
REAL_TIME = frozenset(
    {
        "tests/core/test_clocks.py",
        "tests/gcs/bench/test_faults.py",
        "tests/gcs/log/test_foxglove_live.py",
        "tests/gcs/log/test_mcap_log.py",
        "tests/gcs/test_mock_cli.py",
        "tests/gcs/test_sitl_ardupilot.py",
        "tests/sitl_mock/test_mock_endpoint.py",
        "tests/vehicles/test_no_vehicles.py",
        "tests/vehicles/test_signing.py",
    }
)
REAL_TIME_FOLDERS = ("tests/gcs/live/", "tests/gcs/web/")


def real_time(path: str) -> bool:
    """Does the test file at ``path`` (from the repository's root) run in real time?"""
    return path in REAL_TIME or path.startswith(REAL_TIME_FOLDERS)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    root = config.rootpath
    for item in items:
        if real_time(item.path.relative_to(root).as_posix()):
            item.add_marker(pytest.mark.xdist_group("real_time"))
