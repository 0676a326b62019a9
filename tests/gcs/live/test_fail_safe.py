"""Fail safe (issue: whatever breaks, every vehicle ends under control or safely stopped,
and the record tells the truth): each test is an attack as a hostile peer or a careless
operator would make it, and asserts the safe outcome."""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import io
import json
import math
import os
import struct
import tempfile
import unicodedata
import zlib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink
from rich.console import Console

from core.clocks import ScaledClock
from gcs.cli import main
from gcs.live.display import LiveDisplay
from gcs.live.pilot import Pilot
from gcs.live.readiness import fence_vertices
from gcs.live.shared import Level
from gcs.log.reader import LogError, read_log
from gcs.mission import Mission
from gcs.outcome.result import RunResult
from sitl_mock.drive import DriveSettings
from sitl_mock.events import StatusText as MockStatusText
from sitl_mock.fence import Fence as MockFence
from sitl_mock.modes import Behaviour
from tests.gcs.live.test_mission import SMALL, write_mission
from tests.processes import gcs_run
from tests.vehicles.test_link_commands import FAST, connected
from tests.vehicles.test_link_fake import FakeOptions, FakeVehicle
from tests.vehicles.test_link_vs_mock import BODY_S, SPEEDUP, UDP, linked
from tests.vehicles.test_link_vs_mock import mission as mission
from vehicles.endpoints import free_loopback_udp_ports
from vehicles.errors import LinkError, MissionError, MissionTimeout
from vehicles.fence import inclusion_fence
from vehicles.link import VehicleLink
from vehicles.mission_items import MissionItem
from vehicles.mission_protocol import MissionSettings
from vehicles.modes import VehicleKind
from vehicles.parameters import ParameterRejected
from vehicles.printable import printable
from vehicles.telemetry import StatusText, TelemetryCache, Topic

pytestmark = pytest.mark.timeout(120)


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_a_full_log_disk_is_a_warning_and_the_mission_flies_on(tmp_path: Path) -> None:
    """The log file's every write fails with ENOSPC (it is /dev/full): the operator is told
    once, the vehicles fly the mission to the end and are parked, nobody is lost, no
    traceback; report.json (on a disk with room) says the mission was complete."""
    mission = write_mission(tmp_path, SMALL, [{"type": "rover"}, {"type": "copter"}])
    out = tmp_path / "out"
    out.mkdir()
    (out / "mission.mcap").symlink_to("/dev/full")
    done = gcs_run("run", str(mission), "--sim", "--speedup", "30", "--quiet", "--out", str(out))
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode == 0, done.stderr
    assert "the log stopped at mission time" in done.stderr
    assert "No space left on device" in done.stderr
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] and report["lost_agents"] == 0


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full (Linux)")
def test_a_plan_whose_log_cannot_be_written_is_still_a_plan(tmp_path: Path) -> None:
    mission = write_mission(tmp_path, SMALL, [{"type": "rover"}])
    out = tmp_path / "out"
    out.mkdir()
    (out / "mission.mcap").symlink_to("/dev/full")
    done = gcs_run("plan", str(mission), "--quiet", "--out", str(out))
    assert "Traceback" not in done.stderr, done.stderr
    assert done.returncode == 0, done.stderr
    assert "warning: the log stopped at" in done.stderr
    assert json.loads((out / "report.json").read_text())["complete"]


# -- text from a vehicle -----------------------------------------------------------------

HOSTILE_TEXTS = (
    "\x1b[2J\x1b[Hcleared",  # clears the operator's terminal
    "[link=http://evil.example]click[/link]",  # Rich markup: a link
    "[/bogus] and what follows",  # Rich markup that does not close
    "ok\u202eenil a nrut",  # a right-to-left override
    "two\nlines\rforged",
)


def _statustext_on_the_wire(text: str) -> StatusText:
    codec = mavlink.MAVLink(None, 1, 1)
    frame = codec.statustext_encode(mavlink.MAV_SEVERITY_WARNING, text.encode()[:50]).pack(codec)
    message = mavlink.MAVLink(None).parse_buffer(bytes(frame))[0]
    cache = TelemetryCache()
    update = cache.update(message)
    assert update is not None
    return update[1]


@pytest.mark.parametrize("text", HOSTILE_TEXTS)
def test_a_vehicles_text_reaches_the_operator_printable(text: str) -> None:
    """No control, format or line-breaking character survives the decoding of a
    STATUSTEXT, and the display prints markup as the characters it is."""
    got = _statustext_on_the_wire(text).text
    assert all(not unicodedata.category(c).startswith("C") for c in got), repr(got)
    assert "\n" not in got and "\r" not in got
    display = LiveDisplay(quiet=True)
    display.errors = Console(file=io.StringIO(), force_terminal=True, width=200)
    for _ in range(2):  # the second one is still shown: nothing was swallowed
        display.notify(got, Level.ERROR, 1)
    shown = display.errors.file.getvalue()  # type: ignore[attr-defined]
    assert shown.count(f"error: {got}") == 2, repr(shown)
    assert "\x1b]8;" not in shown  # no terminal hyperlink was made


@given(st.text(max_size=300))
def test_printable_leaves_nothing_a_terminal_acts_on(text: str) -> None:
    got = printable(text)
    assert len(got) <= 200
    assert all(
        c == " " or not (c.isspace() or unicodedata.category(c).startswith("C")) for c in got
    )


# -- values no vehicle can have ----------------------------------------------------------


def _sys_status(remaining: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_sys_status_message(0, 0, 0, 500, 12000, 100, remaining, 0, 0, 0, 0, 0, 0)


def _position(lat_e7: int, lon_e7: int, vx_cm_s: int = 0) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_global_position_int_message(1000, lat_e7, lon_e7, 0, 0, vx_cm_s, 0, 0, 0)


IMPLAUSIBLE = (
    pytest.param(_sys_status(-100), id="battery -100 %"),
    pytest.param(_sys_status(127), id="battery 127 %"),
    pytest.param(_position(2_000_000_000, 85_000_000), id="latitude 200 degrees"),
    pytest.param(_position(473_000_000, -2_000_000_000), id="longitude -200 degrees"),
    pytest.param(_position(473_000_000, 85_000_000, 30_000), id="300 m/s"),
    pytest.param(
        mavlink.MAVLink_home_position_message(900_000_001, 0, 0, 0, 0, 0, [1, 0, 0, 0], 0, 0, 0),
        id="home beyond the pole",
    ),
)


@pytest.mark.parametrize("bad", IMPLAUSIBLE)
async def test_telemetry_out_of_physical_range_is_refused_and_counted(
    bad: mavlink.MAVLink_message,
) -> None:
    """A vehicle (or anyone speaking for it) sends a value no vehicle can have: the link
    keeps the last plausible value, counts the refusal, and stays up."""
    async with connected() as (fake, link):
        await _sent_and_seen(fake, link, _position(473_000_000, 85_000_000), Topic.POSITION)
        await _sent_and_seen(fake, link, _sys_status(80), Topic.BATTERY)
        before = (link.telemetry.battery, link.telemetry.position, link.telemetry.home)
        for _ in range(3):
            fake.send(bad, lossless=True)
        # A plausible message sent after them is taken: they were handled (and refused).
        await _sent_and_seen(fake, link, _sys_status(79), Topic.BATTERY)
        assert link.rejected.implausible == 3
        assert link.telemetry.position == before[1] and link.telemetry.home == before[2]
        assert link.telemetry.battery.remaining_pct == 79.0
        assert link.is_up


async def _sent_and_seen(
    fake: FakeVehicle, link: VehicleLink, msg: mavlink.MAVLink_message, topic: Topic
) -> None:
    seen = asyncio.ensure_future(link.wait_for(topic, lambda _v: True, 2.0))
    await asyncio.sleep(0)  # subscribed before it is sent
    fake.send(msg, lossless=True)
    await seen


# -- hostile mission files and items -----------------------------------------------------

WPL_HEADER = "QGC WPL 110"
HOME = "0\t1\t0\t16\t0\t0\t0\t0\t47.3977\t8.5456\t488\t1"


@pytest.mark.parametrize(
    "item",
    [
        pytest.param("1\t0\t3\t16\t0\t0\t0\t0\tinf\t8.5456\t10\t1", id="infinite latitude"),
        pytest.param("1\t0\t3\t16\t0\t0\t0\t0\t1000\t8.5456\t10\t1", id="latitude 1000"),
        pytest.param("1\t0\t3\t99999\t0\t0\t0\t0\t47.3\t8.5\t10\t1", id="command 99999"),
        pytest.param("1\t0\t3\t16\t1e300\t0\t0\t0\t47.3\t8.5\t10\t1", id="param 1e300"),
        pytest.param("1\t0\t3\t16\t0\t0\t0\t0\t47.3\t8.5\t-inf\t1", id="altitude -inf"),
    ],
)
def test_a_hostile_waypoint_file_is_refused_before_any_frame(tmp_path: Path, item: str) -> None:
    """The whole file is checked before the link opens: a one-line error, exit 2, and not
    one frame sent (the endpoint is a port nobody listens on: a frame would not fail)."""
    path = tmp_path / "m.waypoints"
    path.write_text(f"{WPL_HEADER}\n{HOME}\n{item}\n")
    done = gcs_run("mission", "upload", "udpout:127.0.0.1:9", str(path), "--timeout", "1")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "heartbeat" not in done.stderr.lower()  # refused before any link was tried


@pytest.mark.parametrize("bad", [math.nan, math.inf, 1e30])
async def test_a_vehicle_sending_an_impossible_item_fails_the_download_cleanly(bad: float) -> None:
    """A float MISSION_ITEM whose latitude is NaN, infinite or 1e30: the download fails
    with a MissionError naming the item, nothing is written, the link stays usable."""
    raw = mavlink.MAVLink_mission_item_message(
        255, 190, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, 16, 0, 1, 0, 0, 0, 0, bad, 8.5, 10
    )
    home = MissionItem.waypoint(0, 47.3977, 8.5456, 0.0)
    options = FakeOptions(raw_items={1: raw})
    async with connected(options) as (fake, link):
        fake.mission = [home, home.with_seq(1)]
        with pytest.raises(MissionError, match="at item 1"):
            await link.download_mission()
        assert link.is_up


# -- the record tells the truth ----------------------------------------------------------


@pytest.fixture(scope="module")
def full_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[bytes, RunResult]:
    """A real mission log (the plan of a small mission) and the run it records."""
    folder = tmp_path_factory.mktemp("log")
    mission = write_mission(folder, SMALL, [{"type": "rover"}])
    out = folder / "out"
    assert main(["plan", str(mission), "--quiet", "--out", str(out)]) == 0
    data = (out / "mission.mcap").read_bytes()
    result = read_log(out / "mission.mcap")
    assert result.complete and not result.interrupted
    return data, result


def _read_bytes(data: bytes) -> RunResult | None:
    """What ``gcs report`` makes of these bytes: a run, or None for a refused file."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "cut.mcap"
        path.write_bytes(data)
        try:
            return read_log(path)
        except LogError:
            return None


@settings(max_examples=150, deadline=None)
@given(cut=st.floats(0.0, 1.0, exclude_max=True))
def test_any_prefix_of_a_log_is_interrupted_never_complete(
    full_log: tuple[bytes, RunResult], cut: float
) -> None:
    """A log cut at any byte is read as interrupted (or refused, when not even the run's
    description survived), with coverage counted against the mission's free cells and no
    higher than the whole run's; only a cut after the run's own result record (in the
    index that follows it) still proves the run, and then exactly."""
    data, truth = full_log
    got = _read_bytes(data[: int(cut * len(data))])
    if got is None:
        return
    if not got.interrupted:
        assert (got.complete, got.covered_cells) == (truth.complete, truth.covered_cells)
        return
    assert not got.complete
    assert got.free_cells == truth.free_cells
    assert got.covered_cells <= truth.covered_cells


@settings(max_examples=100, deadline=None)
@given(
    flips=st.lists(
        st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(1, 255)),
        min_size=1,
        max_size=50,
    )
)
def test_a_damaged_log_claims_nothing_it_does_not_hold(
    full_log: tuple[bytes, RunResult], flips: list[tuple[float, int]]
) -> None:
    """Bytes flipped anywhere: the file is refused, or read as interrupted, or (the damage
    missed every record of the run) read exactly as the run was."""
    data, truth = full_log
    damaged = bytearray(data)
    for where, mask in flips:
        damaged[int(where * len(data))] ^= mask
    got = _read_bytes(bytes(damaged))
    if got is None or got.interrupted:
        return
    assert (got.complete, got.covered_cells, got.free_cells) == (
        truth.complete,
        truth.covered_cells,
        truth.free_cells,
    )


def test_gcs_report_on_a_log_cut_during_readiness_says_interrupted(
    full_log: tuple[bytes, RunResult], tmp_path: Path
) -> None:
    data, truth = full_log
    path = tmp_path / "cut.mcap"
    path.write_bytes(data[:1024])
    done = gcs_run("report", str(path), "--out", str(tmp_path / "report"))
    assert "Traceback" not in done.stderr
    if done.returncode == 2:  # not even the run's description in the first kilobyte
        assert len(done.stderr.strip().splitlines()) == 1
        return
    assert done.returncode == 1, done.stdout + done.stderr
    assert "INTERRUPTED" in done.stdout
    report = json.loads((tmp_path / "report" / "report.json").read_text())
    assert report["interrupted"] and not report["complete"]
    assert report["free_cells"] == truth.free_cells


# -- an impostor on a udpin endpoint -----------------------------------------------------


class _Peer(asyncio.DatagramProtocol):
    """A UDP socket on loopback that speaks as system 1 and keeps what it is sent."""

    def __init__(self) -> None:
        self.codec = mavlink.MAVLink(None, 1, 1)
        self.got: list[mavlink.MAVLink_message] = []
        self.parser = mavlink.MAVLink(None)
        self.transport: asyncio.DatagramTransport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        self.got += self.parser.parse_buffer(data) or []

    def heartbeat(self, port: int) -> None:
        msg = self.codec.heartbeat_encode(
            mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0
        )
        assert self.transport is not None
        self.transport.sendto(bytes(msg.pack(self.codec)), ("127.0.0.1", port))

    def commands(self) -> int:
        return sum(1 for m in self.got if m.get_type() == "COMMAND_LONG")


@pytest.mark.parametrize("follow", [False, True])
async def test_an_impostor_does_not_take_the_reply_address(follow: bool) -> None:
    """The vehicle speaks first; a second sender on another port claims system 1: the
    station's commands still go to the vehicle, the impostor's frames are counted as
    from a second address and shown; ``--follow-address`` lets the address move."""
    loop = asyncio.get_running_loop()
    port = free_loopback_udp_ports(1)[0]
    settings = dataclasses.replace(FAST, follow_address=follow)
    link = await VehicleLink.connect(f"udpin:127.0.0.1:{port}", target_system=1, settings=settings)
    peers = []
    try:
        for _ in range(2):
            _, peer = await loop.create_datagram_endpoint(_Peer, local_addr=("127.0.0.1", 0))
            peers.append(peer)
        vehicle, impostor = peers
        vehicle.heartbeat(port)
        await link.wait_heartbeat(timeout_s=2.0)
        vehicle.heartbeat(port)  # the address is locked once the vehicle is known
        await link.wait_for(Topic.STATUS, lambda _s: True, 2.0)
        for _ in range(3):
            impostor.heartbeat(port)
        await asyncio.sleep(0.1)
        with contextlib.suppress(LinkError):  # nobody answers it: only where it went counts
            await link.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 0)
        if follow:  # the address moved with the last sender
            assert link.rejected.other_address == 0
            assert impostor.commands() >= 1 and vehicle.commands() == 0
        else:
            assert link.rejected.other_address == 3
            assert impostor.commands() == 0 and vehicle.commands() >= 1
    finally:
        await link.close()
        for peer in peers:
            assert peer.transport is not None
            peer.transport.close()


# -- hostile maps and mission files ------------------------------------------------------


def _png_header_only(width: int, height: int) -> bytes:
    """A PNG that claims ``width`` x ``height`` pixels and holds one tiny IDAT."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        crc = zlib.crc32(kind + body) & 0xFFFFFFFF
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", crc)

    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)  # 1-bit greyscale
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\x00" * 64))
        + chunk(b"IEND", b"")
    )


def _mission_with_map(folder: Path, map_name: str, name: str = "hostile") -> Path:
    path = folder / "mission.yaml"
    path.write_text(
        f"name: {json.dumps(name)}\nmap: {map_name}\ncharger: [1, 1]\n"
        "fleet:\n  vehicles:\n    - {sysid: 1, type: rover}\n"
    )
    return path


@pytest.mark.parametrize("side", [12_000, 20_000])
def test_a_png_map_larger_than_the_limit_is_refused_unread(tmp_path: Path, side: int) -> None:
    """A few kilobytes claiming hundreds of millions of pixels: refused from the header,
    one line, exit 2 (it used to take 6-7 GB, or raise a decompression-bomb traceback)."""
    (tmp_path / "map.png").write_bytes(_png_header_only(side, side))
    done = gcs_run("plan", str(_mission_with_map(tmp_path, "map.png")), "--quiet")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert "4,000,000 cells" in done.stderr


def test_an_ascii_map_larger_than_the_limit_is_refused_unread(tmp_path: Path) -> None:
    with (tmp_path / "map.txt").open("wb") as sparse:  # 400 MB that take no disk
        sparse.truncate(20_000 * 20_001)
    done = gcs_run("plan", str(_mission_with_map(tmp_path, "map.txt")), "--quiet")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("name", ["\ud800", "bell\u0007", "two\nlines"])
def test_a_mission_name_that_is_not_printable_is_refused(tmp_path: Path, name: str) -> None:
    (tmp_path / "map.txt").write_text("####\n#C.#\n####\n")
    path = tmp_path / "mission.yaml"
    escaped = json.dumps(name)  # YAML reads JSON string escapes, \ud800 included
    path.write_text(
        f"name: {escaped}\nmap: map.txt\nfleet:\n  vehicles:\n    - {{sysid: 1, type: rover}}\n"
    )
    done = gcs_run("plan", str(path), "--quiet")
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert "name" in done.stderr


# -- a slow peer -------------------------------------------------------------------------

SLOW_PEER_LINK = dataclasses.replace(
    FAST,
    mission=MissionSettings(timeout_s=0.1, item_timeout_s=0.05, retries=5, min_transfer_s=1.0),
)


async def test_a_download_dragged_on_by_its_peer_has_a_deadline() -> None:
    """The vehicle answers one item request in five: every item still comes, after
    resends, but the whole download has a deadline from its size and the round trip
    measured at its start, and ends with a MissionTimeout instead of going on for ever."""
    home = MissionItem.waypoint(0, 47.3977, 8.5456, 0.0)
    async with FakeVehicle(FakeOptions(answer_every=5)) as fake:
        fake.mission = [home.with_seq(i) for i in range(60)]
        link = await VehicleLink.connect(fake.endpoint, settings=SLOW_PEER_LINK)
        try:
            await link.wait_heartbeat(timeout_s=2.0)
            loop = asyncio.get_running_loop()
            start = loop.time()
            with pytest.raises(MissionTimeout, match="not done within"):
                async with asyncio.timeout(30):
                    await link.download_mission()
            # 60 items at one answer in five take about 12 s; the deadline is 0.6 s
            # for the resends and 1 s (the floor: the round trip is far shorter) for the items
            assert loop.time() - start < 8.0
        finally:
            await link.close()


async def test_an_upload_asked_for_item_0_for_ever_has_a_deadline() -> None:
    home = MissionItem.waypoint(0, 47.3977, 8.5456, 0.0)
    async with FakeVehicle(FakeOptions(rerequest_first=True, item_timeout_s=0.01)) as fake:
        link = await VehicleLink.connect(fake.endpoint, settings=SLOW_PEER_LINK)
        try:
            await link.wait_heartbeat(timeout_s=2.0)
            with pytest.raises(MissionTimeout, match="not done within"):
                async with asyncio.timeout(30):
                    await link.upload_mission([home.with_seq(i) for i in range(20)])
        finally:
            await link.close()


# -- the geofence ------------------------------------------------------------------------


async def test_a_fenced_rover_stops_at_the_fence_after_the_station_falls_silent(
    mission: Mission,
) -> None:
    """The station fences a rover in (the west half of the map: columns 0-4), sends it
    toward column 8 (17 m east) and falls silent. ArduPilot holds at the breach; so does
    the mock: the rover ends in HOLD, armed and stopped, at most the roll from its speed
    past the fence (2 m/s rolls about 3 m), short of its target."""
    from gcs.mock_fleet import mock_fleet_configs

    base = mock_fleet_configs(mission)[0].vehicle
    geo, size = mission.geo, mission.cell_size_m
    fence_east_m = 5 * size
    corners = ((size, -size), (size, fence_east_m), (-8 * size, fence_east_m), (-8 * size, -size))
    vertices = [geo.local_to_geo(north, east) for north, east in corners]
    vehicle = dataclasses.replace(base, drive=DriveSettings(), speed_m_s=2.0)
    async with asyncio.timeout(BODY_S), linked(mission, UDP, vehicle=vehicle) as pair:
        pilot = Pilot(pair.link, VehicleKind.ROVER, geo, ScaledClock(SPEEDUP), 2.0)
        await pilot.set_fence(vertices)
        truth = pair.truth
        assert truth.fence.active and int(truth.fence.action) == 2
        texts: list[str] = []
        truth.subscribe(lambda e: texts.append(e.text) if isinstance(e, MockStatusText) else None)
        await pilot.underway()
        north, east = geo.cell_centre_local((0, 8))
        lat, lon = geo.local_to_geo(north, east)
        await pair.link.goto(lat, lon, 0.0)
        await pair.link.close()  # the station falls silent
        while not (
            truth.behaviour is Behaviour.HOLD and math.hypot(*truth.velocity_ned_m_s[:2]) < 0.05
        ):
            await asyncio.sleep(0.05)
        assert "Fence Breached" in texts
        assert truth.armed  # held, under the autopilot's control
        assert fence_east_m <= truth.east_m <= fence_east_m + 4.0, truth.east_m


def test_the_mission_fence_holds_every_cell_of_the_map(mission: Mission) -> None:
    """The fence the station uploads (``fence_vertices``) encloses the whole map with a
    cell to spare: no cell a vehicle is sent to can breach it."""
    fence = MockFence()
    fence.replace(inclusion_fence(fence_vertices(mission)))
    fence.enable = 1.0
    assert fence.active
    rows, cols = mission.map.shape
    geo = mission.geo
    for row in (-1, 0, rows // 2, rows - 1, rows):
        for col in (-1, 0, cols // 2, cols - 1, cols):
            centre = geo.local_to_geo(*geo.cell_centre_local((row, col)))
            assert fence.contains(*centre) == (row in range(-1, rows + 1)), (row, col)
    far = geo.local_to_geo(*geo.cell_centre_local((rows + 2, cols + 2)))
    assert not fence.contains(*far)


async def test_a_parameter_the_vehicle_does_not_take_is_an_error(
    mission: Mission,
) -> None:
    """PARAM_SET is checked on its echo: the mock (as ArduPilot with a read-only value)
    answers with the value it keeps, and the station says so instead of believing it."""
    async with asyncio.timeout(BODY_S), linked(mission, UDP) as pair:
        await pair.link.set_param("FENCE_ACTION", 1.0)
        assert pair.truth.fence.action == 1.0
        with pytest.raises(ParameterRejected, match="BATT_CAPACITY"):
            await pair.link.set_param("BATT_CAPACITY", 1.0)
