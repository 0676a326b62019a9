"""The vehicle side of the MAVLink mission protocol: upload, download, clear, set current.

Like ArduPilot, an upload is answered with MISSION_REQUEST (the old float
request) by default, or MISSION_REQUEST_INT when configured; both
MISSION_ITEM_INT and MISSION_ITEM are accepted. Each request is repeated
every ``retry_s`` until its item arrives, and the upload is abandoned with
MAV_MISSION_OPERATION_CANCELLED after ``timeout_s`` of silence. An item with
a sequence number ahead of the expected one is NACKed with
MAV_MISSION_INVALID_SEQUENCE without ending the upload. Unlike ArduPilot,
the new mission replaces the old one only when the last item has arrived
(uploads are atomic), so a failed upload leaves the old mission in place.
If the final ACK was lost and the ground station repeats the last item,
the ACK is sent again.

Protocol timers run on the event loop's real time: they are about network
round trips, not about the simulated vehicle.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_mock.events import Severity, StatusText
from sitl_mock.faults import MissionFailure, MissionFaultTrigger
from sitl_mock.transport import Peer
from sitl_mock.vehicle import CommandRefused, Vehicle
from vehicles.mission_items import MissionItem, MissionItemError

Message: TypeAlias = mavlink.MAVLink_message


class MissionRequestStyle(Enum):
    """Which message asks the ground station for the next item during an upload."""

    MISSION_REQUEST = "mission_request"  # ArduPilot
    MISSION_REQUEST_INT = "mission_request_int"  # PX4, the current MAVLink spec


@dataclass(frozen=True)
class MissionProtocolSettings:
    request_style: MissionRequestStyle = MissionRequestStyle.MISSION_REQUEST
    max_items: int = 1000
    retry_s: float = 1.0
    timeout_s: float = 8.0


#: The mission types served: the mission, and the geofence (``sitl_mock.fence``).
_SERVED = frozenset({mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE})


@dataclass
class _Upload:
    peer: Peer
    gcs: tuple[int, int]
    count: int
    mission_type: int
    items: list[MissionItem] = field(default_factory=list)
    retry: asyncio.TimerHandle | None = None
    deadline: asyncio.TimerHandle | None = None

    @property
    def expected(self) -> int:
        return len(self.items)


class MissionServer:
    def __init__(
        self,
        vehicle: Vehicle,
        codec: mavlink.MAVLink,
        send: Callable[[Peer, Message], None],
        announce: Callable[[StatusText], None],
        settings: MissionProtocolSettings,
        faults: MissionFaultTrigger,
    ) -> None:
        self._vehicle = vehicle
        self._codec = codec
        self._send = send
        self._announce = announce
        self.settings = settings
        self._faults = faults
        self._upload: _Upload | None = None
        #: (peer name, last seq) of the last completed upload, to re-ACK a repeated last item.
        self._completed: tuple[str, int] | None = None

    @property
    def uploading(self) -> bool:
        return self._upload is not None

    def close(self) -> None:
        self._end_upload()

    def handlers(self) -> dict[str, Callable[[Peer, Any], None]]:
        return {
            "MISSION_COUNT": self.on_count,
            "MISSION_ITEM_INT": self.on_item,
            "MISSION_ITEM": self.on_item,
            "MISSION_REQUEST_LIST": self.on_request_list,
            "MISSION_REQUEST_INT": self.on_request,
            "MISSION_REQUEST": self.on_request,
            "MISSION_CLEAR_ALL": self.on_clear_all,
            "MISSION_SET_CURRENT": self.on_set_current,
            "MISSION_ACK": lambda peer, msg: None,
        }

    # ------------------------------------------------------------------ helpers

    def _ack(self, peer: Peer, gcs: tuple[int, int], result: int, mission_type: int = 0) -> None:
        self._send(peer, self._codec.mission_ack_encode(gcs[0], gcs[1], result, mission_type))

    @staticmethod
    def _gcs_of(msg: Any) -> tuple[int, int]:
        return (msg.get_srcSystem(), msg.get_srcComponent())

    # ------------------------------------------------------------------ upload

    def on_count(self, peer: Peer, msg: Any) -> None:
        gcs = self._gcs_of(msg)
        mission_type = int(getattr(msg, "mission_type", 0))
        if mission_type not in _SERVED:
            result = (
                mavlink.MAV_MISSION_ACCEPTED if msg.count == 0 else mavlink.MAV_MISSION_UNSUPPORTED
            )
            self._ack(peer, gcs, result, mission_type)
            return
        if self._faults.fires(MissionFailure.WRITE_COUNT_NO_RESPONSE):
            return
        if not self._vehicle.ready or msg.count > self.settings.max_items:
            self._ack(peer, gcs, mavlink.MAV_MISSION_NO_SPACE, mission_type)
            return
        self._end_upload()
        self._completed = None
        if msg.count == 0:
            self._replace(mission_type, ())
            self._ack(peer, gcs, mavlink.MAV_MISSION_ACCEPTED, mission_type)
            return
        self._upload = _Upload(peer, gcs, int(msg.count), mission_type)
        self._request_next()

    def _replace(self, mission_type: int, items: Any) -> None:
        if mission_type == mavlink.MAV_MISSION_TYPE_FENCE:
            self._vehicle.fence.replace(items)
        else:
            self._vehicle.replace_mission(items)

    def _items(self, mission_type: int) -> tuple[MissionItem, ...]:
        if mission_type == mavlink.MAV_MISSION_TYPE_FENCE:
            return self._vehicle.fence.items
        return self._vehicle.mission

    def _request_next(self) -> None:
        up = self._upload
        if up is None:
            return
        seq = up.expected
        loop = asyncio.get_running_loop()
        if up.retry is not None:
            up.retry.cancel()
        up.retry = loop.call_later(self.settings.retry_s, self._request_next)
        if self._faults.fires(MissionFailure.WRITE_REQUEST_NO_RESPONSE, seq):
            return
        if self._faults.fires(MissionFailure.WRITE_REQUEST_ERROR_ACK, seq):
            self._ack(up.peer, up.gcs, mavlink.MAV_MISSION_ERROR, up.mission_type)
            self._end_upload()
            return
        if self._faults.fires(MissionFailure.WRITE_REQUEST_WRONG_SEQUENCE, seq):
            seq = min(seq + 1, up.count - 1)
        if self.settings.request_style is MissionRequestStyle.MISSION_REQUEST:
            encode = self._codec.mission_request_encode
        else:
            encode = self._codec.mission_request_int_encode
        request = encode(up.gcs[0], up.gcs[1], seq, up.mission_type)
        self._send(up.peer, request)

    def _touch_deadline(self) -> None:
        up = self._upload
        assert up is not None
        if up.deadline is not None:
            up.deadline.cancel()
        up.deadline = asyncio.get_running_loop().call_later(self.settings.timeout_s, self._expire)

    def _expire(self) -> None:
        up = self._upload
        if up is not None:
            self._ack(up.peer, up.gcs, mavlink.MAV_MISSION_OPERATION_CANCELLED, up.mission_type)
            self._end_upload()

    def _end_upload(self) -> None:
        up = self._upload
        if up is None:
            return
        for handle in (up.retry, up.deadline):
            if handle is not None:
                handle.cancel()
        self._upload = None

    def on_item(self, peer: Peer, msg: Any) -> None:
        mission_type = int(getattr(msg, "mission_type", 0))
        up = self._upload
        if up is None:
            if self._completed == (peer.name, msg.seq):
                self._ack(peer, self._gcs_of(msg), mavlink.MAV_MISSION_ACCEPTED, mission_type)
            return
        if mission_type != up.mission_type:
            return
        if peer is not up.peer:
            return  # another ground station's item: ArduPilot serves one upload at a time
        if msg.seq < up.expected:
            return  # a repeat: the next request is on its way (or repeated by the timer)
        if msg.seq > up.expected:
            self._ack(peer, up.gcs, mavlink.MAV_MISSION_INVALID_SEQUENCE, up.mission_type)
            return
        self._touch_deadline()
        try:
            up.items.append(MissionItem.from_message(msg))
        except MissionItemError:  # a value its field cannot hold, a place off the Earth
            self._end_upload()
            self._ack(peer, up.gcs, mavlink.MAV_MISSION_INVALID, up.mission_type)
            return
        if up.expected < up.count:
            self._request_next()
            return
        self._finish(up)

    def _finish(self, up: _Upload) -> None:
        self._end_upload()
        if self._faults.fires(MissionFailure.WRITE_FINAL_ACK_ERROR):
            self._ack(up.peer, up.gcs, mavlink.MAV_MISSION_ERROR, up.mission_type)
            return
        self._replace(up.mission_type, up.items)
        self._completed = (up.peer.name, up.count - 1)
        if not self._faults.fires(MissionFailure.WRITE_FINAL_ACK_NO_RESPONSE):
            self._ack(up.peer, up.gcs, mavlink.MAV_MISSION_ACCEPTED, up.mission_type)
        if up.mission_type == mavlink.MAV_MISSION_TYPE_MISSION:
            self._announce(StatusText(Severity.INFO, "Flight plan received"))

    # ------------------------------------------------------------------ download

    def on_request_list(self, peer: Peer, msg: Any) -> None:
        gcs = self._gcs_of(msg)
        mission_type = int(getattr(msg, "mission_type", 0))
        if self._faults.fires(MissionFailure.READ_LIST_NO_RESPONSE):
            return
        count = len(self._items(mission_type)) if mission_type in _SERVED else 0
        self._send(peer, self._codec.mission_count_encode(gcs[0], gcs[1], count, mission_type))

    def on_request(self, peer: Peer, msg: Any) -> None:
        gcs = self._gcs_of(msg)
        seq = int(msg.seq)
        mission_type = int(getattr(msg, "mission_type", 0))
        if mission_type not in _SERVED:
            self._ack(peer, gcs, mavlink.MAV_MISSION_UNSUPPORTED, mission_type)
            return
        mission = self._items(mission_type)
        if not 0 <= seq < len(mission):
            self._ack(peer, gcs, mavlink.MAV_MISSION_INVALID_SEQUENCE, mission_type)
            return
        if self._faults.fires(MissionFailure.READ_ITEM_NO_RESPONSE, seq):
            return
        if self._faults.fires(MissionFailure.READ_ITEM_ERROR_ACK, seq):
            self._ack(peer, gcs, mavlink.MAV_MISSION_ERROR)
            return
        if self._faults.fires(MissionFailure.READ_ITEM_WRONG_SEQUENCE, seq):
            seq = seq + 1 if seq + 1 < len(mission) else max(0, seq - 1)
        item = mission[seq]
        if msg.get_type() == "MISSION_REQUEST_INT":
            self._send(peer, item.to_message(gcs[0], gcs[1]))
        else:
            self._send(peer, item.to_float_message(gcs[0], gcs[1]))

    # ------------------------------------------------------------------ clear, current

    def on_clear_all(self, peer: Peer, msg: Any) -> None:
        mission_type = int(getattr(msg, "mission_type", 0))
        if mission_type in _SERVED:
            self._end_upload()
            self._replace(mission_type, ())
        self._ack(peer, self._gcs_of(msg), mavlink.MAV_MISSION_ACCEPTED, mission_type)

    def on_set_current(self, peer: Peer, msg: Any) -> None:
        try:
            self._vehicle.set_current(int(msg.seq))
        except CommandRefused as refusal:
            self._announce(StatusText(Severity.WARNING, refusal.text))
