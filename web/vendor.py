#!/usr/bin/env python3
"""Vendor the page's npm packages into the Python package, reproducibly.

    python web/vendor.py          # npm ci (package-lock.json), then copy the files
    python web/vendor.py --check  # the vendored files are what MANIFEST.json says

The page loads nothing from the network at run time: the files an npm package
ships for browsers are copied into ``gcs/web/static/vendor/`` with the
package's licence, and ``MANIFEST.json`` records the version, the lock file's
integrity and each file's SHA-256, which the test suite checks.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
TARGET = HERE.parent / "gcs" / "web" / "static" / "vendor"
#: Package -> the files the page uses, relative to the package's folder.
FILES = {"leaflet": ["dist/leaflet.js", "dist/leaflet.css", "LICENSE"]}


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def vendor() -> dict[str, dict[str, object]]:
    subprocess.run(
        ["npm", "ci", "--ignore-scripts", "--no-audit", "--no-fund"], cwd=HERE, check=True
    )
    lock = json.loads((HERE / "package-lock.json").read_text())["packages"]
    manifest: dict[str, dict[str, object]] = {}
    for package, files in FILES.items():
        source = HERE / "node_modules" / package
        folder = TARGET / package
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        hashes = {}
        for name in files:
            copy = folder / Path(name).name
            shutil.copyfile(source / name, copy)
            hashes[copy.name] = sha256(copy)
        entry = lock[f"node_modules/{package}"]
        manifest[package] = {
            "version": entry["version"],
            "integrity": entry["integrity"],
            "files": hashes,
        }
    (TARGET / "MANIFEST.json").write_text(json.dumps(manifest, indent=2) + "\n")
    return manifest


def check() -> list[str]:
    """What differs between the vendored files and the manifest (nothing: [])."""
    manifest = json.loads((TARGET / "MANIFEST.json").read_text())
    problems = []
    for package, entry in manifest.items():
        for name, digest in entry["files"].items():
            path = TARGET / package / name
            if not path.is_file():
                problems.append(f"{path} is missing")
            elif sha256(path) != digest:
                problems.append(
                    f"{path} differs from its npm package ({package} {entry['version']})"
                )
    return problems


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only check the vendored files")
    args = parser.parse_args()
    if args.check:
        problems = check()
        print("\n".join(problems) or "vendored files match MANIFEST.json")
        return 1 if problems else 0
    for package, entry in vendor().items():
        print(f"vendored {package} {entry['version']} into {TARGET / package}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
