"""Mission files: YAML in, validated frozen values out.

Validation happens here and only here: every problem raises
:class:`MissionError` with a one-line message ``"<file>: <key path>: <problem>"``
and the rest of the ground station can trust a :class:`Mission`.

A mission that gives only ``map`` works: every other key has a default (see
the module constants and the dataclass defaults below).

Connections: a vehicle without an explicit ``connection`` (nor one in
``fleet.defaults``) listens on its own loopback UDP port,
``udpin:127.0.0.1:<14550 + 10 * (sysid - 1)>`` (14550 for sysid 1, 14560 for
sysid 2, ...), the ArduPilot SITL habit of ten ports per instance. The mock
fleet sends to the same ports, so ``--sim`` needs no setup. Several vehicles
may name the same connection (one radio or router for the fleet): the station
opens it once and tells the vehicles apart by system id.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import yaml

from core.cells import Cell
from core.geo import GeoFrame
from sitl_mock.gridmap import GridMap
from sitl_mock.maps import (
    FREE_CHAR,
    OBSTACLE_CHAR,
    PAD_CHAR,
    PNG_SUFFIXES,
    MapError,
    load_map,
    make_map,
    reachable_mask,
)
from vehicles.printable import is_printable

MAX_SYSID = 255
CONNECTION_BASE_PORT = 14550
CONNECTION_PORT_STEP = 10
_MAP_CHARS = frozenset(OBSTACLE_CHAR + FREE_CHAR + PAD_CHAR)


class MissionError(ValueError):
    """A mission file that cannot be used; ``str()`` is one line naming file, key and problem."""

    def __init__(self, source: str, key: str | None, problem: str) -> None:
        where = f"{source}: {key}: " if key else f"{source}: "
        super().__init__(_one_line(where + problem))
        self.source = source
        self.key = key
        self.problem = problem


class VehicleType(StrEnum):
    ROVER = "rover"
    COPTER = "copter"


class Sensing(StrEnum):
    """How a vehicle learns the map: range sensors around it, or the map given up front."""

    RANGE = "range"
    MAP = "map"


class Steering(StrEnum):
    """How a rover turns: in place on its tracks or wheels (skid), or round a turning
    circle (car). The ground station allows for its turns; the mock drives like it."""

    SKID = "skid"
    CAR = "car"


class Charging(StrEnum):
    """How the autopilot learns that its battery was charged on the pad."""

    #: Its battery telemetry rises by itself (a smart battery; the mock's self-charging pad).
    TELEMETRY = "telemetry"
    #: It does not (ArduPilot's analog monitor counts consumed mAh): the ground station
    #: says so with MAV_CMD_BATTERY_RESET when the charge is done.
    RESET = "reset"
    #: Wait on the telemetry; if it has not risen by the time the charge should be done,
    #: reset.
    AUTO = "auto"


class PathPlanner(StrEnum):
    GRID = "grid"
    PRM = "prm"


@dataclass(frozen=True)
class Origin:
    """Geographic position of the north-west corner of cell (0, 0)."""

    lat_deg: float = 47.397742
    lon_deg: float = 8.545594
    alt_m: float = 488.0


@dataclass(frozen=True)
class VehicleDefaults:
    """The settings a vehicle takes when the mission does not give them."""

    type: VehicleType = VehicleType.ROVER
    sensing: Sensing = Sensing.RANGE
    energy_per_m_pct: float = 0.5
    battery_capacity_mah: float = 5000.0
    speed_m_s: float = 2.0
    charge_rate_pct_s: float = 1.0
    steering: Steering = Steering.SKID
    charging: Charging = Charging.AUTO
    fence: bool = True
    #: One connection for every vehicle that names none (a radio or router that carries
    #: the whole fleet); None: each its own UDP port (``default_connection``).
    connection: str | None = None


@dataclass(frozen=True)
class VehicleSpec:
    sysid: int
    type: VehicleType
    sensing: Sensing
    connection: str
    energy_per_m_pct: float
    battery_capacity_mah: float
    speed_m_s: float
    charge_rate_pct_s: float
    #: How a rover turns (copters ignore it).
    steering: Steering = Steering.SKID
    #: How the autopilot learns its charge on the pad.
    charging: Charging = Charging.AUTO
    #: Upload the mission area as a geofence, switched on, before the vehicle arms.
    fence: bool = True


@dataclass(frozen=True)
class PlannerSpec:
    reserve_pct: float = 20.0
    charge_pct_per_step: float | None = None  # None: instant charging, as in the paper
    charging_slots: int | None = None  # None: unlimited, as in the paper
    path_planner: PathPlanner = PathPlanner.GRID
    max_iterations: int | None = None  # None: the caller decides
    #: A target more than this many moves away is searched for again only once half
    #: the way beyond it is travelled (None: at every step; PlannerSettings).
    far_transit_recheck: int | None = None
    #: Charge on the way when the round trip costs at most this share of the charge
    #: gained (None: the planner's default, PlannerSettings.top_up_ratio).
    top_up_ratio: float | None = None
    #: Wait rather than set out for a target another vehicle would sweep first, that
    #: vehicle drawing nearer at this many cells per move (None: the planner's
    #: default, PlannerSettings.rival_pace; 0: shorter missions, longer paths).
    rival_pace: float | None = None
    #: Leave whole to a vehicle the enclosed part of at most this many cells it
    #: sweeps beside or heads into (None: the planner's default,
    #: PlannerSettings.pocket_claims; 0: off, shorter missions, longer paths).
    pocket_claims: int | None = None
    #: When coverage is complete, charge each vehicle to full before it parks (False:
    #: home and park at once; PlannerSettings).
    charge_at_end: bool = False


@dataclass(frozen=True)
class Mission:
    name: str
    source: Path
    map: GridMap
    charger: Cell
    cell_size_m: float
    origin: Origin
    fleet: tuple[VehicleSpec, ...]
    planner: PlannerSpec
    vehicle_defaults: VehicleDefaults = dataclasses.field(default_factory=VehicleDefaults)

    @property
    def geo(self) -> GeoFrame:
        """Where the grid is on Earth: the origin and the cell size."""
        o = self.origin
        return GeoFrame(o.lat_deg, o.lon_deg, o.alt_m, self.cell_size_m)

    @property
    def reachable_cells(self) -> int:
        """The free cells reachable from the charger: what complete coverage covers."""
        return int(self.map.reachable(self.charger).sum())

    def with_agents(self, count: int) -> Mission:
        """The same mission with ``count`` vehicles (the ``--agents N`` override).

        Keeps the first ``count`` vehicles of the fleet, then adds vehicles with
        the default settings, the next free system ids and their default
        connections.
        """
        if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_SYSID:
            raise MissionError(
                str(self.source), "--agents", f"must be an integer in 1..{MAX_SYSID}, got {count}"
            )
        kept = self.fleet[:count]
        added = _generate(self.vehicle_defaults, kept, count - len(kept))
        if len(kept) + len(added) < count:
            raise MissionError(str(self.source), "--agents", f"no free system id for {count}")
        return dataclasses.replace(self, fleet=kept + added)


def on_one_link(mission: Mission, connection: str) -> Mission:
    """The mission with every vehicle on ``connection`` (``gcs run --one-link``)."""
    fleet = tuple(dataclasses.replace(v, connection=connection) for v in mission.fleet)
    return dataclasses.replace(mission, fleet=fleet)


def with_connections(mission: Mission, moved: Mapping[str, str]) -> Mission:
    """The mission with each vehicle's connection ``c`` replaced by ``moved[c]``, if there."""
    fleet = tuple(
        dataclasses.replace(v, connection=moved.get(v.connection, v.connection))
        for v in mission.fleet
    )
    return dataclasses.replace(mission, fleet=fleet)


_A_MAP_NOT_A_MISSION = (
    "a map, not a mission: give the mission file (YAML) that names it, e.g. a file "
    "holding the line 'map: <this file>' (see the README's Mission file reference)"
)


def _looks_like_an_ascii_map(text: str) -> bool:
    """Only lines of map characters (YAML reads a line starting with '#' as a comment)."""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return bool(lines) and all(set(line) <= _MAP_CHARS for line in lines)


def default_connection(sysid: int) -> str:
    """The loopback connection of a vehicle that does not name one (see the module doc)."""
    return f"udpin:127.0.0.1:{CONNECTION_BASE_PORT + CONNECTION_PORT_STEP * (sysid - 1)}"


# ------------------------------------------------------------------------ loading

_TOP_KEYS = ("name", "map", "charger", "cell_size_m", "origin", "fleet", "planner")
_ORIGIN_KEYS = ("lat_deg", "lon_deg", "alt_m")
_FLEET_KEYS = ("count", "defaults", "vehicles")
_DEFAULT_KEYS = (
    "type",
    "sensing",
    "energy_per_m_pct",
    "battery_capacity_mah",
    "speed_m_s",
    "charge_rate_pct_s",
    "steering",
    "charging",
    "fence",
)
_VEHICLE_KEYS = ("sysid", "connection", *_DEFAULT_KEYS)
_PLANNER_KEYS = (
    "reserve_pct",
    "charge_pct_per_step",
    "charging_slots",
    "path_planner",
    "max_iterations",
    "far_transit_recheck",
    "top_up_ratio",
    "rival_pace",
    "pocket_claims",
    "charge_at_end",
)


def load_mission(path: str | Path) -> Mission:
    """Read and validate a mission file; raise :class:`MissionError` on any problem."""
    path = Path(path)
    source = str(path)
    if path.suffix.lower() in PNG_SUFFIXES:
        raise MissionError(source, None, _A_MAP_NOT_A_MISSION)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise MissionError(source, None, "not a text file (not valid UTF-8)") from None
    except OSError as exc:
        raise MissionError(source, None, f"cannot read file: {exc.strerror or exc}") from None
    if _looks_like_an_ascii_map(text):
        raise MissionError(source, None, _A_MAP_NOT_A_MISSION)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise MissionError(source, None, _yaml_problem(exc)) from None
    except ValueError as exc:  # PyYAML's int() of a number longer than Python allows
        raise MissionError(source, None, f"invalid YAML: {exc}") from None
    if data is None:
        raise MissionError(source, None, "file is empty (a mission needs at least 'map')")
    if not isinstance(data, dict):
        raise MissionError(source, None, f"top level must be a mapping of keys, got {_kind(data)}")
    return _Loader(source, path).mission(data)


def _yaml_problem(exc: yaml.YAMLError) -> str:
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    if mark is None:
        return f"invalid YAML: {problem}"
    return f"invalid YAML at line {mark.line + 1}, column {mark.column + 1}: {problem}"


_E = TypeVar("_E", bound=StrEnum)


class _Loader:
    """Validates one mission file; every check raises with the key path it concerns."""

    def __init__(self, source: str, path: Path) -> None:
        self.source = source
        self.path = path

    def fail(self, key: str | None, problem: str) -> MissionError:
        return MissionError(self.source, key, problem)

    # ---------------------------------------------------------------- sections

    def mission(self, data: dict[Any, Any]) -> Mission:
        self.check_keys(data, _TOP_KEYS, "")
        name = data.get("name", self.path.stem)
        if not isinstance(name, str) or not name.strip():
            raise self.fail("name", f"must be a non-empty string, got {_show(name)}")
        if not is_printable(name):
            raise self.fail("name", "must be printable text (no control or lone surrogate)")
        grid, charger = self.grid(data)
        fleet, defaults = self.fleet(data.get("fleet"))
        return Mission(
            name=name,
            source=self.path,
            map=grid,
            charger=charger,
            cell_size_m=self.number(data, "cell_size_m", "", 1.0, above=0.0),
            origin=self.origin(data.get("origin")),
            fleet=fleet,
            planner=self.planner(data.get("planner")),
            vehicle_defaults=defaults,
        )

    def grid(self, data: Mapping[Any, Any]) -> tuple[GridMap, Cell]:
        if "map" not in data:
            raise self.fail("map", "required key is missing")
        value = data["map"]
        if not isinstance(value, str) or not value.strip():
            raise self.fail("map", f"must be a file path, got {_show(value)}")
        file = self.path.parent / value
        try:
            found = file.is_file()
        except OSError as exc:  # e.g. a name too long for the file system
            raise self.fail("map", f"cannot read {file}: {exc.strerror or exc}") from None
        if not found:
            raise self.fail("map", f"file not found: {file}")
        try:
            grid = load_map(file, require_pad=False)
        except MapError as exc:
            raise self.fail("map", exc.problem) from None
        charger = self.charger(data.get("charger"), grid)
        if charger is None:
            if not grid.pads:
                problem = (
                    "no charger: a PNG map cannot mark one, so set 'charger: [row, col]'"
                    if Path(file).suffix.lower() in PNG_SUFFIXES
                    else "no charging pad 'C' (mark one in the map or set 'charger')"
                )
                raise self.fail("map", problem)
            charger = grid.charger
        pads = (charger, *(p for p in grid.pads[1:] if p != charger))
        grid = make_map(grid.obstacle, pads)
        unreachable = ~grid.obstacle & ~reachable_mask(grid.obstacle, charger)
        lost = int(unreachable.sum())
        if lost:
            row, col = (int(x) for x in np.argwhere(unreachable)[0])
            cells = "free cell cannot" if lost == 1 else "free cells cannot"
            raise self.fail(
                "map", f"{lost} {cells} be reached from the charging pad, e.g. ({row}, {col})"
            )
        return grid, charger

    def charger(self, value: Any, grid: GridMap) -> Cell | None:
        if value is None:
            return None
        if not isinstance(value, list) or len(value) != 2 or not all(_is_int(x) for x in value):
            raise self.fail("charger", f"must be [row, col], got {_show(value)}")
        cell = (int(value[0]), int(value[1]))
        height, width = grid.shape
        if not grid.inside(cell):
            raise self.fail("charger", f"cell {cell} is outside the {height}x{width} map")
        if grid.obstacle[cell]:
            raise self.fail("charger", f"cell {cell} is an obstacle")
        return cell

    def origin(self, value: Any) -> Origin:
        if value is None:
            return Origin()
        section = self.section(value, "origin", _ORIGIN_KEYS)
        default = Origin()
        return Origin(
            lat_deg=self.number(section, "lat_deg", "origin", default.lat_deg, within=(-90, 90)),
            lon_deg=self.number(section, "lon_deg", "origin", default.lon_deg, within=(-180, 180)),
            alt_m=self.number(section, "alt_m", "origin", default.alt_m),
        )

    def defaults(self, value: Any) -> VehicleDefaults:
        if value is None:
            return VehicleDefaults()
        given = self.section(value, "fleet.defaults", (*_DEFAULT_KEYS, "connection"))
        connection = given.get("connection")
        if connection is not None:
            connection = self.connection(connection, "fleet.defaults.connection")
        return VehicleDefaults(
            **self.vehicle_settings(given, "fleet.defaults", VehicleDefaults()),
            connection=connection,
        )

    def connection(self, value: Any, where: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.fail(where, f"must be a non-empty string, got {_show(value)}")
        return value.strip()

    def vehicle_settings(
        self, data: Mapping[Any, Any], where: str, base: VehicleDefaults
    ) -> dict[str, Any]:
        return {
            "type": self.choice(data, "type", where, VehicleType, base.type),
            "sensing": self.choice(data, "sensing", where, Sensing, base.sensing),
            "energy_per_m_pct": self.number(
                data, "energy_per_m_pct", where, base.energy_per_m_pct, at_least=0.0
            ),
            "battery_capacity_mah": self.number(
                data, "battery_capacity_mah", where, base.battery_capacity_mah, above=0.0
            ),
            "speed_m_s": self.number(data, "speed_m_s", where, base.speed_m_s, above=0.0),
            "charge_rate_pct_s": self.number(
                data, "charge_rate_pct_s", where, base.charge_rate_pct_s, above=0.0
            ),
            "steering": self.choice(data, "steering", where, Steering, base.steering),
            "charging": self.choice(data, "charging", where, Charging, base.charging),
            "fence": self.flag(data, "fence", where, base.fence),
        }

    def fleet(self, value: Any) -> tuple[tuple[VehicleSpec, ...], VehicleDefaults]:
        section = {} if value is None else self.section(value, "fleet", _FLEET_KEYS)
        defaults = self.defaults(section.get("defaults"))
        listed = self.vehicles(section.get("vehicles"), defaults)
        count = section.get("count")
        if count is None:
            count = max(1, len(listed))
        if not _is_int(count) or count < 1:
            raise self.fail("fleet.count", f"must be a positive integer, got {_show(count)}")
        if count > MAX_SYSID:
            raise self.fail(
                "fleet.count", f"must be at most {MAX_SYSID} (MAVLink system ids), got {count}"
            )
        if count < len(listed):
            raise self.fail(
                "fleet.count", f"{count} is fewer than the {len(listed)} listed vehicles"
            )
        added = _generate(defaults, listed, count - len(listed))
        if len(listed) + len(added) < count:
            raise self.fail("fleet.count", f"not enough free system ids for {count} vehicles")
        return listed + added, defaults

    def vehicles(self, value: Any, defaults: VehicleDefaults) -> tuple[VehicleSpec, ...]:
        if value is None:
            return ()
        if not isinstance(value, list):
            raise self.fail("fleet.vehicles", f"must be a list, got {_kind(value)}")
        items = [
            self.section(item, f"fleet.vehicles[{i}]", _VEHICLE_KEYS)
            for i, item in enumerate(value)
        ]
        sysid_owner: dict[int, str] = {}
        for i, item in enumerate(items):
            if "sysid" not in item:
                continue
            where = f"fleet.vehicles[{i}].sysid"
            sysid = item["sysid"]
            if not _is_int(sysid) or not 1 <= sysid <= MAX_SYSID:
                raise self.fail(where, f"must be an integer in 1..{MAX_SYSID}, got {_show(sysid)}")
            if sysid in sysid_owner:
                raise self.fail(where, f"{sysid} is already used by {sysid_owner[sysid]}")
            sysid_owner[sysid] = f"fleet.vehicles[{i}]"
        free_ids = (n for n in range(1, MAX_SYSID + 1) if n not in sysid_owner)
        specs: list[VehicleSpec] = []
        for i, item in enumerate(items):
            where = f"fleet.vehicles[{i}]"
            sysid = int(item["sysid"]) if "sysid" in item else next(free_ids)
            connection = self.connection(
                item.get("connection", defaults.connection or default_connection(sysid)),
                f"{where}.connection",
            )
            specs.append(
                VehicleSpec(
                    sysid=sysid,
                    connection=connection,
                    **self.vehicle_settings(item, where, defaults),
                )
            )
        return tuple(specs)

    def planner(self, value: Any) -> PlannerSpec:
        if value is None:
            return PlannerSpec()
        section = self.section(value, "planner", _PLANNER_KEYS)
        default = PlannerSpec()
        reserve = section.get("reserve_pct", default.reserve_pct)
        if not _is_number(reserve) or not 0 <= reserve < 100:
            raise self.fail(
                "planner.reserve_pct", f"must be a number in [0, 100), got {_show(reserve)}"
            )
        rate = section.get("charge_pct_per_step")
        if rate is not None and (not _is_number(rate) or rate <= 0):
            raise self.fail(
                "planner.charge_pct_per_step", f"must be a number > 0 or null, got {_show(rate)}"
            )
        top_up = section.get("top_up_ratio")
        if top_up is not None and (not _is_number(top_up) or not 0 <= top_up <= 1):
            raise self.fail(
                "planner.top_up_ratio", f"must be a number in [0, 1] or null, got {_show(top_up)}"
            )
        pace = section.get("rival_pace")
        if pace is not None and (not _is_number(pace) or pace < 0):
            raise self.fail(
                "planner.rival_pace", f"must be a number >= 0 or null, got {_show(pace)}"
            )
        pockets = section.get("pocket_claims")
        if pockets is not None and (not _is_int(pockets) or pockets < 0):
            raise self.fail(
                "planner.pocket_claims", f"must be an integer >= 0 or null, got {_show(pockets)}"
            )
        return PlannerSpec(
            reserve_pct=float(reserve),
            charge_pct_per_step=None if rate is None else float(rate),
            charging_slots=self.optional_count(section, "charging_slots", "planner"),
            path_planner=self.choice(
                section, "path_planner", "planner", PathPlanner, default.path_planner
            ),
            max_iterations=self.optional_count(section, "max_iterations", "planner"),
            far_transit_recheck=self.optional_count(section, "far_transit_recheck", "planner"),
            top_up_ratio=None if top_up is None else float(top_up),
            rival_pace=None if pace is None else float(pace),
            pocket_claims=None if pockets is None else int(pockets),
            charge_at_end=self.flag(section, "charge_at_end", "planner", default.charge_at_end),
        )

    # ----------------------------------------------------------------- helpers

    def flag(self, data: Mapping[Any, Any], key: str, where: str, default: bool) -> bool:
        value = data.get(key, default)
        if not isinstance(value, bool):
            raise self.fail(f"{where}.{key}", f"must be true or false, got {_show(value)}")
        return value

    def section(self, value: Any, where: str, allowed: Sequence[str]) -> dict[Any, Any]:
        if not isinstance(value, dict):
            raise self.fail(where, f"must be a mapping, got {_kind(value)}")
        self.check_keys(value, allowed, where)
        return value

    def check_keys(self, data: Mapping[Any, Any], allowed: Sequence[str], where: str) -> None:
        for key in data:
            if key in allowed:
                continue
            text = str(key)
            path = f"{where}.{text}" if where else text
            close = difflib.get_close_matches(text, allowed, n=1, cutoff=0.6)
            hint = (
                f"did you mean {close[0]!r}?" if close else f"expected one of: {', '.join(allowed)}"
            )
            raise self.fail(path, f"unknown key ({hint})")

    def number(
        self,
        data: Mapping[Any, Any],
        key: str,
        where: str,
        default: float,
        *,
        above: float | None = None,
        at_least: float | None = None,
        within: tuple[float, float] | None = None,
    ) -> float:
        path = f"{where}.{key}" if where else key
        value = data.get(key, default)
        if above is not None:
            wanted, ok = f"a number > {above:g}", _is_number(value) and value > above
        elif at_least is not None:
            wanted, ok = f"a number >= {at_least:g}", _is_number(value) and value >= at_least
        elif within is not None:
            lo, hi = within
            wanted, ok = f"a number in [{lo}, {hi}]", _is_number(value) and lo <= value <= hi
        else:
            wanted, ok = "a number", _is_number(value)
        if not ok:
            raise self.fail(path, f"must be {wanted}, got {_show(value)}")
        return float(value)

    def optional_count(self, data: Mapping[Any, Any], key: str, where: str) -> int | None:
        value = data.get(key)
        if value is None:
            return None
        if not _is_int(value) or value < 1:
            raise self.fail(
                f"{where}.{key}", f"must be a positive integer or null, got {_show(value)}"
            )
        return int(value)

    def choice(
        self, data: Mapping[Any, Any], key: str, where: str, enum: type[_E], default: _E
    ) -> _E:
        value = data.get(key, default)
        names = [member.value for member in enum]
        if isinstance(value, str) and value in names:
            return enum(value)
        problem = f"must be one of {', '.join(names)}, got {_show(value)}"
        close = difflib.get_close_matches(str(value), names, n=1, cutoff=0.6)
        if isinstance(value, str) and close:
            problem += f" (did you mean {close[0]!r}?)"
        raise self.fail(f"{where}.{key}", problem)


def _generate(
    defaults: VehicleDefaults, existing: Sequence[VehicleSpec], count: int
) -> tuple[VehicleSpec, ...]:
    """Up to ``count`` default vehicles on the lowest free system ids and connections."""
    used_ids = {v.sysid for v in existing}
    used_connections = {v.connection for v in existing}
    made: list[VehicleSpec] = []
    for sysid in range(1, MAX_SYSID + 1):
        if len(made) == count:
            break
        connection = defaults.connection or default_connection(sysid)
        if sysid in used_ids or (defaults.connection is None and connection in used_connections):
            continue
        settings = {k: v for k, v in dataclasses.asdict(defaults).items() if k != "connection"}
        made.append(VehicleSpec(sysid=sysid, connection=connection, **settings))
    return tuple(made)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_number(value: Any) -> bool:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer too large for a float
        return False


def _one_line(text: str) -> str:
    """``text`` with line breaks and other unprintable characters escaped, so that a
    key or value from the file (``"a\\nb"``) cannot break the message over lines."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def _kind(value: Any) -> str:
    """A YAML-flavoured name for the type of ``value``."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return "a string"
    return "a number" if _is_number(value) else type(value).__name__


def _show(value: Any) -> str:
    """``value`` as the user wrote it in YAML, short."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        text = repr(value)
    elif isinstance(value, dict | list):
        text = yaml.safe_dump(value, default_flow_style=True, width=10_000).strip()
    else:
        text = str(value)
    return text if len(text) <= 60 else text[:57] + "..."
