"""``gcs run --sim`` takes loopback ports that are free, never the mission's fixed ones:
two simulated runs at once both complete, even with the default port held by another
program; a port in use is named with what probably holds it."""

from __future__ import annotations

import contextlib
import errno
import json
import socket
from collections.abc import Iterator
from pathlib import Path

import pytest

from gcs.cli import main
from gcs.commands.run import on_free_ports
from gcs.mission import CONNECTION_BASE_PORT, load_mission
from tests.processes import gcs_process
from vehicles.errors import LinkError
from vehicles.transport import MavlinkTransport

MAP = """\
##########
#........#
#........#
#...##...#
#........#
####C#####
"""
#: Two rovers with no connection: by default they listen on 14550 and 14560.
MISSION = """\
name: ports
map: map.txt
fleet:
  vehicles:
    - {sysid: 1, type: rover}
    - {sysid: 2, type: rover}
"""


def write_mission(folder: Path, text: str = MISSION) -> Path:
    (folder / "map.txt").write_text(MAP)
    path = folder / "mission.yaml"
    path.write_text(text)
    return path


@contextlib.contextmanager
def holding_udp(port: int) -> Iterator[None]:
    """Hold loopback UDP ``port`` as another ground station would (if no one holds it yet)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError as exc:
            if exc.errno != errno.EADDRINUSE:
                raise
        yield


def test_connections_move_to_free_ports_and_shared_ones_stay_shared(tmp_path: Path) -> None:
    text = MISSION.replace("rover}", "rover, connection: 'udpin:127.0.0.1:14550'}", 2)
    text += "    - {sysid: 3, type: rover, connection: 'tcp:127.0.0.1:5760'}\n"
    mission, line = on_free_ports(load_mission(write_mission(tmp_path, text)))
    one, two, three = (v.connection for v in mission.fleet)
    assert one == two and one.startswith("udpin:127.0.0.1:") and one != "udpin:127.0.0.1:14550"
    assert three.startswith("tcp:127.0.0.1:") and three != "tcp:127.0.0.1:5760"
    assert line == f"simulated vehicles on free loopback ports: {one}, {three}"


@pytest.mark.timeout(240)
def test_two_simulated_runs_at_once_both_complete(tmp_path: Path) -> None:
    mission = write_mission(tmp_path)
    common = ("run", str(mission), "--sim", "--speedup", "40", "--time-limit", "900")
    with (
        holding_udp(CONNECTION_BASE_PORT),
        gcs_process(*common, "--out", str(tmp_path / "a")) as first,
        gcs_process(*common, "--quiet", "--out", str(tmp_path / "b")) as second,
    ):
        out_a, err_a = first.communicate(timeout=200)
        _out_b, err_b = second.communicate(timeout=200)
    assert (first.returncode, second.returncode) == (0, 0), (err_a, err_b)
    assert "simulated vehicles on free loopback ports: udpin:127.0.0.1:" in out_a
    for folder in ("a", "b"):
        report = json.loads((tmp_path / folder / "report.json").read_text())
        assert report["complete"] and report["lost_agents"] == 0


async def test_a_port_in_use_names_what_probably_holds_it() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        with pytest.raises(LinkError) as caught:
            await MavlinkTransport.open(f"udpin:127.0.0.1:{port}")
    text = str(caught.value)
    assert f"UDP port {port} is already in use" in text
    assert "another ground station" in text and f"'ss -ulpn sport = :{port}'" in text


def test_keep_ports_needs_sim(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(write_mission(tmp_path)), "--keep-ports"]) == 2
    assert capsys.readouterr().err.strip() == "gcs run: --keep-ports needs --sim"
