"""A mission item exactly as MISSION_ITEM_INT carries it, and conversions to/from messages."""

from __future__ import annotations

import dataclasses
import math
import struct
from collections.abc import Iterable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

MISSION = mavlink.MAV_MISSION_TYPE_MISSION

#: Frames whose x/y are latitude/longitude (scaled by 1e7 in the INT messages).
GLOBAL_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_GLOBAL,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
#: Frames whose x/y are metres (scaled by 1e4 in the INT messages).
LOCAL_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_LOCAL_NED,
        mavlink.MAV_FRAME_LOCAL_ENU,
        mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
        mavlink.MAV_FRAME_BODY_NED,
        mavlink.MAV_FRAME_BODY_OFFSET_NED,
        mavlink.MAV_FRAME_BODY_FRD,
        mavlink.MAV_FRAME_LOCAL_FRD,
        mavlink.MAV_FRAME_LOCAL_FLU,
    }
)


_FLOAT32_FIELDS = ("param1", "param2", "param3", "param4", "z")
#: Each integer field and the range its wire type holds.
_INT_FIELDS = {
    "seq": (0, 0xFFFF),
    "frame": (0, 0xFF),
    "command": (0, 0xFFFF),
    "current": (0, 0xFF),
    "autocontinue": (0, 0xFF),
    "x": (-(2**31), 2**31 - 1),
    "y": (-(2**31), 2**31 - 1),
    "mission_type": (0, 0xFF),
}


class MissionItemError(ValueError):
    """An item no vehicle can be sent or have: a value its wire field cannot hold, an
    infinite parameter, a latitude beyond the pole."""


def _float32(name: str, value: float) -> float:
    """``value`` as float32; NaN passes (MAVLink's "unused" or "default"), infinity and
    values beyond float32 do not."""
    value = float(value)
    if math.isinf(value):
        raise MissionItemError(f"{name} is infinite")
    try:
        return struct.unpack("<f", struct.pack("<f", value))[0]
    except OverflowError:
        raise MissionItemError(f"{name} {value:g} is beyond a float32") from None


def xy_scale(frame: int) -> float:
    """Factor between a float x/y (MISSION_ITEM, files) and the INT x/y of ``frame``."""
    if frame in GLOBAL_FRAMES:
        return 1e7
    if frame in LOCAL_FRAMES:
        return 1e4
    return 1.0


@dataclass(frozen=True)
class MissionItem:
    """One mission item. ``x``/``y`` are the INT wire values: latitude/longitude in
    degrees × 1e7 for global frames, metres × 1e4 for local frames, raw
    param5/param6 otherwise. ``z`` is altitude in metres (or param7)."""

    seq: int
    frame: int
    command: int
    current: int = 0
    autocontinue: int = 1
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    mission_type: int = MISSION

    def __post_init__(self) -> None:
        """Every item is checked as it is made (read from a file, received, generated):
        one that cannot travel is refused before any transfer starts."""
        # Parameters travel as float32: store them that way so that an item
        # equals itself after a trip over the wire.
        for name in _FLOAT32_FIELDS:
            object.__setattr__(self, name, _float32(name, getattr(self, name)))
        for name, (low, high) in _INT_FIELDS.items():
            value = int(getattr(self, name))
            if not low <= value <= high:
                raise MissionItemError(f"{name} {value} is outside {low}..{high}")
            object.__setattr__(self, name, value)
        if self.frame in GLOBAL_FRAMES and (
            abs(self.x) > 900_000_000 or abs(self.y) > 1_800_000_000
        ):
            raise MissionItemError(
                f"latitude/longitude {self.x / 1e7:g}, {self.y / 1e7:g} is off the Earth"
            )

    @classmethod
    def waypoint(
        cls,
        seq: int,
        lat_deg: float,
        lon_deg: float,
        alt_m: float,
        *,
        frame: int = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        command: int = mavlink.MAV_CMD_NAV_WAYPOINT,
        hold_s: float = 0.0,
    ) -> MissionItem:
        return cls(
            seq=seq,
            frame=frame,
            command=command,
            param1=hold_s,
            x=round(lat_deg * 1e7),
            y=round(lon_deg * 1e7),
            z=alt_m,
        )

    @property
    def lat_deg(self) -> float:
        return self.x / 1e7

    @property
    def lon_deg(self) -> float:
        return self.y / 1e7

    @property
    def x_float(self) -> float:
        """x as MISSION_ITEM and the text formats carry it (degrees, metres, raw)."""
        return self.x / xy_scale(self.frame)

    @property
    def y_float(self) -> float:
        return self.y / xy_scale(self.frame)

    @property
    def has_position(self) -> bool:
        """A place on the Earth (a global frame and not 0, 0: "no position")."""
        return self.frame in GLOBAL_FRAMES and (self.x != 0 or self.y != 0)

    def with_seq(self, seq: int) -> MissionItem:
        return dataclasses.replace(self, seq=seq)

    def to_message(
        self, target_system: int, target_component: int
    ) -> mavlink.MAVLink_mission_item_int_message:
        return mavlink.MAVLink_mission_item_int_message(
            target_system, target_component, *self._fields(self.x, self.y)
        )

    def to_float_message(
        self, target_system: int, target_component: int
    ) -> mavlink.MAVLink_mission_item_message:
        """The old float MISSION_ITEM (x/y in degrees, metres or raw, by frame)."""
        return mavlink.MAVLink_mission_item_message(
            target_system, target_component, *self._fields(self.x_float, self.y_float)
        )

    def _fields(self, x: float, y: float) -> tuple[float, ...]:
        """The fields both item messages carry after the target, in their order."""
        return (
            self.seq,
            self.frame,
            self.command,
            self.current,
            self.autocontinue,
            self.param1,
            self.param2,
            self.param3,
            self.param4,
            x,
            y,
            self.z,
            self.mission_type,
        )

    @classmethod
    def from_message(cls, msg: mavlink.MAVLink_message) -> MissionItem:
        """From MISSION_ITEM_INT, or the old float MISSION_ITEM (x/y scaled to INT)."""
        if msg.get_type() == "MISSION_ITEM":
            scale = xy_scale(msg.frame)
            if not (math.isfinite(msg.x) and math.isfinite(msg.y)):
                raise MissionItemError(f"x/y {msg.x}, {msg.y} is not a position")
            x, y = round(msg.x * scale), round(msg.y * scale)
        else:
            x, y = msg.x, msg.y
        return cls(
            seq=msg.seq,
            frame=msg.frame,
            command=msg.command,
            current=msg.current,
            autocontinue=msg.autocontinue,
            param1=msg.param1,
            param2=msg.param2,
            param3=msg.param3,
            param4=msg.param4,
            x=x,
            y=y,
            z=msg.z,
            mission_type=getattr(msg, "mission_type", MISSION),
        )


def renumber(items: Iterable[MissionItem], start: int = 0) -> list[MissionItem]:
    """The items with consecutive ``seq`` from ``start``."""
    return [item.with_seq(start + i) for i, item in enumerate(items)]


def same_items(a: Iterable[MissionItem], b: Iterable[MissionItem]) -> bool:
    """Equality that treats NaN parameters as equal (NaN means "unset" in MAVLink)."""
    la, lb = list(a), list(b)
    return len(la) == len(lb) and all(_same(x, y) for x, y in zip(la, lb, strict=True))


def _same(a: MissionItem, b: MissionItem) -> bool:
    for field in dataclasses.fields(MissionItem):
        va, vb = getattr(a, field.name), getattr(b, field.name)
        if isinstance(va, float) and isinstance(vb, float) and math.isnan(va) and math.isnan(vb):
            continue
        if va != vb:
            return False
    return True
