"""Test-wide settings.

Under CI the property tests use a fixed derandomised search, so that a run
is reproducible; locally hypothesis explores new examples every run.
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")
