"""Views of the code's structure: who imports whom, the largest modules, the longest
functions and the widest signatures. Read by people reviewing a change of layout
(run it on two commits and compare); the suite holds the rules themselves.

    python tools/structure.py [ROOT] [--graph modules|packages] [--top N]
"""

from __future__ import annotations

import argparse
import ast
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path

PACKAGES = ("core", "planner", "vehicles", "sitl_mock", "gcs")
LONG = 60
WIDE = 8


@dataclass(frozen=True)
class Function:
    where: str
    lines: int
    params: int


def modules(root: Path) -> dict[str, Path]:
    """Every module of the product by its dotted name."""
    found: dict[str, Path] = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = path
    return found


def imports(path: Path, name: str) -> set[str]:
    """The product's modules that ``name`` imports, at any depth of the file."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            out.add(base)
            out.update(f"{base}.{alias.name}" for alias in node.names)
    return {m for m in out if m.split(".")[0] in PACKAGES}


def graph(root: Path, level: str) -> dict[str, set[str]]:
    """Edges between modules (or top-level packages) that exist in the tree."""
    known = modules(root)
    edges: dict[str, set[str]] = defaultdict(set)
    for name, path in known.items():
        for target in imports(path, name):
            if target not in known:
                continue
            if level == "modules":
                a, b = name, target
            else:
                a, b = name.split(".")[0], target.split(".")[0]
            if a != b:
                edges[a].add(b)
    return edges


def functions(root: Path) -> list[Function]:
    rows = []
    for name, path in modules(root).items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                args = node.args
                count = len(args.posonlyargs) + len(args.args) + len(args.kwonlyargs)
                if args.args and args.args[0].arg in ("self", "cls"):
                    count -= 1
                end = node.end_lineno or node.lineno
                rows.append(Function(f"{name}.{node.name}", end - node.lineno + 1, count))
    return rows


def report(root: Path, level: str, top: int) -> str:
    lines = [f"# structure of {root.name}", ""]
    sizes = {
        name: len(path.read_text(encoding="utf-8").splitlines())
        for name, path in modules(root).items()
    }
    per_package = Counter[str]()
    for name, size in sizes.items():
        per_package[name.split(".")[0]] += size
    lines.append("lines per package: " + ", ".join(f"{p} {n}" for p, n in per_package.items()))
    lines.append(f"modules over 400 lines: {sum(size > 400 for size in sizes.values())}")
    largest = sorted(sizes.items(), key=lambda x: -x[1])[:top]
    lines += [f"  {size:5d}  {name}" for name, size in largest]
    rows = functions(root)
    long = sorted((f for f in rows if f.lines > LONG), key=lambda f: -f.lines)
    wide = sorted((f for f in rows if f.params > WIDE), key=lambda f: -f.params)
    by_package = Counter(f.where.split(".")[0] for f in long)
    lines.append(f"functions over {LONG} lines: {len(long)} ({dict(by_package)})")
    lines += [f"  {f.lines:5d}  {f.where}" for f in long[:top]]
    lines.append(f"functions with over {WIDE} parameters: {len(wide)}")
    lines += [f"  {f.params:5d}  {f.where}" for f in wide[:top]]
    lines += ["", f"imports between {level} (mermaid):", "", "graph TD"]
    for source, targets in sorted(graph(root, level).items()):
        lines += [f"  {source} --> {target}" for target in sorted(targets)]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", nargs="?", type=Path, default=Path(__file__).parents[1])
    parser.add_argument("--graph", choices=("modules", "packages"), default="packages")
    parser.add_argument("--top", type=int, default=15, help="rows of each list (default 15)")
    options = parser.parse_args()
    print(report(options.root.resolve(), options.graph, options.top))


if __name__ == "__main__":
    main()
