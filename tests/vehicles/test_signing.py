"""MAVLink 2 signing end to end: key files, signed mock vehicles, spoofers and replays.

Key files are parsed with exact one-line errors; ``gcs run --sim --keys``
completes a mission signed both ways and its log holds no key; a mock vehicle
with a key executes nothing unsigned, wrongly signed or replayed (on the same
connection or a new one); the ground station takes no unsigned or wrongly
signed frame as its vehicle's. The spoofers are raw sockets with a pymavlink
codec. Every wait has a timeout; loopback only.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import json
import os
import socket
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from core.clocks import ScaledClock
from gcs.cli import main
from gcs.mission import load_mission
from gcs.mock_fleet import mock_fleet_configs
from gcs.sitl_cli import main as sitl_main
from sitl_mock.fleet import MockFleet
from sitl_mock.modes import RoverMode
from vehicles.commands import CommandSettings
from vehicles.endpoints import free_loopback_tcp_ports, free_loopback_udp_ports
from vehicles.keyfile import KeyFile, KeyFileError, load_key_file, loose_permissions
from vehicles.link import LinkSettings, VehicleLink
from vehicles.signing import SigningConfig, apply_signing, signing_timestamp
from vehicles.transport import MavlinkTransport

pytestmark = pytest.mark.timeout(90)

PASSPHRASE = "staying alive test"
KEY = hashlib.sha256(PASSPHRASE.encode()).digest()
KEY2_HEX = bytes(range(1, 33)).hex()
OTHER_KEY = bytes(range(100, 132))
SPEEDUP = 25.0
WAIT_S = 5.0
FAST = LinkSettings(commands=CommandSettings(timeout_s=0.25, retries=4))
GCS_SYSID = 255
GCS_COMPID = mavlink.MAV_COMP_ID_MISSIONPLANNER
#: A spoofed position, far from the mission's area.
SPOOF_LAT_E7 = 10 * 10**7

MAP = """\
#######
#.....#
#.....#
#..C..#
#######
"""


# ---------------------------------------------------------------------- files


def write_mission(tmp_path: Path, vehicles: int = 1) -> Path:
    (tmp_path / "map.txt").write_text(MAP)
    lines = ["name: signed", "map: map.txt", "fleet:", "  vehicles:"]
    for sysid, port in enumerate(free_loopback_udp_ports(vehicles), 1):
        lines.append(
            f"    - {{sysid: {sysid}, type: rover, connection: 'udpin:127.0.0.1:{port}', "
            "energy_per_m_pct: 0.5}"
        )
    path = tmp_path / "mission.yaml"
    path.write_text("\n".join([*lines, "planner:", "  reserve_pct: 20", ""]))
    return path


def write_keys(tmp_path: Path, text: str | None = None, mode: int = 0o600) -> Path:
    path = tmp_path / "keys.yaml"
    path.write_text(text if text is not None else f'vehicles:\n  1: "passphrase:{PASSPHRASE}"\n')
    path.chmod(mode)
    return path


# ---------------------------------------------------------------------- key files


def test_a_good_key_file(tmp_path: Path) -> None:
    path = write_keys(
        tmp_path,
        f'# comment\nvehicles:\n  1: "passphrase:{PASSPHRASE}"\n  "2": "{KEY2_HEX.upper()}"\n',
    )
    keys = load_key_file(path)
    assert keys.keys == {1: KEY, 2: bytes(range(1, 33))}
    assert keys.sysids == {1, 2}
    signing = keys.signing(1)
    assert signing == SigningConfig(KEY, require_signed=True)
    assert keys.signing(3) is None
    keys.check_fleet([1, 2, 3])
    for text in (repr(keys), repr(signing), str(keys)):
        assert KEY.hex() not in text and repr(KEY) not in text and KEY2_HEX not in text.lower()


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("", "file is empty (a key file needs 'vehicles')"),
        ("- 1\n", "top level must be a mapping with 'vehicles', got a list"),
        ("vehicle: {}\n", "unknown key 'vehicle' (a key file has 'vehicles')"),
        ("keys: 1\nvehicles: {}\n", "unknown key 'keys' (a key file has 'vehicles')"),
        ("{}\n", "vehicles: missing (a mapping of system id to key)"),
        ("vehicles: [1]\n", "vehicles: must be a mapping of system id to key, got a list"),
        ("vehicles: {}\n", "vehicles: no vehicle has a key"),
        ("vehicles:\n  1: [\n", "invalid YAML at line 3, column 1"),
        (
            f'vehicles:\n  one: "{KEY2_HEX}"\n',
            "vehicles.one: not a system id (an integer 1..255)",
        ),
        (f'vehicles:\n  0: "{KEY2_HEX}"\n', "vehicles.0: system id out of range 1..255"),
        (f'vehicles:\n  256: "{KEY2_HEX}"\n', "vehicles.256: system id out of range 1..255"),
        (
            f'vehicles:\n  1: "{KEY2_HEX}"\n  "1": "{KEY2_HEX}"\n',
            "vehicles.1: given twice",
        ),
        (
            "vehicles:\n  1: " + "1234567890" * 6 + "1234\n",
            "vehicles.1: must be a string, 64 hex digits or 'passphrase:...'; "
            "got a number (quote it)",
        ),
        (
            "vehicles:\n  1: null\n",
            "vehicles.1: must be a string, 64 hex digits or 'passphrase:...'; got null",
        ),
        (
            'vehicles:\n  1: "abcdef0123"\n',
            "vehicles.1: must be 64 hex digits or 'passphrase:...'; got 10 characters",
        ),
        (
            f'vehicles:\n  1: "{"g" * 64}"\n',
            "vehicles.1: must be 64 hex digits or 'passphrase:...'; "
            "got characters that are not hex digits",
        ),
        (
            f'vehicles:\n  1: "{"0" * 64}"\n',
            "vehicles.1: an all-zero key means 'no signing' to ArduPilot",
        ),
        ('vehicles:\n  1: "passphrase:"\n', "vehicles.1: empty passphrase"),
    ],
)
def test_bad_key_files_say_file_key_and_problem(tmp_path: Path, text: str, problem: str) -> None:
    path = write_keys(tmp_path, text)
    with pytest.raises(KeyFileError) as caught:
        load_key_file(path)
    assert str(caught.value) == f"{path}: {problem}"
    assert "abcdef0123" not in problem and "g" * 64 not in problem  # never the key


def test_missing_and_binary_key_files(tmp_path: Path) -> None:
    missing = tmp_path / "nope.yaml"
    with pytest.raises(KeyFileError) as caught:
        load_key_file(missing)
    assert str(caught.value) == f"{missing}: cannot read file: No such file or directory"
    binary = tmp_path / "keys.bin"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(KeyFileError) as caught:
        load_key_file(binary)
    assert str(caught.value) == f"{binary}: not a text file (not valid UTF-8)"


def test_a_key_for_a_vehicle_outside_the_fleet(tmp_path: Path) -> None:
    keys = load_key_file(write_keys(tmp_path, f'vehicles:\n  1: "{KEY2_HEX}"\n  7: "{KEY2_HEX}"\n'))
    with pytest.raises(KeyFileError) as caught:
        keys.check_fleet([1, 2])
    assert str(caught.value) == f"{keys.source}: vehicles.7: no vehicle 7 in the fleet"


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_a_key_file_open_to_others_is_warned_about(tmp_path: Path) -> None:
    path = write_keys(tmp_path, mode=0o644)
    assert (
        loose_permissions(path) == f"{path}: open to group or others (mode 0644); chmod 600 {path}"
    )
    path.chmod(0o600)
    assert loose_permissions(path) is None


@pytest.mark.parametrize(
    ("keys_text", "problem"),
    [
        ('vehicles:\n  1: "abc"\n', "vehicles.1: must be 64 hex digits or 'passphrase:...'"),
        (f'vehicles:\n  2: "{KEY2_HEX}"\n', "vehicles.2: no vehicle 2 in the fleet"),
    ],
)
def test_bad_keys_are_one_line_errors_of_both_clis(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], keys_text: str, problem: str
) -> None:
    mission = write_mission(tmp_path)
    keys = write_keys(tmp_path, keys_text)
    assert main(["run", str(mission), "--sim", "--quiet", "--keys", str(keys)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"gcs run: {keys}: {problem}") and err.count("\n") == 1, err
    assert sitl_main([str(mission), "--keys", str(keys)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"sitl-mock: {keys}: {problem}") and err.count("\n") == 1, err


# ---------------------------------------------------------------------- gcs run


def test_signed_mission_end_to_end_and_no_key_in_the_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission = write_mission(tmp_path)
    keys = write_keys(tmp_path)
    out = tmp_path / "live"
    argv = ["run", str(mission), "--sim", "--keys", str(keys), "--quiet", "--out", str(out)]
    argv += ["--speedup", str(SPEEDUP), "--time-limit", "900", "--heartbeat-timeout", "10"]
    code = main(argv)
    report_text = (out / "report.json").read_text()
    report = json.loads(report_text)
    assert code == 0, report
    assert report["complete"] and report["lost_agents"] == 0
    assert capsys.readouterr().err == ""  # a 0600 key file: no warning
    log_bytes = (out / "mission.mcap").read_bytes()
    for text in (log_bytes, report_text.encode()):
        assert KEY not in text
        assert KEY.hex().encode() not in text and KEY.hex().upper().encode() not in text
        assert PASSPHRASE.encode() not in text
    frames = {"in": 0, "out": 0}
    with (out / "mission.mcap").open("rb") as stream:
        for _schema, channel, message in make_reader(stream).iter_messages(
            topics=["/mavlink/1/in", "/mavlink/1/out"]
        ):
            frame = message.data
            assert frame[0] == mavlink.PROTOCOL_MARKER_V2, channel.topic
            assert frame[2] & mavlink.MAVLINK_IFLAG_SIGNED, channel.topic
            frames[channel.topic.rsplit("/", 1)[1]] += 1
    assert frames["in"] > 50 and frames["out"] > 10, frames


async def test_gcs_refuses_an_unsigned_vehicle_it_has_a_key_for(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission_path = write_mission(tmp_path)
    keys = write_keys(tmp_path, mode=0o644)
    mission = load_mission(mission_path)
    argv = ["run", str(mission_path), "--keys", str(keys), "--quiet"]
    argv += ["--speedup", str(SPEEDUP), "--heartbeat-timeout", "1"]
    fleet = MockFleet(
        mock_fleet_configs(mission), mission.map, mission.geo, ScaledClock(SPEEDUP), seed=1
    )
    async with fleet:
        code = await asyncio.to_thread(main, argv)
        assert not fleet.vehicles[1].armed
    assert code == 1
    lines = capsys.readouterr().err.splitlines()
    assert (
        lines[0]
        == f"gcs run: warning: {keys}: open to group or others (mode 0644); chmod 600 {keys}"
    )
    where = f"(listening on {mission.fleet[0].connection}); "
    assert lines[1].startswith(
        f"gcs run: no heartbeat within 1 s from any of the 1 vehicle(s) {where}"
    ), lines
    assert (
        "frame(s) refused for their signature (unsigned, or signed with another key):" in (lines[1])
    ), lines
    assert len(lines) == 2, lines


# ---------------------------------------------------------------------- the mock vehicle


@contextlib.asynccontextmanager
async def signed_vehicle(
    tmp_path: Path, *, tcp: bool = False
) -> AsyncIterator[tuple[MockFleet, VehicleLink, KeyFile]]:
    """A signed mock rover configured as ``sitl-mock --keys`` does, and its signed link."""
    mission = load_mission(write_mission(tmp_path))
    keys = load_key_file(write_keys(tmp_path))
    tcp_port = free_loopback_tcp_ports(1)[0] if tcp else None
    configs = mock_fleet_configs(mission, tcp_base_port=tcp_port, keys=keys)
    assert configs[0].link.signing_key == KEY
    gcs_side = f"tcp:127.0.0.1:{tcp_port}" if tcp else mission.fleet[0].connection
    async with MockFleet(configs, mission.map, mission.geo, ScaledClock(SPEEDUP), seed=1) as fleet:
        link = await VehicleLink.connect(
            gcs_side, target_system=1, signing=keys.signing(1), settings=FAST
        )
        try:
            await link.wait_heartbeat(WAIT_S)
            yield fleet, link, keys
        finally:
            await link.close()


@contextlib.contextmanager
def udp_spoofer() -> Any:
    """A raw UDP socket on loopback; ``send(frame, port)``."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind(("127.0.0.1", 0))
        yield lambda frame, port: sock.sendto(frame, ("127.0.0.1", port))
    finally:
        sock.close()


def codec(sysid: int, compid: int, signing: SigningConfig | None = None) -> mavlink.MAVLink:
    c = mavlink.MAVLink(None, sysid, compid)
    c.robust_parsing = True
    apply_signing(c, signing)
    return c


def arm_frame(c: mavlink.MAVLink, arm: bool = True) -> bytes:
    msg = c.command_long_encode(
        1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, float(arm), 21196, 0, 0, 0, 0, 0
    )
    return bytes(msg.pack(c))


async def sync(link: VehicleLink) -> None:
    """A signed command and its ack: everything sent to the vehicle's socket before it
    has been read by then (one socket, in order)."""
    ack = await link.command_long(
        mavlink.MAV_CMD_REQUEST_MESSAGE, float(mavlink.MAVLINK_MSG_ID_HEARTBEAT)
    )
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED


async def test_spoofed_unsigned_commands_are_rejected(tmp_path: Path) -> None:
    """The acceptance test: unsigned (and wrongly signed) commands change nothing."""
    async with signed_vehicle(tmp_path) as (fleet, link, _keys):
        vehicle, endpoint = fleet.vehicles[1], fleet.endpoints[1]
        mode, rejected = vehicle.mode, endpoint.rejected_signatures
        unsigned = codec(GCS_SYSID, GCS_COMPID)
        wrong = codec(GCS_SYSID, GCS_COMPID, SigningConfig(OTHER_KEY))
        set_mode = mavlink.MAVLink_set_mode_message(
            1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, RoverMode.MANUAL
        )
        with udp_spoofer() as send:
            for c in (unsigned, wrong):
                send(arm_frame(c), endpoint.local_port)
                send(bytes(set_mode.pack(c)), endpoint.local_port)
            await sync(link)
        assert not vehicle.armed
        assert vehicle.mode == mode == RoverMode.HOLD
        assert endpoint.rejected_signatures == rejected + 4
        # The key holder is obeyed.
        await link.arm(force=True)
        assert vehicle.armed


async def test_a_forged_frame_stamped_ahead_does_not_lock_out_the_key_holder(
    tmp_path: Path,
) -> None:
    """pymavlink records a frame's timestamp before it checks the signature; we must not."""
    async with signed_vehicle(tmp_path) as (fleet, link, _keys):
        endpoint = fleet.endpoints[1]
        rejected = endpoint.rejected_signatures
        forger = codec(GCS_SYSID, GCS_COMPID, SigningConfig(OTHER_KEY))
        forger.signing.timestamp = signing_timestamp() + 100_000 * 86_400  # a day ahead
        with udp_spoofer() as send:
            send(arm_frame(forger), endpoint.local_port)
            await sync(link)  # times out if the key holder's stream was poisoned
        assert endpoint.rejected_signatures == rejected + 1
        assert not fleet.vehicles[1].armed


@pytest.mark.parametrize("tcp", [False, True], ids=["udp", "tcp-new-connection"])
async def test_a_replayed_signed_command_is_not_executed(tmp_path: Path, tcp: bool) -> None:
    async with signed_vehicle(tmp_path, tcp=tcp) as (fleet, link, keys):
        vehicle, endpoint = fleet.vehicles[1], fleet.endpoints[1]
        captured: list[bytes] = []

        def capture(direction: str, frame: bytes, msg: Any) -> None:
            if direction == "out" and msg.get_type() == "COMMAND_LONG" and msg.param1 == 1:
                captured.append(frame)

        link.transport.add_tap(capture)
        await link.arm(force=True)
        assert vehicle.armed and captured
        assert captured[0][2] & mavlink.MAVLINK_IFLAG_SIGNED
        await link.disarm(force=True)
        assert not vehicle.armed
        rejected = endpoint.rejected_signatures
        if tcp:
            await replay_on_a_new_connection(endpoint.local_port, captured[0], keys)
        else:
            with udp_spoofer() as send:
                send(captured[0], endpoint.local_port)
                await sync(link)
        assert not vehicle.armed
        assert endpoint.rejected_signatures == rejected + 1


async def replay_on_a_new_connection(port: int, frame: bytes, keys: KeyFile) -> None:
    """Replay ``frame`` on a TCP connection of its own, then wait for the ack of a
    signed command sent after it on the same connection (another signing link id)."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        signing = keys.signing(1, link_id=7)
        assert signing is not None
        c = codec(GCS_SYSID, GCS_COMPID, signing)
        request = c.command_long_encode(
            1,
            1,
            mavlink.MAV_CMD_REQUEST_MESSAGE,
            0,
            mavlink.MAVLINK_MSG_ID_HEARTBEAT,
            0,
            0,
            0,
            0,
            0,
            0,
        )
        writer.write(frame + bytes(request.pack(c)))
        await writer.drain()
        await asyncio.wait_for(_read_until(reader, c, _is_request_ack), WAIT_S)
    finally:
        writer.close()
        with contextlib.suppress(ConnectionError):
            await writer.wait_closed()


def _is_request_ack(msg: Any) -> bool:
    return msg.get_type() == "COMMAND_ACK" and msg.command == mavlink.MAV_CMD_REQUEST_MESSAGE


async def _read_until(
    reader: asyncio.StreamReader, c: mavlink.MAVLink, predicate: Callable[[Any], bool]
) -> Any:
    while data := await reader.read(4096):
        for msg in c.parse_buffer(data) or []:
            if predicate(msg):
                return msg
    raise ConnectionError("the vehicle closed the connection")


# ---------------------------------------------------------------------- the ground station


async def test_gcs_ignores_unsigned_or_forged_telemetry_of_its_vehicle(tmp_path: Path) -> None:
    async with signed_vehicle(tmp_path) as (fleet, link, _keys):
        seen: list[Any] = []
        assert isinstance(link.transport, MavlinkTransport)
        link.transport.add_tap(lambda direction, _frame, msg: seen.append(msg))
        vehicle_address = link.transport.peer
        gcs_port = int(load_mission(tmp_path / "mission.yaml").fleet[0].connection.rsplit(":")[-1])
        bad_signatures = link.transport.stats.bad_signatures
        unsigned = codec(1, 1)
        forger = codec(1, 1, SigningConfig(OTHER_KEY))
        forger.signing.timestamp = signing_timestamp() + 100_000 * 86_400  # a day ahead
        heartbeat = mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GROUND_ROVER,
            mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
            mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED,
            RoverMode.MANUAL,
            mavlink.MAV_STATE_ACTIVE,
            3,
        )
        position = mavlink.MAVLink_global_position_int_message(
            0, SPOOF_LAT_E7, SPOOF_LAT_E7, 0, 0, 0, 0, 0, 0
        )
        with udp_spoofer() as send:
            for c in (unsigned, forger):
                send(bytes(heartbeat.pack(c)), gcs_port)
                send(bytes(position.pack(c)), gcs_port)
            # The command goes to the vehicle (not to the spoofer) and its signed ack
            # is read after the spoofed frames (also: the forger poisoned no stream).
            await sync(link)
        assert link.transport.peer == vehicle_address
        assert link.transport.stats.bad_signatures == bad_signatures + 4
        incoming = [m for m in seen if m.get_srcSystem() == 1]
        assert incoming and all(m.get_signed() for m in incoming)
        assert not any(getattr(m, "lat", None) == SPOOF_LAT_E7 for m in seen)
        assert link.status is not None and not link.status.armed
        assert link.telemetry.position is not None
        assert link.telemetry.position.lat_deg != pytest.approx(SPOOF_LAT_E7 / 1e7)
        assert not fleet.vehicles[1].armed


# ---------------------------------------------------------------------- one option everywhere


async def test_status_and_mission_sign_with_the_key_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--keys`` is the signing option of ``gcs status`` and ``gcs mission`` too: the
    right key hears the signed vehicle and moves its mission, another key hears nothing,
    and a file with several different keys needs ``--sysid``."""
    mission = load_mission(write_mission(tmp_path))
    keys_path = write_keys(tmp_path)
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text(f'vehicles:\n  1: "{OTHER_KEY.hex()}"\n')
    wrong.chmod(0o600)
    several = tmp_path / "several.yaml"
    several.write_text(f'vehicles:\n  1: "passphrase:{PASSPHRASE}"\n  2: "{KEY2_HEX}"\n')
    several.chmod(0o600)
    (tcp_port,) = free_loopback_tcp_ports(1)
    configs = mock_fleet_configs(mission, tcp_base_port=tcp_port, keys=load_key_file(keys_path))
    endpoint = f"tcp:127.0.0.1:{tcp_port}"
    waypoints = tmp_path / "got.waypoints"

    async def gcs(*argv: str) -> int:
        return await asyncio.to_thread(main, list(argv))

    async with MockFleet(configs, mission.map, mission.geo, ScaledClock(SPEEDUP), seed=1):
        assert await gcs("status", endpoint, "--keys", str(keys_path), "--timeout", "5") == 0
        assert "GROUND_ROVER" in capsys.readouterr().out
        assert await gcs("status", endpoint, "--keys", str(wrong), "--timeout", "1") == 1
        assert "no heartbeat" in capsys.readouterr().err
        assert await gcs("status", endpoint, "--keys", str(several)) == 2
        assert "different keys for systems 1, 2" in capsys.readouterr().err
        download = ("mission", "download", endpoint, str(waypoints), "--timeout", "5")
        assert await gcs(*download, "--keys", str(several), "--sysid", "1") == 0
        assert waypoints.read_text().startswith("QGC WPL 110")
        assert await gcs(*download[:-1], "1", "--keys", str(wrong)) == 1
