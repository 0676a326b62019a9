"""``gcs run`` against ArduPilot's own software-in-the-loop simulator (opt-in).

Skipped unless ``ARDUPILOT_SITL`` names a folder with ready-built ``ardurover`` and
``arducopter`` binaries and ArduPilot's stock parameter files (``rover.parm``,
``rover-skid.parm``, ``copter.parm`` from ``Tools/autotest/default_params``). SITL
listens on every interface, so the test also refuses to run outside a network
namespace that has only loopback; run it as (root)::

    ip netns add sitl && ip netns exec sitl ip link set lo up
    ARDUPILOT_SITL=/path/to/sitl ip netns exec sitl .venv/bin/python -m pytest \\
        tests/gcs/test_sitl_ardupilot.py

Each case starts the vehicles right before ``gcs run`` (so the station waits for
their GPS fix and position estimate); the station dials each vehicle's TCP port, or
(the ``one-port`` case) every vehicle sends to one station UDP port from SITL's
``--serial0 udpclient``, or (``mavproxy``) MAVProxy routes both vehicles' TCP ports
to one station UDP port, with the stock parameters and only
BATT_CAPACITY lowered so that every vehicle must charge, runs the real CLI to the
end, then reads each vehicle back from SITL's second port: disarmed, within a metre
of the pad.
"""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import pytest
from pymavlink import mavutil

from core.geo import GeoFrame

SITL_ENV = "ARDUPILOT_SITL"
SITL_DIR = os.environ.get(SITL_ENV)

pytestmark = [
    pytest.mark.skipif(
        not SITL_DIR, reason=f"{SITL_ENV} does not name a folder of ArduPilot SITL binaries"
    ),
    pytest.mark.timeout(1800),
]

#: Where SITL puts its home; the pad is the cell whose centre is there.
HOME = (47.397742, 8.545594, 488.0)
SPEEDUP = 5
CELL_M = 2.0
#: A yard of 2 m cells with a few posts; the pad 'C' is on the home.
YARD = """\
##############
#............#
#............#
#...##.......#
#...##...##..#
#........##..#
#............#
#..###.......#
#............#
#.......##...#
#......C.....#
##############
"""


@dataclass(frozen=True)
class Vehicle:
    """One SITL vehicle of a case: its model, parameter files and mission entry."""

    binary: str
    model: str
    params: tuple[str, ...]
    kind: str
    steering: str = "skid"
    capacity_mah: int = 800


CAR = Vehicle("ardurover", "rover", ("rover.parm",), "rover", steering="car")
SKID = Vehicle("ardurover", "rover-skid", ("rover.parm", "rover-skid.parm"), "rover")
QUAD = Vehicle("arducopter", "quad", ("copter.parm",), "copter", capacity_mah=2500)

CASES = {
    "rover": [CAR],
    "rover-skid": [SKID],
    "quad": [QUAD],
    # Each covers about half the yard: smaller batteries, so that each still charges.
    "rover-and-copter": [replace(SKID, capacity_mah=400), replace(QUAD, capacity_mah=2000)],
}
CASES["rover-and-copter-one-port"] = CASES["rover-and-copter-mavproxy"] = CASES["rover-and-copter"]
#: The one UDP port of the station in the cases that share one.
STATION_PORT = 14550


def only_loopback() -> bool:
    return sorted(os.listdir("/sys/class/net")) == ["lo"]


def origin_for(pad: tuple[int, int]) -> tuple[float, float]:
    """The map's north-west corner, so that the pad's centre is SITL's home."""
    lat, lon = HOME[0], HOME[1]
    for _ in range(3):  # the metres per degree depend a little on the origin itself
        geo = GeoFrame(lat, lon, HOME[2], CELL_M)
        centre = geo.cell_centre(pad)
        lat, lon = lat + HOME[0] - centre[0], lon + HOME[1] - centre[1]
    return lat, lon


def write_mission(folder: Path, vehicles: list[Vehicle], shared: bool = False) -> Path:
    (folder / "yard.txt").write_text(YARD)
    rows = YARD.splitlines()
    pad = next((r, row.index("C")) for r, row in enumerate(rows) if "C" in row)
    lat, lon = origin_for(pad)
    lines = [
        "name: sitl-yard",
        "map: yard.txt",
        f"cell_size_m: {CELL_M}",
        f"origin: {{lat_deg: {lat:.9f}, lon_deg: {lon:.9f}, alt_m: {HOME[2]}}}",
        "fleet:",
        "  vehicles:",
    ]
    for i, v in enumerate(vehicles):
        connection = (
            f"udpin:127.0.0.1:{STATION_PORT}" if shared else f"tcp:127.0.0.1:{5760 + 10 * i}"
        )
        lines.append(
            f"    - {{sysid: {i + 1}, type: {v.kind}, steering: {v.steering}, sensing: map, "
            f'connection: "{connection}", speed_m_s: 2.0, charge_rate_pct_s: 2.0}}'
        )
    path = folder / "mission.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture
def sitl(tmp_path: Path) -> Iterator[list[subprocess.Popen[bytes]]]:
    """Processes started by the test; every one is stopped at the end."""
    started: list[subprocess.Popen[bytes]] = []
    yield started
    for process in started:
        process.terminate()
    for process in started:
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def start_vehicle(
    folder: Path,
    v: Vehicle,
    instance: int,
    started: list[subprocess.Popen[bytes]],
    serial0: str | None = None,
) -> None:
    assert SITL_DIR is not None
    sitl_dir = Path(SITL_DIR)
    work = folder / f"sitl{instance}"
    work.mkdir()
    extra = work / "case.parm"
    extra.write_text(f"BATT_CAPACITY {v.capacity_mah}\n")
    defaults = ",".join([*(str(sitl_dir / p) for p in v.params), str(extra)])
    argv = [
        str(sitl_dir / v.binary),
        "--model",
        v.model,
        "--speedup",
        str(SPEEDUP),
        "--defaults",
        defaults,
        "-I",
        str(instance),
        "--sysid",
        str(instance + 1),
        "--home",
        f"{HOME[0]},{HOME[1]},{HOME[2]},0",
        "-w",
        *(["--serial0", serial0] if serial0 else []),
    ]
    log = (work / "sitl.out").open("wb")
    started.append(subprocess.Popen(argv, cwd=work, stdout=log, stderr=subprocess.STDOUT))


def start_router(folder: Path, vehicles: int, started: list[subprocess.Popen[bytes]]) -> None:
    """MAVProxy as a plain router: each vehicle's TCP port in, one UDP port out (once
    every vehicle's port is open, so that MAVProxy finds each master there)."""
    deadline = time.monotonic() + 60
    for i in range(vehicles):
        while True:
            try:
                socket.create_connection(("127.0.0.1", 5760 + 10 * i), timeout=1).close()
                break
            except OSError:
                assert time.monotonic() < deadline, f"SITL {i} serves no TCP port"
                time.sleep(0.2)  # polling a port nobody announces: SITL has no other sign
    home = folder / "mavproxy"
    home.mkdir()
    argv = [
        sys.executable,
        str(Path(sys.executable).parent / "mavproxy.py"),
        *(f"--master=tcp:127.0.0.1:{5760 + 10 * i}" for i in range(vehicles)),
        f"--out=udpout:127.0.0.1:{STATION_PORT}",
        "--non-interactive",
        "--no-state",
        "--default-modules=",
        "--streamrate=-1",
    ]
    log = (home / "mavproxy.out").open("wb")
    env = {**os.environ, "HOME": str(home)}
    started.append(
        subprocess.Popen(
            argv, cwd=home, env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT
        )
    )


def read_back(
    instance: int, sysid: int, pad: tuple[float, float]
) -> tuple[float, bool, float | None]:
    """Distance of the vehicle from the pad's centre (m), whether it is armed, and its
    FENCE_ENABLE (the station's geofence switched on), read on SITL's second port."""
    link = mavutil.mavlink_connection(f"tcp:127.0.0.1:{5762 + 10 * instance}")
    try:
        deadline = time.monotonic() + 30
        position = heartbeat = fence = None
        asked = 0.0
        while (
            position is None or heartbeat is None or fence is None
        ) and time.monotonic() < deadline:
            if time.monotonic() - asked > 2.0:  # this port streams nothing unasked
                asked = time.monotonic()
                link.mav.command_long_send(
                    sysid, 1, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                    mavutil.mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 200_000, 0, 0, 0, 0, 0,
                )  # fmt: skip
                link.mav.param_request_read_send(sysid, 1, b"FENCE_ENABLE", -1)
            msg = link.recv_match(blocking=True, timeout=1)
            if msg is None or msg.get_srcSystem() != sysid:
                continue
            if msg.get_type() == "GLOBAL_POSITION_INT":
                position = (msg.lat / 1e7, msg.lon / 1e7)
            elif msg.get_type() == "HEARTBEAT" and msg.type != 6:
                heartbeat = msg
            elif msg.get_type() == "PARAM_VALUE" and msg.param_id.startswith("FENCE_ENABLE"):
                fence = float(msg.param_value)
        assert position is not None and heartbeat is not None
        geo = GeoFrame(pad[0], pad[1], HOME[2], CELL_M)
        north, east = geo.geo_to_local(*position)
        armed = bool(heartbeat.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        return math.hypot(north, east), armed, fence
    finally:
        link.close()


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_whole_mission_on_ardupilot_sitl(
    case: str, tmp_path: Path, sitl: list[subprocess.Popen[bytes]]
) -> None:
    if not only_loopback():
        pytest.skip("SITL listens on every interface: run inside a loopback-only netns")
    vehicles = CASES[case]
    mission = write_mission(tmp_path, vehicles, shared=case.endswith(("one-port", "mavproxy")))
    one_port = f"udpclient:127.0.0.1:{STATION_PORT}" if case.endswith("one-port") else None
    for instance, v in enumerate(vehicles):
        start_vehicle(tmp_path, v, instance, sitl, serial0=one_port)
    if case.endswith("mavproxy"):
        start_router(tmp_path, len(vehicles), sitl)
    out = tmp_path / "out"
    started = time.monotonic()
    argv = ["run", str(mission), "--speedup", str(SPEEDUP), "--quiet", "--out", str(out)]
    run = subprocess.run(
        [sys.executable, "-m", "gcs.cli", *argv, "--time-limit", "3600"],
        capture_output=True,
        text=True,
        timeout=1700,
    )
    wall_s = time.monotonic() - started
    assert (out / "report.json").exists(), (run.returncode, run.stderr[-3000:])
    got = json.loads((out / "report.json").read_text())
    print(f"{case}: exit {run.returncode}, wall {wall_s:.0f} s, mission {got.get('mission_s')} s")
    print(json.dumps(got["agents"]))
    print(run.stderr[-3000:])
    assert run.returncode == 0, run.stderr[-3000:]
    assert got["complete"] and got["lost_agents"] == 0
    for agent in got["agents"]:
        assert agent["charges"] >= 1, agent
    for instance in range(len(vehicles)):
        off_m, armed, fence = read_back(instance, instance + 1, HOME[:2])
        print(f"vehicle {instance + 1}: {off_m:.2f} m from the pad, armed {armed}, fence {fence}")
        assert not armed
        assert off_m <= 1.0
        assert fence == 1.0  # the station's geofence, switched on
