"""Importing the planner does nothing but define it: no file is read or written
(beyond the modules' own code), no import hook is installed, and no numba kernel
is compiled. A program chooses when to check a stale build
(``planner.native.use_sources_if_stale``) and when to compile the kernels
(``warm_up``)."""

from __future__ import annotations

import json
import subprocess
import sys

#: Run in a fresh interpreter: the planner's dependencies first, then every planner
#: module, watching what the imports open. numba probes that its cache directory
#: (``__pycache__``) is writable when a ``cache=True`` kernel is defined: not a file.
PROBE = """
import importlib, json, pkgutil, sys
import numba, numpy, networkx, scipy.ndimage
from numba.core.registry import CPUDispatcher

CODE = (".py", ".pyc", ".so")
opened = []

def watch(event, args):
    if event in ("open", "os.mkdir", "os.remove", "os.rename"):
        path = str(args[0])
        if not path.endswith(CODE) and not path.endswith("__pycache__"):
            opened.append(path)

sys.addaudithook(watch)
hooks = list(sys.meta_path)
import planner
names = [m.name for m in pkgutil.walk_packages(planner.__path__, "planner.")]
for name in names:
    importlib.import_module(name)
kernels = [
    (name, value.__name__, len(value.signatures))
    for name in names
    for value in vars(sys.modules[name]).values()
    if isinstance(value, CPUDispatcher)
]
print(json.dumps({
    "opened": opened,
    "hooks_unchanged": sys.meta_path == hooks,
    "modules": names,
    "kernels": kernels,
}))
"""


def test_importing_the_planner_opens_nothing_and_compiles_nothing() -> None:
    done = subprocess.run(
        [sys.executable, "-c", PROBE], capture_output=True, text=True, timeout=120, check=True
    )
    seen = json.loads(done.stdout)
    assert seen["opened"] == []
    assert seen["hooks_unchanged"]
    assert "planner.coordinator" in seen["modules"]
    assert seen["kernels"], "no numba kernel found: the probe looks in the wrong place"
    assert [k for k in seen["kernels"] if k[2]] == []
