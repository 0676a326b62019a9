"""A mission log written by a process of its own, for the offline run.

The offline run logs every iteration, and encoding the record (the fleet's columns,
the tracks, the map snapshots, the compression) costs a fifth of the planner's time on
the largest maps. ``LogProcess`` takes the run's calls, gathers them into batches and
hands each batch over a pipe to a child process that writes them through
:class:`gcs.log.mcap_log.McapMissionLog`: on a machine with a second core the record
is written while the planner plans, and the file is the one the run would have
written itself.

The pipe's buffer bounds what is in flight: a writer that falls behind slows the run
to its pace instead of filling memory. A writer that fails or dies ends the log, not
the run: its reason is kept in ``failure`` and every later call returns quietly, as
``McapMissionLog`` does with a full disk.
"""

from __future__ import annotations

import json
import pickle
import signal
import struct
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import IO, Any

import numpy as np

from core.cells import Cell, CellState, Direction
from gcs.log.mcap_log import LoggedMission, LogSettings, McapMissionLog
from gcs.log.mission_log import FleetStep, GeoFix, MissionProgress, VehicleStatus
from gcs.outcome.result import RunResult

#: Calls gathered before a batch goes to the writer: a few milliseconds of its work,
#: so that it writes while the run goes on, and few enough sends to cost little.
BATCH_CALLS = 200
#: The longest wait for the writer to finish once the log is closed. What it has left
#: then is at most what the pipe holds and the last batch.
CLOSE_TIMEOUT_S = 120.0
#: A batch's length ahead of it on the pipe.
_LENGTH = struct.Struct("<Q")
#: The writer's start: this module's ``serve`` on the run's ``sys.path`` (a child
#: process started by ``multiprocessing`` would import the run's main script again).
_SERVE = "import json, sys; sys.path[:0] = json.loads(sys.argv[1]); import {0}; {0}.serve()"


class LogProcess:
    """Implements :class:`gcs.log.mission_log.MissionLog` by a writer process."""

    def __init__(
        self,
        path: Path,
        mission: LoggedMission,
        settings: LogSettings | None = None,
        *,
        started_unix_s: float | None = None,
        batch_calls: int = BATCH_CALLS,
        close_timeout_s: float = CLOSE_TIMEOUT_S,
    ) -> None:
        """Starts the writer of ``path``. The file is created here first, so that a
        place that cannot be written raises ``OSError`` now rather than ending the
        log later. ``started_unix_s``: as for ``McapMissionLog``, now by default."""
        path.open("wb").close()
        self._process = subprocess.Popen(
            [sys.executable, "-c", _SERVE.format(__name__), json.dumps(sys.path)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
        )
        self._batch_calls = batch_calls
        self._close_timeout_s = close_timeout_s
        self._calls: list[tuple[str, tuple[Any, ...]]] = []
        self._closed = False
        self._fleet_logged = False
        #: Why the file stopped being written, if it did (the writer's words, or ours
        #: when the writer is gone).
        self.failure: str | None = None
        started = time.time() if started_unix_s is None else started_unix_s
        self._send([("open", (str(path), mission, settings or LogSettings(), started))])

    # ------------------------------------------------------------ MissionLog

    def start(self, unix_s: float | None = None) -> None:
        self._call("start", unix_s)

    def raw(self, sysid: int, outgoing: bool, t_s: float, frame: bytes) -> None:
        self._call("raw", sysid, outgoing, t_s, frame)

    def agent_state(
        self,
        t_s: float,
        sysid: int,
        cell: Cell,
        battery_pct: float,
        mode: str,
        fix: GeoFix | None = None,
        readings: Mapping[Direction, CellState] | None = None,
    ) -> None:
        self._call("agent_state", t_s, sysid, cell, battery_pct, mode, fix, readings)

    def fleet_step(self, t_s: float, step: FleetStep) -> None:
        self._fleet_logged = True
        self._call("fleet_step", t_s, step)

    def coverage(self, t_s: float, belief: np.ndarray, covered: np.ndarray) -> None:
        self._call("coverage", t_s, belief, covered)

    def btps(self, t_s: float, cells: Sequence[Cell]) -> None:
        self._call("btps", t_s, list(cells))

    def event(self, t_s: float, text: str, level: str = "info", sysid: int | None = None) -> None:
        self._call("event", t_s, text, level, sysid)

    def status(
        self, t_s: float, vehicles: Sequence[VehicleStatus], progress: MissionProgress
    ) -> None:
        self._call("status", t_s, list(vehicles), progress)

    def result(self, t_s: float, result: RunResult) -> None:
        if self._fleet_logged:
            # The log leaves each agent's steps out of /run/result where /fleet/states
            # holds them: not sent (on the maze, a pickle of 16 million cells).
            bare = tuple(replace(a, track=(), battery_pct=()) for a in result.agents)
            result = replace(result, agents=bare)
        self._call("result", t_s, result)

    def close(self) -> None:
        """Sends what is left, waits for the writer to end the file (at most
        ``close_timeout_s``) and takes its ``failure``."""
        if self._closed:
            return
        self._closed = True
        if self.failure is None and self._calls:
            self._send(self._calls)
        self._calls = []
        self._end_writer()

    # -------------------------------------------------------------- plumbing

    def _call(self, name: str, *args: Any) -> None:
        if self._closed or self.failure is not None:
            return
        self._calls.append((name, args))
        if len(self._calls) >= self._batch_calls:
            batch, self._calls = self._calls, []
            self._send(batch)

    def _send(self, batch: list[tuple[str, tuple[Any, ...]]]) -> None:
        data = pickle.dumps(batch, protocol=pickle.HIGHEST_PROTOCOL)
        pipe = self._process.stdin
        assert pipe is not None
        try:
            pipe.write(_LENGTH.pack(len(data)))
            pipe.write(data)
            pipe.flush()
        except (OSError, ValueError):  # the writer is gone, or its pipe closed
            self._end_writer("the log's writer ended before the log did")

    def _end_writer(self, reason: str | None = None) -> None:
        """The writer's end of the file: the pipe closed, its last word taken (its
        ``failure``, or ``reason`` when it has none to give)."""
        try:
            out, _ = self._process.communicate(timeout=self._close_timeout_s)
        except (OSError, ValueError):
            out = b""
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.communicate()
            out = b""
            reason = f"the log's writer did not finish within {self._close_timeout_s:.0f} s"
        word = _read_word(out)
        if word is not None and word.failure is not None:
            self.failure = word.failure
        elif reason is not None or word is None:  # calls lost, or no word from it
            self.failure = reason or "the log's writer ended without a word"
        self._closed = True


@dataclass(frozen=True)
class _Word:
    """The writer's last word on its standard output: why the file stopped, if it did."""

    failure: str | None


def _read_word(out: bytes) -> _Word | None:
    try:
        word = pickle.loads(out)
    except Exception:  # nothing, or not ours: the writer died before its last word
        return None
    return word if isinstance(word, _Word) else None


def serve(stdin: IO[bytes] | None = None, stdout: IO[bytes] | None = None) -> None:
    """The writer process: every batch's calls on the file's log until the run's end
    of the pipe closes; then its last word (``_Word``) on ``stdout``. An interrupt
    (the operator's Ctrl-C reaches the whole terminal) is the run's to handle: the
    writer ends the file when the run closes the pipe, or exits."""
    if stdin is None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    stdin = stdin or sys.stdin.buffer
    stdout = stdout or sys.stdout.buffer
    failure: str | None = None
    log: McapMissionLog | None = None
    try:
        while header := stdin.read(_LENGTH.size):
            (length,) = _LENGTH.unpack(header)
            for name, args in pickle.loads(stdin.read(length)):
                if name == "open":
                    path, mission, settings, started = args
                    log = McapMissionLog(path, mission, settings, started_unix_s=started)
                elif log is not None:
                    getattr(log, name)(*args)
    except Exception as exc:  # the writer's end, told to the run rather than lost
        failure = f"the log's writer failed: {type(exc).__name__}: {exc}"
    finally:
        if log is not None:
            log.close()
            failure = failure or log.failure
        try:
            stdout.write(pickle.dumps(_Word(failure)))
            stdout.flush()
        except OSError:
            pass  # the run is gone: nobody to tell
