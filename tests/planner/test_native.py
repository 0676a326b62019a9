"""The planner's compiled modules (``planner/native.py``): used when built from the
sources as they are, never when a source changed since the build."""

from __future__ import annotations

import importlib.machinery
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from planner import native
from planner.agent import Action, ActionKind

SUFFIX = importlib.machinery.EXTENSION_SUFFIXES[0]
#: The packages whose modules ``native.COMPILED`` may list.
PACKAGES = ("planner", "core")


def _planner_copy(root: Path) -> Path:
    """The planner's sources (and ``core``'s) under ``root``, each compiled module with an extension
    file beside it that cannot load (so only the sources can run), and a record
    of the sources as they are."""
    for package in PACKAGES:
        shutil.copytree(
            native.HERE.parent / package,
            root / package,
            ignore=shutil.ignore_patterns("*.so", "*.json", "__pycache__"),
        )
    for module in native.COMPILED:
        native.source_of(module, root).with_suffix(SUFFIX).write_bytes(b"not a library")
    (root / "planner" / native.RECORD).write_text(json.dumps(native.record(root)))
    return root


def test_every_compiled_module_is_a_planner_or_core_source() -> None:
    for module in native.COMPILED:
        assert module.split(".")[0] in PACKAGES
        assert native.source_of(module).is_file()


def test_a_source_changed_since_the_build_is_stale(tmp_path: Path) -> None:
    root = _planner_copy(tmp_path)
    assert native.stale(root) == []
    with native.source_of("planner.belief", root).open("a") as source:
        source.write("# changed\n")
    assert native.stale(root) == ["planner.belief"]
    (root / "planner" / native.RECORD).unlink()
    assert native.stale(root) == list(native.COMPILED)  # built, but from what is unknown


def test_a_stale_build_runs_every_compiled_module_from_its_source(tmp_path: Path) -> None:
    root = _planner_copy(tmp_path)
    with native.source_of("planner.belief", root).open("a") as source:
        source.write("# changed\n")
    probe = (
        "import importlib, sys\n"
        "from planner import native\n"
        "native.use_sources_if_stale()\n"
        "for m in native.COMPILED: importlib.import_module(m)\n"
        "print([sys.modules[m].__file__.endswith('.py') for m in native.COMPILED])"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe],
        cwd=root,
        env={**os.environ, "PYTHONPATH": str(root)},
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    )
    # The extensions beside them cannot load: each module came from its source.
    assert done.stdout.strip() == str([True] * len(native.COMPILED))
    assert "planner.belief changed since the planner was compiled" in done.stderr


def test_the_installed_planner_runs_compiled_unless_its_sources_changed() -> None:
    if native.stale():
        assert not native.compiled()  # the sources run, not what was built from others
    elif os.environ.get("STAYING_ALIVE_PURE"):
        assert not any(native.built(m) for m in native.COMPILED)
    else:
        assert native.compiled(), "the install did not compile the planner (see setup.py)"


def test_an_action_is_a_value_and_read_only_when_compiled() -> None:
    move, same = Action(ActionKind.MOVE, (2, 3)), Action(ActionKind.MOVE, (2, 3))
    assert move == same and hash(move) == hash(same)
    assert move != Action(ActionKind.MOVE, (3, 2)) and move != Action(ActionKind.WAIT)
    assert repr(move) == "Action(move, (2, 3))"
    if native.compiled():
        with pytest.raises(AttributeError):
            move.to = (0, 0)  # type: ignore[misc]
