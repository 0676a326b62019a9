"""What every ``gcs bench`` shares: its numeric list options and its JSON output."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from rich.console import Console

from gcs.errors import UsageError


def positive_numbers(text: str, what: str, kind: type = int) -> list[Any]:
    """A comma-separated option of positive numbers, e.g. ``--sizes 100,300``."""
    try:
        values = [kind(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise UsageError(f"--{what}: expected comma-separated numbers, got {text!r}") from None
    if not values or any(v <= 0 for v in values):
        raise UsageError(f"--{what}: expected positive numbers, got {text!r}")
    return values


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
