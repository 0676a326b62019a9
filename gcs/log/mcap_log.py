"""The mission log as an MCAP file that Foxglove opens with its well-known schemas.

Why MCAP: one self-describing file holds the raw MAVLink traffic (so a mission
can be replayed) next to derived, viewable topics (map, positions, tracks,
batteries, events) and the final result (so ``gcs report`` needs nothing else).

Robustness: the file is written in small chunks and flushed at least every
``flush_s`` wall seconds, so a ground station that dies leaves a file that is
readable up to its last flushed chunk (only the summary section is missing);
:mod:`gcs.log.reader` reads such files.

Cost: ``agent_state`` may run thousands of times per second in an offline run,
so it only formats three small messages (pose and fix only when they change);
track and BTP scene updates are buffered and emitted at a modest rate of
mission time.

Frames: ``map`` is a local East-North-Up frame whose origin is the north-west
corner of cell (0, 0) (``x`` east, ``y`` north, metres), the corner the
mission's geographic origin names.

Time: every message's ``log_time`` (and ``publish_time``, and the ``timestamp``
inside the Foxglove messages) is UTC: the wall clock at mission time 0 (the
mission's start, ``start``) plus the mission seconds of the message. Mission
time, not the wall clock at the moment of writing, because the mission clock is
injected and runs faster than real time under a speed-up (``core.clocks``):
stamped on the wall clock, a simulated run's log would squeeze ten minutes of
battery drain into one and put events in the order the event loop happened to
write them, while stamped on mission time a log reads the same, in vehicle
seconds, whatever the speed-up, and a real mission (speed-up 1) is on the wall
clock anyway. The stamp is computed from the mission seconds alone, so writing
never waits on a clock or on anything else. The mission seconds stay readable:
``t_s`` in the vehicle states and the events, and for any message
``(log_time - started_unix_ns) / 1e9`` with ``started_unix_ns`` of ``/run/meta``
(exact: the stamp is built that way). In an offline run the mission "seconds"
are iterations.

Events (``/events``, ``foxglove.Log``, what Foxglove's Log panel shows) name their
source (``gcs`` or ``vehicle N``) and carry a level (debug, info, warning, error,
fatal).
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import orjson

from core.cells import Cell, CellState, Direction
from core.geo import GeoFrame
from gcs.log.mcap_file import Channel, McapFile
from gcs.log.mission_log import FleetStep, GeoFix, MissionProgress, VehicleStatus
from gcs.log.result_json import result_to_json
from gcs.log.scenes import (
    IDENTITY,
    GridEncoder,
    btps_entity,
    move_heading,
    stamp,
    track_entity,
)
from gcs.log.topics import (
    BATTERY_SCHEMA,
    BTPS_TOPIC,
    EVENTS_TOPIC,
    FLEET_STATES_SCHEMA,
    FLEET_STATES_TOPIC,
    LOG_LEVELS,
    MAP_FRAME,
    MAP_TOPIC,
    META_SCHEMA,
    META_TOPIC,
    PROFILE,
    PROGRESS_SCHEMA,
    PROGRESS_TOPIC,
    RAW_ENCODING,
    RESULT_SCHEMA,
    RESULT_TOPIC,
    SCHEMAS,
    STATUS_SCHEMA,
    TF_TOPIC,
    TRACK_RGB,
    TRACKS_TOPIC,
    sensed_code,
    status_topic,
)
from gcs.mission import Mission
from gcs.outcome.result import RunResult


def _unix_ns(unix_s: float | None) -> int:
    return time.time_ns() if unix_s is None else round(unix_s * 1e9)


def _straight_on(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float]) -> bool:
    """Whether ``c`` lies on the line from ``a`` through ``b``, beyond ``b``."""
    ab = (b[0] - a[0], b[1] - a[1])
    bc = (c[0] - b[0], c[1] - b[1])
    cross = ab[0] * bc[1] - ab[1] * bc[0]
    return abs(cross) < 1e-9 and ab[0] * bc[0] + ab[1] * bc[1] > 0


class LogSink(Protocol):
    """Something that takes the log's messages as they are written (a live view): every
    message but the raw MAVLink frames, as the JSON bytes the file gets. Called on the
    thread that writes the log; it must return at once."""

    def publish(self, topic: str, schema: str, t_s: float, data: bytes) -> None: ...


#: A vehicle's cell, battery (%) and mode, as ``/vehicle/N/battery`` holds them.
_State = tuple[Cell, float, str]


@dataclass
class _Vehicle:
    """What the log keeps per vehicle between calls."""

    sysid: int
    colour: tuple[float, float, float]
    #: Track points as JSON ``foxglove.Point3`` text, ready to splice into a scene update;
    #: a point on the line through the two before it replaces the last one.
    track: list[str] = field(default_factory=list)
    #: The last two track points (east, north): where a straight run goes on.
    tail: tuple[tuple[float, float], ...] = ()
    last_cell: Cell | None = None
    #: The last move between cells (rows, columns) of an offline run.
    last_move: tuple[int, int] | None = None
    last_fix: tuple[Any, ...] | None = None
    heading_deg: float = 0.0
    #: The last ``/vehicle/N/battery`` state written of an offline run, and the last
    #: time it was seen since, unchanged and not written again.
    state: _State | None = None
    state_seen_t: float | None = None


@dataclass(frozen=True)
class LoggedMission:
    """What the log says of the mission in ``/run/meta``, and the frame it draws in."""

    name: str
    shape: tuple[int, int]
    cell_size_m: float
    charger: Cell
    geo: GeoFrame
    reserve_pct: float
    #: The mission's own count of free cells, against which a log cut short is reported.
    free_cells: int | None = None

    @classmethod
    def of(cls, mission: Mission, free_cells: int | None = None) -> LoggedMission:
        return cls(
            name=mission.name,
            shape=mission.map.shape,
            cell_size_m=mission.cell_size_m,
            charger=mission.charger,
            geo=mission.geo,
            reserve_pct=mission.planner.reserve_pct,
            free_cells=free_cells,
        )


@dataclass(frozen=True)
class LogSettings:
    """How the file is written: chunks (bytes) flushed at least every ``flush_s`` wall
    seconds; ``scene_period_s`` is the shortest mission time between two track or BTP
    scene updates; later in a long mission the track update waits at least
    ``scene_fraction`` of the elapsed time, since each update holds the whole tracks (so
    that seeking in Foxglove shows them) and must not make the file grow with the
    square of the mission's length."""

    chunk_size: int = 1024 * 1024
    #: An offline run's steps gathered in one ``/fleet/states`` message; each vehicle's
    #: pose, fix and battery state are written at the last of them.
    steps_per_message: int = 25
    flush_s: float = 1.0
    scene_period_s: float = 5.0
    scene_fraction: float = 0.05


class McapMissionLog:
    """Writes a mission to an MCAP file; implements :class:`gcs.log.mission_log.MissionLog`."""

    def __init__(
        self,
        path: Path | str | None,
        mission: LoggedMission,
        settings: LogSettings = LogSettings(),
        *,
        sinks: Sequence[LogSink] = (),
        on_failure: Callable[[str], None] | None = None,
        started_unix_s: float | None = None,
    ) -> None:
        """``path`` None writes no file: the messages go to the ``sinks`` only (live
        views: Foxglove's, the web page's), which get every message but the raw MAVLink
        ones.

        ``started_unix_s``: the wall clock (Unix seconds) at mission time 0; now by
        default, and set again by ``start`` when the mission's clock starts later.

        Writing the log is never flying: a write that fails (a full disk, a file
        system gone) ends the file where it is, is told once to ``on_failure`` and
        kept in ``failure``; every later call returns quietly, and the live view goes
        on. The file then has no summary, and ``gcs report`` reads it as cut."""
        self.path = None if path is None else Path(path)
        self._file: McapFile | None = None
        if self.path is not None:
            self._file = McapFile(self.path, profile=PROFILE, chunk_size=settings.chunk_size)
        self._sinks = tuple(sinks)
        self._mission = mission
        self._settings = settings
        #: What was last written of each vehicle's status and of the progress.
        self._statuses: dict[int, VehicleStatus] = {}
        self._progress: MissionProgress | None = None
        self._channels: dict[str, Channel] = {}
        self._vehicles: dict[int, _Vehicle] = {}
        self._steps: list[tuple[float, FleetStep]] = []
        #: Whether the vehicles' steps went to /fleet/states (an offline run).
        self._fleet_logged = False
        self._last_flush = time.monotonic()
        self._next_tracks_t = 0.0
        self._tracks_dirty = False
        self._btps: list[Cell] | None = None
        self._grid = GridEncoder(mission.cell_size_m)
        self._next_btps_t = 0.0
        self._last_t = 0.0
        self._closed = False
        #: Why and when (mission seconds) the file stopped being written, if it did.
        self.failure: str | None = None
        self.on_failure = on_failure
        #: UTC nanoseconds of mission time 0: every stamp is this plus the mission time.
        self.started_unix_ns = _unix_ns(started_unix_s)
        self._write_meta()
        self._write_frame()
        self.flush()

    @classmethod
    def for_mission(
        cls,
        mission: Mission,
        path: Path | str | None,
        *,
        free_cells: int | None = None,
        settings: LogSettings = LogSettings(),
        sinks: Sequence[LogSink] = (),
        on_failure: Callable[[str], None] | None = None,
        started_unix_s: float | None = None,
    ) -> McapMissionLog:
        """The log of ``mission`` at ``path`` (None: no file)."""
        return cls(
            path,
            LoggedMission.of(mission, free_cells),
            settings,
            sinks=sinks,
            on_failure=on_failure,
            started_unix_s=started_unix_s,
        )

    def start(self, unix_s: float | None = None) -> None:
        """Mission time 0 is now (or ``unix_s``, Unix seconds): what is logged from here
        is stamped from it, and ``/run/meta`` is written again with it (a reader takes
        the last one). For a mission whose clock starts a while after the log is opened
        (the live mission's, once the planner is compiled); call it before logging
        anything else."""
        self.started_unix_ns = _unix_ns(unix_s)
        self._write_meta()
        self.flush()

    def _ns(self, t_s: float) -> int:
        """The UTC stamp (ns) of mission time ``t_s``: see the module's docstring."""
        return self.started_unix_ns + max(0, round(t_s * 1e9))

    # -------------------------------------------------------------- plumbing

    def _channel(self, file: McapFile, topic: str, schema: str | None) -> Channel:
        channel = self._channels.get(topic)
        if channel is None:
            if schema is None:
                metadata = {"format": "one MAVLink v1/v2 frame per message"}
                channel = file.channel(topic, encoding=RAW_ENCODING, metadata=metadata)
            else:
                channel = file.channel(
                    topic, encoding="json", schema_name=schema, schema=SCHEMAS[schema]
                )
            self._channels[topic] = channel
        return channel

    def _write(self, topic: str, schema: str | None, t_s: float, data: bytes) -> None:
        if self._closed:
            return
        self._last_t = max(self._last_t, t_s)
        if schema is not None:
            for sink in self._sinks:
                sink.publish(topic, schema, t_s, data)
        file = self._file
        if file is None:
            return
        try:
            self._channel(file, topic, schema).log(data, log_time=self._ns(t_s))
        except Exception as exc:  # whatever breaks the file must not reach the caller
            self._fail(exc)
            return
        now = time.monotonic()
        if now - self._last_flush >= self._settings.flush_s:
            self.flush()

    def _fail(self, exc: BaseException) -> None:
        """Stop writing the file (keep what reached it) and say so once."""
        if self.failure is not None:
            return
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        self.failure = f"the log stopped at mission time {self._last_t:.1f} s: {reason}"
        file, self._file = self._file, None
        if file is not None:
            with contextlib.suppress(Exception):
                file.close()
        if self.on_failure is not None:
            self.on_failure(self.failure)

    def _json(self, topic: str, schema: str, t_s: float, message: dict[str, Any]) -> None:
        self._write(topic, schema, t_s, orjson.dumps(message, option=orjson.OPT_SERIALIZE_NUMPY))

    def flush(self) -> None:
        """Close the current chunk and hand it to the OS: a crash after this loses nothing."""
        if self._closed or self._file is None:
            return
        try:
            self._file.flush()
        except Exception as exc:
            self._fail(exc)
        if self._file is not None and self._file.failure is not None:
            self._fail(self._file.failure)
        self._last_flush = time.monotonic()

    def _write_meta(self) -> None:
        """What the run is about, first in the file: with the mission's own count of free
        cells, against which a log cut short is reported, and the wall clock at mission
        time 0 (``started_unix_s``, and exactly, ``started_unix_ns``)."""
        mission = self._mission
        geo = mission.geo
        meta: dict[str, Any] = {
            "mission": mission.name,
            "shape": list(mission.shape),
            "cell_size_m": mission.cell_size_m,
            "charger": list(mission.charger),
            "reserve_pct": mission.reserve_pct,
            "origin": {"lat_deg": geo.lat_deg, "lon_deg": geo.lon_deg, "alt_m": geo.alt_m},
            "started_unix_s": self.started_unix_ns / 1e9,
            "started_unix_ns": self.started_unix_ns,
        }
        if mission.free_cells is not None:
            meta["free_cells"] = mission.free_cells
        self._json(META_TOPIC, META_SCHEMA, 0.0, meta)

    def _write_frame(self) -> None:
        self._json(
            TF_TOPIC,
            "foxglove.FrameTransform",
            0.0,
            {
                "timestamp": stamp(self._ns(0.0)),
                "parent_frame_id": "world",
                "child_frame_id": MAP_FRAME,
                "translation": {"x": 0.0, "y": 0.0, "z": 0.0},
                "rotation": IDENTITY,
            },
        )

    def _vehicle(self, sysid: int) -> _Vehicle:
        vehicle = self._vehicles.get(sysid)
        if vehicle is None:
            colour = TRACK_RGB[len(self._vehicles) % len(TRACK_RGB)]
            vehicle = self._vehicles[sysid] = _Vehicle(sysid, colour)
        return vehicle

    # -------------------------------------------------------------- MissionLog

    def raw(self, sysid: int, outgoing: bool, t_s: float, frame: bytes) -> None:
        self._write(f"/mavlink/{sysid}/{'out' if outgoing else 'in'}", None, t_s, bytes(frame))

    def agent_state(
        self,
        t_s: float,
        sysid: int,
        cell: Cell,
        battery_pct: float,
        mode: str,
        fix: GeoFix | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        if self._closed:
            return
        row, col = int(cell[0]), int(cell[1])
        self._state(t_s, sysid, (row, col), battery_pct, mode, readings)
        vehicle = self._vehicle(sysid)
        lat_deg, lon_deg, heading_deg = fix or (None, None, None)
        if heading_deg is None and vehicle.last_cell is not None:
            heading_deg = move_heading(vehicle.last_cell, (row, col))
        if heading_deg is not None:
            vehicle.heading_deg = heading_deg
        shown = (row, col, lat_deg, lon_deg, vehicle.heading_deg)
        if shown != vehicle.last_fix:
            vehicle.last_fix = shown
            self._position(t_s, vehicle, (row, col), lat_deg, lon_deg)
        vehicle.last_cell = (row, col)
        self._scenes_due(t_s)

    def _scenes_due(self, t_s: float) -> None:
        if t_s >= self._next_tracks_t:
            self._emit_tracks(t_s)
        if self._btps is not None and t_s >= self._next_btps_t:
            self._emit_btps(t_s)

    def _state(
        self,
        t_s: float,
        sysid: int,
        cell: Cell,
        battery_pct: float,
        mode: str,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        """``/vehicle/N/battery``: battery, mode, cell and what was sensed there."""
        row, col = cell
        sensed = f',"sensed":"{sensed_code(readings)}"' if readings else ""
        state = (
            f'{{"t_s":{float(t_s)!r},"sysid":{int(sysid)},"battery_pct":{float(battery_pct)!r},'
            f'"mode":{json.dumps(str(mode))},"row":{row},"col":{col},"cell":[{row},{col}]'
            f"{sensed}}}"
        )
        self._write(f"/vehicle/{sysid}/battery", BATTERY_SCHEMA, t_s, state.encode())

    def fleet_step(self, t_s: float, step: FleetStep) -> None:
        if self._closed:
            return
        self._fleet_logged = True
        self._steps.append((t_s, step))
        if len(self._steps) >= self._settings.steps_per_message:
            self._write_steps()

    def _write_steps(self) -> None:
        """The gathered steps as one ``/fleet/states`` message (columns; orjson encodes
        the cells straight from their array); each vehicle's track through them, and its
        pose, fix and ``/vehicle/N/battery`` state at the last one, where they changed
        (for Foxglove's panels; a reader takes the states from ``/fleet/states``)."""
        steps, self._steps = self._steps, []
        if not steps:
            return
        t_s, last = steps[-1]
        cells = [step.cells for _, step in steps]
        grid = np.array(cells, dtype=np.int64)
        states = {
            "sysids": [int(sysid) for sysid in last.sysids],
            "t_s": [t for t, _ in steps],
            "row": np.ascontiguousarray(grid[:, :, 0]),
            "col": np.ascontiguousarray(grid[:, :, 1]),
            "battery_pct": [list(step.battery_pct) for _, step in steps],
            "mode": [list(step.modes) for _, step in steps],
        }
        self._json(FLEET_STATES_TOPIC, FLEET_STATES_SCHEMA, t_s, states)
        vehicles = [self._vehicle(sysid) for sysid in last.sysids]
        self._tracks_through(vehicles, cells, grid)
        for k, vehicle in enumerate(vehicles):
            here = (int(last.cells[k][0]), int(last.cells[k][1]))
            self._state_if_changed(t_s, vehicle, (here, last.battery_pct[k], last.modes[k]))
            shown = (*here, None, None, vehicle.heading_deg)
            if shown != vehicle.last_fix:
                vehicle.last_fix = shown
                self._position(t_s, vehicle, here, None, None)
        self._scenes_due(t_s)

    def _state_if_changed(self, t_s: float, vehicle: _Vehicle, state: _State) -> None:
        """``/vehicle/N/battery`` of an offline run, written when it changes: most of a
        crowd in a maze waits for hundreds of steps. Before a change, the state it
        changes from is written again at the last time it was seen, so that a plot of
        it steps where the state did rather than sloping across the wait."""
        if state == vehicle.state:
            vehicle.state_seen_t = t_s
            return
        self._held_state(vehicle)
        vehicle.state = state
        self._state(t_s, vehicle.sysid, *state)

    def _held_state(self, vehicle: _Vehicle) -> None:
        """The vehicle's state again at the last time it was seen unchanged, if later
        than it was written."""
        if vehicle.state is not None and vehicle.state_seen_t is not None:
            self._state(vehicle.state_seen_t, vehicle.sysid, *vehicle.state)
        vehicle.state_seen_t = None

    def _position(
        self,
        t_s: float,
        vehicle: _Vehicle,
        cell: Cell,
        lat_deg: float | None,
        lon_deg: float | None,
    ) -> None:
        """LocationFix and PoseInFrame, formatted by hand: this runs at every move."""
        geo = self._mission.geo
        if lat_deg is None or lon_deg is None:
            north, east = geo.cell_centre_local(cell)
            lat_deg, lon_deg = geo.local_to_geo(north, east)
        else:
            north, east = geo.geo_to_local(lat_deg, lon_deg)
        ns = self._ns(t_s)
        stamp = f'{{"sec":{ns // 1_000_000_000},"nsec":{ns % 1_000_000_000}}}'
        fix = (
            f'{{"timestamp":{stamp},"frame_id":"vehicle_{vehicle.sysid}",'
            f'"latitude":{lat_deg!r},"longitude":{lon_deg!r},"altitude":{geo.alt_m!r},'
            f'"position_covariance":[0,0,0,0,0,0,0,0,0],"position_covariance_type":0}}'
        )
        self._write(f"/vehicle/{vehicle.sysid}/fix", "foxglove.LocationFix", t_s, fix.encode())
        yaw = math.radians(90.0 - vehicle.heading_deg) / 2.0
        pose = (
            f'{{"timestamp":{stamp},"frame_id":"{MAP_FRAME}","pose":{{"position":'
            f'{{"x":{east!r},"y":{north!r},"z":0.0}},"orientation":'
            f'{{"x":0.0,"y":0.0,"z":{math.sin(yaw)!r},"w":{math.cos(yaw)!r}}}}}}}'
        )
        self._write(f"/vehicle/{vehicle.sysid}/pose", "foxglove.PoseInFrame", t_s, pose.encode())
        self._track_point(vehicle, north, east)

    def _tracks_through(
        self, vehicles: Sequence[_Vehicle], cells: Sequence[Sequence[Cell]], grid: np.ndarray
    ) -> None:
        """Every vehicle's track on through its cells at successive steps (``cells``, each
        step's; ``grid`` the same as steps by vehicles by row and column). The vehicles
        that stood still through them all on the cell they were on (most of a crowd held
        back in a maze) are found for all at once and passed over: walking every
        vehicle's cells one by one cost more than the rest of the message."""
        if any(v.last_cell is None for v in vehicles):  # the first steps
            moving: Sequence[int] = range(len(vehicles))
        else:
            before = np.array([v.last_cell for v in vehicles], dtype=np.int64)
            moving = np.flatnonzero((grid != before).any(axis=(0, 2))).tolist()
        if moving:
            tracks = list(zip(*cells, strict=True))  # the steps' rows, transposed
            for k in moving:
                self._track_through(vehicles[k], tracks[k])

    def _track_through(self, vehicle: _Vehicle, cells: Sequence[Cell]) -> None:
        """A vehicle's track on through ``cells`` (its cell at successive steps): a point
        where it turns and where it ends, none along a straight run."""
        centre = self._mission.geo.cell_centre_local
        last, move = vehicle.last_cell, vehicle.last_move
        for cell in cells:
            if cell == last:
                continue
            if last is None:
                self._track_point(vehicle, *centre(cell))
            else:
                step = (cell[0] - last[0], cell[1] - last[1])
                if step != move:
                    self._track_point(vehicle, *centre(last))
                    move = step
            last = cell
        if last is not None:
            self._track_point(vehicle, *centre(last))
            if move is not None:
                vehicle.heading_deg = move_heading((0, 0), move) or vehicle.heading_deg
        vehicle.last_cell, vehicle.last_move = last, move

    def _track_point(self, vehicle: _Vehicle, north: float, east: float) -> None:
        here = (round(east, 3), round(north, 3))
        tail = vehicle.tail
        if tail and tail[-1] == here:
            return
        point = f'{{"x":{here[0]!r},"y":{here[1]!r},"z":0.0}}'
        self._tracks_dirty = True
        if len(tail) == 2 and _straight_on(tail[0], tail[1], here):
            vehicle.track[-1] = point
            vehicle.tail = (tail[0], here)
            return
        vehicle.track.append(point)
        vehicle.tail = (*tail[-1:], here)

    def _emit_tracks(self, t_s: float) -> None:
        """Every vehicle's whole track, so that a seek in Foxglove shows it too."""
        self._next_tracks_t = t_s + max(
            self._settings.scene_period_s, self._settings.scene_fraction * t_s
        )
        if not self._tracks_dirty:
            return
        self._tracks_dirty = False
        width = 0.15 * self._mission.cell_size_m
        ns = self._ns(t_s)
        entities = [
            track_entity(ns, v.sysid, v.colour, v.track, width)
            for v in self._vehicles.values()
            if v.track
        ]
        update = f'{{"deletions":[],"entities":[{",".join(entities)}]}}'
        self._write(TRACKS_TOPIC, "foxglove.SceneUpdate", t_s, update.encode())

    def _emit_btps(self, t_s: float) -> None:
        cells, self._btps = self._btps or [], None
        self._next_btps_t = t_s + self._settings.scene_period_s
        mission = self._mission
        entity = btps_entity(self._ns(t_s), cells, mission.geo, mission.cell_size_m)
        self._json(BTPS_TOPIC, "foxglove.SceneUpdate", t_s, {"deletions": [], "entities": [entity]})

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        grid = self._grid.message(self._ns(t_s), belief, covered)
        self._write(MAP_TOPIC, "foxglove.Grid", t_s, grid)

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        self._btps = [(int(r), int(c)) for r, c in cells]
        if t_s >= self._next_btps_t:
            self._emit_btps(t_s)

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        """A ``foxglove.Log`` on ``/events``: ``level`` one of ``LOG_LEVELS``, ``name`` the
        source (``vehicle N`` or ``gcs``), ``t_s`` the mission seconds."""
        message = {
            "timestamp": stamp(self._ns(t_s)),
            "level": LOG_LEVELS.get(level.lower(), 0),
            "message": text,
            "name": f"vehicle {sysid}" if sysid is not None else "gcs",
            "file": "",
            "line": 0,
            "t_s": float(t_s),
        }
        self._json(EVENTS_TOPIC, "foxglove.Log", t_s, message)

    def result(self, t_s: float, result: RunResult) -> None:
        self._emit_pending(t_s)
        # An offline run's steps are in /fleet/states already: not written twice.
        message = result_to_json(result, traces=not self._fleet_logged)
        self._json(RESULT_TOPIC, RESULT_SCHEMA, t_s, message)
        self.flush()

    def status(
        self, t_s: float, vehicles: Sequence[VehicleStatus], progress: MissionProgress
    ) -> None:
        """Each vehicle's status and the mission's progress, those that changed since
        they were last written (the time since a vehicle was last heard counts only once
        it reaches 2 s, and then by whole seconds; the time left by tens of seconds)."""
        if self._closed:
            return
        for v in vehicles:
            heard = v.heard_s_ago
            key = replace(v, heard_s_ago=None if heard is None or heard < 2 else int(heard))
            if self._statuses.get(v.sysid) != key:
                self._statuses[v.sysid] = key
                # vars(): shallow, where asdict copies each cell of the way again.
                self._json(status_topic(v.sysid), STATUS_SCHEMA, t_s, {"t_s": t_s, **vars(v)})
        left = progress.time_left_s
        shown = replace(progress, time_left_s=None if left is None else round(left / 10))
        if shown != self._progress:
            self._progress = shown
            message = {"t_s": t_s, **vars(progress), "pct": round(progress.pct, 3)}
            self._json(PROGRESS_TOPIC, PROGRESS_SCHEMA, t_s, message)

    def _emit_pending(self, t_s: float) -> None:
        self._write_steps()
        for vehicle in self._vehicles.values():
            self._held_state(vehicle)
        if self._tracks_dirty:
            self._emit_tracks(t_s)
        if self._btps is not None:
            self._emit_btps(t_s)

    def close(self) -> None:
        if self._closed:
            return
        try:
            self._emit_pending(self._last_t)
            if self._file is not None:
                self._file.close()
                if self._file.failure is not None:
                    self._fail(self._file.failure)
        except Exception as exc:
            self._fail(exc)
        finally:
            self._closed = True

    def __enter__(self) -> McapMissionLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
