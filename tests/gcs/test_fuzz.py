"""Fuzzing, bounded: the mission loader and the MAVLink input path never fail but as designed.

* ``gcs.mission.load_mission`` on generated YAML (nested values under the
  mission's real keys mixed with junk keys, mangled texts, random maps) either
  returns a ``Mission`` or raises ``MissionError`` whose message is one line
  starting with the file path; never any other exception.
* The ground station's transport (``MavlinkTransport._feed``) and the mock
  vehicle's (``VehicleEndpoint.peer_received``) take random bytes and mutated
  valid frames (bit flips, truncation, concatenation, good CRCs over random
  payloads) without raising; their counters only grow; and a valid frame sent
  afterwards is still decoded (on a byte stream, within the longest frame).
* Valid frames with nonsense field values go through the link's message
  handling (telemetry, replies) and the mock's handlers without raising.

Each test has a fixed number of examples and no deadline, so the file runs in
seconds; the CI profile (``tests/conftest.py``) makes the search reproducible.
"""

from __future__ import annotations

import asyncio
import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import ScaledClock
from core.geo import GeoFrame
from gcs.mission import (
    _DEFAULT_KEYS,
    _FLEET_KEYS,
    _ORIGIN_KEYS,
    _PLANNER_KEYS,
    _VEHICLE_KEYS,
    Mission,
    MissionError,
    load_mission,
)
from sitl_mock import commands as mock_commands
from sitl_mock.endpoint import LinkSettings as MockLinkSettings
from sitl_mock.endpoint import VehicleEndpoint
from sitl_mock.fleet import MockFleet, MockVehicleConfig
from sitl_mock.gridmap import GridMap
from sitl_mock.modes import VehicleKind
from sitl_mock.vehicle import VehicleSettings
from tests import frames
from vehicles.endpoints import parse_endpoint
from vehicles.link import VehicleLink
from vehicles.transport import MavlinkTransport

pytestmark = pytest.mark.timeout(120)


def fuzz(examples: int) -> Any:
    """Bounded: ``examples`` examples, no per-example deadline (a slow CI machine is
    not a failure), and fixtures shared across examples allowed."""
    return settings(
        max_examples=examples,
        deadline=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )


# ---------------------------------------------------------------------- mission loader

MAP_FILE = "map.txt"
#: Values a mission may well hold, so the loader gets past its first checks.
PLAUSIBLE = st.sampled_from(
    [MAP_FILE, "rover", "copter", "range", "map", "grid", "prm", "udpin:127.0.0.1:14550", ""]
)
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.floats(),
    st.text(max_size=12),
    st.text(alphabet="ab/.", min_size=250, max_size=300),  # longer than a file name may be
    PLAUSIBLE,
)
JUNK_KEYS = st.one_of(st.text(max_size=10), st.integers(), st.booleans(), st.none())
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(JUNK_KEYS, inner, max_size=4),
    max_leaves=12,
)


def section(keys: tuple[str, ...], values: st.SearchStrategy[Any] = VALUES) -> Any:
    """A mapping of the section's real keys, sometimes with a junk key, sometimes not
    a mapping at all."""
    real = st.dictionaries(st.sampled_from(keys), values, max_size=len(keys))
    with_junk = st.builds(lambda d, k, v: {**d, k: v}, real, JUNK_KEYS, VALUES)
    return st.one_of(real, real, real, with_junk, VALUES)


SMALL_INTS = st.integers(min_value=-2, max_value=300)
VEHICLE = section(_VEHICLE_KEYS, st.one_of(VALUES, SMALL_INTS, PLAUSIBLE))
FLEET = st.one_of(
    section(_FLEET_KEYS, VALUES),
    st.fixed_dictionaries(
        {},
        optional={
            "count": st.one_of(SMALL_INTS, VALUES),
            "defaults": section(_DEFAULT_KEYS, st.one_of(VALUES, PLAUSIBLE)),
            "vehicles": st.lists(VEHICLE, max_size=4),
        },
    ),
)
MISSION_DOC = st.fixed_dictionaries(
    {"map": st.one_of(st.just(MAP_FILE), st.just(MAP_FILE), VALUES)},
    optional={
        "name": VALUES,
        "charger": st.one_of(st.lists(SMALL_INTS, min_size=2, max_size=2), VALUES),
        "cell_size_m": VALUES,
        "origin": section(_ORIGIN_KEYS),
        "fleet": FLEET,
        "planner": section(_PLANNER_KEYS),
    },
)
TOP_WITH_JUNK = st.builds(lambda d, k, v: {**d, k: v}, MISSION_DOC, JUNK_KEYS, VALUES)


@st.composite
def map_texts(draw: st.DrawFn) -> str:
    """A rectangle of '#', '.' and 'C' (often a good map), or any text."""
    if draw(st.booleans()):
        return draw(st.text(alphabet="#.C x\t\r\n\u2028", max_size=60))
    rows, cols = draw(st.integers(1, 6)), draw(st.integers(1, 8))
    cells = st.sampled_from("..........##C")
    lines = ["".join(draw(st.lists(cells, min_size=cols, max_size=cols))) for _ in range(rows)]
    return "\n".join(lines) + "\n"


@st.composite
def mission_texts(draw: st.DrawFn) -> str:
    """A dumped mission document, sometimes mangled, or any text at all."""
    kind = draw(st.sampled_from(["doc", "doc", "junk-top", "mangled", "text"]))
    if kind == "text":
        return draw(st.text(max_size=200))
    doc = draw(TOP_WITH_JUNK if kind == "junk-top" else MISSION_DOC)
    text = yaml.safe_dump(doc, allow_unicode=True, sort_keys=False)
    if kind == "mangled" and text:
        start = draw(st.integers(0, len(text) - 1))
        end = draw(st.integers(start, min(len(text), start + 8)))
        text = text[:start] + draw(st.text(alphabet=":-[]{}'\"\n #&*!|>", max_size=4)) + text[end:]
    return text


def _encode(text: str) -> bytes:
    """UTF-8; a lone surrogate goes through as the invalid bytes it would be on disk."""
    return text.encode("utf-8", errors="surrogatepass")


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz_mission")


def assert_loads_or_says_why(path: Path) -> None:
    try:
        mission = load_mission(path)
    except MissionError as exc:
        message = str(exc)
        assert len(message.splitlines()) == 1, message
        assert message.startswith(f"{path}: "), message
        return
    assert isinstance(mission, Mission)
    assert not mission.map.obstacle[mission.charger]
    assert mission.fleet and mission.cell_size_m > 0


@fuzz(600)
@given(text=mission_texts(), map_text=map_texts())
def test_mission_loader_returns_a_mission_or_a_one_line_error(
    folder: Path, text: str, map_text: str
) -> None:
    (folder / MAP_FILE).write_bytes(_encode(map_text))
    path = folder / "mission.yaml"
    path.write_bytes(_encode(text))
    assert_loads_or_says_why(path)


@fuzz(100)
@given(data=st.binary(max_size=200))
def test_mission_loader_on_any_bytes(folder: Path, data: bytes) -> None:
    path = folder / "bytes.yaml"
    path.write_bytes(data)
    assert_loads_or_says_why(path)


# ---------------------------------------------------------------------- MAVLink input

VEHICLE_ID = 1
FOREIGN_ID = 42
#: The frame sent after the fuzz, which must still be decoded.
PROBE = frames.vehicle_heartbeat(VEHICLE_ID)
#: On a byte stream the parser may be inside a bogus frame of up to the longest length:
#: the probe, repeated this often, comes out whole at least once.
STREAM_REPEATS = math.ceil(frames.MAX_FRAME_LEN / len(PROBE)) + 2
SEEDS = (
    PROBE,
    frames.vehicle_heartbeat(FOREIGN_ID),
    frames.statustext(VEHICLE_ID, "PreArm: fuzz"),
    frames.gcs_command(VEHICLE_ID, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 1e6),
    frames.gcs_command(FOREIGN_ID, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1),
    frames.unknown_id_frame(VEHICLE_ID),
)
#: Messages either side acts on (and so may trip over).
HANDLED = (
    mavlink.MAVLINK_MSG_ID_HEARTBEAT,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
    mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR,
    mavlink.MAVLINK_MSG_ID_OBSTACLE_DISTANCE,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT,
    mavlink.MAVLINK_MSG_ID_MISSION_ITEM_REACHED,
    mavlink.MAVLINK_MSG_ID_STATUSTEXT,
    mavlink.MAVLINK_MSG_ID_COMMAND_ACK,
    mavlink.MAVLINK_MSG_ID_COMMAND_LONG,
    mavlink.MAVLINK_MSG_ID_COMMAND_INT,
    mavlink.MAVLINK_MSG_ID_SET_MODE,
    mavlink.MAVLINK_MSG_ID_SET_POSITION_TARGET_GLOBAL_INT,
    mavlink.MAVLINK_MSG_ID_TIMESYNC,
    mavlink.MAVLINK_MSG_ID_MISSION_COUNT,
    mavlink.MAVLINK_MSG_ID_MISSION_REQUEST_LIST,
    mavlink.MAVLINK_MSG_ID_MISSION_REQUEST_INT,
    mavlink.MAVLINK_MSG_ID_MISSION_REQUEST,
    mavlink.MAVLINK_MSG_ID_MISSION_ITEM_INT,
    mavlink.MAVLINK_MSG_ID_MISSION_ACK,
    mavlink.MAVLINK_MSG_ID_MISSION_CLEAR_ALL,
    mavlink.MAVLINK_MSG_ID_MISSION_SET_CURRENT,
)


@st.composite
def random_payload_frames(draw: st.DrawFn) -> bytes:
    """A frame of a handled message with random payload bytes and a good CRC."""
    msg_id = draw(st.sampled_from(HANDLED))
    sysid = draw(st.sampled_from([VEHICLE_ID, FOREIGN_ID, frames.GCS_SYSTEM]))
    payload = draw(st.binary(max_size=255))
    return frames.with_payload(msg_id, payload, sysid, frames.VEHICLE_COMPONENT)


@st.composite
def mutated_frames(draw: st.DrawFn) -> bytes:
    """Valid frames, bit-flipped, cut and glued together."""
    parts = draw(st.lists(st.sampled_from(SEEDS) | random_payload_frames(), min_size=1, max_size=3))
    data = bytearray(b"".join(parts))
    for _ in range(draw(st.integers(0, 3))):
        bit = draw(st.integers(0, 8 * len(data) - 1))
        data[bit // 8] ^= 1 << (bit % 8)
    if draw(st.booleans()):
        start = draw(st.integers(0, len(data) - 1))
        end = draw(st.integers(start + 1, len(data)))
        data = data[start:end]
    return bytes(data)


WIRE_CHUNKS = st.lists(
    st.one_of(st.binary(min_size=1, max_size=300), mutated_frames(), random_payload_frames()),
    max_size=6,
)


@fuzz(500)
@given(chunks=WIRE_CHUNKS, whole_frames=st.booleans())
def test_transport_takes_any_bytes(chunks: list[bytes], whole_frames: bool) -> None:
    """UDP (a datagram per chunk) and TCP (a stream cut anywhere) alike."""
    transport = MavlinkTransport(parse_endpoint("udpin:127.0.0.1:0"))
    before = dataclasses.astuple(transport.stats)
    for chunk in chunks:
        transport._feed(chunk, whole_frames=whole_frames)
        after = dataclasses.astuple(transport.stats)
        assert all(a >= b for a, b in zip(after, before, strict=True)), (before, after)
        before = after
    repeats = 1 if whole_frames else STREAM_REPEATS
    decoded = [m for _ in range(repeats) for m in transport._feed(PROBE, whole_frames=whole_frames)]
    assert any(m.get_type() == "HEARTBEAT" and m.get_srcSystem() == VEHICLE_ID for m in decoded), (
        decoded
    )


# The mock vehicle, fed directly (no sockets) through a fake peer.

GEO = GeoFrame(47.397742, 8.545594, 488.0, 1.0)
ENDPOINT_COUNTERS = ("bad_frames", "rejected_signatures", "unknown_messages", "foreign_frames")


@dataclasses.dataclass
class FakePeer:
    """Collects what the mock writes back."""

    datagrams: bool
    name: str = "fuzz"
    written: bytearray = dataclasses.field(default_factory=bytearray)

    def write(self, data: bytes) -> None:
        self.written.extend(data)

    def replies(self) -> list[Any]:
        codec = mavlink.MAVLink(None, frames.GCS_SYSTEM, frames.GCS_COMPONENT)
        codec.robust_parsing = True
        return codec.parse_buffer(bytes(self.written)) or []


def mock_fleet() -> MockFleet:
    grid = GridMap(obstacle=np.zeros((4, 5), dtype=bool), pads=((0, 0),))
    config = MockVehicleConfig(
        VEHICLE_ID,
        VehicleSettings(kind=VehicleKind.ROVER, start_cell=(0, 0)),
        MockLinkSettings("udpin:127.0.0.1:14550"),  # never opened,
    )
    return MockFleet([config], grid, GEO, ScaledClock(1.0))


def endpoint_counts(endpoint: VehicleEndpoint) -> tuple[int, ...]:
    return tuple(getattr(endpoint, name) for name in ENDPOINT_COUNTERS)


def probe_acked(peer: FakePeer) -> bool:
    return any(
        r.get_type() == "COMMAND_ACK" and r.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
        for r in peer.replies()
    )


async def _feed_mock(chunks: list[bytes], datagrams: bool) -> None:
    fleet = mock_fleet()
    endpoint = fleet.endpoints[VEHICLE_ID]
    peer = FakePeer(datagrams)
    endpoint.peer_opened(peer)
    try:
        before = endpoint_counts(endpoint)
        for chunk in chunks:
            endpoint.peer_received(peer, chunk)
            after = endpoint_counts(endpoint)
            assert all(a >= b for a, b in zip(after, before, strict=True)), (before, after)
            before = after
        peer.written.clear()
        probe = frames.gcs_command(VEHICLE_ID, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 1e6)
        assert frames.clean(probe)
        for _ in range(1 if datagrams else STREAM_REPEATS):
            endpoint.peer_received(peer, probe)
        assert probe_acked(peer) or fleet.vehicles[VEHICLE_ID].dead, peer.replies()
    finally:
        await endpoint.close()


@fuzz(300)
@given(chunks=WIRE_CHUNKS, datagrams=st.booleans())
def test_mock_endpoint_takes_any_bytes(chunks: list[bytes], datagrams: bool) -> None:
    asyncio.run(_feed_mock(chunks, datagrams))


# Valid frames, nonsense values: through the handlers on both sides.

_INT_RANGES = {
    "int8_t": (-(2**7), 2**7 - 1),
    "uint8_t": (0, 2**8 - 1),
    "int16_t": (-(2**15), 2**15 - 1),
    "uint16_t": (0, 2**16 - 1),
    "int32_t": (-(2**31), 2**31 - 1),
    "uint32_t": (0, 2**32 - 1),
    "int64_t": (-(2**63), 2**63 - 1),
    "uint64_t": (0, 2**64 - 1),
}
#: Fields drawn from their meaningful values half the time, so handlers get past
#: "not for me" and "unknown command" and act on the nonsense in the rest.
_MEANINGFUL = {
    "target_system": st.sampled_from([0, VEHICLE_ID, FOREIGN_ID]),
    "target_component": st.sampled_from([0, frames.VEHICLE_COMPONENT]),
    "command": st.sampled_from(sorted(mock_commands.HANDLERS)),
    "mission_type": st.sampled_from([mavlink.MAV_MISSION_TYPE_MISSION, 255]),
}


def _field(name: str, ftype: str, length: int) -> st.SearchStrategy[Any]:
    if ftype == "char":
        return st.text(alphabet=st.characters(max_codepoint=127), max_size=length).map(str.encode)
    if ftype in ("float", "double"):
        one: st.SearchStrategy[Any] = st.floats(width=32 if ftype == "float" else 64)
    else:
        lo, hi = _INT_RANGES[ftype]
        one = st.integers(lo, hi)
        if name in _MEANINGFUL:
            one = st.one_of(_MEANINGFUL[name], one)
    return st.lists(one, min_size=length, max_size=length) if length else one


@st.composite
def nonsense_messages(draw: st.DrawFn) -> bytes:
    """A valid frame of a handled message, every field any value of its type."""
    msgtype = mavlink.mavlink_map[draw(st.sampled_from(HANDLED))]
    # Array lengths are listed in wire order, field types in declaration order.
    lengths = dict(zip(msgtype.ordered_fieldnames, msgtype.array_lengths, strict=True))
    values = [
        draw(_field(name, ftype, lengths[name]))
        for name, ftype in zip(msgtype.fieldnames, msgtype.fieldtypes, strict=True)
    ]
    sysid = draw(st.sampled_from([VEHICLE_ID, FOREIGN_ID, frames.GCS_SYSTEM]))
    return frames.pack(msgtype(*values), sysid, frames.VEHICLE_COMPONENT)


@fuzz(400)
@given(data=st.lists(nonsense_messages(), min_size=1, max_size=5))
def test_link_handles_nonsense_values(data: list[bytes]) -> None:
    """Telemetry, command replies and the mission protocol take any field values."""
    transport = MavlinkTransport(parse_endpoint("udpin:127.0.0.1:0"))
    link = VehicleLink(transport, target_system=VEHICLE_ID)
    for frame in data:
        for msg in transport._feed(frame, whole_frames=True):
            link._handle(msg)
    assert link.messages_in == len(data)


async def _mock_handles(data: list[bytes]) -> None:
    fleet = mock_fleet()
    endpoint = fleet.endpoints[VEHICLE_ID]
    peer = FakePeer(datagrams=True)
    endpoint.peer_opened(peer)
    try:
        for frame in data:
            endpoint.peer_received(peer, frame)
    finally:
        await endpoint.close()


@fuzz(400)
@given(data=st.lists(nonsense_messages(), min_size=1, max_size=5))
def test_mock_handles_nonsense_values(data: list[bytes]) -> None:
    asyncio.run(_mock_handles(data))
