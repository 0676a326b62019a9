"""``gcs run`` with vehicles missing: one line that names every vehicle not heard, where
the station listened and what to try, on a line of its own after the display."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from pathlib import Path

from tests.processes import ctrl_c, gcs_process, gcs_run
from vehicles.endpoints import free_loopback_udp_ports

MAP = """\
#######
#.....#
#..C..#
#######
"""


def write_mission(folder: Path, count: int) -> tuple[Path, list[int]]:
    (folder / "map.txt").write_text(MAP)
    ports = free_loopback_udp_ports(count)
    lines = ["map: map.txt", "fleet:", "  vehicles:"]
    lines += [
        f"    - {{sysid: {i}, connection: 'udpin:127.0.0.1:{p}'}}" for i, p in enumerate(ports, 1)
    ]
    path = folder / "mission.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path, ports


def test_no_vehicle_there_names_them_all_and_suggests_sim(tmp_path: Path) -> None:
    mission, ports = write_mission(tmp_path, 5)
    done = gcs_run("run", str(mission), "--heartbeat-timeout", "0.5", timeout_s=60)
    assert done.returncode == 1
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("gcs run: no heartbeat within 0.5 s from any of the 5 vehicle(s)")
    assert all(f"udpin:127.0.0.1:{p}" in last for p in ports[:3]) and last.count(", ...") == 1
    assert "add --sim" in last and "README" in last


def test_the_error_starts_a_line_of_its_own(tmp_path: Path) -> None:
    """Display and error in one stream (as a terminal or a log file shows them)."""
    mission, _ = write_mission(tmp_path, 2)
    done = subprocess.run(
        [sys.executable, "-m", "gcs.cli", "run", str(mission), "--heartbeat-timeout", "0.5"],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 1
    assert any(line.startswith("gcs run: no heartbeat") for line in done.stdout.splitlines())


def wait_until_bound(port: int, timeout_s: float) -> None:
    """Until someone holds loopback UDP ``port`` (checked every 50 ms, up to a deadline)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                return
        time.sleep(0.05)
    raise TimeoutError(f"nobody bound UDP port {port} within {timeout_s} s")


def test_one_ctrl_c_while_waiting_for_vehicles_stops_the_station(tmp_path: Path) -> None:
    """Ctrl-C before the start stops at once (exit 130): no vehicle is armed yet."""
    mission, ports = write_mission(tmp_path, 2)
    with gcs_process("run", str(mission), "--heartbeat-timeout", "60") as station:
        wait_until_bound(ports[-1], timeout_s=30)  # the station listens: it waits now
        started = time.monotonic()
        _out, err = ctrl_c(station, timeout_s=20)
    assert station.returncode == 130, err
    assert time.monotonic() - started < 20
    assert err.strip().splitlines()[-1] == (
        "gcs run: interrupted before the start: no vehicle was armed"
    )
