"""``sitl-mock`` on the command line: bad input exits 2 with one line; a run serves and stops."""

from __future__ import annotations

import asyncio
import signal
import sys
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from gcs.sitl_cli import main
from vehicles.endpoints import free_loopback_tcp_ports

pytestmark = pytest.mark.timeout(60)

MAP = "C....\n.#...\n.....\n"
MISSION = """
name: tiny
map: tiny.txt
cell_size_m: 2.0
fleet:
  count: 2
"""


@pytest.fixture
def mission_file(tmp_path: Path) -> Path:
    (tmp_path / "tiny.txt").write_text(MAP, encoding="utf-8")
    path = tmp_path / "tiny.yaml"
    path.write_text(MISSION, encoding="utf-8")
    return path


def test_bad_input_exits_2_with_one_line(
    tmp_path: Path, mission_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main([str(tmp_path / "missing.yaml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sitl-mock: ")
    assert main([str(mission_file), "--speedup", "-1"]) == 2
    assert "speedup" in capsys.readouterr().err
    assert main([str(mission_file), "--tcp-base-port", "65530"]) == 2
    assert main([str(mission_file), "--agents", "0"]) == 2


def _free_tcp_base() -> int:
    """A base port whose vehicle 2 (base + 10), the one the test dials, is free."""
    return free_loopback_tcp_ports(1)[0] - 10


async def test_serves_over_tcp_and_stops_on_sigterm(mission_file: Path) -> None:
    base = _free_tcp_base()
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "gcs.sitl_cli",
        str(mission_file),
        "--tcp-base-port",
        str(base),
        "--speedup",
        "5",
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    try:
        assert proc.stdout is not None
        header = await asyncio.wait_for(proc.stdout.readline(), 20)
        assert b"2 vehicle(s)" in header, header
        lines = [await asyncio.wait_for(proc.stdout.readline(), 5) for _ in range(2)]
        assert lines[1].decode().strip() == f"vehicle 2 rover: tcp:127.0.0.1:{base + 10}"
        reader, writer = await asyncio.open_connection("127.0.0.1", base + 10)
        codec = mavlink.MAVLink(None, 255, 190)
        codec.robust_parsing = True
        heartbeat = None
        while heartbeat is None:
            data = await asyncio.wait_for(reader.read(4096), 5)
            msgs = codec.parse_buffer(data) or []
            heartbeat = next((m for m in msgs if m.get_type() == "HEARTBEAT"), None)
        assert heartbeat.get_srcSystem() == 2
        writer.close()
        proc.send_signal(signal.SIGTERM)
        assert await asyncio.wait_for(proc.wait(), 10) == 0
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
