"""The mission log written by a process of its own: the same file as written in the
run's process, and a writer that fails or dies ends the log, not the run."""

from __future__ import annotations

import io
import json
import pickle
from pathlib import Path

import pytest
from mcap.reader import make_reader

from gcs.log.log_process import LogProcess, _read_word, serve
from gcs.log.mcap_log import LoggedMission, LogSettings, McapMissionLog
from gcs.log.reader import read_log
from gcs.mission import Mission
from gcs.offline.simulate import simulate
from sitl_mock import mapgen
from tests.checks import make_mission

#: The result's keys that measure the machine, not the run.
TIMING_KEYS = {"wall_s", "planner_s"}
STARTED_UNIX_S = 1.7e9


def _mission() -> Mission:
    return make_mission(mapgen.rooms(24, 24, 3), 3, 0.6, name="rooms24")


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as handle:
        return [
            (channel.topic, message.log_time, message.data)
            for _, channel, message in make_reader(handle).iter_messages(log_time_order=False)
        ]


def _timeless(message: tuple[str, int, bytes]) -> tuple[str, int, object]:
    """A message with the run's timings taken out of ``/run/result``."""
    topic, stamp, data = message
    if topic != "/run/result":
        return topic, stamp, data
    result = {k: v for k, v in json.loads(data).items() if k not in TIMING_KEYS}
    return topic, stamp, result


def test_the_writer_process_writes_the_file_the_run_would(tmp_path: Path) -> None:
    mission = _mission()
    logged = LoggedMission.of(mission, mission.reachable_cells)
    here = McapMissionLog(tmp_path / "here.mcap", logged, started_unix_s=STARTED_UNIX_S)
    simulate(mission, log=here)
    # Small batches: many sends, some while the writer is busy.
    there = LogProcess(
        tmp_path / "there.mcap", logged, started_unix_s=STARTED_UNIX_S, batch_calls=7
    )
    result = simulate(mission, log=there)
    assert result.complete and there.failure is None and here.failure is None
    ours, theirs = _messages(tmp_path / "here.mcap"), _messages(tmp_path / "there.mcap")
    assert len(ours) > 100
    assert [_timeless(m) for m in ours] == [_timeless(m) for m in theirs]
    assert read_log(tmp_path / "there.mcap").total_path_m == result.total_path_m


def test_a_writer_that_cannot_write_ends_the_log_not_the_run(tmp_path: Path) -> None:
    mission = _mission()
    path = tmp_path / "gone" / "mission.mcap"
    path.parent.mkdir()
    log = LogProcess(path, LoggedMission.of(mission, mission.reachable_cells))
    path.unlink()
    path.parent.rmdir()  # the writer opens the file after this: it cannot
    result = simulate(mission, log=log)
    assert result.complete
    assert log.failure is not None and "FileNotFoundError" in log.failure


def test_a_writer_that_dies_ends_the_log_not_the_run(tmp_path: Path) -> None:
    mission = _mission()
    log = LogProcess(
        tmp_path / "mission.mcap", LoggedMission.of(mission, mission.reachable_cells), batch_calls=1
    )
    log._process.kill()  # as the system's out-of-memory killer would
    log._process.wait(timeout=10)
    result = simulate(mission, log=log)
    assert result.complete
    assert log.failure == "the log's writer ended before the log did"
    log.close()  # again: nothing more to do
    assert log._process.returncode is not None


def test_a_place_that_cannot_be_written_is_told_at_once(tmp_path: Path) -> None:
    mission = _mission()
    with pytest.raises(OSError):
        LogProcess(tmp_path / "none" / "mission.mcap", LoggedMission.of(mission, None))


def test_the_writer_gives_its_failure_as_its_last_word(tmp_path: Path) -> None:
    """``serve`` on pipes of bytes: a call it cannot make is its failure, said last."""
    mission = _mission()
    logged = LoggedMission.of(mission, None)
    opening = (str(tmp_path / "m.mcap"), logged, LogSettings(), STARTED_UNIX_S)
    batch = [("open", opening), ("nope", ())]
    data = pickle.dumps(batch)
    out = io.BytesIO()
    serve(io.BytesIO(len(data).to_bytes(8, "little") + data), out)
    word = _read_word(out.getvalue())
    assert word is not None and word.failure is not None and "AttributeError" in word.failure
