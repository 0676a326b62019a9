"""A geofence for the mission area: the last line of defence, which holds when the
ground station is gone.

QGroundControl and Mission Planner upload one with every mission; so do we. The
mission area's outer boundary is an inclusion polygon
(MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION items, param1 the vertex count, sent
with the mission protocol as MAV_MISSION_TYPE_FENCE), read back to check it, and
switched on with the action that brings the vehicle to its safe state: a rover
holds, a copter lands (``gcs.live.pilot.Pilot.make_safe``, the same rule).
"""

from __future__ import annotations

from collections.abc import Sequence

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.mission_items import MissionItem

FENCE = mavlink.MAV_MISSION_TYPE_FENCE


def inclusion_fence(vertices: Sequence[tuple[float, float]]) -> list[MissionItem]:
    """One inclusion polygon of (latitude, longitude) vertices, as fence items."""
    if len(vertices) < 3:
        raise ValueError("a polygon needs at least three vertices")
    return [
        MissionItem(
            seq=seq,
            frame=mavlink.MAV_FRAME_GLOBAL,
            command=mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            param1=len(vertices),
            x=round(lat * 1e7),
            y=round(lon * 1e7),
            mission_type=FENCE,
        )
        for seq, (lat, lon) in enumerate(vertices)
    ]


def same_fence(sent: Sequence[MissionItem], read_back: Sequence[MissionItem]) -> bool:
    """Whether the vehicle holds the fence that was sent: the same vertices in the same
    order. ArduPilot keeps no more of a fence item than that (it reads back with
    autocontinue 0), so nothing else is compared."""

    def vertices(items: Sequence[MissionItem]) -> list[tuple[int, int, int, int]]:
        return [(i.command, round(i.param1), i.x, i.y) for i in items]

    return vertices(sent) == vertices(read_back)
