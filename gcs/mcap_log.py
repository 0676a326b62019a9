"""The mission log as an MCAP file that Foxglove opens with its well-known schemas.

Why MCAP: one self-describing file holds the raw MAVLink traffic (so a mission
can be replayed) next to derived, viewable topics (map, positions, tracks,
batteries, events) and the final result (so ``gcs report`` needs nothing else).

Robustness: the file is written in small chunks and flushed at least every
``flush_s`` wall seconds, so a ground station that dies leaves a file that is
readable up to its last flushed chunk (only the summary section is missing);
:mod:`gcs.log_reader` reads such files.

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

import base64
import contextlib
import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import IO, Any, Protocol

import numpy as np
from mcap.writer import CompressionType, Writer

from core.cells import Cell, CellState, Direction
from core.geo import GeoFrame
from gcs.mission import Mission
from gcs.mission_log import MissionProgress, VehicleStatus
from gcs.result import AgentTrace, BtpRecord, RunResult

PROFILE = ""
MAP_FRAME = "map"
#: Encoding of the raw MAVLink channels: each message is one frame's bytes as on the wire.
RAW_ENCODING = "mavlink"

META_TOPIC = "/run/meta"
RESULT_TOPIC = "/run/result"
MAP_TOPIC = "/map"
EVENTS_TOPIC = "/events"
TRACKS_TOPIC = "/scene/tracks"
BTPS_TOPIC = "/scene/btps"
TF_TOPIC = "/tf"
PROGRESS_TOPIC = "/run/progress"

META_SCHEMA = "staying_alive.RunMeta"
RESULT_SCHEMA = "staying_alive.RunResult"
BATTERY_SCHEMA = "staying_alive.VehicleState"
STATUS_SCHEMA = "staying_alive.VehicleStatus"
PROGRESS_SCHEMA = "staying_alive.MissionProgress"


def status_topic(sysid: int) -> str:
    return f"/vehicle/{sysid}/status"


#: Codes of the map grid's ``state`` field: the planner's cell states, and covered.
GRID_UNKNOWN = int(CellState.UNKNOWN)
GRID_FREE = int(CellState.FREE)
GRID_OBSTACLE = int(CellState.OBSTACLE)
GRID_COVERED = 3
#: RGBA of each grid code: unknown translucent grey, free (uncovered) amber,
#: obstacle black, covered white, as in the coverage figure.
GRID_RGBA = np.array(
    [[150, 150, 150, 60], [255, 217, 51, 255], [0, 0, 0, 255], [255, 255, 255, 255]],
    dtype=np.uint8,
)
#: Colours (r, g, b) of vehicle tracks, cycled by order of appearance.
TRACK_RGB = (
    (0.17, 0.63, 0.17),
    (1.0, 0.5, 0.05),
    (0.58, 0.4, 0.74),
    (0.55, 0.34, 0.29),
    (0.89, 0.47, 0.76),
    (0.09, 0.75, 0.81),
    (0.74, 0.74, 0.13),
    (0.5, 0.5, 0.5),
)
LOG_LEVELS = {"debug": 1, "info": 2, "warning": 3, "warn": 3, "error": 4, "fatal": 5}


def _unix_ns(unix_s: float | None) -> int:
    return time.time_ns() if unix_s is None else round(unix_s * 1e9)


# ------------------------------------------------------------------ JSON schemas
# Foxglove recognises its well-known schemas by name; the JSON schemas below
# describe the subset of fields we write, with Foxglove's field names.


def _obj(title: str | None = None, **props: Any) -> dict[str, Any]:
    schema: dict[str, Any] = {"type": "object", "properties": props}
    if title:
        schema["title"] = title
    return schema


def _num() -> dict[str, str]:
    return {"type": "number"}


def _int() -> dict[str, str]:
    return {"type": "integer"}


def _str() -> dict[str, str]:
    return {"type": "string"}


def _arr(items: dict[str, Any]) -> dict[str, Any]:
    return {"type": "array", "items": items}


def _time() -> dict[str, Any]:
    return _obj("time", sec=_int(), nsec=_int())


def _vec3(title: str = "foxglove.Vector3") -> dict[str, Any]:
    return _obj(title, x=_num(), y=_num(), z=_num())


def _pose() -> dict[str, Any]:
    quat = _obj("foxglove.Quaternion", x=_num(), y=_num(), z=_num(), w=_num())
    return _obj("foxglove.Pose", position=_vec3(), orientation=quat)


def _color() -> dict[str, Any]:
    return _obj("foxglove.Color", r=_num(), g=_num(), b=_num(), a=_num())


def _key_values() -> dict[str, Any]:
    return _arr(_obj("foxglove.KeyValuePair", key=_str(), value=_str()))


def _scene_update_schema() -> dict[str, Any]:
    line = _obj(
        "foxglove.LinePrimitive",
        type=_int(),
        pose=_pose(),
        thickness=_num(),
        scale_invariant={"type": "boolean"},
        points=_arr(_vec3("foxglove.Point3")),
        color=_color(),
        colors=_arr(_color()),
        indices=_arr(_int()),
    )
    sphere = _obj("foxglove.SpherePrimitive", pose=_pose(), size=_vec3(), color=_color())
    entity = _obj(
        "foxglove.SceneEntity",
        timestamp=_time(),
        frame_id=_str(),
        id=_str(),
        lifetime=_obj("duration", sec=_int(), nsec=_int()),
        frame_locked={"type": "boolean"},
        metadata=_key_values(),
        arrows=_arr({"type": "object"}),
        cubes=_arr({"type": "object"}),
        spheres=_arr(sphere),
        cylinders=_arr({"type": "object"}),
        lines=_arr(line),
        triangles=_arr({"type": "object"}),
        texts=_arr({"type": "object"}),
        models=_arr({"type": "object"}),
    )
    deletion = _obj("foxglove.SceneEntityDeletion", timestamp=_time(), type=_int(), id=_str())
    return _obj("foxglove.SceneUpdate", deletions=_arr(deletion), entities=_arr(entity))


def _grid_schema() -> dict[str, Any]:
    field_schema = _obj("foxglove.PackedElementField", name=_str(), offset=_int(), type=_int())
    return _obj(
        "foxglove.Grid",
        timestamp=_time(),
        frame_id=_str(),
        pose=_pose(),
        column_count=_int(),
        cell_size=_obj("foxglove.Vector2", x=_num(), y=_num()),
        row_stride=_int(),
        cell_stride=_int(),
        fields=_arr(field_schema),
        data={"type": "string", "contentEncoding": "base64"},
    )


SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.Grid": _grid_schema(),
    "foxglove.LocationFix": _obj(
        "foxglove.LocationFix",
        timestamp=_time(),
        frame_id=_str(),
        latitude=_num(),
        longitude=_num(),
        altitude=_num(),
        position_covariance=_arr(_num()),
        position_covariance_type=_int(),
    ),
    "foxglove.PoseInFrame": _obj(
        "foxglove.PoseInFrame", timestamp=_time(), frame_id=_str(), pose=_pose()
    ),
    "foxglove.FrameTransform": _obj(
        "foxglove.FrameTransform",
        timestamp=_time(),
        parent_frame_id=_str(),
        child_frame_id=_str(),
        translation=_vec3(),
        rotation=_obj("foxglove.Quaternion", x=_num(), y=_num(), z=_num(), w=_num()),
    ),
    "foxglove.SceneUpdate": _scene_update_schema(),
    "foxglove.Log": _obj(
        "foxglove.Log",
        timestamp=_time(),
        level=_int(),
        message=_str(),
        name=_str(),
        file=_str(),
        line=_int(),
        # Ours, besides Foxglove's fields: the event's mission seconds.
        t_s=_num(),
    ),
    BATTERY_SCHEMA: _obj(
        BATTERY_SCHEMA,
        t_s=_num(),
        sysid=_int(),
        battery_pct=_num(),
        mode=_str(),
        row=_int(),
        col=_int(),
        cell=_arr(_int()),
        sensed=_str(),
    ),
    META_SCHEMA: _obj(
        META_SCHEMA,
        mission=_str(),
        shape=_arr(_int()),
        cell_size_m=_num(),
        charger=_arr(_int()),
        reserve_pct=_num(),
        origin=_obj(None, lat_deg=_num(), lon_deg=_num(), alt_m=_num()),
        started_unix_s=_num(),
        started_unix_ns=_int(),
        free_cells=_int(),
    ),
    STATUS_SCHEMA: _obj(
        STATUS_SCHEMA,
        t_s=_num(),
        sysid=_int(),
        kind=_str(),
        activity=_str(),
        phase=_str(),
        task=_str(),
        cell=_arr(_int()),
        battery_pct=_num(),
        energy_pct_per_m=_num(),
        range_m=_num(),
        home_m=_num(),
        charges=_int(),
        way=_arr(_arr(_int())),
        link_up={"type": "boolean"},
        heard_s_ago=_num(),
        rejected_frames=_int(),
    ),
    PROGRESS_SCHEMA: _obj(
        PROGRESS_SCHEMA,
        t_s=_num(),
        covered=_int(),
        free=_int(),
        pct=_num(),
        state=_str(),
        time_left_s=_num(),
        speedup=_num(),
    ),
    RESULT_SCHEMA: {"type": "object", "title": RESULT_SCHEMA},
}


# ------------------------------------------------------------------ RunResult <-> JSON


def _array_json(array: np.ndarray) -> dict[str, Any]:
    return {"dtype": str(array.dtype), "data": array.tolist()}


def _array_from(value: dict[str, Any]) -> np.ndarray:
    return np.array(value["data"], dtype=value["dtype"])


def _cell(value: Sequence[int]) -> Cell:
    return (int(value[0]), int(value[1]))


def result_to_json(result: RunResult) -> dict[str, Any]:
    """Every field of a RunResult, JSON-ready; :func:`result_from_json` inverts it exactly."""
    return {
        "mission": result.mission,
        "shape": list(result.shape),
        "cell_size_m": result.cell_size_m,
        "charger": list(result.charger),
        "reserve_pct": result.reserve_pct,
        "belief": _array_json(result.belief),
        "covered": _array_json(result.covered),
        "agents": [
            {
                "id": a.id,
                "track": [list(c) for c in a.track],
                "battery_pct": list(a.battery_pct),
                "path_m": a.path_m,
                "homing_m": a.homing_m,
                "charges": a.charges,
                "min_battery_pct": a.min_battery_pct,
                "lost": a.lost,
            }
            for a in result.agents
        ],
        "btps": [
            [list(b.cell), b.detected_by, b.detected_at, b.covered_by, b.covered_at]
            for b in result.btps
        ],
        "covered_per_iteration": list(result.covered_per_iteration),
        "iterations": result.iterations,
        "free_cells": result.free_cells,
        "covered_cells": result.covered_cells,
        "out_of_range_cells": result.out_of_range_cells,
        "safety_net_fires": result.safety_net_fires,
        "wall_s": result.wall_s,
        "planner_s": result.planner_s,
        "extra": dict(result.extra),
    }


def result_from_json(data: dict[str, Any]) -> RunResult:
    agents = tuple(
        AgentTrace(
            id=int(a["id"]),
            track=tuple(_cell(c) for c in a["track"]),
            battery_pct=tuple(float(b) for b in a["battery_pct"]),
            path_m=float(a["path_m"]),
            homing_m=float(a["homing_m"]),
            charges=int(a["charges"]),
            min_battery_pct=float(a["min_battery_pct"]),
            lost=bool(a["lost"]),
        )
        for a in data["agents"]
    )
    btps = tuple(
        BtpRecord(_cell(cell), int(by), int(at), cov_by, cov_at)
        for cell, by, at, cov_by, cov_at in data["btps"]
    )
    return RunResult(
        mission=str(data["mission"]),
        shape=_cell(data["shape"]),
        cell_size_m=float(data["cell_size_m"]),
        charger=_cell(data["charger"]),
        reserve_pct=float(data["reserve_pct"]),
        belief=_array_from(data["belief"]),
        covered=_array_from(data["covered"]),
        agents=agents,
        btps=btps,
        covered_per_iteration=tuple(int(c) for c in data["covered_per_iteration"]),
        iterations=int(data["iterations"]),
        free_cells=int(data["free_cells"]),
        covered_cells=int(data["covered_cells"]),
        out_of_range_cells=int(data["out_of_range_cells"]),
        safety_net_fires=int(data["safety_net_fires"]),
        wall_s=float(data["wall_s"]),
        planner_s=float(data["planner_s"]),
        extra=dict(data.get("extra", {})),
    )


# ------------------------------------------------------------------ message builders


def _stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def _move_heading(a: Cell, b: Cell) -> float | None:
    """Compass heading of a move between neighbouring cells (rows grow southwards)."""
    if a == b:
        return None
    return math.degrees(math.atan2(b[1] - a[1], a[0] - b[0])) % 360.0


def _entity(ns: int, entity_id: str, **primitives: Any) -> dict[str, Any]:
    entity: dict[str, Any] = {
        "timestamp": _stamp(ns),
        "frame_id": MAP_FRAME,
        "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0},
        "frame_locked": False,
        "metadata": primitives.pop("metadata", []),
    }
    for kind in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts"):
        entity[kind] = primitives.pop(kind, [])
    entity["models"] = []
    return entity


def sensed_code(readings: Mapping[Direction, CellState]) -> str:
    """The 8 readings of an arrival as 8 digits (``CellState`` values) in ``Direction``
    order, so that a restarted ground station knows what was sensed up to the end of
    the log (``gcs run --resume``), not only up to the last map."""
    return "".join(str(int(readings.get(d, CellState.UNKNOWN))) for d in Direction)


def readings_from_code(code: str) -> dict[Direction, CellState]:
    return {d: CellState(int(x)) for d, x in zip(Direction, code, strict=True)}


def grid_codes(belief: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """The map's uint8 codes: belief states, with covered cells as ``GRID_COVERED``."""
    codes = np.asarray(belief, dtype=np.uint8).copy()
    codes[np.asarray(covered, dtype=bool)] = GRID_COVERED
    return codes


def codes_from_grid(message: dict[str, Any]) -> np.ndarray:
    """Invert :func:`grid_message`'s data back to (rows north-first) uint8 codes."""
    raw = np.frombuffer(base64.b64decode(message["data"]), dtype=np.uint8)
    cols = int(message["column_count"])
    cells = raw.reshape(-1, cols, int(message["cell_stride"]))
    return np.flipud(cells[:, :, 0]).copy()


class LogSink(Protocol):
    """Something that takes the log's messages as they are written (a live view): every
    message but the raw MAVLink frames, as the JSON bytes the file gets. Called on the
    thread that writes the log; it must return at once."""

    def publish(self, topic: str, schema: str, t_s: float, data: bytes) -> None: ...


@dataclass
class _Vehicle:
    """What the log keeps per vehicle between calls."""

    sysid: int
    colour: tuple[float, float, float]
    #: Track points as JSON ``foxglove.Point3`` text, ready to splice into a scene update.
    track: list[str] = field(default_factory=list)
    last_cell: Cell | None = None
    last_fix: tuple[Any, ...] | None = None
    heading_deg: float = 0.0


class McapMissionLog:
    """Writes a mission to an MCAP file; implements :class:`gcs.mission_log.MissionLog`.

    ``scene_period_s`` is the shortest mission time between two track or BTP
    scene updates; later in a long mission the track update waits at least
    ``scene_fraction`` of the elapsed time, since each update holds the whole
    tracks (so that seeking in Foxglove shows them) and must not make the file
    grow with the square of the mission's length.
    """

    def __init__(
        self,
        path: Path | str | None,
        *,
        mission_name: str,
        shape: tuple[int, int],
        cell_size_m: float,
        charger: Cell,
        geo: GeoFrame,
        reserve_pct: float,
        free_cells: int | None = None,
        chunk_size: int = 64 * 1024,
        flush_s: float = 1.0,
        scene_period_s: float = 5.0,
        scene_fraction: float = 0.05,
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
        self._file: IO[bytes] | None = None
        self._writer: Writer | None = None
        if self.path is not None:
            self._file = open(self.path, "wb")  # noqa: SIM115 - closed in close()
            self._writer = Writer(
                self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD
            )
            self._writer.start(profile=PROFILE, library="staying-alive-gcs")
        self._sinks = tuple(sinks)
        #: What was last written of each vehicle's status and of the progress.
        self._statuses: dict[int, VehicleStatus] = {}
        self._progress: MissionProgress | None = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._vehicles: dict[int, _Vehicle] = {}
        self._shape = shape
        self._cell_size_m = cell_size_m
        self._geo = geo
        self._flush_s = flush_s
        self._last_flush = time.monotonic()
        self._scene_period_s = scene_period_s
        self._scene_fraction = scene_fraction
        self._next_tracks_t = 0.0
        self._tracks_dirty = False
        self._btps: list[Cell] | None = None
        self._next_btps_t = 0.0
        self._last_t = 0.0
        self._sequence = 0
        self._closed = False
        #: Why and when (mission seconds) the file stopped being written, if it did.
        self.failure: str | None = None
        self.on_failure = on_failure
        #: UTC nanoseconds of mission time 0: every stamp is this plus the mission time.
        self.started_unix_ns = _unix_ns(started_unix_s)
        self._meta = (mission_name, charger, reserve_pct, free_cells)
        self._write_meta()
        self._write_frame()
        self.flush()

    @classmethod
    def for_mission(
        cls, mission: Mission, path: Path | str | None, **options: Any
    ) -> McapMissionLog:
        """The log of ``mission`` at ``path`` (None: no file); ``options``: the log's own
        settings (``sinks``, ``free_cells``, chunking...)."""
        return cls(
            path,
            mission_name=mission.name,
            shape=mission.map.shape,
            cell_size_m=mission.cell_size_m,
            charger=mission.charger,
            geo=mission.geo,
            reserve_pct=mission.planner.reserve_pct,
            **options,
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

    def _channel(
        self, writer: Writer, topic: str, schema: str | None, encoding: str = "json"
    ) -> int:
        channel = self._channels.get(topic)
        if channel is not None:
            return channel
        schema_id = 0
        if schema is not None:
            schema_id = self._schemas.get(schema, 0)
            if not schema_id:
                data = json.dumps(SCHEMAS[schema]).encode()
                schema_id = writer.register_schema(schema, "jsonschema", data)
                self._schemas[schema] = schema_id
        metadata = {"format": "one MAVLink v1/v2 frame per message"} if schema is None else {}
        channel = writer.register_channel(topic, encoding, schema_id, metadata)
        self._channels[topic] = channel
        return channel

    def _write(self, topic: str, schema: str | None, t_s: float, data: bytes) -> None:
        if self._closed:
            return
        self._last_t = max(self._last_t, t_s)
        if schema is not None:
            for sink in self._sinks:
                sink.publish(topic, schema, t_s, data)
        writer = self._writer
        if writer is None:
            return
        try:
            channel = self._channel(writer, topic, schema, "json" if schema else RAW_ENCODING)
            ns = self._ns(t_s)
            self._sequence += 1
            writer.add_message(channel, ns, data, ns, self._sequence)
        except Exception as exc:  # whatever breaks the file must not reach the caller
            self._fail(exc)
            return
        now = time.monotonic()
        if now - self._last_flush >= self._flush_s:
            self.flush()

    def _fail(self, exc: BaseException) -> None:
        """Stop writing the file (keep what reached it) and say so once."""
        if self.failure is not None:
            return
        reason = getattr(exc, "strerror", None) or str(exc) or type(exc).__name__
        self.failure = f"the log stopped at mission time {self._last_t:.1f} s: {reason}"
        self._writer = None
        if self._file is not None:
            with contextlib.suppress(Exception):
                self._file.close()
        if self.on_failure is not None:
            self.on_failure(self.failure)

    def _json(self, topic: str, schema: str, t_s: float, message: dict[str, Any]) -> None:
        self._write(topic, schema, t_s, json.dumps(message, separators=(",", ":")).encode())

    def flush(self) -> None:
        """Close the current chunk and hand it to the OS: a crash after this loses nothing."""
        if self._closed or self._writer is None:
            return
        try:
            self._writer.flush()
            if self._file is not None:
                self._file.flush()
        except Exception as exc:
            self._fail(exc)
        self._last_flush = time.monotonic()

    def _write_meta(self) -> None:
        """What the run is about, first in the file: with the mission's own count of free
        cells, against which a log cut short is reported, and the wall clock at mission
        time 0 (``started_unix_s``, and exactly, ``started_unix_ns``)."""
        mission, charger, reserve_pct, free_cells = self._meta
        geo = self._geo
        meta: dict[str, Any] = {
            "mission": mission,
            "shape": list(self._shape),
            "cell_size_m": self._cell_size_m,
            "charger": list(charger),
            "reserve_pct": reserve_pct,
            "origin": {"lat_deg": geo.lat_deg, "lon_deg": geo.lon_deg, "alt_m": geo.alt_m},
            "started_unix_s": self.started_unix_ns / 1e9,
            "started_unix_ns": self.started_unix_ns,
        }
        if free_cells is not None:
            meta["free_cells"] = free_cells
        self._json(META_TOPIC, META_SCHEMA, 0.0, meta)

    def _write_frame(self) -> None:
        self._json(
            TF_TOPIC,
            "foxglove.FrameTransform",
            0.0,
            {
                "timestamp": _stamp(self._ns(0.0)),
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
        lat_deg: float | None = None,
        lon_deg: float | None = None,
        heading_deg: float | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        if self._closed:
            return
        row, col = int(cell[0]), int(cell[1])
        sensed = f',"sensed":"{sensed_code(readings)}"' if readings else ""
        state = (
            f'{{"t_s":{float(t_s)!r},"sysid":{int(sysid)},"battery_pct":{float(battery_pct)!r},'
            f'"mode":{json.dumps(str(mode))},"row":{row},"col":{col},"cell":[{row},{col}]'
            f"{sensed}}}"
        )
        self._write(f"/vehicle/{sysid}/battery", BATTERY_SCHEMA, t_s, state.encode())
        vehicle = self._vehicle(sysid)
        if heading_deg is None and vehicle.last_cell is not None:
            heading_deg = _move_heading(vehicle.last_cell, (row, col))
        if heading_deg is not None:
            vehicle.heading_deg = heading_deg
        fix = (row, col, lat_deg, lon_deg, vehicle.heading_deg)
        if fix != vehicle.last_fix:
            vehicle.last_fix = fix
            self._position(t_s, vehicle, (row, col), lat_deg, lon_deg)
        vehicle.last_cell = (row, col)
        if t_s >= self._next_tracks_t:
            self._emit_tracks(t_s)
        if self._btps is not None and t_s >= self._next_btps_t:
            self._emit_btps(t_s)

    def _position(
        self,
        t_s: float,
        vehicle: _Vehicle,
        cell: Cell,
        lat_deg: float | None,
        lon_deg: float | None,
    ) -> None:
        """LocationFix and PoseInFrame, formatted by hand: this runs at every move."""
        geo = self._geo
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
        point = f'{{"x":{round(east, 3)!r},"y":{round(north, 3)!r},"z":0.0}}'
        if not vehicle.track or vehicle.track[-1] != point:
            vehicle.track.append(point)
            self._tracks_dirty = True

    def _emit_tracks(self, t_s: float) -> None:
        """Every vehicle's whole track, so that a seek in Foxglove shows it too."""
        self._next_tracks_t = t_s + max(self._scene_period_s, self._scene_fraction * t_s)
        if not self._tracks_dirty:
            return
        self._tracks_dirty = False
        width = 0.15 * self._cell_size_m
        entities = []
        for v in self._vehicles.values():
            if not v.track:
                continue
            line = {
                "type": 0,  # LINE_STRIP
                "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.05}, "orientation": IDENTITY},
                "thickness": width,
                "scale_invariant": False,
                "points": [],
                "color": {"r": v.colour[0], "g": v.colour[1], "b": v.colour[2], "a": 0.9},
                "colors": [],
                "indices": [],
            }
            metadata = [{"key": "sysid", "value": str(v.sysid)}]
            entity = _entity(self._ns(t_s), f"track/{v.sysid}", lines=[line], metadata=metadata)
            text = json.dumps(entity)
            # The points are kept as JSON text: splice them in instead of encoding them again.
            entities.append(text.replace('"points": []', f'"points":[{",".join(v.track)}]', 1))
        update = f'{{"deletions":[],"entities":[{",".join(entities)}]}}'
        self._write(TRACKS_TOPIC, "foxglove.SceneUpdate", t_s, update.encode())

    def _emit_btps(self, t_s: float) -> None:
        cells, self._btps = self._btps or [], None
        self._next_btps_t = t_s + self._scene_period_s
        size = 0.5 * self._cell_size_m
        spheres = []
        for cell in cells:
            north, east = self._geo.cell_centre_local(cell)
            spheres.append(
                {
                    "pose": {
                        "position": {"x": east, "y": north, "z": 0.1},
                        "orientation": IDENTITY,
                    },
                    "size": {"x": size, "y": size, "z": size},
                    "color": {"r": 0.9, "g": 0.1, "b": 0.1, "a": 0.9},
                }
            )
        cells_json = json.dumps([list(c) for c in cells], separators=(",", ":"))
        entity = _entity(
            self._ns(t_s),
            "btps",
            spheres=spheres,
            metadata=[{"key": "cells", "value": cells_json}],
        )
        self._json(BTPS_TOPIC, "foxglove.SceneUpdate", t_s, {"deletions": [], "entities": [entity]})

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        codes = grid_codes(belief, covered)
        rows, cols = codes.shape
        cells = np.concatenate([codes[:, :, None], GRID_RGBA[codes]], axis=2)
        data = np.flipud(cells).tobytes()  # Foxglove's first row is the southern one
        stride = cells.shape[2]
        names = ("state", "red", "green", "blue", "alpha")
        grid = {
            "timestamp": _stamp(self._ns(t_s)),
            "frame_id": MAP_FRAME,
            "pose": {
                "position": {"x": 0.0, "y": -rows * self._cell_size_m, "z": 0.0},
                "orientation": IDENTITY,
            },
            "column_count": cols,
            "cell_size": {"x": self._cell_size_m, "y": self._cell_size_m},
            "row_stride": cols * stride,
            "cell_stride": stride,
            "fields": [{"name": n, "offset": k, "type": 1} for k, n in enumerate(names)],
            "data": base64.b64encode(data).decode("ascii"),
        }
        self._json(MAP_TOPIC, "foxglove.Grid", t_s, grid)

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        self._btps = [(int(r), int(c)) for r, c in cells]
        if t_s >= self._next_btps_t:
            self._emit_btps(t_s)

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        """A ``foxglove.Log`` on ``/events``: ``level`` one of ``LOG_LEVELS``, ``name`` the
        source (``vehicle N`` or ``gcs``), ``t_s`` the mission seconds."""
        message = {
            "timestamp": _stamp(self._ns(t_s)),
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
        self._json(RESULT_TOPIC, RESULT_SCHEMA, t_s, result_to_json(result))
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
        if self._tracks_dirty:
            self._emit_tracks(t_s)
        if self._btps is not None:
            self._emit_btps(t_s)

    def close(self) -> None:
        if self._closed:
            return
        try:
            self._emit_pending(self._last_t)
            if self._writer is not None and self._file is not None:
                self._writer.finish()
                self._file.flush()
        except Exception as exc:
            self._fail(exc)
        finally:
            self._closed = True
            if self._file is not None:
                with contextlib.suppress(Exception):
                    self._file.close()

    def __enter__(self) -> McapMissionLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
