"""The log's scenes: map snapshots (re-encoded where cells changed) and the tracks."""

from __future__ import annotations

import base64
import itertools
import json
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from core.cells import Cell
from core.geo import GeoFrame
from gcs.log.mcap_log import LoggedMission, LogSettings, McapMissionLog
from gcs.log.mission_log import FleetStep
from gcs.log.scenes import GridEncoder
from gcs.log.topics import GRID_RGBA, TRACKS_TOPIC, codes_from_grid, grid_codes


@st.composite
def snapshots(draw: st.DrawFn) -> tuple[tuple[int, int], list[tuple[np.ndarray, np.ndarray]]]:
    """A map's shape (any number of cells, whole groups of three or not) and the
    belief and coverage of a few snapshots, each changing some cells of the last."""
    rows, cols = draw(st.integers(1, 9)), draw(st.integers(1, 9))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    belief = rng.integers(0, 3, (rows, cols)).astype(np.uint8)
    covered = np.zeros((rows, cols), dtype=bool)
    grids = []
    for _ in range(draw(st.integers(1, 5))):
        changed = rng.integers(0, rows * cols, draw(st.integers(0, 4)))
        belief.flat[changed] = rng.integers(0, 3, changed.size)
        covered.flat[rng.integers(0, rows * cols, draw(st.integers(0, 3)))] = True
        grids.append((belief.copy(), covered.copy()))
    return (rows, cols), grids


@settings(max_examples=150, deadline=None)
@given(snapshots())
def test_each_snapshot_is_the_map_as_it_is_then(
    case: tuple[tuple[int, int], list[tuple[np.ndarray, np.ndarray]]],
) -> None:
    """Every message of one encoder decodes to the codes and colours of its own
    snapshot, and equals what a new encoder writes for that snapshot alone."""
    _, grids = case
    encoder = GridEncoder(2.0)
    for belief, covered in grids:
        data = encoder.message(7, belief, covered)
        assert data == GridEncoder(2.0).message(7, belief, covered)
        message = json.loads(data)
        codes = grid_codes(belief, covered)
        np.testing.assert_array_equal(codes_from_grid(message), codes)
        cells = np.frombuffer(base64.b64decode(message["data"]), dtype=np.uint8)
        colours = cells.reshape(-1, message["cell_stride"])[:, 1:]
        np.testing.assert_array_equal(colours, GRID_RGBA[np.flipud(codes).ravel()])


class _Tracks:
    """A live view that keeps the last ``/scene/tracks`` message."""

    def __init__(self) -> None:
        self.last: dict[str, Any] | None = None

    def publish(self, topic: str, schema: str, t_s: float, data: bytes) -> None:
        if topic == TRACKS_TOPIC:
            self.last = json.loads(data)


@st.composite
def walks(draw: st.DrawFn) -> tuple[int, list[list[Cell]]]:
    """A few vehicles' cells at each step, each a lazy walk of moves to a neighbour,
    and how many steps go in one ``/fleet/states`` message."""
    vehicles, steps = draw(st.integers(1, 4)), draw(st.integers(1, 40))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    moves = [(0, 0), (0, 0), (1, 0), (-1, 0), (0, 1), (0, -1)]
    straight = draw(st.floats(0.0, 0.9))
    walks = []
    for _ in range(vehicles):
        cell, move = (10, 10), (0, 1)
        walk = [cell]
        for _ in range(steps - 1):
            if rng.random() >= straight:
                move = moves[rng.integers(len(moves))]
            cell = (cell[0] + move[0], cell[1] + move[1])
            walk.append(cell)
        walks.append(walk)
    return draw(st.integers(1, 7)), [list(step) for step in zip(*walks, strict=True)]


@settings(max_examples=150, deadline=None)
@given(walks())
def test_a_track_goes_through_every_cell_with_a_point_only_where_it_turns(
    case: tuple[int, list[list[Cell]]],
) -> None:
    """Followed from point to point, a vehicle's drawn track passes through the cells it
    was in, in order; its points are where it starts, turns and is now."""
    per_message, steps = case
    cell_m = 2.0
    sink = _Tracks()
    mission = LoggedMission(
        name="walks",
        shape=(30, 30),
        cell_size_m=cell_m,
        charger=(10, 10),
        geo=GeoFrame(50.0, 8.0, 100.0, cell_m),
        reserve_pct=20.0,
    )
    log = McapMissionLog(None, mission, LogSettings(steps_per_message=per_message), sinks=[sink])
    sysids = list(range(1, len(steps[0]) + 1))
    for t, cells in enumerate(steps):
        log.fleet_step(t, FleetStep(sysids, cells, [50.0] * len(cells), ["exploring"] * len(cells)))
    log.close()
    assert sink.last is not None
    drawn = {e["id"]: e["lines"][0]["points"] for e in sink.last["entities"]}
    for k, sysid in enumerate(sysids):
        points = [
            (round(-p["y"] / cell_m - 0.5), round(p["x"] / cell_m - 0.5))
            for p in drawn[f"track/{sysid}"]
        ]
        walk = [cells[k] for cells in steps]
        visited = [c for t, c in enumerate(walk) if t == 0 or c != walk[t - 1]]
        followed = [points[0]]
        for a, b in itertools.pairwise(points):
            assert a != b and (a[0] == b[0] or a[1] == b[1]), (a, b)
            length = abs(b[0] - a[0]) + abs(b[1] - a[1])
            unit = ((b[0] - a[0]) // length, (b[1] - a[1]) // length)
            followed += [(a[0] + unit[0] * i, a[1] + unit[1] * i) for i in range(1, length + 1)]
        assert followed == visited
        for a, b, c in zip(points, points[1:], points[2:], strict=False):
            straight_on = (b[0] - a[0]) * (c[1] - b[1]) == (b[1] - a[1]) * (c[0] - b[0])
            same_way = (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]) > 0
            assert not (straight_on and same_way), (a, b, c)


class _States:
    """A live view that keeps every ``/vehicle/1/battery`` message."""

    def __init__(self) -> None:
        self.states: list[dict[str, Any]] = []

    def publish(self, topic: str, schema: str, t_s: float, data: bytes) -> None:
        if topic == "/vehicle/1/battery":
            self.states.append(json.loads(data))


def test_a_waiting_vehicles_state_is_written_where_it_changes() -> None:
    """An offline run's ``/vehicle/N/battery`` skips the messages of a wait, yet read as
    a value held until the next message it gives the state at every message's time,
    and the state before a change is written again at the wait's last message."""
    cells = [(5, 5)] * 100 + [(5, 5 + k) for k in range(1, 11)] + [(5, 15)] * 60
    battery = [80.0] * 100 + [80.0 - k for k in range(1, 11)] + [70.0] * 60
    sink = _States()
    mission = LoggedMission("wait", (30, 30), 1.0, (5, 5), GeoFrame(50.0, 8.0, 0.0, 1.0), 20.0)
    log = McapMissionLog(None, mission, LogSettings(steps_per_message=5), sinks=[sink])
    for t, (cell, pct) in enumerate(zip(cells, battery, strict=True)):
        log.fleet_step(t, FleetStep([1], [cell], [pct], ["exploring"]))
    log.close()
    times = [s["t_s"] for s in sink.states]
    assert times == sorted(times)
    assert len(sink.states) < len(cells) // 5 / 2
    for t in range(4, len(cells), 5):  # the last step of each message
        held = [s for s in sink.states if s["t_s"] <= t][-1]
        assert (tuple(held["cell"]), held["battery_pct"]) == (cells[t], battery[t]), t
    assert sink.states[-1]["t_s"] == len(cells) - 1
    assert 99 in times  # the wait's last message, before the first move
