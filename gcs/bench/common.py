"""What the ``gcs bench`` commands share: list options, planner settings given as
``KEY=VALUE``, and the JSON output."""

from __future__ import annotations

import argparse
import enum
import json
import types
import typing
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path
from typing import Any

import yaml
from rich.console import Console

from gcs.errors import UsageError
from planner.settings import PlannerSettings

#: Settings that come from the mission, not from the strategy being measured.
MISSION_SETTINGS = frozenset({"cell_size_m", "reserve_pct", "seed"})


def positive_numbers(text: str, what: str, kind: type = int) -> list[Any]:
    """A comma-separated option of positive numbers, e.g. ``--sizes 100,300``; whole
    numbers may be given as ranges too, e.g. ``--seeds 1-37``."""
    try:
        values: list[Any] = []
        for part in (x.strip() for x in text.split(",")):
            if kind is int and "-" in part[1:]:
                first, last = (int(end) for end in part.split("-", 1))
                values += range(first, last + 1)
            elif part:
                values.append(kind(part))
    except ValueError:
        raise UsageError(f"--{what}: expected comma-separated numbers, got {text!r}") from None
    if not values or any(v <= 0 for v in values):
        raise UsageError(f"--{what}: expected positive numbers, got {text!r}")
    return values


def chosen(text: str, what: str, known: Sequence[str]) -> list[str]:
    """A comma-separated option of names, each one of ``known``, e.g. ``--kinds rooms,open``."""
    names = [name.strip() for name in text.split(",") if name.strip()]
    if not names or any(name not in known for name in names):
        raise UsageError(f"--{what}: choose from {', '.join(known)}, got {text!r}")
    return names


def json_path(text: str) -> Path:
    """The ``--json`` option, checked before the bench runs (some run for an hour):
    its folder must exist and the path must not be a folder."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder, not a file")
    if not path.parent.is_dir():
        raise argparse.ArgumentTypeError(f"no folder {path.parent} to write {path.name} in")
    return path


def write_json(path: Path | None, figures: dict[str, Any], console: Console) -> None:
    """The figures as JSON to ``--json`` (if given); a file that cannot be written is a
    usage error naming it."""
    if path is None:
        return
    try:
        path.write_text(json.dumps(figures, indent=1) + "\n")
    except OSError as exc:
        raise UsageError(f"--json: cannot write {path}: {exc.strerror}") from exc
    console.print(f"wrote {path}")


def strategy_fields() -> dict[str, Any]:
    """The planner settings a strategy may change, with their types."""
    hints = typing.get_type_hints(PlannerSettings)
    return {
        f.name: hints[f.name] for f in fields(PlannerSettings) if f.name not in MISSION_SETTINGS
    }


def _coerce(key: str, kind: Any, value: Any) -> Any:
    """``value`` (as YAML read it) as a value of the setting's type ``kind``."""
    options = typing.get_args(kind) if isinstance(kind, types.UnionType) else (kind,)
    if value is None and type(None) in options:
        return None
    for option in options:
        if isinstance(option, type) and issubclass(option, enum.Enum):
            try:
                return option(value)
            except ValueError:
                choices = ", ".join(str(m.value) for m in option)
                raise ValueError(f"{key}: choose from {choices}, got {value!r}") from None
        if option is bool and isinstance(value, bool):
            return value
        if option is int and isinstance(value, int) and not isinstance(value, bool):
            return value
        if option is float and isinstance(value, int | float) and not isinstance(value, bool):
            return float(value)
    raise ValueError(f"{key}: expected {_type_name(kind)}, got {value!r}")


def _type_name(kind: Any) -> str:
    options = typing.get_args(kind) if isinstance(kind, types.UnionType) else (kind,)
    return " or ".join("null" if o is type(None) else o.__name__ for o in options)


def parse_settings(pairs: Sequence[str], what: str) -> dict[str, Any]:
    """``KEY=VALUE`` pairs as planner setting overrides, checked as the planner checks them."""
    known = strategy_fields()
    overrides: dict[str, Any] = {}
    for pair in pairs:
        key, sep, text = pair.partition("=")
        key = key.strip()
        if not sep or not key:
            raise UsageError(f"--{what}: expected KEY=VALUE, got {pair!r}")
        if key not in known:
            raise UsageError(f"--{what}: unknown setting {key!r}; choose from {', '.join(known)}")
        try:
            overrides[key] = _coerce(key, known[key], yaml.safe_load(text))
        except yaml.YAMLError:
            raise UsageError(f"--{what}: cannot read the value of {pair!r}") from None
        except ValueError as exc:
            raise UsageError(f"--{what}: {exc}") from None
    try:
        PlannerSettings(**overrides)
    except ValueError as exc:
        raise UsageError(f"--{what}: {exc}") from None
    return overrides
