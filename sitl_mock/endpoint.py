"""The MAVLink face of one mock vehicle: codec, dispatch, telemetry streams, signing, faults.

pymavlink is used only as a codec (``parse_buffer`` in, ``pack`` out); the
bytes travel over our own asyncio transports (``sitl_mock.transport``).
Each peer gets its own codec, so sequence numbers and parser state are
per peer, as on a real autopilot's channels; signing stream timestamps are
shared by all of them (``sitl_mock.signing``).
Telemetry streams tick on the injected clock, so a sped-up clock speeds
every stream up with it.

When the vehicle dies (battery empty) the endpoint sends the vehicle's last
words and then goes silent, as a real autopilot would when its power goes.
"""

from __future__ import annotations

import asyncio
import logging
import random
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import Clock
from sitl_mock import commands, parameters, telemetry
from sitl_mock.connection import Endpoint, parse_mock_side
from sitl_mock.events import (
    ItemReached,
    MissionCurrentChanged,
    Severity,
    StatusText,
    VehicleDied,
    VehicleEvent,
)
from sitl_mock.faults import (
    CommandFaultDice,
    CommandVerdict,
    MissionFaultTrigger,
    VehicleFaults,
)
from sitl_mock.mission_server import MissionProtocolSettings, MissionServer
from sitl_mock.signing import StreamTimestamps, enable_signing
from sitl_mock.transport import Peer, Transport, make_transport
from sitl_mock.vehicle import CommandRefused, Vehicle
from vehicles.transport import reset_parser

log = logging.getLogger(__name__)

Message: TypeAlias = mavlink.MAVLink_message
_STATUSTEXT_LEN = 50
_POSITION_IGNORED = (
    mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE
)


@dataclass(frozen=True)
class LinkSettings:
    """How the vehicle talks: where, signed or not, and the mission protocol's manners."""

    #: The mock's own side, e.g. ``udpout:127.0.0.1:14550`` (see ``connection.mirror``).
    connection: str
    signing_key: bytes | None = field(default=None, repr=False)
    allow_non_loopback: bool = False
    component_id: int = mavlink.MAV_COMP_ID_AUTOPILOT1
    mission: MissionProtocolSettings = field(default_factory=MissionProtocolSettings)
    #: Overrides of the default stream intervals (message id -> simulated seconds; <= 0 off).
    stream_intervals_s: Mapping[int, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.signing_key is not None and len(self.signing_key) != 32:
            raise ValueError(f"signing_key must be 32 bytes, got {len(self.signing_key)}")


def _stream_intervals(vehicle: Vehicle, link: LinkSettings) -> dict[int, float]:
    """The telemetry streams' periods at the start: the defaults, as the link's settings
    change them, without range readings on a vehicle that senses none."""
    intervals: dict[int, float] = dict(telemetry.DEFAULT_INTERVALS_S)
    for message_id, interval in link.stream_intervals_s.items():
        intervals[message_id] = interval
    if not vehicle.settings.range_sensing:
        intervals.pop(mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR, None)
        intervals.pop(mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE, None)
    return intervals


@dataclass
class _Channel:
    peer: Peer
    codec: mavlink.MAVLink


class VehicleEndpoint:
    def __init__(
        self,
        vehicle: Vehicle,
        link: LinkSettings,
        clock: Clock,
        faults: VehicleFaults | None = None,
        seed: int = 0,
        *,
        own_transport: bool = True,
    ) -> None:
        """``own_transport`` false: the vehicle shares a transport with others (one
        radio for the fleet); whoever made it feeds this endpoint as its listener."""
        self.vehicle = vehicle
        self.link = link
        self.clock = clock
        self.faults = faults or VehicleFaults()
        self.endpoint: Endpoint = parse_mock_side(link.connection, link.allow_non_loopback)
        self._encoder = mavlink.MAVLink(None, vehicle.id, link.component_id)
        self._channels: dict[int, _Channel] = {}
        self._transport: Transport | None = (
            make_transport(self.endpoint, self) if own_transport else None
        )
        self._streams: dict[int, asyncio.Task[None]] = {}
        self._intervals_s = _stream_intervals(vehicle, link)
        self._rng_to_gcs = random.Random(f"{seed}/{vehicle.id}/to_gcs")
        self._rng_from_gcs = random.Random(f"{seed}/{vehicle.id}/from_gcs")
        self._command_dice = CommandFaultDice(
            self.faults.commands, random.Random(f"{seed}/{vehicle.id}/commands")
        )
        self.mission = MissionServer(
            vehicle,
            self._encoder,
            self._send_to,
            self._announce,
            link.mission,
            MissionFaultTrigger(self.faults.mission),
        )
        self._handlers = self._message_handlers()
        self.silent = False
        #: Incoming messages refused for a missing or bad signature.
        self.rejected_signatures = 0
        #: Incoming garbage: bytes that are no frame, truncated frames, bad CRCs.
        self.bad_frames = 0
        #: Well-formed frames of a message id the dialect does not know.
        self.unknown_messages = 0
        #: Good frames addressed to another system (``target_system``), ignored.
        self.foreign_frames = 0
        #: Every good frame heard, by (message type, target system; 0 when it has none).
        self.heard: Counter[tuple[str, int]] = Counter()
        #: Signing stream timestamps, one table for every peer (no replay on another).
        self._signing_streams: StreamTimestamps = {}
        self._started = False
        vehicle.subscribe(self._on_vehicle_event)

    def _message_handlers(self) -> dict[str, Callable[[Peer, Any], None]]:
        """What answers each message the vehicle takes, by message type."""
        return {
            "COMMAND_LONG": self._on_command,
            "COMMAND_INT": self._on_command,
            "SET_MODE": self._on_set_mode,
            "SET_POSITION_TARGET_GLOBAL_INT": self._on_position_target,
            "TIMESYNC": self._on_timesync,
            "HEARTBEAT": self._on_heartbeat,
            "PARAM_REQUEST_READ": self._on_parameters,
            "PARAM_REQUEST_LIST": self._on_parameters,
            "PARAM_SET": self._on_parameters,
            **self.mission.handlers(),
        }

    # ------------------------------------------------------------------ lifecycle

    @property
    def local_port(self) -> int:
        if self._transport is None:
            raise RuntimeError("a vehicle on a shared transport has no port of its own")
        return self._transport.local_port

    async def start(self) -> None:
        if self._transport is not None:
            await self._transport.start()
        self._started = True
        for message_id in list(self._intervals_s):
            self._restart_stream(message_id)

    async def close(self) -> None:
        self._stop_streams()
        self.mission.close()
        if self._transport is not None:
            await self._transport.close()
        self._channels.clear()

    def _stop_streams(self) -> None:
        for task in self._streams.values():
            task.cancel()
        self._streams.clear()

    # ------------------------------------------------------------------ PeerListener

    def peer_opened(self, peer: Peer) -> None:
        codec = mavlink.MAVLink(None, self.vehicle.id, self.link.component_id)
        codec.robust_parsing = True
        if self.link.signing_key is not None:
            enable_signing(codec, self.link.signing_key, self._signing_streams)
        self._channels[id(peer)] = _Channel(peer, codec)

    def peer_closed(self, peer: Peer) -> None:
        self._channels.pop(id(peer), None)

    def peer_received(self, peer: Peer, data: bytes) -> None:
        channel = self._channels.get(id(peer))
        if channel is None or self.silent:
            return
        for msg in self._parse(channel.codec, data, whole_frames=peer.datagrams):
            if self._link_down() or self._lost(self._rng_from_gcs, self.faults.link.loss_from_gcs):
                continue
            latency = self.clock.to_real(self.faults.link.delay_s(self._rng_from_gcs))
            if latency > 0:
                asyncio.get_running_loop().call_later(latency, self._dispatch, peer, msg)
            else:
                self._dispatch(peer, msg)

    def _parse(self, codec: mavlink.MAVLink, data: bytes, *, whole_frames: bool) -> list[Message]:
        """The good messages in ``data`` for this vehicle. Garbage, truncated frames,
        bad CRCs and signatures, unknown message ids and frames addressed to another
        system are counted and dropped, never raised: nothing on the wire may stop
        the mock. ``whole_frames``: ``data`` is a datagram, so a frame cut at its
        end is garbage, not the start of the next datagram's frame."""
        try:
            messages = codec.parse_buffer(data) or []
        except Exception as exc:  # pymavlink raises a few things; never let them out
            log.debug("vehicle %d: unparsable data: %s", self.vehicle.id, exc)
            self.bad_frames += 1
            reset_parser(codec)
            return []
        good = [msg for msg in messages if self._count_in(msg)]
        if whole_frames and codec.buf_len() > 0:
            self.bad_frames += 1
            reset_parser(codec)
        return good

    def overheard(self, message_type: str, target_system: int) -> None:
        """A frame for another vehicle behind the same radio (``sitl_mock.radio``)."""
        if not self.silent:
            self.heard[message_type, target_system] += 1
            self.foreign_frames += 1

    def _count_in(self, msg: Message) -> bool:
        """Count a parsed message; true if it is a good one for this vehicle."""
        if isinstance(msg, mavlink.MAVLink_bad_data):
            if "signature" in str(msg.reason).lower():
                self.rejected_signatures += 1
            else:
                self.bad_frames += 1
            return False
        if isinstance(msg, mavlink.MAVLink_unknown):
            self.unknown_messages += 1
            return False
        self.heard[msg.get_type(), getattr(msg, "target_system", 0)] += 1
        if getattr(msg, "target_system", 0) not in (0, self.vehicle.id):
            self.foreign_frames += 1
            return False
        return True

    # ------------------------------------------------------------------ faults

    def _link_down(self) -> bool:
        return self.faults.link.cut_at(self.vehicle.elapsed_s)

    @staticmethod
    def _lost(rng: random.Random, probability: float) -> bool:
        return probability > 0 and rng.random() < probability

    # ------------------------------------------------------------------ sending

    def _write(self, channel: _Channel, msg: Message) -> None:
        if self._link_down() or self._lost(self._rng_to_gcs, self.faults.link.loss_to_gcs):
            return
        data = msg.pack(channel.codec)
        channel.codec.seq = (channel.codec.seq + 1) % 256
        latency = self.clock.to_real(self.faults.link.delay_s(self._rng_to_gcs))
        if latency > 0:
            asyncio.get_running_loop().call_later(latency, channel.peer.write, data)
        else:
            channel.peer.write(data)

    def _send_to(self, peer: Peer, msg: Message) -> None:
        channel = self._channels.get(id(peer))
        if channel is not None and not self.silent:
            self._write(channel, msg)

    def broadcast(self, msg: Message) -> None:
        if self.silent:
            return
        for channel in list(self._channels.values()):
            self._write(channel, msg)

    def _announce(self, status: StatusText) -> None:
        text = status.text.encode("utf-8")[:_STATUSTEXT_LEN]
        self.broadcast(self._encoder.statustext_encode(int(status.severity), text))

    def _on_vehicle_event(self, event: VehicleEvent) -> None:
        if isinstance(event, StatusText):
            self._announce(event)
        elif isinstance(event, ItemReached):
            self.broadcast(self._encoder.mission_item_reached_encode(event.seq))
        elif isinstance(event, MissionCurrentChanged):
            for msg in telemetry.mission_current(self._encoder, self.vehicle):
                self.broadcast(msg)
        elif isinstance(event, VehicleDied):
            self.silent = True
            self._stop_streams()
            self.mission.close()

    # ------------------------------------------------------------------ streams

    def _restart_stream(self, message_id: int) -> None:
        old = self._streams.pop(message_id, None)
        if old is not None:
            old.cancel()
        interval = self._intervals_s.get(message_id)
        if interval is None or interval <= 0 or not self._started or self.silent:
            return
        self._streams[message_id] = asyncio.get_running_loop().create_task(
            self._stream(message_id, interval), name=f"sitl-{self.vehicle.id}-stream-{message_id}"
        )

    async def _stream(self, message_id: int, interval_s: float) -> None:
        builder = telemetry.BUILDERS[message_id]
        while True:
            if self._channels:
                try:
                    messages = builder(self._encoder, self.vehicle)
                except Exception:  # one bad message must not end the stream for good
                    log.exception(
                        "vehicle %d: cannot build message %d", self.vehicle.id, message_id
                    )
                    messages = []
                for msg in messages:
                    self.broadcast(msg)
            await self.clock.sleep(interval_s)

    # CommandHost -------------------------------------------------------

    def set_interval(self, message_id: int, interval_us: float) -> bool:
        if message_id not in telemetry.BUILDERS:
            return False
        if interval_us == 0:
            default = telemetry.DEFAULT_INTERVALS_S.get(message_id)
            if default is None:
                self._intervals_s.pop(message_id, None)
            else:
                self._intervals_s[message_id] = default
        elif interval_us < 0:
            self._intervals_s[message_id] = 0.0
        else:
            self._intervals_s[message_id] = interval_us / 1e6
        self._restart_stream(message_id)
        return True

    def interval_us(self, message_id: int) -> int:
        interval = self._intervals_s.get(message_id)
        if interval is None or interval <= 0:
            return -1
        return round(interval * 1e6)

    def build(self, message_id: int) -> list[Message] | None:
        builder = telemetry.BUILDERS.get(message_id)
        return None if builder is None else builder(self._encoder, self.vehicle)

    def encoder(self) -> mavlink.MAVLink:
        return self._encoder

    # ------------------------------------------------------------------ dispatch

    def _dispatch(self, peer: Peer, msg: Any) -> None:
        if self.silent:
            return
        target = getattr(msg, "target_system", 0)
        if target not in (0, self.vehicle.id):
            return
        component = getattr(msg, "target_component", 0)
        if component not in (0, self.link.component_id):
            return
        handler = self._handlers.get(msg.get_type())
        if handler is not None:
            handler(peer, msg)

    def _on_command(self, peer: Peer, msg: Any) -> None:
        cmd = commands.Command.from_message(msg)
        verdict = self._command_dice.roll(cmd.command)
        if verdict is CommandVerdict.IGNORE:
            return
        if verdict is CommandVerdict.FAIL:
            outcome, refusal = commands.Outcome(mavlink.MAV_RESULT_FAILED), None
        else:
            outcome, refusal = commands.execute(self, cmd)
        ack = self._encoder.command_ack_encode(
            cmd.command, outcome.result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
        )
        self._send_to(peer, ack)
        for reply in outcome.replies:
            self._send_to(peer, reply)
        if refusal is not None:
            self._announce(StatusText(_refusal_severity(refusal), refusal))

    def _on_set_mode(self, peer: Peer, msg: Any) -> None:
        result = mavlink.MAV_RESULT_ACCEPTED
        try:
            if not msg.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                raise CommandRefused("Only custom modes are supported", mavlink.MAV_RESULT_DENIED)
            self.vehicle.set_mode(int(msg.custom_mode))
        except CommandRefused as refusal:
            result = refusal.result
            self._announce(StatusText(_refusal_severity(refusal.text), refusal.text))
        ack = self._encoder.command_ack_encode(
            mavlink.MAVLINK_MSG_ID_SET_MODE,
            result,
            0,
            0,
            msg.get_srcSystem(),
            msg.get_srcComponent(),
        )
        self._send_to(peer, ack)

    def _on_position_target(self, peer: Peer, msg: Any) -> None:
        """GUIDED target; like ArduPilot, ignored silently outside GUIDED."""
        if msg.type_mask & _POSITION_IGNORED == _POSITION_IGNORED:
            return
        geo = self.vehicle.world.geo
        north, east = geo.geo_to_local(msg.lat_int / 1e7, msg.lon_int / 1e7)
        alt = msg.alt
        if msg.coordinate_frame in (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT):
            alt -= geo.alt_m
        if msg.type_mask & mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE:
            alt = None
        try:
            self.vehicle.goto(north, east, alt)
        except CommandRefused as refusal:
            log.debug("vehicle %d ignored a position target: %s", self.vehicle.id, refusal.text)

    def _on_parameters(self, peer: Peer, msg: Any) -> None:
        for reply in parameters.answer(self._encoder, self.vehicle, msg):
            self._send_to(peer, reply)

    def _on_heartbeat(self, peer: Peer, msg: Any) -> None:
        """A ground station's heartbeat keeps the vehicle's GCS failsafe away."""
        if msg.type == mavlink.MAV_TYPE_GCS:
            self.vehicle.gcs_heartbeat()

    def _on_timesync(self, peer: Peer, msg: Any) -> None:
        if msg.tc1 == 0:
            now_ns = int(self.vehicle.elapsed_s * 1e9)
            self._send_to(peer, self._encoder.timesync_encode(now_ns, msg.ts1))


def _refusal_severity(text: str) -> Severity:
    return Severity.CRITICAL if text.startswith(("PreArm", "Arm:")) else Severity.WARNING
