"""``gcs run`` over the links of the field, end to end, each in processes of its own.

- a serial radio carrying the whole fleet (a pseudo-terminal pair,
  ``tests.serial_cable``), unplugged for a moment mid-mission;
- MAVProxy, the independent router, between the vehicles and the station
  (one ``--master`` per vehicle, one ``--out`` to the station), and a hub that
  broadcasts every frame to every vehicle, as a radio does;
- ``--forward`` to a second ground station (pymavlink on loopback) that watches
  the mission and whose command is not passed on.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.cli import main
from tests.gcs.live.test_mission import SMALL, one_port_demo, report, write_mission
from tests.serial_cable import SerialCable
from tests.udp_hub import UdpHub
from vehicles.endpoints import free_loopback_udp_ports

pytestmark = pytest.mark.timeout(240)

#: Real seconds any one process may run.
PROCESS_S = 200.0
#: A mission line of the live display: ``[m:ss] vehicle N ...``.
_MISSION_LINE = re.compile(r"^\[\d+:\d\d\] vehicle \d+ ")


def _python(*args: str, home: Path | None = None, **kwargs: Any) -> subprocess.Popen[str]:
    """``python ARGS`` with its output unbuffered and wide; ``home``: its $HOME."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}
    if home is not None:
        env["HOME"] = str(home)
    return subprocess.Popen(
        [sys.executable, *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
        **kwargs,
    )


@contextmanager
def _running(process: subprocess.Popen[str]) -> Iterator[subprocess.Popen[str]]:
    """``process``, stopped at the end whatever happened."""
    try:
        yield process
    finally:
        if process.poll() is None:
            process.terminate()
            try:
                process.communicate(timeout=10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.communicate()


def _wait_line(process: subprocess.Popen[str], pattern: re.Pattern[str], lines: list[str]) -> str:
    """Read ``process``'s output (kept in ``lines``) up to a line matching ``pattern``."""
    assert process.stdout is not None
    deadline = time.monotonic() + PROCESS_S
    for line in process.stdout:
        lines.append(line)
        if pattern.search(line):
            return line
        assert time.monotonic() < deadline, "".join(lines)
    text = "".join(lines)
    raise AssertionError(f"no line matching {pattern.pattern} in:\n{text}")


def _finish(process: subprocess.Popen[str], lines: list[str]) -> str:
    rest, _ = process.communicate(timeout=PROCESS_S)
    return "".join(lines) + rest


def _mock(mission: Path, speedup: float, *extra: str) -> subprocess.Popen[str]:
    """``sitl-mock`` on ``mission``, once it says its fleet is up."""
    process = _python("-m", "gcs.sitl_cli", str(mission), "--speedup", str(speedup), *extra)
    _wait_line(process, re.compile(r"^sitl-mock: \d+ vehicle"), [])
    return process


def test_the_demo_over_a_serial_radio_unplugged_mid_mission(tmp_path: Path) -> None:
    """The whole fleet behind one serial radio; once the mission is under way, the
    station's radio is pulled out for 8 s of mission time and plugged back: every vehicle's
    link is lost and comes back, the device is reopened, the mission completes."""
    speedup = 20.0
    with SerialCable(tmp_path) as cable:
        mission = one_port_demo(tmp_path, f"serial:{cable.station_end}:57600")
        with (
            _running(_mock(mission, speedup, "--one-link", f"serial:{cable.vehicle_end}:57600")),
            _running(
                _python(
                    "-m",
                    "gcs.cli",
                    "run",
                    str(mission),
                    "--speedup",
                    str(speedup),
                    "--out",
                    str(tmp_path / "out"),
                )
            ) as station,
        ):
            lines: list[str] = []
            _wait_line(station, _MISSION_LINE, lines)
            cable.unplug()
            # Out this long (8 s of mission time): the fault, not a wait. Short beside the
            # 30 s a vehicle may stay unheard (1.5 s here), as the device is tried again
            # every 0.5 s of real time.
            time.sleep(0.4)
            cable.plug()
            output = _finish(station, lines)
    (tmp_path / "station.txt").write_text(output)
    assert station.returncode == 0, output
    got = report(tmp_path / "out")
    assert got["complete"] and got["lost_agents"] == 0, got
    for sysid in range(1, 6):
        assert f"vehicle {sysid} link lost" in output, output
        assert f"vehicle {sysid} link is back" in output, output
    assert "device gone" in output and "device back" in output, output
    # Five vehicles fill a 57600 baud radio at the usual rates: they are slowed to fit.
    assert "5 vehicle(s) on one radio: telemetry rates at" in output, output
    assert cable.to_station > 100_000 and cable.to_vehicle > 10_000


def _mavproxy() -> list[str]:
    script = Path(sys.executable).parent / "mavproxy.py"
    if not script.exists():
        pytest.fail(f"MAVProxy is a test dependency, but {script} is missing")
    return [str(script)]


#: The fleet of the router and hub missions, and their speed-up.
ROUTED = ["rover", "copter", "rover"]
ROUTED_SPEEDUP = 40.0


def _routed_missions(
    tmp_path: Path, vehicle_ports: list[int], station_port: int
) -> tuple[Path, Path]:
    """One mission twice: the vehicles' side, each vehicle sending to its own port of
    the router, and the station's, the whole fleet on one port."""
    sides = []
    for side, ports in (("vehicles", vehicle_ports), ("station", [station_port] * len(ROUTED))):
        (tmp_path / side).mkdir()
        fleet = [
            {"type": t, "connection": f"udpin:127.0.0.1:{port}"}
            for t, port in zip(ROUTED, ports, strict=True)
        ]
        sides.append(write_mission(tmp_path / side, SMALL, fleet))
    return sides[0], sides[1]


def _station(mission: Path, out: Path) -> subprocess.Popen[str]:
    """``gcs run`` of a routed mission (no --sim: the vehicles are out there)."""
    speedup = str(ROUTED_SPEEDUP)
    return _python(
        "-m", "gcs.cli", "run", str(mission), "--speedup", speedup,
        "--time-limit", "900", "--out", str(out),
    )  # fmt: skip


def test_a_mission_through_mavproxy_as_a_router(tmp_path: Path) -> None:
    """MAVProxy between the fleet (one --master per vehicle, each its own UDP port) and
    the station (one --out to one port): it routes each command to the link where its
    target was heard, and the mission completes."""
    vehicle_ports = free_loopback_udp_ports(len(ROUTED))
    (station_port,) = free_loopback_udp_ports(1)
    vehicles, station = _routed_missions(tmp_path, vehicle_ports, station_port)
    home = tmp_path / "mavproxy-home"  # MAVProxy keeps its settings under $HOME
    home.mkdir()
    router = [
        *_mavproxy(),
        *(f"--master=udpin:127.0.0.1:{port}" for port in vehicle_ports),
        f"--out=udpout:127.0.0.1:{station_port}",
        "--non-interactive",
        "--no-state",  # no tlog or parameter files
        "--default-modules=",  # a plain router: no parameter, map or terrain downloads
        "--streamrate=-1",  # leave the telemetry rates to the station
        # MAVProxy's own heartbeat keeps each vehicle's GCS failsafe fed (ours reaches only
        # the first link, as MAVProxy sends what has no target there): 1 Hz of real time
        # is 1 Hz of vehicle time at this speed-up.
        f"--heartbeat-rate={ROUTED_SPEEDUP:g}",
    ]
    with (
        _running(_mock(vehicles, ROUTED_SPEEDUP)),
        _running(_python(*router, home=home, cwd=home)),
        _running(_station(station, tmp_path / "out")) as gcs,
    ):
        output = _finish(gcs, [])
    assert gcs.returncode == 0, output
    got = report(tmp_path / "out")
    assert got["complete"] and got["lost_agents"] == 0, got


class _Watcher:
    """A second ground station (pymavlink) listening where ``--forward`` sends: it
    notes every vehicle's heartbeat and position, and sends a command of its own."""

    SYSID = 200

    def __init__(self, port: int) -> None:
        self.connection = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=self.SYSID, source_component=190
        )
        self.heartbeats: set[int] = set()
        self.positions: set[int] = set()
        self.acks_to_us = 0
        self.signed = 0
        self.commands_sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._listen, daemon=True)

    def __enter__(self) -> _Watcher:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        self.connection.close()

    def _listen(self) -> None:
        while not self._stop.is_set():
            msg = self.connection.recv_match(blocking=True, timeout=0.2)
            if msg is None:
                continue
            kind = msg.get_type()
            if kind == "HEARTBEAT" and msg.type != mavlink.MAV_TYPE_GCS:
                self.heartbeats.add(msg.get_srcSystem())
                if len(self.heartbeats) == 1 or self.commands_sent < 5:
                    self._command(msg.get_srcSystem())
            elif kind == "GLOBAL_POSITION_INT":
                self.positions.add(msg.get_srcSystem())
            elif kind == "COMMAND_ACK" and msg.target_system == self.SYSID:
                self.acks_to_us += 1

    def _command(self, target: int) -> None:
        """Ask the vehicle for its home position: harmless, and acknowledged if it came."""
        self.commands_sent += 1
        self.connection.mav.command_long_send(
            target,
            1,
            mavlink.MAV_CMD_REQUEST_MESSAGE,
            0,
            mavlink.MAVLINK_MSG_ID_HOME_POSITION,
            0,
            0,
            0,
            0,
            0,
            0,
        )


def test_a_forwarded_station_watches_every_vehicle_and_cannot_command(tmp_path: Path) -> None:
    """``--forward`` copies the fleet's traffic to a second station (pymavlink): it sees
    each vehicle's heartbeat and position; without ``--forward-commands`` the commands
    it sends are dropped (counted, never acknowledged by a vehicle). The fleet is on
    one port given on the command line (``--one-link``), its mock behind one radio."""
    port, fleet_port = free_loopback_udp_ports(2)
    vehicles = [{"type": "rover"}, {"type": "copter"}, {"type": "rover"}]
    mission = write_mission(tmp_path, SMALL, vehicles)
    run = ["run", str(mission), "--sim", "--speedup", "40", "--time-limit", "900"]
    links = ["--one-link", f"udpin:127.0.0.1:{fleet_port}", "--forward", f"udpout:127.0.0.1:{port}"]
    with (
        _Watcher(port) as watcher,
        _running(_python("-m", "gcs.cli", *run, *links, "--out", str(tmp_path / "out"))) as gcs,
    ):
        output = _finish(gcs, [])
    assert gcs.returncode == 0, output
    got = report(tmp_path / "out")
    assert got["complete"] and got["lost_agents"] == 0, got
    assert "not in the mission" not in output  # the one link carries the fleet alone
    assert watcher.heartbeats == {1, 2, 3}
    assert watcher.positions == {1, 2, 3}
    assert watcher.commands_sent > 0
    assert watcher.acks_to_us == 0
    assert got["forward_refused"] >= watcher.commands_sent, json.dumps(got)


def test_a_mission_through_a_broadcast_hub(tmp_path: Path) -> None:
    """A hub that passes every station frame to every vehicle, as a radio does: each
    mock vehicle hears the others' commands and answers only its own."""
    (station_port,) = free_loopback_udp_ports(1)
    with UdpHub(len(ROUTED), ("127.0.0.1", station_port)) as hub:
        vehicles, station = _routed_missions(tmp_path, hub.vehicle_ports, station_port)
        with (
            _running(_mock(vehicles, ROUTED_SPEEDUP)),
            _running(_station(station, tmp_path / "out")) as gcs,
        ):
            output = _finish(gcs, [])
    assert gcs.returncode == 0, output
    got = report(tmp_path / "out")
    assert got["complete"] and got["lost_agents"] == 0, got
    assert hub.to_vehicles > 0 and hub.to_station > 0


def test_status_lists_every_vehicle_behind_one_radio(tmp_path: Path) -> None:
    types = ["rover", "copter", "rover"]
    mission = write_mission(tmp_path, SMALL, [{"type": t} for t in types])
    with SerialCable(tmp_path) as cable:
        radio = f"{cable.vehicle_end},57600"  # MAVProxy's spelling of a serial device
        with _running(_mock(mission, 1.0, "--one-link", radio, "--startup-delay", "0")):
            status = subprocess.run(
                [sys.executable, "-m", "gcs.cli", "status", f"serial:{cable.station_end}:57600"],
                capture_output=True,
                text=True,
                timeout=60,
                env={**os.environ, "COLUMNS": "200"},
                check=False,
            )
    assert status.returncode == 0, status.stderr
    rows = [line for line in status.stdout.splitlines() if "serial:" in line]
    assert len(rows) == 3, status.stdout
    mav_type = {"rover": "GROUND_ROVER", "copter": "QUADROTOR"}
    for sysid, kind in enumerate(types, 1):
        heard = rf"│\s*{sysid}\s*│\s*{mav_type[kind]}\s*│\s*ARDUPILOTMEGA"
        assert any(re.search(heard, row) for row in rows), rows


@pytest.mark.parametrize(
    ("extra", "connection", "message"),
    [
        (["--sim"], "serial:/dev/ttyUSB0:57600", "a serial link's far end is another device"),
        (["--forward-commands"], None, "--forward-commands needs --forward ENDPOINT"),
        (["--forward", "udpout:10.0.0.1:14550"], None, "--forward: bad endpoint"),
        (["--forward", "qgc"], None, "--forward: bad endpoint 'qgc'"),
    ],
)
def test_link_options_are_checked_before_anything_opens(
    tmp_path: Path, extra: list[str], connection: str | None, message: str, capsys
) -> None:
    vehicle = {"type": "rover"} if connection is None else {"connection": connection}
    mission = write_mission(tmp_path, SMALL, [vehicle])
    assert main(["run", str(mission), "--quiet", *extra]) == 2
    assert message in capsys.readouterr().err
