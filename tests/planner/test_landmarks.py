"""The landmarks' distances are exact for the map as known, however it grew, and
the bounds they give change no plan."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from core.cells import CellState
from planner.belief import UNREACHED, MapBelief
from planner.paths import bfs_distances
from planner.speed import bounds, landmarks
from planner.speed.compiled_search import CompiledSearch
from planner.speed.landmarks import HOME, Landmarks
from sitl_mock import mapgen
from tests.planner.test_target_search import _tracks_digest

SIDE = 30


def _column(belief: MapBelief, source: int) -> np.ndarray:
    """The distances from ``source`` over the known free cells, by a plain search."""
    column = np.full(len(belief.state), UNREACHED, dtype=np.int64)
    for v, d in bfs_distances(belief, source).items():
        column[v] = d
    return column


def _assert_exact(marks: Landmarks) -> None:
    belief = marks.belief
    free = np.frombuffer(belief.state, dtype=np.uint8) == int(CellState.FREE)
    home = np.frombuffer(belief.charger_dist, dtype=np.int32)
    assert np.array_equal(marks.lands[free, HOME], home[free])
    assert len(marks.cells) == marks.lands.shape[1]
    for col, source in enumerate(marks.cells):
        assert belief.state[source] == int(CellState.FREE)
        assert np.array_equal(marks.lands[free, col], _column(belief, source)[free])


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    walls=st.floats(0.0, 0.4),
    blocks=st.integers(0, 3),
)
def test_distances_stay_exact_as_the_map_grows_and_cells_are_blocked(
    seed: int, walls: float, blocks: int
) -> None:
    """Cells become free in a random order (far from the known map too, joined
    later), a few landmarks are blocked for good; brought up to date at random
    moments, every column is the distances from its landmark, the charger's
    those of the belief."""
    rng = np.random.default_rng(seed)
    belief = MapBelief((SIDE, SIDE), (0, 0))
    marks = Landmarks(belief)
    cells = [(r, c) for r in range(SIDE) for c in range(SIDE) if rng.random() >= walls]
    order = rng.permutation(len(cells))
    block_at = set(rng.choice(len(cells), size=blocks, replace=False).tolist())
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(landmarks, "DETOUR", 0.0)  # landmarks on open ground too
        for step, k in enumerate(order):
            belief.mark_free(belief.index(cells[k]))
            if step in block_at and len(marks.cells) > 1:
                belief.block(marks.cells[int(rng.integers(1, len(marks.cells)))])
            if rng.random() < 0.02:
                marks.update()
                _assert_exact(marks)
        marks.update()
    _assert_exact(marks)


def _found_outwards(belief: MapBelief, marks: Landmarks) -> set[tuple[int, ...]]:
    """Make the map known ring by ring from the charger, bringing the landmarks up
    to date at each; the landmarks chosen, each time they changed."""
    rows, cols = belief.shape
    r0, c0 = belief.charger
    chosen = set()
    for ring in range(1, rows + cols):
        for r in range(rows):
            for c in range(cols):
                if abs(r - r0) + abs(c - c0) == ring:
                    belief.mark_free(belief.index((r, c)))
        marks.update()
        if len(marks.cells) > 1 and tuple(marks.cells) not in chosen:
            chosen.add(tuple(marks.cells))
            home = np.frombuffer(belief.charger_dist, dtype=np.int32)
            assert home[marks.cells[1]] == home[home < UNREACHED].max()
            assert len(set(marks.cells)) == len(marks.cells)
    return chosen


def test_landmarks_are_chosen_far_apart_as_the_map_is_found(monkeypatch) -> None:
    """Found outwards from the charger in the middle of the map, the landmarks are
    chosen once enough is known, and again as it grows: all of them, apart, the
    first as far from the charger as any known cell."""
    monkeypatch.setattr(landmarks, "DETOUR", 0.0)
    belief = MapBelief((SIDE, SIDE), (SIDE // 2, SIDE // 2))
    marks = Landmarks(belief)
    chosen = _found_outwards(belief, marks)
    _assert_exact(marks)
    assert len(marks.cells) == 1 + landmarks.MOST
    assert len(chosen) > 1  # chosen again as the map grew


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), walls=st.floats(0.0, 0.4), grown=st.integers(0, 3))
def test_each_landmark_is_the_first_cell_farthest_from_those_before(
    seed: int, walls: float, grown: int
) -> None:
    """Checked against plain searches, after the map grew a few times (the columns
    are chosen again in place): landmark k is the first cell the charger reaches
    whose nearest of the charger and landmarks 1 to k-1 is the farthest."""
    rng = np.random.default_rng(seed)
    belief = MapBelief((SIDE, SIDE), (0, 0))
    marks = Landmarks(belief)
    free = [(r, c) for r in range(SIDE) for c in range(SIDE) if rng.random() >= walls]
    order = rng.permutation(len(free))
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(landmarks, "DETOUR", 0.0)
        for part in np.array_split(order, grown + 1):
            for k in part:
                belief.mark_free(belief.index(free[k]))
            marks.update()
            marks._choose()
    _assert_exact(marks)
    home = _column(belief, belief.charger_index)
    near = np.where(home < UNREACHED, home, -1)
    for cell in marks.cells[1:]:
        assert near.max() > 0 and cell == int(np.argmax(near))
        near = np.minimum(near, _column(belief, cell))
    assert len(marks.cells) == 1 + landmarks.MOST or near.max() <= 0


def test_open_ground_keeps_the_charger_alone() -> None:
    belief = MapBelief((SIDE, SIDE), (SIDE // 2, SIDE // 2))
    marks = Landmarks(belief)
    assert not _found_outwards(belief, marks)
    assert marks.lands.shape[1] == 1
    _assert_exact(marks)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), walls=st.floats(0.0, 0.4))
def test_the_bound_is_never_more_than_the_way(seed: int, walls: float) -> None:
    rng = np.random.default_rng(seed)
    belief = MapBelief((SIDE, SIDE), (0, 0))
    grid = rng.random((SIDE, SIDE)) < walls
    grid[0, 0] = False
    for r, c in zip(*np.nonzero(~grid), strict=True):
        belief.mark_free(belief.index((int(r), int(c))))
    search = CompiledSearch(belief)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(landmarks, "DETOUR", 0.0)
        lands = search.landmarks.update()
    reached = [v for v in range(len(belief.state)) if belief.charger_dist[v] < UNREACHED]
    for u in rng.choice(reached, size=5):
        way = bfs_distances(belief, int(u))
        for v in rng.choice(reached, size=20):
            bound = bounds.way_at_least(int(u), int(v), belief.stride, lands)
            assert bound <= way[int(v)]
            for moves in (bound - 1, bound, way[int(v)]):
                within = bounds.way_within(int(u), int(v), moves, belief.stride, lands)
                assert within == (bound <= moves)


@pytest.mark.parametrize(
    ("grid", "agents", "detour"),
    [
        (mapgen.open_field(60, 60, 2), 12, 0.0),  # landmarks on open ground too
        (mapgen.rooms(60, 60, 5), 9, landmarks.DETOUR),
    ],
    ids=["open60-12", "rooms60-9"],
)
def test_plans_are_the_same_with_the_charger_alone(
    monkeypatch, grid, agents: int, detour: float
) -> None:
    """The landmarks only rule out what the searches would not take: with the
    charger as the only one, every move is the same."""
    monkeypatch.setattr(landmarks, "DETOUR", detour)
    chosen = []
    choose = Landmarks._choose

    def counted(self) -> int:
        found = choose(self)
        chosen.append(len(self.cells))
        return found

    monkeypatch.setattr(Landmarks, "_choose", counted)
    with_landmarks = _tracks_digest(grid, agents)
    assert max(chosen) == 1 + landmarks.MOST
    monkeypatch.setattr(Landmarks, "_choose", lambda self: landmarks.MOST)
    assert _tracks_digest(grid, agents) == with_landmarks
