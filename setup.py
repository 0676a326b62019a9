"""Compiles the planner's hot modules with mypyc when installed (see ``planner/native.py``).

``STAYING_ALIVE_PURE=1`` installs them as plain Python. Where they cannot be
compiled (no C compiler, say) the install goes on without, with a warning:
the planner is the same, only slower.
"""

from __future__ import annotations

import json
import os
import runpy
import sys
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
native = runpy.run_path(str(ROOT / "planner" / "native.py"))


def not_compiled(error: BaseException) -> None:
    print(f"warning: the planner was not compiled ({error}); it runs as Python", file=sys.stderr)


class OptionalBuildExt(build_ext):
    def run(self) -> None:
        try:
            super().run()
        except Exception as error:
            not_compiled(error)


def ext_modules() -> list[Extension]:
    if os.environ.get("STAYING_ALIVE_PURE"):
        return []
    sources = [str(native["source_of"](m, ROOT).relative_to(ROOT)) for m in native["COMPILED"]]
    try:
        from mypyc.build import mypycify

        modules = mypycify(sources, opt_level="3", group_name="planner")
    except (Exception, SystemExit) as error:  # mypyc exits on a type error
        not_compiled(error)
        return []
    record = ROOT / "planner" / native["RECORD"]
    record.write_text(json.dumps(native["record"](ROOT), indent=1) + "\n")
    return modules


setup(ext_modules=ext_modules(), cmdclass={"build_ext": OptionalBuildExt})
