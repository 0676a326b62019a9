"""Test-wide settings.

Before anything imports the planner, a stale build of its compiled modules is
set aside for their sources (``planner.native.use_sources_if_stale``), as the
programs do. Under CI the property tests use a fixed derandomised search, so that a run
is reproducible; locally hypothesis explores new examples every run.
"""

from __future__ import annotations

import os

from planner.native import use_sources_if_stale

use_sources_if_stale()

from hypothesis import settings  # noqa: E402

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
