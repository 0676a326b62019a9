"""Mission files (gcs.mission): the shipped missions, defaults, and one-line errors."""

from __future__ import annotations

import json
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from gcs.cli import main
from gcs.mission import (
    Mission,
    MissionError,
    Origin,
    PathPlanner,
    PlannerSpec,
    Sensing,
    VehicleType,
    default_connection,
    load_mission,
)
from gcs.offline.simulate import SimOptions, simulate
from gcs.planning import planner_settings
from gcs.preflight import charger_distances
from planner.settings import PlannerSettings
from sitl_mock import mapgen
from sitl_mock.gridmap import GridMap
from tests.checks import make_mission

MISSIONS = Path(__file__).resolve().parents[2] / "missions"

#: name: (free cells in the paper, fleet size)
SHIPPED = {
    "scenario1": (2068, 1),
    "scenario2": (2029, 5),
    "scenario3": (3631, 5),
    "bob30": (None, 4),
}

MAP = "#####\n#...#\n#.#.#\n#...#\n##C##\n"


def distances(grid: GridMap) -> np.ndarray:
    """Steps from the charger to every reachable cell (-1 elsewhere)."""
    dist = np.full(grid.shape, -1)
    dist[grid.charger] = 0
    queue = deque([grid.charger])
    while queue:
        r, c = queue.popleft()
        for nxt in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if grid.is_free(nxt) and dist[nxt] < 0:
                dist[nxt] = dist[r, c] + 1
                queue.append(nxt)
    return dist


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_missions_load(name: str) -> None:
    paper_free, count = SHIPPED[name]
    mission = load_mission(MISSIONS / f"{name}.yaml")
    grid = mission.map
    assert mission.name == name
    assert len(mission.fleet) == count
    assert (MISSIONS / "maps" / f"{name}.txt").read_text().count("C") == 1
    assert grid.charger == mission.charger == (grid.shape[0] - 1, grid.shape[1] // 2)
    assert np.array_equal(grid.reachable(), ~grid.obstacle)
    if paper_free is not None:
        assert abs(grid.free_count - paper_free) <= 0.02 * paper_free
    # A full battery must reach the farthest cell and come back above the reserve.
    farthest_m = distances(grid).max() * mission.cell_size_m
    for vehicle in mission.fleet:
        assert 2 * farthest_m * vehicle.energy_per_m_pct <= 100 - mission.planner.reserve_pct


def test_bob30_is_the_papers_benchmark() -> None:
    mission = load_mission(MISSIONS / "bob30.yaml")
    assert mission.map.shape == (30, 30)
    assert all(v.energy_per_m_pct == 0 for v in mission.fleet)


def write(tmp_path: Path, text: str, map_text: str = MAP, map_name: str = "m.txt") -> Path:
    (tmp_path / map_name).write_text(map_text)
    path = tmp_path / "mission.yaml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("given", "used"), [("null", PlannerSettings().top_up_ratio), ("0", 0.0), ("0.25", 0.25)]
)
def test_top_up_ratio_null_is_the_planners_default_and_0_the_papers_rule(
    tmp_path: Path, given: str, used: float
) -> None:
    mission = load_mission(write(tmp_path, f"map: m.txt\nplanner: {{top_up_ratio: {given}}}\n"))
    assert planner_settings(mission).top_up_ratio == used


@pytest.mark.parametrize(
    ("given", "used"), [("null", PlannerSettings().rival_pace), ("0", 0.0), ("0.3", 0.3)]
)
def test_rival_pace_null_is_the_planners_default(tmp_path: Path, given: str, used: float) -> None:
    mission = load_mission(write(tmp_path, f"map: m.txt\nplanner: {{rival_pace: {given}}}\n"))
    assert planner_settings(mission).rival_pace == used


@pytest.mark.parametrize(
    ("given", "used"), [("null", PlannerSettings().pocket_claims), ("0", 0), ("32", 32)]
)
def test_pocket_claims_null_is_the_planners_default(tmp_path: Path, given: str, used: int) -> None:
    mission = load_mission(write(tmp_path, f"map: m.txt\nplanner: {{pocket_claims: {given}}}\n"))
    assert planner_settings(mission).pocket_claims == used


def test_gcs_plan_no_top_up_plans_with_the_papers_charging_rule(tmp_path: Path) -> None:
    mission = load_mission(MISSIONS / "scenario3.yaml").with_agents(11)
    papers = simulate(mission, SimOptions(settings=planner_settings(mission, top_up_ratio=0.0)))
    ours = simulate(mission)
    assert papers.total_path_m != ours.total_path_m  # else this tells nothing
    args = ["plan", str(MISSIONS / "scenario3.yaml"), "--agents", "11", "--quiet"]
    assert main([*args, "--no-top-up", "--out", str(tmp_path)]) == 0
    assert json.loads((tmp_path / "report.json").read_text())["total_path_m"] == papers.total_path_m


def test_a_map_alone_is_a_mission(tmp_path: Path) -> None:
    mission = load_mission(write(tmp_path, "map: m.txt\n"))
    assert mission.name == "mission"
    assert mission.charger == (4, 2)
    assert mission.cell_size_m == 1.0
    assert mission.origin == Origin(47.397742, 8.545594, 488.0)
    assert mission.planner == PlannerSpec(20.0, None, None, PathPlanner.GRID, None)
    (vehicle,) = mission.fleet
    assert vehicle.sysid == 1
    assert vehicle.type is VehicleType.ROVER
    assert vehicle.sensing is Sensing.RANGE
    assert vehicle.connection == "udpin:127.0.0.1:14550"
    assert (vehicle.energy_per_m_pct, vehicle.battery_capacity_mah, vehicle.speed_m_s) == (
        0.5,
        5000.0,
        2.0,
    )


FULL = """\
name: full
map: m.txt
cell_size_m: 2.5
origin: {lat_deg: -33.5, lon_deg: 151.25, alt_m: 10}
fleet:
  count: 4
  defaults: {type: copter, sensing: map, energy_per_m_pct: 0.2, speed_m_s: 5}
  vehicles:
    - {sysid: 2, connection: "udpout:10.0.0.2:14550"}
    - {type: rover, speed_m_s: 1.5, charge_rate_pct_s: 0.5}
planner:
  reserve_pct: 25
  charge_pct_per_step: 2.5
  charging_slots: 1
  path_planner: prm
  max_iterations: 5000
  far_transit_recheck: 64
  top_up_ratio: 0.25
"""


def test_every_key_is_read(tmp_path: Path) -> None:
    mission = load_mission(write(tmp_path, FULL))
    assert mission.name == "full"
    assert mission.cell_size_m == 2.5
    assert mission.origin == Origin(-33.5, 151.25, 10.0)
    assert mission.planner == PlannerSpec(25.0, 2.5, 1, PathPlanner.PRM, 5000, 64, 0.25)
    assert [(v.sysid, v.type, v.speed_m_s, v.charge_rate_pct_s) for v in mission.fleet] == [
        (2, VehicleType.COPTER, 5.0, 1.0),
        (1, VehicleType.ROVER, 1.5, 0.5),
        (3, VehicleType.COPTER, 5.0, 1.0),
        (4, VehicleType.COPTER, 5.0, 1.0),
    ]
    assert [v.connection for v in mission.fleet] == [
        "udpout:10.0.0.2:14550",
        default_connection(1),
        default_connection(3),
        default_connection(4),
    ]
    assert all(v.sensing is Sensing.MAP and v.energy_per_m_pct == 0.2 for v in mission.fleet)


def test_with_agents_keeps_listed_vehicles_and_adds_defaults(tmp_path: Path) -> None:
    mission = load_mission(write(tmp_path, FULL))
    assert [v.sysid for v in mission.with_agents(1).fleet] == [2]
    assert mission.with_agents(4) == mission
    more = mission.with_agents(6)
    assert [v.sysid for v in more.fleet] == [2, 1, 3, 4, 5, 6]
    assert len({v.connection for v in more.fleet}) == 6
    assert more.fleet[-1].type is VehicleType.COPTER  # the mission's defaults
    with pytest.raises(MissionError) as info:
        mission.with_agents(0)
    assert str(info.value) == f"{mission.source}: --agents: must be an integer in 1..255, got 0"


def test_generated_vehicles_avoid_taken_connections(tmp_path: Path) -> None:
    vehicle = f'{{sysid: 5, connection: "{default_connection(1)}"}}'
    text = f"map: m.txt\nfleet:\n  count: 2\n  vehicles: [{vehicle}]\n"
    mission: Mission = load_mission(write(tmp_path, text))
    assert [(v.sysid, v.connection) for v in mission.fleet] == [
        (5, default_connection(1)),
        (2, default_connection(2)),
    ]


def test_vehicles_may_share_one_connection(tmp_path: Path) -> None:
    """One radio or router for the fleet: a connection in the defaults is every
    vehicle's that names none, including those ``--agents`` adds; one may name its own."""
    radio = "serial:/dev/ttyUSB0:57600"
    vehicle = '{sysid: 4, connection: "tcp:127.0.0.1:5760"}'
    text = (
        f"map: m.txt\nfleet:\n  count: 3\n  defaults: {{connection: '{radio}'}}\n"
        f"  vehicles: [{{sysid: 1}}, {vehicle}]\n"
    )
    mission = load_mission(write(tmp_path, text))
    assert [(v.sysid, v.connection) for v in mission.fleet] == [
        (1, radio),
        (4, "tcp:127.0.0.1:5760"),
        (2, radio),
    ]
    assert [v.connection for v in mission.with_agents(5).fleet[3:]] == [radio, radio]


def test_charger_overrides_the_pad(tmp_path: Path) -> None:
    mission = load_mission(write(tmp_path, "map: m.txt\ncharger: [1, 1]\n"))
    assert mission.charger == (1, 1)
    assert mission.map.pads == ((1, 1),)
    assert not mission.map.obstacle[4, 2]  # the old pad is still a free cell


def test_png_map_with_a_charger(tmp_path: Path) -> None:
    pixels = np.zeros((4, 5), dtype=np.uint8)  # dark: obstacle
    pixels[1, 1:4] = 255
    pixels[2, 1] = pixels[2, 3] = 255
    Image.fromarray(pixels).save(tmp_path / "m.png")
    (tmp_path / "mission.yaml").write_text("map: m.png\ncharger: [2, 1]\n")
    mission = load_mission(tmp_path / "mission.yaml")
    assert mission.charger == (2, 1)
    assert mission.map.pads == ((2, 1),)
    assert mission.map.free_count == 5


A_MAP = (
    "a map, not a mission: give the mission file (YAML) that names it, e.g. a file holding "
    "the line 'map: <this file>' (see the README's Mission file reference)"
)
# Malformed missions: (mission text, map text or None for the default, expected message).
BAD: list[tuple[str, str | None, str]] = [
    ("", None, "file is empty (a mission needs at least 'map')"),
    ("#####\n#..C#\n#####\n", None, A_MAP),
    (
        "map: m.txt\nplanner: {charge_at_end: 1}\n",
        None,
        "planner.charge_at_end: must be true or false, got 1",
    ),
    ("....\n..C.\n", None, A_MAP),
    ("- map: m.txt\n", None, "top level must be a mapping of keys, got a list"),
    (
        "map: m.txt\nfleet: {count: 2\n",
        None,
        "invalid YAML at line 3, column 1: expected ',' or '}', but got '<stream end>'",
    ),
    ("name: x\n", None, "map: required key is missing"),
    ("map: 3\n", None, "map: must be a file path, got 3"),
    ("map: m.txt\nplaner: {}\n", None, "planer: unknown key (did you mean 'planner'?)"),
    (
        "map: m.txt\nzzz: 1\n",
        None,
        "zzz: unknown key (expected one of: name, map, charger, cell_size_m, origin, fleet, "
        "planner)",
    ),
    ("map: m.txt\nfleet: {count: -3}\n", None, "fleet.count: must be a positive integer, got -3"),
    (
        "map: m.txt\nfleet: {count: true}\n",
        None,
        "fleet.count: must be a positive integer, got true",
    ),
    (
        "map: m.txt\nfleet: {count: 1, vehicles: [{}, {}]}\n",
        None,
        "fleet.count: 1 is fewer than the 2 listed vehicles",
    ),
    (
        "map: m.txt\nfleet: {defaults: {sped_m_s: 3}}\n",
        None,
        "fleet.defaults.sped_m_s: unknown key (did you mean 'speed_m_s'?)",
    ),
    (
        "map: m.txt\nfleet: {defaults: {type: rovr}}\n",
        None,
        "fleet.defaults.type: must be one of rover, copter, got 'rovr' (did you mean 'rover'?)",
    ),
    (
        "map: m.txt\nfleet: {defaults: {energy_per_m_pct: -0.1}}\n",
        None,
        "fleet.defaults.energy_per_m_pct: must be a number >= 0, got -0.1",
    ),
    (
        "map: m.txt\nfleet: {vehicles: [{sysid: 3}, {sysid: 3}]}\n",
        None,
        "fleet.vehicles[1].sysid: 3 is already used by fleet.vehicles[0]",
    ),
    (
        "map: m.txt\nfleet: {vehicles: [{sysid: 0}]}\n",
        None,
        "fleet.vehicles[0].sysid: must be an integer in 1..255, got 0",
    ),
    (
        "map: m.txt\nfleet: {defaults: {connection: 5}}\n",
        None,
        "fleet.defaults.connection: must be a non-empty string, got 5",
    ),
    ("map: m.txt\nfleet: {vehicles: 3}\n", None, "fleet.vehicles: must be a list, got a number"),
    (
        "map: m.txt\nfleet: {vehicles: [{speed_m_s: 0}]}\n",
        None,
        "fleet.vehicles[0].speed_m_s: must be a number > 0, got 0",
    ),
    (
        "map: m.txt\nfleet: {defaults: {charge_rate_pct_s: -1}}\n",
        None,
        "fleet.defaults.charge_rate_pct_s: must be a number > 0, got -1",
    ),
    ("map: m.txt\ncell_size_m: 0\n", None, "cell_size_m: must be a number > 0, got 0"),
    ("map: m.txt\ncell_size_m: '1'\n", None, "cell_size_m: must be a number > 0, got '1'"),
    (
        "map: m.txt\norigin: {lat_deg: 91}\n",
        None,
        "origin.lat_deg: must be a number in [-90, 90], got 91",
    ),
    ("map: m.txt\norigin: [1, 2]\n", None, "origin: must be a mapping, got a list"),
    (
        "map: m.txt\nplanner: {reserve_pct: 100}\n",
        None,
        "planner.reserve_pct: must be a number in [0, 100), got 100",
    ),
    (
        "map: m.txt\nplanner: {charge_pct_per_step: 0}\n",
        None,
        "planner.charge_pct_per_step: must be a number > 0 or null, got 0",
    ),
    (
        "map: m.txt\nplanner: {charging_slots: 0}\n",
        None,
        "planner.charging_slots: must be a positive integer or null, got 0",
    ),
    (
        "map: m.txt\nplanner: {max_iterations: 1.5}\n",
        None,
        "planner.max_iterations: must be a positive integer or null, got 1.5",
    ),
    (
        "map: m.txt\nplanner: {far_transit_recheck: -3}\n",
        None,
        "planner.far_transit_recheck: must be a positive integer or null, got -3",
    ),
    (
        "map: m.txt\nplanner: {top_up_ratio: 1.5}\n",
        None,
        "planner.top_up_ratio: must be a number in [0, 1] or null, got 1.5",
    ),
    (
        "map: m.txt\nplanner: {rival_pace: -0.1}\n",
        None,
        "planner.rival_pace: must be a number >= 0 or null, got -0.1",
    ),
    (
        "map: m.txt\nplanner: {pocket_claims: 1.5}\n",
        None,
        "planner.pocket_claims: must be an integer >= 0 or null, got 1.5",
    ),
    (
        "map: m.txt\nplanner: {path_planner: astar}\n",
        None,
        "planner.path_planner: must be one of grid, prm, got 'astar'",
    ),
    (
        "map: m.txt\n",
        "#####\n#...#\n#..#\n##C##\n",
        "map: not rectangular: line 3 has 4 cells, expected 5",
    ),
    (
        "map: m.txt\n",
        "#####\n#.x.#\n##C##\n",
        "map: unknown character 'x' at line 2, column 3 (expected '#', '.' or 'C')",
    ),
    (
        "map: m.txt\n",
        "#####\n#...#\n#####\n",
        "map: no charging pad 'C' (mark one in the map or set 'charger')",
    ),
    (
        "map: m.txt\n",
        "#######\n#.#...#\n###...#\n###C###\n",
        "map: 1 free cell cannot be reached from the charging pad, e.g. (1, 1)",
    ),
    (
        "map: m.txt\n",
        "#####\n#.#.#\n#.#.#\n##C##\n",
        "map: 4 free cells cannot be reached from the charging pad, e.g. (1, 1)",
    ),
    ("map: m.txt\ncharger: [2, 2]\n", None, "charger: cell (2, 2) is an obstacle"),
    ("map: m.txt\ncharger: [9, 2]\n", None, "charger: cell (9, 2) is outside the 5x5 map"),
    ("map: m.txt\ncharger: 5\n", None, "charger: must be [row, col], got 5"),
    ("map: m.txt\ncharger: [1, x]\n", None, "charger: must be [row, col], got [1, x]"),
]


@pytest.mark.parametrize(("text", "map_text", "problem"), BAD)
def test_malformed_missions_give_one_line(
    tmp_path: Path, text: str, map_text: str | None, problem: str
) -> None:
    path = write(tmp_path, text, MAP if map_text is None else map_text)
    with pytest.raises(MissionError) as info:
        load_mission(path)
    assert str(info.value) == f"{path}: {problem}"


def test_missing_map_file(tmp_path: Path) -> None:
    path = tmp_path / "mission.yaml"
    path.write_text("map: maps/nope.txt\n")
    with pytest.raises(MissionError) as info:
        load_mission(path)
    assert str(info.value) == f"{path}: map: file not found: {tmp_path / 'maps' / 'nope.txt'}"


def test_unreadable_mission_file(tmp_path: Path) -> None:
    path = tmp_path / "absent.yaml"
    with pytest.raises(MissionError) as info:
        load_mission(path)
    assert str(info.value) == f"{path}: cannot read file: No such file or directory"


def test_png_map_needs_a_charger(tmp_path: Path) -> None:
    Image.fromarray(np.full((3, 3), 255, dtype=np.uint8)).save(tmp_path / "m.png")
    path = tmp_path / "mission.yaml"
    path.write_text("map: m.png\n")
    with pytest.raises(MissionError) as info:
        load_mission(path)
    assert str(info.value) == (
        f"{path}: map: no charger: a PNG map cannot mark one, so set 'charger: [row, col]'"
    )


@pytest.mark.parametrize("seed", range(6))
def test_charger_distances_are_breadth_first_moves_over_the_true_map(seed: int) -> None:
    makers: list[Callable[[int, int, int], GridMap]] = [
        mapgen.rooms,
        mapgen.caves,
        mapgen.open_field,
    ]
    grid = makers[seed % 3](23, 31, seed)
    expected = np.full(grid.shape, -1)
    expected[grid.charger] = 0
    queue = deque([grid.charger])
    while queue:
        r, c = queue.popleft()
        for nr, nc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if grid.is_free((nr, nc)) and expected[nr, nc] < 0:
                expected[nr, nc] = expected[r, c] + 1
                queue.append((nr, nc))
    assert (charger_distances(make_mission(grid, 1)) == expected).all()


def test_a_png_map_given_as_the_mission(tmp_path: Path) -> None:
    path = tmp_path / "map.png"
    path.write_bytes(b"\x89PNG\r\n\x1a\n")
    with pytest.raises(MissionError, match="a map, not a mission"):
        load_mission(path)
