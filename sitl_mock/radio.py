"""Vehicles behind one radio: one transport for several mock vehicles.

A radio carries every frame to every vehicle behind it; each keeps what is
addressed to it (``target_system`` 0 or its own) and drops the rest. Here the
frames are split and their targets read once, with a codec of the link's own
(no keys: a signature is checked by the vehicle the frame is for), and only the
vehicles a frame is for parse it; the others are told they overheard it, and
count it as foreign as they would. Parsing every frame in every vehicle made a
fleet of 64 behind one radio cost the simulation 64 times the parsing, in the
event loop it shares with the ground station under ``gcs run --sim``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl_mock.transport import Peer
from vehicles.transport import reset_parser


class RadioListener(Protocol):
    """A vehicle behind the radio (``sitl_mock.endpoint.VehicleEndpoint``)."""

    def peer_opened(self, peer: Peer) -> None: ...

    def peer_received(self, peer: Peer, data: bytes) -> None: ...

    def peer_closed(self, peer: Peer) -> None: ...

    def overheard(self, message_type: str, target_system: int) -> None: ...


class Radio:
    """A ``PeerListener`` that hands each frame to the vehicles it is for."""

    def __init__(self, vehicles: Mapping[int, RadioListener]) -> None:
        self.vehicles = dict(vehicles)
        self._codecs: dict[int, mavlink.MAVLink] = {}

    def peer_opened(self, peer: Peer) -> None:
        codec = mavlink.MAVLink(None)
        codec.robust_parsing = True
        self._codecs[id(peer)] = codec
        for vehicle in self.vehicles.values():
            vehicle.peer_opened(peer)

    def peer_closed(self, peer: Peer) -> None:
        self._codecs.pop(id(peer), None)
        for vehicle in self.vehicles.values():
            vehicle.peer_closed(peer)

    def peer_received(self, peer: Peer, data: bytes) -> None:
        codec = self._codecs.get(id(peer))
        if codec is None:
            return
        try:
            messages = codec.parse_buffer(data) or []
        except Exception:  # pymavlink raises a few things: every vehicle counts the garbage
            reset_parser(codec)
            self._to_all(peer, data)
            return
        if peer.datagrams and codec.buf_len() > 0:  # a frame cut at a datagram's end
            leftover = bytes(codec.buf[codec.buf_index :])
            reset_parser(codec)
            self._to_all(peer, leftover)  # garbage, as each vehicle counts it
        for msg in messages:
            frame = bytes(msg.get_msgbuf())
            if isinstance(msg, mavlink.MAVLink_bad_data | mavlink.MAVLink_unknown):
                self._to_all(peer, frame)
                continue
            target = getattr(msg, "target_system", 0)
            for sysid, vehicle in self.vehicles.items():
                if target in (0, sysid):
                    vehicle.peer_received(peer, frame)
                else:
                    vehicle.overheard(msg.get_type(), target)

    def _to_all(self, peer: Peer, data: bytes) -> None:
        for vehicle in self.vehicles.values():
            vehicle.peer_received(peer, data)
