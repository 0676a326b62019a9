"""The rules the code is held to, checked by the suite itself (the README's test
command runs them, and so does CI): ruff's lint and format, mypy over the whole tree
(the product, its tests and tools), the layers' imports, and the size rules of a
module, a function and a compiled kernel."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import real_time

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("core", "planner", "vehicles", "sitl_mock", "gcs")
#: Everything mypy reads: the product, its tests and the developer's tools.
TYPED = (*PACKAGES, "tests", "tools", "web")
#: What each package may not import: the layers, bottom (``core``) to top (``gcs``).
FORBIDDEN = {
    "core": ("planner", "vehicles", "sitl_mock", "gcs"),
    "planner": ("vehicles", "sitl_mock", "gcs"),
    "vehicles": ("planner", "sitl_mock", "gcs"),
    "sitl_mock": ("planner", "gcs"),
}

pytestmark = pytest.mark.timeout(300)


def _run(*argv: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=280,
        check=False,
    )


def test_ruff_finds_nothing() -> None:
    done = _run("ruff", "check", ".")
    assert done.returncode == 0, done.stdout + done.stderr


def test_ruff_format_has_nothing_to_change() -> None:
    done = _run("ruff", "format", "--check", ".")
    assert done.returncode == 0, done.stdout + done.stderr


def test_mypy_finds_nothing_in_the_tree(tmp_path: Path) -> None:
    done = _run("mypy", "--cache-dir", str(tmp_path / "mypy"), *TYPED)
    assert done.returncode == 0, done.stdout + done.stderr


def _imported(path: Path) -> set[str]:
    """The top-level packages ``path`` imports, at any depth of its code."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_imports_flow_down_the_layers(package: str) -> None:
    """``core`` imports none of the others; ``planner`` (pure) and ``vehicles`` (how we
    talk to a vehicle) know nothing of each other, of the mock or of the station; the
    mock fleet uses ``vehicles``' MAVLink helpers but not the planner; nothing imports
    ``gcs``."""
    offenders = [
        f"{path.relative_to(ROOT)}: {name}"
        for path in sorted((ROOT / package).rglob("*.py"))
        for name in sorted(_imported(path) & set(FORBIDDEN[package]))
    ]
    assert offenders == []


def _importing(folder: Path, modules: tuple[str, ...]) -> list[str]:
    """The lines of ``folder``'s modules that import one of ``modules``, at any depth."""
    prefixes = tuple(f"{kind} {m}" for kind in ("from", "import") for m in modules)
    return [
        f"{path.relative_to(ROOT)}: {line.strip()}"
        for path in sorted(folder.glob("*.py"))
        for line in path.read_text(encoding="utf-8").splitlines()
        if line.strip().startswith(prefixes)
    ]


def test_the_live_mission_imports_no_command_line() -> None:
    """``gcs.live`` is the mission, not a command: it imports no CLI module."""
    cli = ("gcs.cli", "gcs.sitl_cli", "gcs.commands", "gcs.options")
    assert _importing(ROOT / "gcs" / "live", cli) == []


def test_the_live_mission_builds_no_simulated_fleet() -> None:
    """A rehearsal's simulated fleet is built by its caller and handed to ``run_live``:
    ``gcs.live`` imports neither the mock fleet nor its faults."""
    sim = ("gcs.mock_fleet", "sitl_mock.fleet", "sitl_mock.faults")
    assert _importing(ROOT / "gcs" / "live", sim) == []


def test_the_benches_drive_the_product_through_its_api() -> None:
    """``gcs.bench`` runs missions through their API, never through a command's code
    (its own options, ``gcs.options``, hold only argparse tables and their defaults),
    nor starts one (``python -m gcs.cli``)."""
    bench = ROOT / "gcs" / "bench"
    started = [
        f"{path.relative_to(ROOT)}: {line.strip()}"
        for path in sorted(bench.glob("*.py"))
        for line in path.read_text(encoding="utf-8").splitlines()
        if '"gcs.cli"' in line or '"gcs.sitl_cli"' in line
    ]
    assert _importing(bench, ("gcs.cli", "gcs.sitl_cli", "gcs.commands")) + started == []


@pytest.mark.parametrize(
    ("tests", "allowed"),
    [("core", {"core"}), ("planner", {"core", "planner", "sitl_mock"})],
)
def test_the_lower_layers_are_tested_on_their_own(tests: str, allowed: set[str]) -> None:
    """The planner's tests need only the planner (and the simulated world for the
    truth it is flown against, ``tests/planner/flights.py``); ``core``'s only core."""
    product = set(PACKAGES)
    offenders = [
        f"{path.relative_to(ROOT)}: {name}"
        for path in sorted((ROOT / "tests" / tests).rglob("*.py"))
        for name in sorted((_imported(path) & product) - allowed)
    ]
    assert offenders == []


#: Functions that are argparse tables: one ``add_argument`` after another, read as a list.
ARGPARSE_TABLES = {"gcs/options/run.py:register", "gcs/options/bench.py:_perf"}


def _functions(package: str) -> list[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef]]:
    found = []
    for path in sorted((ROOT / package).rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                found.append((f"{path.relative_to(ROOT)}:{node.name}", node))
    return found


def _lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    return (node.end_lineno or node.lineno) - node.lineno + 1


def test_each_planner_module_reads_in_a_sitting() -> None:
    """No module of the planner over 400 lines."""
    long = [
        f"{path.relative_to(ROOT)}: {n}"
        for path in sorted((ROOT / "planner").rglob("*.py"))
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > 400
    ]
    assert long == []


def test_no_function_is_over_60_lines() -> None:
    """Docstrings included; argparse tables (``ARGPARSE_TABLES``) excepted."""
    long = [
        f"{where}: {_lines(node)}"
        for package in PACKAGES
        for where, node in _functions(package)
        if _lines(node) > 60 and where not in ARGPARSE_TABLES
    ]
    assert long == []


def test_no_compiled_kernel_takes_over_8_parameters() -> None:
    """numba kernels take their arrays in bundles (``planner/speed/kernel_args.py``)."""

    def is_kernel(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
        return any(
            "njit" in ast.unparse(decorator) or "jit" in ast.unparse(decorator)
            for decorator in node.decorator_list
        )

    wide = [
        f"{where}: {len(node.args.args)}"
        for where, node in _functions("planner")
        if is_kernel(node) and len(node.args.args) + len(node.args.kwonlyargs) > 8
    ]
    assert wide == []


#: What a test file that flies a mission or times a link in real time says.
REAL_TIME_SIGNS = ("speedup", "run_against_fleet", '"--sim"')


def test_real_time_tests_run_one_after_another() -> None:
    """A test file that flies a mock fleet at a speed-up is in the real-time group
    (``tests/conftest.py``): beside another such test on the second core, each
    starves the other's event loop."""
    outside = [
        path
        for file in sorted((ROOT / "tests").rglob("test_*.py"))
        if file != Path(__file__).resolve()
        and any(sign in file.read_text() for sign in REAL_TIME_SIGNS)
        and not real_time(path := file.relative_to(ROOT).as_posix())
    ]
    assert outside == []
