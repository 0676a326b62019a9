"""Mission files: ``QGC WPL 110`` text and QGroundControl ``.plan`` JSON.

Both read into the same list of ``MissionItem`` with item 0 the home position
(the WPL and ArduPilot convention): a ``.plan`` keeps home apart, as
``plannedHomePosition``, and its first SimpleItem becomes seq 1. Only
SimpleItems are supported (frame, command, params, lat/lon/alt kept as is);
complex items (surveys, corridor scans) are refused with a clear error.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.mission_items import MissionItem, MissionItemError, xy_scale

WPL_HEADER = "QGC WPL 110"
_WPL_COLUMNS = 12


class MissionFileError(ValueError):
    """A mission file that cannot be read; says where and why."""

    def __init__(self, source: str, reason: str, line: int | None = None) -> None:
        where = source if line is None else f"{source}:{line}"
        super().__init__(f"{where}: {reason}")
        self.source = source
        self.reason = reason
        self.line = line


# -- number formatting ----------------------------------------------------------------


def _fmt_float32(value: float) -> str:
    """The shortest text that reads back as the same float32 value."""
    if math.isnan(value):
        return "nan"
    for digits in range(6, 10):
        text = f"{value:.{digits}g}"
        if struct.unpack("<f", struct.pack("<f", float(text)))[0] == value:
            return text
    return repr(value)


def _fmt_xy(value_int: int, frame: int) -> str:
    scale = xy_scale(frame)
    if scale == 1e7:
        return f"{value_int / 1e7:.7f}"
    if scale == 1e4:
        return f"{value_int / 1e4:.4f}"
    return str(value_int)


def _xy_from_float(value: float, frame: int) -> int:
    value = float(value)
    if math.isnan(value):
        return 0
    if math.isinf(value):
        raise MissionItemError("x/y is infinite")
    return round(value * xy_scale(frame))


# -- QGC WPL 110 ------------------------------------------------------------------------


def format_wpl(items: Sequence[MissionItem]) -> str:
    lines = [WPL_HEADER]
    for item in items:
        cols = [
            str(item.seq),
            str(item.current),
            str(item.frame),
            str(item.command),
            *(_fmt_float32(p) for p in (item.param1, item.param2, item.param3, item.param4)),
            _fmt_xy(item.x, item.frame),
            _fmt_xy(item.y, item.frame),
            _fmt_float32(item.z),
            str(item.autocontinue),
        ]
        lines.append("\t".join(cols))
    return "\n".join(lines) + "\n"


def parse_wpl(text: str, source: str = "<wpl>") -> list[MissionItem]:
    lines = text.splitlines()
    if not lines or not lines[0].strip().startswith("QGC WPL"):
        raise MissionFileError(source, f"first line must be {WPL_HEADER!r}", line=1)
    version = lines[0].split()[-1]
    if version != "110":
        raise MissionFileError(source, f"unsupported WPL version {version} (need 110)", line=1)
    items = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cols = line.split()
        if len(cols) != _WPL_COLUMNS:
            raise MissionFileError(
                source, f"expected {_WPL_COLUMNS} columns, found {len(cols)}", line=number
            )
        try:
            frame = int(cols[2])
            item = MissionItem(
                seq=int(cols[0]),
                current=int(cols[1]),
                frame=frame,
                command=int(cols[3]),
                param1=float(cols[4]),
                param2=float(cols[5]),
                param3=float(cols[6]),
                param4=float(cols[7]),
                x=_xy_from_float(float(cols[8]), frame),
                y=_xy_from_float(float(cols[9]), frame),
                z=float(cols[10]),
                autocontinue=int(float(cols[11])),
            )
        except ValueError as exc:
            raise MissionFileError(source, f"bad number: {exc}", line=number) from None
        items.append(item)
    _check_sequence(items, source)
    return items


def _check_sequence(items: Sequence[MissionItem], source: str) -> None:
    for expected, item in enumerate(items):
        if item.seq != expected:
            raise MissionFileError(source, f"item {expected} has seq {item.seq}")


# -- QGroundControl .plan ---------------------------------------------------------------

_PLAN_FIRMWARE_ARDUPILOT = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA


def format_plan(
    items: Sequence[MissionItem],
    *,
    firmware_type: int = _PLAN_FIRMWARE_ARDUPILOT,
    vehicle_type: int = mavlink.MAV_TYPE_GROUND_ROVER,
    cruise_speed_m_s: float = 2.0,
    hover_speed_m_s: float = 5.0,
) -> str:
    """A ``.plan`` document; ``items[0]`` becomes the planned home position."""
    if not items:
        raise ValueError("a .plan needs at least the home item")
    home, rest = items[0], items[1:]
    plan = {
        "fileType": "Plan",
        "version": 1,
        "groundStation": "staying-alive-gcs",
        "mission": {
            "version": 2,
            "firmwareType": firmware_type,
            "vehicleType": vehicle_type,
            "cruiseSpeed": cruise_speed_m_s,
            "hoverSpeed": hover_speed_m_s,
            "plannedHomePosition": [home.lat_deg, home.lon_deg, home.z],
            "items": [_plan_item(item) for item in rest],
        },
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "rallyPoints": {"points": [], "version": 2},
    }
    return json.dumps(plan, indent=4) + "\n"


def _json_number(value: float) -> float | None:
    return None if math.isnan(value) else value


def _plan_item(item: MissionItem) -> dict[str, Any]:
    params = [item.param1, item.param2, item.param3, item.param4]
    params += [item.x_float, item.y_float, item.z]
    return {
        "type": "SimpleItem",
        "autoContinue": bool(item.autocontinue),
        "command": item.command,
        "doJumpId": item.seq,
        "frame": item.frame,
        "params": [_json_number(p) for p in params],
    }


def parse_plan(text: str, source: str = "<plan>") -> list[MissionItem]:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MissionFileError(source, f"not JSON: {exc.msg}", line=exc.lineno) from None
    if not isinstance(doc, dict) or doc.get("fileType") != "Plan":
        raise MissionFileError(source, 'not a QGroundControl plan (fileType is not "Plan")')
    mission = _require(doc, "mission", dict, source)
    home = _require(mission, "plannedHomePosition", list, source, "mission.")
    if len(home) != 3 or not all(isinstance(v, int | float) for v in home):
        raise MissionFileError(source, "mission.plannedHomePosition must be [lat, lon, alt]")
    try:
        items = [
            MissionItem(
                seq=0,
                frame=mavlink.MAV_FRAME_GLOBAL,
                command=mavlink.MAV_CMD_NAV_WAYPOINT,
                x=_xy_from_float(home[0], mavlink.MAV_FRAME_GLOBAL),
                y=_xy_from_float(home[1], mavlink.MAV_FRAME_GLOBAL),
                z=float(home[2]),
            )
        ]
    except ValueError as exc:
        raise MissionFileError(source, f"mission.plannedHomePosition: {exc}") from None
    raw_items = _require(mission, "items", list, source, "mission.")
    for index, raw in enumerate(raw_items):
        items.append(_parse_plan_item(raw, seq=len(items), where=f"mission.items[{index}]"))
    return items


def _parse_plan_item(raw: Any, seq: int, where: str) -> MissionItem:
    if not isinstance(raw, dict):
        raise MissionFileError(where, "must be an object")
    kind = raw.get("type")
    if kind != "SimpleItem":
        raise MissionFileError(where, f"type {kind!r} not supported (only SimpleItem)")
    params = raw.get("params")
    if not isinstance(params, list) or len(params) != 7:
        raise MissionFileError(where, "params must be a list of 7 numbers or nulls")
    try:
        values = [math.nan if p is None else float(p) for p in params]
        frame = int(raw["frame"])
        command = int(raw["command"])
    except (KeyError, TypeError, ValueError) as exc:
        raise MissionFileError(where, f"bad or missing field: {exc}") from None
    try:
        return _simple_item(raw, seq, frame, command, values)
    except ValueError as exc:
        raise MissionFileError(where, str(exc)) from None


def _simple_item(
    raw: dict[str, Any], seq: int, frame: int, command: int, values: list[float]
) -> MissionItem:
    return MissionItem(
        seq=seq,
        frame=frame,
        command=command,
        autocontinue=int(bool(raw.get("autoContinue", True))),
        param1=values[0],
        param2=values[1],
        param3=values[2],
        param4=values[3],
        x=_xy_from_float(values[4], frame),
        y=_xy_from_float(values[5], frame),
        z=0.0 if math.isnan(values[6]) else values[6],
    )


def _require(obj: dict[str, Any], key: str, kind: type, source: str, prefix: str = "") -> Any:
    value = obj.get(key)
    if not isinstance(value, kind):
        raise MissionFileError(source, f"{prefix}{key} missing or not a {kind.__name__}")
    return value


# -- by file name ---------------------------------------------------------------------

_Reader = Callable[[str, str], list[MissionItem]]
_Writer = Callable[[Sequence[MissionItem]], str]

#: Format by file extension.
FORMATS: dict[str, tuple[_Reader, _Writer]] = {
    ".waypoints": (parse_wpl, format_wpl),
    ".txt": (parse_wpl, format_wpl),
    ".plan": (parse_plan, format_plan),
}


def _format_for(path: Path) -> tuple[_Reader, _Writer]:
    try:
        return FORMATS[path.suffix.lower()]
    except KeyError:
        known = ", ".join(FORMATS)
        raise MissionFileError(
            str(path), f"unknown mission file extension {path.suffix!r} (use {known})"
        ) from None


def read_mission(path: str | Path) -> list[MissionItem]:
    """Read a mission file, choosing the format by extension."""
    path = Path(path)
    reader, _ = _format_for(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise MissionFileError(str(path), exc.strerror or str(exc)) from None
    return reader(text, str(path))


def write_mission(path: str | Path, items: Sequence[MissionItem]) -> None:
    """Write a mission file, choosing the format by extension."""
    path = Path(path)
    _, writer = _format_for(path)
    path.write_text(writer(items), encoding="utf-8")
