"""Mission items as the vehicle stores them, and their conversion to and from MAVLink.

Items are kept exactly as MISSION_ITEM_INT carries them (latitude and
longitude in 1e-7 degrees), so a mission uploaded with MISSION_ITEM_INT
downloads bit for bit identical. Items that arrive as the old float
MISSION_ITEM are converted once, on arrival.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

#: Frames whose x/y are latitude/longitude (so the float form is scaled by 1e7).
_GLOBAL_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_GLOBAL,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)


@dataclass(frozen=True)
class MissionItem:
    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float
    mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION

    @property
    def lat_deg(self) -> float:
        return self.x / 1e7

    @property
    def lon_deg(self) -> float:
        return self.y / 1e7

    @property
    def has_position(self) -> bool:
        return self.frame in _GLOBAL_FRAMES and (self.x != 0 or self.y != 0)

    @staticmethod
    def from_message(msg: Any) -> MissionItem:
        """From a MISSION_ITEM_INT or a MISSION_ITEM."""
        if msg.get_type() == "MISSION_ITEM_INT":
            x, y = int(msg.x), int(msg.y)
        elif msg.frame in _GLOBAL_FRAMES:
            x, y = round(msg.x * 1e7), round(msg.y * 1e7)
        else:
            x, y = round(msg.x), round(msg.y)
        return MissionItem(
            seq=int(msg.seq),
            frame=int(msg.frame),
            command=int(msg.command),
            current=int(msg.current),
            autocontinue=int(msg.autocontinue),
            param1=float(msg.param1),
            param2=float(msg.param2),
            param3=float(msg.param3),
            param4=float(msg.param4),
            x=x,
            y=y,
            z=float(msg.z),
            mission_type=int(getattr(msg, "mission_type", 0)),
        )

    def to_int_message(
        self, codec: mavlink.MAVLink, target_system: int, target_component: int
    ) -> mavlink.MAVLink_message:
        return codec.mission_item_int_encode(
            target_system,
            target_component,
            self.seq,
            self.frame,
            self.command,
            self.current,
            self.autocontinue,
            self.param1,
            self.param2,
            self.param3,
            self.param4,
            self.x,
            self.y,
            self.z,
            self.mission_type,
        )

    def to_float_message(
        self, codec: mavlink.MAVLink, target_system: int, target_component: int
    ) -> mavlink.MAVLink_message:
        scale = 1e7 if self.frame in _GLOBAL_FRAMES else 1.0
        return codec.mission_item_encode(
            target_system,
            target_component,
            self.seq,
            self.frame,
            self.command,
            self.current,
            self.autocontinue,
            self.param1,
            self.param2,
            self.param3,
            self.param4,
            self.x / scale,
            self.y / scale,
            self.z,
            self.mission_type,
        )
