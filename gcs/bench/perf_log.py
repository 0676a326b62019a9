"""What the mission log costs an offline run: each planner case of ``gcs bench perf``
run without its log and with it, side by side, compared."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from rich.table import Table

#: A run with its log may take at most this many times the same run without.
GOAL_LOG_RATIO = 1.3


@dataclass(frozen=True)
class Goal:
    """A goal of ``gcs bench perf``, judged on the figures that measure it."""

    what: str
    measured: str
    met: bool
    #: Judged beyond the goal's own cases (``STRETCH_KINDS``).
    stretch: bool = False


def log_pairs(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The cases run both ways, both finished: their run times (the whole ``simulate``,
    the log's last writes and close included) and the ratio."""
    without = {_key(r): r for r in rows if not r.get("log") and "error" not in r}
    pairs = []
    for r in rows:
        base = without.get(_key(r))
        if not r.get("log") or "error" in r or base is None:
            continue
        pairs.append(
            {
                "kind": r["kind"],
                "size": r["size"],
                "agents": r["agents"],
                "run_s_without": base["run_s"],
                "run_s_with": r["run_s"],
                "ratio": round(r["run_s"] / max(base["run_s"], 1e-9), 3),
                "log_mb": round(r["log_bytes"] / 1e6, 1),
                "writer_mb": r["log_peak_mb"],
                "writer_cpu_s": r["log_cpu_s"],
                "same_plan": base["total_path_m"] == r["total_path_m"],
            }
        )
    return pairs


def _key(row: dict[str, Any]) -> tuple[Any, ...]:
    return row["kind"], row["size"], row["agents"], tuple(sorted(row["settings"].items()))


#: The log's writer is a process of its own: its memory and processor time apart.
COLUMNS = ("map", "agents", "run s", "with log s", "ratio", "log MB", "writer MB", "writer cpu s")


def log_table(pairs: list[dict[str, Any]]) -> Table:
    table = Table(title="the mission log's cost (gcs plan --out against gcs plan)")
    for name in (*COLUMNS, "same plan"):
        table.add_column(name, justify="left" if name == "map" else "right")
    for p in pairs:
        table.add_row(
            f"{p['kind']} {p['size']}x{p['size']}",
            str(p["agents"]),
            f"{p['run_s_without']:.2f}",
            f"{p['run_s_with']:.2f}",
            f"{p['ratio']:.3f}",
            f"{p['log_mb']:.1f}",
            str(p["writer_mb"]),
            f"{p['writer_cpu_s']:.1f}",
            "yes" if p["same_plan"] else "NO",
        )
    return table


def log_goals(pairs: list[dict[str, Any]], side: int) -> list[Goal]:
    """The log's goal on the largest maps: within ``GOAL_LOG_RATIO`` of the run without."""
    return [
        Goal(
            f"planner, {p['kind']} {side}x{side}, {p['agents']} agents, with its mission log: "
            f"within {GOAL_LOG_RATIO:g} times the same run without",
            f"{p['run_s_with']:.1f} s against {p['run_s_without']:.1f} s (x{p['ratio']:.3f}), "
            f"{p['log_mb']:.0f} MB",
            p["ratio"] <= GOAL_LOG_RATIO and p["same_plan"],
        )
        for p in pairs
        if p["size"] == side
    ]
