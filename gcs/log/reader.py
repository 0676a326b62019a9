"""Read a mission log (MCAP) back into a :class:`~gcs.outcome.result.RunResult`.

A finished log carries the whole result on ``/run/result`` and is rebuilt
exactly. A log whose writer died has no result and no summary section, and
may end inside a record: it is read record by record up to the last complete
chunk, and the result is reconstructed from what is there (the run's
metadata, every vehicle state, the last map, the events), marked with
``extra["log_truncated"] = 1``.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from mcap.records import Channel, Chunk, Footer, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import MCAP0_MAGIC

from core.cells import Cell, CellState, Direction
from gcs.log.result_json import AgentSteps, result_from_json
from gcs.log.topics import (
    BTPS_TOPIC,
    EVENTS_TOPIC,
    FLEET_STATES_TOPIC,
    GRID_COVERED,
    GRID_FREE,
    MAP_TOPIC,
    META_TOPIC,
    RESULT_TOPIC,
    codes_from_grid,
    readings_from_code,
)
from gcs.outcome.result import AgentTrace, BtpRecord, RunResult
from planner.agent import AgentMode, EventKind

#: Modes whose moves count as driving home after coverage, not as coverage path.
HOMING_MODES = frozenset({AgentMode.HOMING.value, AgentMode.DONE.value})


class LogError(ValueError):
    """The file is missing, not an MCAP file, or holds nothing to rebuild a run from."""


@dataclass
class VehicleState:
    t_s: float
    cell: Cell
    battery_pct: float
    mode: str
    #: What the vehicle sensed on arrival there (live missions), if anything.
    sensed: dict[Direction, CellState] | None = None


@dataclass
class LogEvent:
    t_s: float
    level: int
    name: str
    text: str

    @property
    def sysid(self) -> int | None:
        prefix, _, number = self.name.partition(" ")
        return int(number) if prefix == "vehicle" and number.isdigit() else None

    @property
    def kind(self) -> str:
        return self.text.partition(":")[0]


@dataclass
class LogContents:
    """What a mission log holds, decoded; ``truncated`` when the file ends early."""

    meta: dict[str, Any] | None = None
    result: dict[str, Any] | None = None
    states: dict[int, list[VehicleState]] = field(default_factory=dict)
    last_map: dict[str, Any] | None = None
    btps: list[Cell] = field(default_factory=list)
    events: list[LogEvent] = field(default_factory=list)
    topics: dict[str, str] = field(default_factory=dict)  # topic -> schema name
    truncated: bool = False


def mcap_records(path: Path) -> Iterator[Schema | Channel | Message | Footer]:
    """Schemas, channels and messages in file order; raises ``EOFError`` at a cut."""
    with open(path, "rb") as handle:
        if handle.read(len(MCAP0_MAGIC)) != MCAP0_MAGIC:
            raise LogError(f"{path}: not an MCAP file")
        handle.seek(0)
        # No record is longer than the file: a damaged length field must not make the
        # reader try to allocate gigabytes.
        size = path.stat().st_size
        reader = StreamReader(handle, emit_chunks=True, record_size_limit=size, validate_crcs=True)
        try:
            for record in reader.records:
                if isinstance(record, Chunk):
                    yield from breakup_chunk(record)  # type: ignore[misc]
                elif isinstance(record, Schema | Channel | Message | Footer):
                    yield record
        # Whatever the MCAP library raises on damaged bytes (its own errors, struct, zstd,
        # overflows and allocations from a damaged length) means the file ends there.
        except Exception as exc:
            raise EOFError(str(exc)) from exc


def read_contents(path: Path | str) -> LogContents:
    """Decode every message we know of; stop quietly at a truncation."""
    path = Path(path)
    if not path.is_file():
        raise LogError(f"{path}: {'is a folder' if path.is_dir() else 'no such file'}")
    contents = LogContents(truncated=True)
    schemas: dict[int, str] = {}
    channels: dict[int, Channel] = {}
    try:
        for record in mcap_records(path):
            if isinstance(record, Schema):
                schemas[record.id] = record.name
            elif isinstance(record, Channel):
                channels[record.id] = record
                contents.topics[record.topic] = schemas.get(record.schema_id, "")
            elif isinstance(record, Footer):
                contents.truncated = False
            elif record.channel_id in channels:
                try:
                    _take(contents, channels[record.channel_id], record)
                except (KeyError, TypeError, ValueError, IndexError, AttributeError):
                    continue  # a message damaged inside its JSON: skipped, never believed
    except EOFError:
        contents.truncated = True
    except OSError as exc:
        raise LogError(f"{path}: cannot read: {exc.strerror}") from exc
    if contents.result is not None:
        contents.truncated = False  # the writer got to the end of the run
    return contents


def _take(contents: LogContents, channel: Channel, message: Message) -> None:
    topic = channel.topic
    if channel.message_encoding != "json":
        return
    try:
        data = json.loads(message.data)
    except ValueError:
        return
    if topic.startswith("/vehicle/") and topic.endswith("/battery"):
        if FLEET_STATES_TOPIC in contents.topics:
            return  # an offline run's: every step of it is in /fleet/states
        state = VehicleState(
            float(data["t_s"]),
            (int(data["row"]), int(data["col"])),
            data["battery_pct"],
            data["mode"],
            readings_from_code(data["sensed"]) if "sensed" in data else None,
        )
        contents.states.setdefault(int(data["sysid"]), []).append(state)
    elif topic == FLEET_STATES_TOPIC:
        _take_fleet_states(contents, data)
    elif topic == MAP_TOPIC:
        contents.last_map = data
    elif topic == BTPS_TOPIC:
        contents.btps = _btp_cells(data)
    elif topic == EVENTS_TOPIC:
        t_s = float(data["t_s"]) if "t_s" in data else mission_s(contents, message.log_time)
        contents.events.append(LogEvent(t_s, data["level"], data["name"], data["message"]))
    elif topic == META_TOPIC:
        contents.meta = data
    elif topic == RESULT_TOPIC:
        contents.result = data


def _take_fleet_states(contents: LogContents, data: dict[str, Any]) -> None:
    """An offline run's gathered steps: a state per vehicle per step (all of the
    message's or, if any of it is damaged, none)."""
    sysids = [int(sysid) for sysid in data["sysids"]]
    taken: dict[int, list[VehicleState]] = {sysid: [] for sysid in sysids}
    steps = zip(
        data["t_s"], data["row"], data["col"], data["battery_pct"], data["mode"], strict=True
    )
    for t_s, rows, cols, batteries, modes in steps:
        for sysid, row, col, pct, mode in zip(sysids, rows, cols, batteries, modes, strict=True):
            taken[sysid].append(VehicleState(float(t_s), (int(row), int(col)), float(pct), mode))
    for sysid, states in taken.items():
        contents.states.setdefault(sysid, []).extend(states)


def mission_s(contents: LogContents, log_time_ns: int) -> float:
    """The mission seconds of a message's ``log_time``: UTC since ``started_unix_ns`` of
    ``/run/meta`` (see :mod:`gcs.log.mcap_log`); logs written before that stamped mission
    time itself (from 0)."""
    started = (contents.meta or {}).get("started_unix_ns")
    return (log_time_ns - int(started)) / 1e9 if started is not None else log_time_ns / 1e9


def _btp_cells(update: dict[str, Any]) -> list[Cell]:
    for entity in update.get("entities", []):
        for pair in entity.get("metadata", []):
            if pair.get("key") == "cells":
                return [(int(r), int(c)) for r, c in json.loads(pair["value"])]
    return []


def read_log(path: Path | str) -> RunResult:
    """The run a log records: exact from ``/run/result``, else rebuilt from the stream."""
    return result_of(read_contents(path), path)


def result_of(contents: LogContents, path: Path | str) -> RunResult:
    """The run that ``contents`` (read from ``path``) records (see ``read_log``)."""
    if contents.result is not None:
        try:
            return result_from_json(contents.result, _steps_of(contents))
        except (KeyError, TypeError, ValueError) as exc:
            raise LogError(f"{path}: /run/result is malformed ({exc})") from exc
    if contents.meta is None:
        raise LogError(f"{path}: no /run/meta record: the log holds no run")
    return reconstruct(contents)


def _steps_of(contents: LogContents) -> dict[int, AgentSteps]:
    """Each vehicle's cell and battery at every logged state."""
    return {
        sysid: AgentSteps(
            tuple(state.cell for state in states), tuple(state.battery_pct for state in states)
        )
        for sysid, states in contents.states.items()
    }


def reconstruct(contents: LogContents) -> RunResult:
    """A best-effort RunResult of a run whose log ends before its result.

    Tracks are cut to the last iteration every vehicle reached. Coverage
    counts the cells the vehicles stood on (which is what covering means),
    against the mission's free cells (``/run/meta``; logs written before it
    carried them: those the last map and the tracks know). Such a run is
    never complete: ``interrupted``. Wall and planner times are unknown (0).
    """
    meta = contents.meta or {}
    shape = (int(meta["shape"][0]), int(meta["shape"][1]))
    cell_m = float(meta["cell_size_m"])
    ids = list(contents.states)
    steps = min((len(s) for s in contents.states.values()), default=0)
    states = {i: contents.states[i][:steps] for i in ids}
    belief, covered = final_map(contents, shape, states)
    kinds = _event_counts(contents)
    agents = tuple(_agent(i, states[i], cell_m, kinds) for i in ids)
    t_end = states[ids[0]][-1].t_s if steps else 0.0
    btps = tuple(BtpRecord(cell, 0, int(t_end)) for cell in contents.btps)
    free = belief == CellState.FREE
    return RunResult(
        mission=str(meta["mission"]),
        shape=shape,
        cell_size_m=cell_m,
        charger=(int(meta["charger"][0]), int(meta["charger"][1])),
        reserve_pct=float(meta["reserve_pct"]),
        belief=belief,
        covered=covered,
        agents=agents,
        btps=btps,
        covered_per_iteration=_covered_series(states, steps),
        iterations=_coverage_iteration(contents, steps),
        free_cells=int(meta.get("free_cells", free.sum())),
        covered_cells=int((covered & free).sum()),
        out_of_range_cells=0,
        safety_net_fires=sum(kinds.get((EventKind.SAFETY_NET.value, i), 0) for i in (*ids, None)),
        wall_s=0.0,
        planner_s=0.0,
        extra={"log_truncated": 1, "total_iterations": max(steps - 1, 0)},
    )


def _coverage_iteration(contents: LogContents, steps: int) -> int:
    """When coverage completed (the paper's iteration count), else the last iteration logged."""
    for event in contents.events:
        if event.kind == EventKind.COVERAGE_COMPLETE.value and event.t_s < steps:
            return int(event.t_s)
    return max(steps - 1, 0)


def _event_counts(contents: LogContents) -> dict[tuple[str, int | None], int]:
    counts: dict[tuple[str, int | None], int] = {}
    for event in contents.events:
        key = (event.kind, event.sysid)
        counts[key] = counts.get(key, 0) + 1
    return counts


def final_map(
    contents: LogContents, shape: tuple[int, int], states: dict[int, list[VehicleState]]
) -> tuple[np.ndarray, np.ndarray]:
    """The last logged map, with every cell a vehicle stood on since marked free and covered,
    and what the vehicles sensed there."""
    belief = np.zeros(shape, dtype=np.int8)
    covered = np.zeros(shape, dtype=bool)
    if contents.last_map is not None:
        codes = codes_from_grid(contents.last_map)
        if codes.shape == shape:
            covered = codes == GRID_COVERED
            belief = np.where(covered, GRID_FREE, codes).astype(np.int8)
    rows, cols = shape
    for track in states.values():
        for state in track:
            belief[state.cell] = CellState.FREE
            covered[state.cell] = True
            for direction, seen in (state.sensed or {}).items():
                r, c = state.cell[0] + direction.dr, state.cell[1] + direction.dc
                # The planner keeps the first thing it was told of a cell: so do we.
                if 0 <= r < rows and 0 <= c < cols and belief[r, c] == CellState.UNKNOWN:
                    belief[r, c] = seen
    return belief, covered


def _covered_series(states: dict[int, list[VehicleState]], steps: int) -> tuple[int, ...]:
    seen: set[Cell] = set()
    series = []
    for k in range(steps):
        for track in states.values():
            seen.add(track[k].cell)
        series.append(len(seen))
    return tuple(series)


def _agent(
    sysid: int,
    states: list[VehicleState],
    cell_m: float,
    kinds: dict[tuple[str, int | None], int],
) -> AgentTrace:
    path = homing = 0
    for before, after in itertools.pairwise(states):
        if before.cell != after.cell:
            if after.mode in HOMING_MODES:
                homing += 1
            else:
                path += 1
    batteries = tuple(float(s.battery_pct) for s in states)
    lost = bool(states) and states[-1].mode == AgentMode.LOST.value
    return AgentTrace(
        id=sysid,
        track=tuple(s.cell for s in states),
        battery_pct=batteries,
        path_m=path * cell_m,
        homing_m=homing * cell_m,
        charges=kinds.get((EventKind.CHARGED.value, sysid), 0),
        min_battery_pct=min(batteries, default=0.0),
        lost=lost or kinds.get((EventKind.LOST.value, sysid), 0) > 0,
    )
