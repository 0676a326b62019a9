"""The MCAP mission log: Foxglove schemas and topics, exact rebuild, truncated files, gcs report."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from gcs.cli import main
from gcs.commands.plan import LOG_NAME
from gcs.log.reader import LogError, mission_s, read_contents, read_log, reconstruct
from gcs.log.topics import SCHEMAS, codes_from_grid, grid_codes
from gcs.mission import Mission
from gcs.offline.simulate import simulate
from gcs.outcome.figures import BATTERY_PNG, COVERAGE_PNG, EXPLORED_PNG, PATH_LENGTH_PNG
from gcs.outcome.report import report_dict
from gcs.outcome.result import RunResult
from sitl_mock import mapgen
from sitl_mock.maps import to_ascii
from tests.checks import make_mission, open_mission_log
from tests.gcs.live.test_mission import SMALL, write_mission

PNGS = (COVERAGE_PNG, PATH_LENGTH_PNG, BATTERY_PNG, EXPLORED_PNG)
#: Report keys that measure the machine, not the run.
TIMING_KEYS = ("wall_s", "planner_s", "us_per_agent_step")
#: Battery use that makes the agents of the test map charge a few times.
ENERGY_PER_M_PCT = 0.6


def _mission() -> Mission:
    return make_mission(mapgen.rooms(24, 24, 3), 3, ENERGY_PER_M_PCT, name="rooms24")


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunResult, Path]:
    """One logged run, with small chunks so that a cut file keeps many of them."""
    mission = _mission()
    path = tmp_path_factory.mktemp("log") / LOG_NAME
    result = simulate(mission, log=open_mission_log(path, mission, chunk_size=4096))
    assert result.complete and sum(a.charges for a in result.agents) > 0
    return result, path


def _without_timing(report: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in report.items() if k not in TIMING_KEYS}


def test_log_has_foxglove_schemas_and_topics(run: tuple[RunResult, Path]) -> None:
    _, path = run
    with open(path, "rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        assert summary is not None
        schemas = {s.name: s for s in summary.schemas.values()}
        channels = {c.topic: c for c in summary.channels.values()}
        messages = [(ch.topic, m) for _, ch, m in reader.iter_messages()]
    for name in (
        "foxglove.Grid",
        "foxglove.LocationFix",
        "foxglove.PoseInFrame",
        "foxglove.SceneUpdate",
        "foxglove.Log",
    ):
        assert schemas[name].encoding == "jsonschema"
        assert json.loads(schemas[name].data)["title"] == name
    topics = {"/map", "/events", "/scene/tracks", "/scene/btps", "/run/meta", "/run/result"}
    topics.add("/fleet/states")  # an offline run's states, gathered
    for sysid in (1, 2, 3):
        topics |= {f"/vehicle/{sysid}/{kind}" for kind in ("fix", "pose", "battery")}
    assert topics <= set(channels)
    assert all(channels[t].message_encoding == "json" for t in topics)
    assert schemas["foxglove.Grid"].id == channels["/map"].schema_id
    seen = {topic for topic, _ in messages}
    assert topics <= seen
    for _, message in messages:
        json.loads(message.data)


def test_map_grid_decodes_to_the_final_belief(run: tuple[RunResult, Path]) -> None:
    result, path = run
    contents = read_contents(path)
    assert contents.last_map is not None
    grid = contents.last_map
    assert grid["column_count"] == result.shape[1]
    assert grid["pose"]["position"]["y"] == -result.shape[0] * result.cell_size_m
    assert [f["name"] for f in grid["fields"]][:1] == ["state"]
    np.testing.assert_array_equal(codes_from_grid(grid), grid_codes(result.belief, result.covered))


def test_events_and_states_are_logged(run: tuple[RunResult, Path]) -> None:
    result, path = run
    contents = read_contents(path)
    assert not contents.truncated
    kinds = {e.kind for e in contents.events}
    assert {"return_to_charge", "charged", "coverage_complete"} <= kinds
    steps = len(result.agents[0].track)
    assert {i: len(s) for i, s in contents.states.items()} == {a.id: steps for a in result.agents}
    meta = contents.meta
    assert meta is not None
    assert (meta["mission"], meta["shape"]) == ("rooms24", list(result.shape))


def test_read_log_rebuilds_the_result(run: tuple[RunResult, Path]) -> None:
    result, path = run
    rebuilt = read_log(path)
    assert report_dict(rebuilt) == report_dict(result)
    assert rebuilt.agents == result.agents
    assert rebuilt.btps == result.btps
    assert rebuilt.covered_per_iteration == result.covered_per_iteration
    np.testing.assert_array_equal(rebuilt.belief, result.belief)
    assert rebuilt.belief.dtype == result.belief.dtype
    np.testing.assert_array_equal(rebuilt.covered, result.covered)


def test_reconstruction_without_result_matches_the_run(run: tuple[RunResult, Path]) -> None:
    """With ``/run/result`` ignored, the stream alone gives back the run's report."""
    result, path = run
    contents = read_contents(path)
    contents.result = None
    rebuilt = reconstruct(contents)
    assert [a.track for a in rebuilt.agents] == [a.track for a in result.agents]
    assert [a.battery_pct for a in rebuilt.agents] == [a.battery_pct for a in result.agents]
    assert [a.charges for a in rebuilt.agents] == [a.charges for a in result.agents]
    assert rebuilt.covered_per_iteration == result.covered_per_iteration
    assert rebuilt.iterations == result.iterations
    assert rebuilt.covered_cells == result.covered_cells == rebuilt.free_cells
    assert rebuilt.extra["log_truncated"] == 1


def test_truncated_log_gives_the_states_up_to_the_cut(
    run: tuple[RunResult, Path], tmp_path: Path
) -> None:
    result, path = run
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.4)])
    contents = read_contents(cut)
    assert contents.truncated and contents.result is None
    rebuilt = read_log(cut)
    assert rebuilt.extra["log_truncated"] == 1
    steps = len(rebuilt.agents[0].track)
    assert 1 < steps < len(result.agents[0].track)
    for got, want in zip(rebuilt.agents, result.agents, strict=True):
        assert got.id == want.id
        assert got.track == want.track[:steps]
        assert got.battery_pct == want.battery_pct[:steps]
    assert rebuilt.covered_per_iteration == result.covered_per_iteration[:steps]
    # Cut before coverage was complete, it does not claim completeness.
    assert steps <= result.iterations
    assert not rebuilt.complete
    report_dict(rebuilt)  # JSON-ready


def test_unclosed_log_is_readable(tmp_path: Path) -> None:
    """A ground station that dies never calls close(): what was flushed is there."""
    mission = _mission()
    path = tmp_path / "dead.mcap"
    log = open_mission_log(path, mission, flush_s=0.0)
    for t in range(5):
        log.agent_state(t, 1, (23, 12 - t), 100.0 - t, "exploring")
        log.raw(1, False, t, b"\xfd\x09\x00\x00\x00\x01\x01\x00\x00\x00")
    log.event(4, "lost: vehicle 1", "error", 1)
    log.flush()
    rebuilt = read_log(path)
    assert rebuilt.agents[0].track == tuple((23, 12 - t) for t in range(5))
    assert rebuilt.agents[0].lost  # from the event
    assert rebuilt.agents[0].path_m == 4.0
    assert read_contents(path).truncated
    log.close()
    assert not read_contents(path).truncated


def test_raw_frames_keep_their_bytes(tmp_path: Path) -> None:
    mission = _mission()
    path = tmp_path / "raw.mcap"
    frames = [bytes([0xFD, 9, 0, 0, k, 1, 1, 0, 0, 0]) + bytes(11) for k in range(3)]
    with open_mission_log(path, mission) as log:
        for k, frame in enumerate(frames):
            log.raw(7, k % 2 == 1, float(k), frame)
    with open(path, "rb") as handle:
        reader = make_reader(handle)
        got = [(ch.topic, ch.message_encoding, m.data) for _, ch, m in reader.iter_messages()]
    raw = [g for g in got if g[0].startswith("/mavlink/")]
    assert raw == [
        ("/mavlink/7/in", "mavlink", frames[0]),
        ("/mavlink/7/out", "mavlink", frames[1]),
        ("/mavlink/7/in", "mavlink", frames[2]),
    ]


def test_gcs_report_rebuilds_report_and_figures(
    run: tuple[RunResult, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    result, path = run
    out = tmp_path / "out"
    assert main(["report", str(path), "--out", str(out)]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report == report_dict(result)
    for name in PNGS:
        assert (out / name).read_bytes()[:4] == b"\x89PNG"
    assert "rooms24" in capsys.readouterr().out


def test_gcs_plan_out_writes_the_log(tmp_path: Path) -> None:
    grid = mapgen.rooms(16, 16, 1)
    (tmp_path / "map.txt").write_text(to_ascii(grid))
    (tmp_path / "m.yaml").write_text("name: tiny\nmap: map.txt\nfleet:\n  count: 2\n")
    out = tmp_path / "out"
    assert main(["plan", str(tmp_path / "m.yaml"), "--out", str(out), "--quiet"]) == 0
    planned = json.loads((out / "report.json").read_text())
    rebuilt = read_log(out / LOG_NAME)
    assert _without_timing(report_dict(rebuilt)) == _without_timing(planned)


@pytest.mark.parametrize("kind", ["missing", "text", "empty", "directory", "magic_only"])
def test_gcs_report_rejects_bad_files(
    kind: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.mcap"
    if kind == "text":
        path.write_text("name: not a log\n")
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "directory":
        path.mkdir()
    elif kind == "magic_only":
        path.write_bytes(b"\x89MCAP0\r\n")
    assert main(["report", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gcs report: ") and "\n" not in err
    assert "Traceback" not in err
    with pytest.raises(LogError):
        read_log(path)


# -- time: UTC stamps, mission seconds kept -------------------------------------------

FRAME = bytes([0xFD, 9, 0, 0, 0, 1, 1, 0, 0, 0]) + bytes(11)


def _messages(path: Path) -> list[tuple[str, Any]]:
    with open(path, "rb") as handle:
        return [(ch.topic, m) for _, ch, m in make_reader(handle).iter_messages()]


def _ns(stamp: dict[str, int]) -> int:
    return stamp["sec"] * 1_000_000_000 + stamp["nsec"]


def test_stamps_are_utc_from_the_mission_start(tmp_path: Path) -> None:
    """log_time, publish_time and the messages' own timestamps are the wall clock at
    mission time 0 plus the mission time; the mission seconds stay in the payloads."""
    mission = _mission()
    path = tmp_path / "utc.mcap"
    opened = 1_700_000_000.0
    started = opened + 12.5  # the live mission's clock starts once the planner is compiled
    log = open_mission_log(path, mission, started_unix_s=opened)
    log.start(started)
    log.agent_state(2.5, 1, (23, 12), 99.0, "exploring")
    log.event(3.0, "vehicle 1 link lost", "warning", 1)
    log.raw(1, False, 3.5, FRAME)
    log.coverage(4.0, np.zeros(mission.map.shape, np.int8), np.zeros(mission.map.shape, bool))
    log.close()
    start_ns = 1_700_000_012_500_000_000
    messages = _messages(path)
    metas = [json.loads(m.data) for topic, m in messages if topic == "/run/meta"]
    assert [m["started_unix_ns"] for m in metas] == [1_700_000_000_000_000_000, start_ns]
    assert metas[-1]["started_unix_s"] == started
    times = {topic: m for topic, m in messages}
    for topic, t_s in (
        ("/vehicle/1/battery", 2.5),
        ("/vehicle/1/fix", 2.5),
        ("/vehicle/1/pose", 2.5),
        ("/events", 3.0),
        ("/mavlink/1/in", 3.5),
        ("/map", 4.0),
    ):
        message = times[topic]
        assert message.log_time == message.publish_time == start_ns + round(t_s * 1e9), topic
        if not topic.startswith("/mavlink/"):
            data = json.loads(message.data)
            if "timestamp" in data:
                assert _ns(data["timestamp"]) == message.log_time, topic
    event = json.loads(times["/events"].data)
    assert (event["t_s"], event["level"], event["name"]) == (3.0, 3, "vehicle 1")
    contents = read_contents(path)
    assert [(e.t_s, e.text) for e in contents.events] == [(3.0, "vehicle 1 link lost")]
    assert contents.states[1][0].t_s == 2.5
    assert mission_s(contents, times["/mavlink/1/in"].log_time) == 3.5
    assert contents.meta is not None and contents.meta["started_unix_ns"] == start_ns


def test_a_log_stamped_in_mission_time_still_reads(tmp_path: Path) -> None:
    """Logs written before the UTC stamps had log_time = mission time, and events without
    ``t_s``: their events keep their mission seconds (``gcs report``, ``--resume``)."""
    path = tmp_path / "old.mcap"
    origin = {"lat_deg": 47.0, "lon_deg": 8.0, "alt_m": 0.0}
    meta = {
        "mission": "old",
        "shape": [2, 2],
        "cell_size_m": 1.0,
        "charger": [1, 1],
        "reserve_pct": 20.0,
        "origin": origin,
        "started_unix_s": 1_700_000_000.0,
    }
    event = {
        "timestamp": {"sec": 4, "nsec": 0},
        "level": 4,
        "message": "lost: vehicle 1",
        "name": "vehicle 1",
        "file": "",
        "line": 0,
    }
    records = [
        ("/run/meta", "staying_alive.RunMeta", 0, meta),
        ("/events", "foxglove.Log", 4, event),
    ]
    with open(path, "wb") as handle:
        writer = Writer(handle)
        writer.start()
        for k, (topic, schema, t_s, data) in enumerate(records):
            definition = json.dumps(SCHEMAS[schema]).encode()
            channel = writer.register_channel(
                topic, "json", writer.register_schema(schema, "jsonschema", definition)
            )
            ns = t_s * 1_000_000_000
            writer.add_message(channel, ns, json.dumps(data).encode(), ns, k)
        writer.finish()
    contents = read_contents(path)
    assert [(e.t_s, e.kind, e.sysid) for e in contents.events] == [(4.0, "lost", 1)]


def _screen_events(out: str) -> list[tuple[int, str]]:
    """The operator's messages of a run's output: (mission seconds, text), those stamped."""
    found = []
    for line in out.splitlines():
        match = re.match(r"^\[(\d+):(\d\d)\] (.*?)\s*$", line)
        if match:
            found.append((60 * int(match[1]) + int(match[2]), match[3]))
    return found


@pytest.mark.timeout(120)
def test_a_live_run_logs_what_the_operator_saw_in_utc(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``gcs run --sim`` with the link cut for a while and a battery that needs one
    charge: the link lost and back, the vehicle's own texts, the charge and the parking
    are events in the log, stamped in UTC within the run's wall window from the mission
    start, and every message the display showed is in the log at its mission time."""
    monkeypatch.setenv("COLUMNS", "300")  # no message wrapped in the captured output
    mission = write_mission(tmp_path, SMALL, [{"type": "rover"}], energy=0.9)
    out = tmp_path / "out"
    before = time.time_ns()
    code = main(
        [
            "run", str(mission), "--sim", "--speedup", "40", "--time-limit", "900",
            "--sim-cut", "1:30:40", "--lost-after", "120", "--sim-sag", "20:2",
            "--out", str(out),
        ]
    )  # fmt: skip
    after = time.time_ns()
    screen = capsys.readouterr().out
    assert code == 0, screen
    assert not screen.startswith("\n") and "\n\n\n" not in screen
    path = out / LOG_NAME
    contents = read_contents(path)
    assert contents.meta is not None
    started = contents.meta["started_unix_ns"]
    assert before <= started <= after
    events = {e.text: e for e in contents.events}

    def event(prefix: str) -> Any:
        found = [e for text, e in events.items() if text.startswith(prefix)]
        assert found, (prefix, sorted(events))
        return found[0]

    lost, back = event("vehicle 1 link lost"), event("vehicle 1 link is back after")
    assert (lost.level, lost.name) == (3, "vehicle 1")
    assert back.level == 2 and lost.t_s < back.t_s
    assert event("vehicle 1 says: Battery sag").level == 3  # a WARNING
    assert event("vehicle 1 says: Arming motors").level == 2  # an INFO: the log only
    assert event("vehicle 1 charging from").t_s < event("vehicle 1 charged to").t_s
    assert event("vehicle 1 is home, parked and disarmed").level == 2
    # UTC: the mission start plus the mission time, within what the run's wall time allows.
    mission_ns_max = (after - before) * 40
    for topic, message in _messages(path):
        if topic == "/events":
            t_s = json.loads(message.data)["t_s"]
            assert message.log_time == started + round(t_s * 1e9)
            assert started <= message.log_time <= started + mission_ns_max
    # What the screen said is what the log says, at the same mission time.
    shown = _screen_events(screen)
    assert any("link lost" in text for _, text in shown)
    logged: dict[str, list[float]] = {}
    for e in contents.events:
        logged.setdefault(e.text, []).append(e.t_s)
    for t_s, text in shown:
        assert text in logged, (text, sorted(logged))
        # The screen shows whole seconds: the log's time is in that second (or just after).
        assert any(abs(t - t_s - 0.5) <= 1.0 for t in logged[text]), (text, logged[text], t_s)
