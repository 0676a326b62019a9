"""The mission log's topics and their schemas: Foxglove's well-known ones (it
recognises them by name; the JSON schemas describe the subset of fields we write,
with Foxglove's field names) and ours; and the codes the messages carry (the map
grid's cell codes, an arrival's 8 readings)."""

from __future__ import annotations

import base64
from collections.abc import Mapping
from typing import Any

import numpy as np

from core.cells import CellState, Direction

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
#: An offline run's vehicle states, gathered: many steps of the whole fleet a message.
FLEET_STATES_TOPIC = "/fleet/states"

META_SCHEMA = "staying_alive.RunMeta"
RESULT_SCHEMA = "staying_alive.RunResult"
BATTERY_SCHEMA = "staying_alive.VehicleState"
STATUS_SCHEMA = "staying_alive.VehicleStatus"
PROGRESS_SCHEMA = "staying_alive.MissionProgress"
FLEET_STATES_SCHEMA = "staying_alive.FleetStates"


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
    # Columns: t_s[i] is step i; row[i][k], col[i][k], battery_pct[i][k], mode[i][k] are
    # those of vehicle sysids[k] at step i.
    FLEET_STATES_SCHEMA: _obj(
        FLEET_STATES_SCHEMA,
        sysids=_arr(_int()),
        t_s=_arr(_num()),
        row=_arr(_arr(_int())),
        col=_arr(_arr(_int())),
        battery_pct=_arr(_arr(_num())),
        mode=_arr(_arr(_str())),
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
    """The (rows north-first) uint8 codes in a map message's data
    (:class:`gcs.log.scenes.GridEncoder`)."""
    raw = np.frombuffer(base64.b64decode(message["data"]), dtype=np.uint8)
    cols = int(message["column_count"])
    cells = raw.reshape(-1, cols, int(message["cell_stride"]))
    return np.flipud(cells[:, :, 0]).copy()
