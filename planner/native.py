"""Which planner modules are compiled to native code (mypyc), and what runs when
their sources changed since.

An install builds the modules of ``COMPILED`` with mypyc (``setup.py``) and
records a hash of each source in ``native_build.json``. The extension modules
sit beside the sources and Python imports them first, so a source edited
since the build would not run. ``use_sources_if_stale``, which each program
calls before it imports a compiled module (``gcs.cli.main``,
the tests' ``conftest.py``; importing ``planner`` itself reads nothing),
compares the sources with the record: when any differs, every module of the
list is imported from its source (they are one compiled group, and compiled
code reads the attributes of the others' classes natively), with a warning
until they are built again. Nothing here imports beyond the standard library:
``setup.py`` reads the list before anything is installed.
"""

from __future__ import annotations

import hashlib
import importlib.abc
import importlib.machinery
import importlib.util
import json
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType

#: The planner's modules on every agent-step's path (with ``core.cells``, the cells and
#: directions they use), compiled by an install.
#: Modules that hold numba kernels stay Python: numba reads their bytecode.
COMPILED = (
    "core.cells",
    "planner.belief",
    "planner.btp",
    "planner.team",
    "planner.target_search",
    "planner.speed.settled_target",
    "planner.speed.memory",
    "planner.speed.search_scratch",
    "planner.speed.confirmation",
    "planner.speed.compiled_search",
    "planner.agent",
    "planner.staying_alive",
    "planner.traffic",
    "planner.give_way",
    "planner.sweep",
    "planner.pockets",
    "planner.targets",
    "planner.known_map",
    "planner.coordinator",
    "planner.turns",
)
#: What the build records beside the modules: {module: sha256 of its source}.
RECORD = "native_build.json"
HERE = Path(__file__).resolve().parent


def source_of(module: str, root: Path = HERE.parent) -> Path:
    return root.joinpath(*module.split(".")).with_suffix(".py")


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def record(root: Path) -> dict[str, str]:
    """The hashes an install writes to ``RECORD`` (in the package under ``root``)."""
    return {m: digest(source_of(m, root)) for m in COMPILED}


def built(module: str, root: Path = HERE.parent) -> Path | None:
    """The compiled extension module beside ``module``'s source, if any."""
    source = source_of(module, root)
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = source.with_suffix(suffix)
        if path.exists():
            return path
    return None


def stale(root: Path = HERE.parent) -> list[str]:
    """The compiled modules whose source is not the one they were built from."""
    try:
        kept = json.loads((root / "planner" / RECORD).read_text())
    except (OSError, ValueError):
        kept = {}
    return [
        m
        for m in COMPILED
        if built(m, root) is not None and kept.get(m) != digest(source_of(m, root))
    ]


def compiled() -> bool:
    """Does the planner run compiled: every module of ``COMPILED`` loaded native?"""
    native = tuple(importlib.machinery.EXTENSION_SUFFIXES)
    return all((importlib.import_module(m).__file__ or "").endswith(native) for m in COMPILED)


class _FromSources(importlib.abc.MetaPathFinder):
    """Finds the modules of ``COMPILED`` as their sources, ahead of the extensions."""

    def __init__(self, root: Path) -> None:
        self.root = root

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname not in COMPILED:
            return None
        return importlib.util.spec_from_file_location(fullname, source_of(fullname, self.root))


def use_sources_if_stale(root: Path = HERE.parent) -> None:
    """Import the modules of ``COMPILED`` from their sources from now on, when the
    build beside them is stale; idempotent. Call it before any of them is imported."""
    changed = stale(root)
    if not changed or any(isinstance(f, _FromSources) for f in sys.meta_path):
        return
    sys.meta_path.insert(0, _FromSources(root))
    warnings.warn(
        f"{', '.join(changed)} changed since the planner was compiled: it runs as "
        "Python (slower) until `pip install -e .` builds it again",
        RuntimeWarning,
        stacklevel=2,
    )
