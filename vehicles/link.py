"""``VehicleLink``: the ground station's MAVLink link to one vehicle.

It owns a transport, sends our HEARTBEAT at 1 Hz, tracks the vehicle's
heartbeat (link up / link lost), keeps a telemetry cache with async streams,
and offers commands, modes, guided targets and the mission protocol. Every
operation returns normally or raises a ``vehicles.errors.LinkError``.

    async with await VehicleLink.connect("tcp:127.0.0.1:5760") as link:
        status = await link.wait_heartbeat(timeout_s=10)
        await link.upload_mission(items)
        await link.set_mode(FlightMode.AUTO)
        async for pos in link.stream(Topic.POSITION): ...
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
from collections.abc import AsyncGenerator, Callable, Iterable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, Self

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.commands import CommandAck, CommandSender, CommandSettings
from vehicles.endpoints import Endpoint
from vehicles.errors import (
    CommandDenied,
    CommandTimeout,
    HeartbeatTimeout,
    LinkError,
    ModeNotSupported,
    TransportClosed,
)
from vehicles.mission_items import MISSION, MissionItem
from vehicles.mission_protocol import MissionClient, MissionSettings, TransferReport
from vehicles.models import VehicleProfile
from vehicles.modes import FlightMode
from vehicles.parameters import ParameterClient, ParameterSettings
from vehicles.router import Message, MessageRouter
from vehicles.signing import SigningConfig
from vehicles.telemetry import (
    ImplausibleTelemetry,
    TelemetryCache,
    Topic,
    TopicStreams,
    VehicleStatus,
)
from vehicles.transport import (
    GCS_COMPONENT_ID,
    GCS_SYSTEM_ID,
    MavlinkTransport,
    MessagePort,
    TransportStats,
)

log = logging.getLogger(__name__)

#: SET_POSITION_TARGET type_mask for "go to this position": everything but x/y/z ignored.
POSITION_ONLY_MASK = (
    mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
)
ARM_FORCE_MAGIC = 21196

#: Rates the ground station wants by default (Hz).
DEFAULT_RATES_HZ: dict[int, float] = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 5.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 2.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 2.0,
    mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR: 5.0,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
}


class LinkEvent(StrEnum):
    UP = "up"
    LOST = "lost"


@dataclass(frozen=True)
class RejectedFrames:
    """What a link received and threw away, by reason: counted, never raised."""

    #: Garbage, truncated frames, bad CRCs.
    bad_frames: int = 0
    bad_signatures: int = 0
    #: Well-formed frames of a message id the dialect does not know.
    unknown_messages: int = 0
    #: Good frames from a system id other than the vehicle's.
    foreign_frames: int = 0
    #: Telemetry carrying values no vehicle can have (``ImplausibleTelemetry``).
    implausible: int = 0
    #: ``udpin`` datagrams speaking for the vehicle from a second address (an impostor).
    other_address: int = 0

    @classmethod
    def of(cls, stats: TransportStats, *, foreign_frames: int = 0, implausible: int = 0) -> Self:
        """A transport's counts, with the ones its reader keeps."""
        return cls(
            bad_frames=stats.bad_frames,
            bad_signatures=stats.bad_signatures,
            unknown_messages=stats.unknown_messages,
            foreign_frames=foreign_frames,
            implausible=implausible,
            other_address=stats.other_address,
        )

    @property
    def total(self) -> int:
        return sum(dataclasses.astuple(self))

    def __add__(self, other: RejectedFrames) -> RejectedFrames:
        mine, theirs = dataclasses.astuple(self), dataclasses.astuple(other)
        return RejectedFrames(*(a + b for a, b in zip(mine, theirs, strict=True)))

    def report_fields(self, prefix: str = "link_") -> dict[str, int]:
        """The counts as report keys, e.g. ``link_bad_frames``."""
        return {f"{prefix}{k}": v for k, v in dataclasses.asdict(self).items()}


def rejected_frames(links: Iterable[VehicleLink]) -> RejectedFrames:
    """The rejected frames of several links, added up (a shared connection's own counts
    are its network's: ``MavlinkNetwork.rejected``)."""
    total = RejectedFrames()
    for link in links:
        total += link.rejected
    return total


@dataclass(frozen=True)
class LinkSettings:
    own_system: int = GCS_SYSTEM_ID
    own_component: int = GCS_COMPONENT_ID
    heartbeat_period_s: float = 1.0
    #: The link is lost when nothing came from the vehicle for this long (once up, any
    #: message shows it alive: on a lossy link the 1 Hz heartbeat alone goes missing
    #: three times in a row far more often than the whole telemetry stream does).
    link_lost_after_s: float = 3.0
    #: Pause between retries of an operation the vehicle is not ready for (arming
    #: during pre-arm checks), cut short by any STATUSTEXT.
    not_ready_retry_s: float = 1.0
    #: ``udpin``: follow a vehicle whose address changes (a router restarted) instead of
    #: staying with the address it first spoke from (``MavlinkTransport``).
    follow_address: bool = False
    commands: CommandSettings = field(default_factory=CommandSettings)
    mission: MissionSettings = field(default_factory=MissionSettings)
    parameters: ParameterSettings = field(default_factory=ParameterSettings)


class VehicleLink:
    """The link to one vehicle (``target_system``; the first autopilot heard if None).

    On a transport of its own it sends the station's heartbeat and counts frames of
    other systems as foreign; on its share of a connection that carries several
    vehicles (``vehicles.network``) the network does both, once per connection."""

    def __init__(
        self,
        transport: MessagePort,
        *,
        target_system: int | None = None,
        target_component: int | None = None,
        profile: VehicleProfile | None = None,
        settings: LinkSettings | None = None,
        on_wait: Callable[[str], None] | None = None,
    ) -> None:
        self.transport = transport
        #: Whether the transport is ours alone (not a share of a fleet's connection).
        self.owns_transport = isinstance(transport, MavlinkTransport)
        self.settings = settings or LinkSettings()
        self._target_system = target_system
        self._target_component = target_component
        self.telemetry = TelemetryCache(profile=profile)
        #: Every MAVLink message read from the transport (any system).
        self.messages_in = 0
        #: Good messages from another system than the vehicle's, ignored.
        self.foreign_frames = 0
        self.implausible = 0
        if isinstance(transport, MavlinkTransport):
            transport.wanted = self._from_vehicle
            transport.follow_moves = self.settings.follow_address
        self._fixed_profile = profile
        self.router = MessageRouter()
        self.streams = TopicStreams()
        self.on_wait = on_wait
        self.commands = CommandSender(
            self._send, self.router, self.settings.own_system, self._target, self.settings.commands
        )
        self.missions = MissionClient(
            self._send, self.router, self._target, self.settings.mission, on_wait=self._tell_wait
        )
        self.parameters = ParameterClient(
            self._send, self.router, self._target, self.settings.parameters
        )
        self._up = asyncio.Event()
        #: Set by every sign of life: a heartbeat, or once up any message of the vehicle.
        self._heard = asyncio.Event()
        self._tasks: list[asyncio.Task[None]] = []
        self._log = logging.LoggerAdapter(log, {"vehicle": target_system})

    # -- life cycle -----------------------------------------------------------------

    @classmethod
    async def connect(
        cls,
        endpoint: str | Endpoint,
        *,
        target_system: int | None = None,
        allow_remote: bool = False,
        signing: SigningConfig | None = None,
        settings: LinkSettings | None = None,
        **kwargs: Any,
    ) -> VehicleLink:
        """Open ``endpoint`` and start the link (heartbeats, reader, watchdog)."""
        s = settings or LinkSettings()
        transport = await MavlinkTransport.open(
            endpoint,
            allow_remote=allow_remote,
            source_system=s.own_system,
            source_component=s.own_component,
            signing=signing,
        )
        link = cls(transport, target_system=target_system, settings=s, **kwargs)
        link.start()
        return link

    def start(self) -> None:
        loop = asyncio.get_running_loop()
        tasks = [self._read(), self._watch_heartbeat()]
        if self.owns_transport:
            tasks.append(send_heartbeats(self.transport, self.settings.heartbeat_period_s))
        for coro in tasks:
            self._tasks.append(loop.create_task(coro))

    async def close(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await task
        self._tasks.clear()
        await self.transport.close()

    async def __aenter__(self) -> VehicleLink:
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # -- identity and state -----------------------------------------------------------

    @property
    def target_system(self) -> int | None:
        return self._target_system

    @property
    def target_component(self) -> int:
        return self._target_component or mavlink.MAV_COMP_ID_AUTOPILOT1

    def _target(self) -> tuple[int, int]:
        if self._target_system is None:
            raise LinkError("no vehicle heard yet: wait_heartbeat() first")
        return self._target_system, self.target_component

    def _from_vehicle(self, system: int) -> bool:
        """Whether ``system`` is our vehicle (any system until one is known)."""
        return self._target_system is None or system == self._target_system

    @property
    def rejected(self) -> RejectedFrames:
        """Frames received and thrown away so far, by reason (on a shared connection,
        those of this vehicle alone: the connection counts its garbage itself)."""
        if not self.owns_transport:
            return RejectedFrames(implausible=self.implausible)
        return RejectedFrames.of(
            self.transport.stats, foreign_frames=self.foreign_frames, implausible=self.implausible
        )

    @property
    def is_up(self) -> bool:
        return self._up.is_set()

    @property
    def status(self) -> VehicleStatus | None:
        return self.telemetry.status

    @property
    def profile(self) -> VehicleProfile | None:
        return self.telemetry.profile

    def _require_profile(self) -> VehicleProfile:
        if self.telemetry.profile is None:
            raise LinkError("vehicle type unknown: no heartbeat from a rover or copter yet")
        return self.telemetry.profile

    async def wait_heartbeat(self, timeout_s: float = 10.0) -> VehicleStatus:
        """Wait until the vehicle's heartbeat is heard; its status then."""
        try:
            async with asyncio.timeout(timeout_s):
                await self._up.wait()
        except TimeoutError:
            raise HeartbeatTimeout(self._target_system, timeout_s) from None
        assert self.telemetry.status is not None
        return self.telemetry.status

    def stream(self, topic: Topic) -> AsyncGenerator[Any, None]:
        """Updates on ``topic`` from now on (see ``vehicles.telemetry.Topic``)."""
        return self.streams.stream(topic)

    async def wait_for(
        self, topic: Topic, predicate: Callable[[Any], bool], timeout_s: float
    ) -> Any:
        """The first update on ``topic`` that satisfies ``predicate``."""
        updates = self.stream(topic)
        try:
            async with asyncio.timeout(timeout_s):
                async for value in updates:
                    if predicate(value):
                        return value
        finally:
            await updates.aclose()
        raise TransportClosed("stream ended")

    # -- background tasks ---------------------------------------------------------------

    def _send(self, msg: Message) -> None:
        self.transport.send(msg)

    def _tell_wait(self, text: str) -> None:
        if self.on_wait is not None:
            self.on_wait(text)

    async def _read(self) -> None:
        async for msg in self.transport:
            try:
                self._handle(msg)
            except Exception:  # one odd message must not end the reader (and the link)
                self._log.exception("cannot handle %s", msg.get_type())

    def _handle(self, msg: Message) -> None:
        """Take in one message from the transport: ours (telemetry, replies) or a stranger's."""
        self.messages_in += 1
        if self._target_system is None:
            if not _is_vehicle_heartbeat(msg):
                return
            self._target_system = msg.get_srcSystem()
            self._log = logging.LoggerAdapter(log, {"vehicle": self._target_system})
        if msg.get_srcSystem() != self._target_system:
            self.foreign_frames += 1
            return
        if _is_vehicle_heartbeat(msg):
            if self._target_component is None:
                self._target_component = msg.get_srcComponent()
            if msg.get_srcComponent() == self._target_component:
                self._on_heartbeat()
        elif self._up.is_set():
            self._heard.set()
        try:
            update = self.telemetry.update(msg)
        except ImplausibleTelemetry as exc:
            self.implausible += 1
            if self.implausible == 1:
                self._log.warning("refused %s: %s", msg.get_type(), exc)
            return
        if self._fixed_profile is not None:
            self.telemetry.profile = self._fixed_profile
        if update is not None:
            self.streams.publish(*update)
        self.router.dispatch(msg)

    def _on_heartbeat(self) -> None:
        self._heard.set()
        if not self._up.is_set():
            self._up.set()
            self._log.info("link up with system %s", self._target_system)
            self.streams.publish(Topic.LINK, LinkEvent.UP)

    async def _watch_heartbeat(self) -> None:
        while True:
            await self._heard.wait()
            self._heard.clear()
            try:
                async with asyncio.timeout(self.settings.link_lost_after_s):
                    await self._heard.wait()
            except TimeoutError:
                if self._up.is_set():
                    self._up.clear()
                    self._log.warning(
                        "link lost: nothing heard for %g s", self.settings.link_lost_after_s
                    )
                    self.streams.publish(Topic.LINK, LinkEvent.LOST)

    # -- commands -----------------------------------------------------------------------

    async def command_long(self, command: int, *params: float, **kwargs: Any) -> CommandAck:
        return await self.commands.long(command, *params, **kwargs)

    async def command_int(self, command: int, **kwargs: Any) -> CommandAck:
        return await self.commands.int(command, **kwargs)

    async def set_message_interval(self, message_id: int, rate_hz: float) -> CommandAck:
        """Ask for ``message_id`` at ``rate_hz`` (0 or less stops it)."""
        interval_us = -1.0 if rate_hz <= 0 else 1e6 / rate_hz
        return await self.command_long(
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, message_id, interval_us
        )

    async def request_rates(
        self, rates_hz: dict[int, float] | None = None
    ) -> dict[int, CommandAck | LinkError]:
        """Request several message rates; the result (ACK or error) per message id.
        A vehicle that refuses one rate does not stop the others."""
        results: dict[int, CommandAck | LinkError] = {}
        for message_id, rate in (rates_hz or DEFAULT_RATES_HZ).items():
            try:
                results[message_id] = await self.set_message_interval(message_id, rate)
            except LinkError as exc:
                self._log.info("rate for message %d not set: %s", message_id, exc)
                results[message_id] = exc
        return results

    async def set_mode(self, mode: FlightMode) -> None:
        """Switch to ``mode`` with MAV_CMD_DO_SET_MODE in the autopilot's encoding.

        If no ACK comes (some peers send none) but the next heartbeat shows the
        mode, that counts as success."""
        profile = self._require_profile()
        params = profile.flavour.set_mode_params(profile.kind, mode)
        if params is None:
            raise ModeNotSupported(mode.value, profile.name)
        try:
            await self.command_long(
                mavlink.MAV_CMD_DO_SET_MODE,
                params.base_mode,
                params.custom_mode,
                params.custom_sub_mode,
            )
        except CommandTimeout:
            if not await self._mode_shown(mode):
                raise

    async def _mode_shown(self, mode: FlightMode) -> bool:
        status = self.telemetry.status
        if status is not None and status.flight_mode == mode:
            return True
        try:
            await self.wait_for(
                Topic.STATUS,
                lambda s: s.flight_mode == mode,
                timeout_s=self.settings.link_lost_after_s,
            )
        except TimeoutError:
            return False
        return True

    async def arm(self, *, force: bool = False, wait_ready_s: float = 0.0) -> None:
        """Arm; with ``wait_ready_s`` > 0, keep retrying while the vehicle refuses
        (pre-arm checks after boot), telling ``on_wait`` why."""
        await self._until_ready(
            lambda: self.command_long(
                mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, ARM_FORCE_MAGIC if force else 0
            ),
            wait_ready_s,
            "arming",
        )

    async def disarm(self, *, force: bool = False) -> None:
        await self.command_long(
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, ARM_FORCE_MAGIC if force else 0
        )

    async def _until_ready(self, op: Callable[[], Any], wait_ready_s: float, what: str) -> None:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + wait_ready_s
        while True:
            try:
                await op()
                return
            except CommandDenied as exc:
                if loop.time() >= deadline:
                    raise
                last = self.telemetry.statustext
                reason = f" ({last.text})" if last is not None else ""
                self._tell_wait(f"system {self._target_system} refused {what}{reason}; retrying")
                # Wait for news from the vehicle (a STATUSTEXT) or the retry pause.
                pause = min(self.settings.not_ready_retry_s, max(0.0, deadline - loop.time()))
                with contextlib.suppress(TimeoutError):
                    await self.wait_for(Topic.STATUSTEXT, lambda _t: True, timeout_s=pause)
                self._log.debug("retrying %s after %s", what, exc)

    async def takeoff(self, alt_m: float) -> None:
        await self.command_long(
            mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, alt_m
        )

    async def land(self) -> None:
        profile = self._require_profile()
        if profile.supports(FlightMode.LAND):
            await self.set_mode(FlightMode.LAND)
        else:
            await self.command_long(mavlink.MAV_CMD_NAV_LAND)

    async def return_to_launch(self) -> None:
        """RTL through the mode (acknowledged on ArduPilot, PX4 and MAVSDK alike)."""
        await self.set_mode(FlightMode.RTL)

    async def goto(
        self, lat_deg: float, lon_deg: float, alt_m: float, *, yaw_deg: float | None = None
    ) -> None:
        """Guided target with SET_POSITION_TARGET_GLOBAL_INT (altitude relative to home).
        The vehicle must be in GUIDED (ArduPilot) or OFFBOARD (PX4). No ACK exists."""
        mask = POSITION_ONLY_MASK
        yaw = 0.0
        if yaw_deg is not None:
            mask &= ~mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE
            yaw = math.radians(yaw_deg)
        system, component = self._target()
        self._send(
            mavlink.MAVLink_set_position_target_global_int_message(
                0,
                system,
                component,
                mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                mask,
                round(lat_deg * 1e7),
                round(lon_deg * 1e7),
                alt_m,
                0,
                0,
                0,
                0,
                0,
                0,
                yaw,
                0,
            )
        )

    async def reposition(
        self, lat_deg: float, lon_deg: float, alt_m: float, *, speed_m_s: float = -1.0
    ) -> CommandAck:
        """MAV_CMD_DO_REPOSITION (switches to guided/hold mode as needed)."""
        return await self.command_int(
            mavlink.MAV_CMD_DO_REPOSITION,
            frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            params=(speed_m_s, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0.0, math.nan),
            x=round(lat_deg * 1e7),
            y=round(lon_deg * 1e7),
            z=alt_m,
        )

    async def set_speed(self, speed_m_s: float) -> CommandAck:
        return await self.command_long(mavlink.MAV_CMD_DO_CHANGE_SPEED, 1, speed_m_s, -1)

    async def read_param(self, name: str) -> float:
        """A parameter's value; ``ParameterUnavailable`` if the vehicle does not answer."""
        return await self.parameters.read(name)

    async def set_param(self, name: str, value: float) -> None:
        """Set a parameter; ``ParameterRejected`` if the vehicle keeps another value."""
        await self.parameters.write(name, value)

    # -- mission ------------------------------------------------------------------------

    async def upload_mission(
        self, items: Sequence[MissionItem], mission_type: int = MISSION
    ) -> TransferReport:
        return await self.missions.upload(items, mission_type)

    async def download_mission(self, mission_type: int = MISSION) -> list[MissionItem]:
        return await self.missions.download(mission_type)

    async def clear_mission(self, mission_type: int = MISSION) -> None:
        await self.missions.clear(mission_type)

    async def start_mission(self, first: int = 0, last: int = 0) -> CommandAck:
        return await self.command_long(mavlink.MAV_CMD_MISSION_START, first, last)

    async def set_current_item(self, seq: int) -> CommandAck:
        return await self.command_long(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, seq)


async def send_heartbeats(transport: MessagePort, period_s: float) -> None:
    """The ground station's HEARTBEAT on ``transport`` every ``period_s``, until cancelled."""
    heartbeat = mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
    )
    while True:
        with contextlib.suppress(TransportClosed):
            transport.send(heartbeat)
        await asyncio.sleep(period_s)


def _is_vehicle_heartbeat(msg: Message) -> bool:
    return (
        msg.get_type() == "HEARTBEAT"
        and msg.type != mavlink.MAV_TYPE_GCS
        and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID
    )
