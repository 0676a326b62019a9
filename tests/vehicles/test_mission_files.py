"""QGC WPL 110 and QGroundControl .plan files: round trips and clear errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vehicles.mission_files import (
    MissionFileError,
    format_plan,
    format_wpl,
    parse_plan,
    parse_wpl,
    read_mission,
    write_mission,
)
from vehicles.mission_items import MissionItem, same_items

MISSION_PLANNER_WPL = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t47.397742\t8.545594\t488.000000\t1
1\t0\t3\t16\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t47.39780000\t8.54560000\t10.000000\t1
2\t0\t3\t178\t1.00000000\t2.50000000\t-1.00000000\t0.00000000\t0.00000000\t0.00000000\t0.000000\t1
3\t0\t3\t20\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.000000\t1
"""


def _home() -> MissionItem:
    return MissionItem(
        seq=0,
        frame=mavlink.MAV_FRAME_GLOBAL,
        command=mavlink.MAV_CMD_NAV_WAYPOINT,
        x=473977420,
        y=85455940,
        z=488.0,
    )


def _mission() -> list[MissionItem]:
    return [
        _home(),
        MissionItem.waypoint(1, 47.3978, 8.5456, 10.0, frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT),
        MissionItem.waypoint(2, 47.3979123, -8.5457001, 12.5, hold_s=3.0),
        MissionItem(
            seq=3,
            frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
            command=mavlink.MAV_CMD_DO_CHANGE_SPEED,
            param1=1.0,
            param2=2.5,
            param3=-1.0,
        ),
        MissionItem(
            seq=4,
            frame=mavlink.MAV_FRAME_MISSION,
            command=mavlink.MAV_CMD_DO_JUMP,
            param1=1.0,
            param2=3.0,
            autocontinue=0,
        ),
        MissionItem(seq=5, frame=mavlink.MAV_FRAME_LOCAL_NED, command=16, x=12345, y=-6789, z=-2),
        MissionItem(
            seq=6,
            frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
            command=mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH,
            param4=math.nan,
        ),
    ]


def test_reads_mission_planner_file() -> None:
    items = parse_wpl(MISSION_PLANNER_WPL)
    assert [i.command for i in items] == [16, 16, 178, 20]
    assert items[0].current == 1
    assert (items[1].x, items[1].y, items[1].z) == (473978000, 85456000, 10.0)
    assert (items[2].param1, items[2].param2, items[2].param3) == (1.0, 2.5, -1.0)


def test_wpl_round_trip(tmp_path: Path) -> None:
    items = _mission()
    path = tmp_path / "m.waypoints"
    write_mission(path, items)
    assert path.read_text().startswith("QGC WPL 110\n")
    assert same_items(read_mission(path), items)
    assert same_items(parse_wpl(format_wpl(items)), items)


def test_plan_round_trip(tmp_path: Path) -> None:
    items = _mission()
    path = tmp_path / "m.plan"
    write_mission(path, items)
    doc = json.loads(path.read_text())
    assert doc["fileType"] == "Plan"
    assert doc["mission"]["plannedHomePosition"] == [47.397742, 8.545594, 488.0]
    assert len(doc["mission"]["items"]) == len(items) - 1
    assert all(i["type"] == "SimpleItem" for i in doc["mission"]["items"])
    assert doc["mission"]["items"][-1]["params"][3] is None  # NaN is null in QGC plans
    assert same_items(read_mission(path), items)


def test_wpl_to_plan_to_wpl() -> None:
    items = parse_wpl(MISSION_PLANNER_WPL)
    again = parse_wpl(format_wpl(parse_plan(format_plan(items))))
    # the home item's "current" flag has no place in a .plan; the rest survives
    assert same_items(again[1:], items[1:])
    assert (again[0].x, again[0].y, again[0].z) == (items[0].x, items[0].y, items[0].z)


float32s = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(-900_000_000, 900_000_000),
            st.integers(-1_800_000_000, 1_800_000_000),
            float32s,
            float32s,
            st.sampled_from([0, 3, 6, 10]),
        ),
        min_size=1,
        max_size=20,
    )
)
def test_round_trips_any_global_items(raw: list[tuple[int, int, float, float, int]]) -> None:
    items = [
        MissionItem(seq=i, frame=frame, command=16, param1=p1, x=x, y=y, z=z)
        for i, (x, y, z, p1, frame) in enumerate(raw)
    ]
    assert parse_wpl(format_wpl(items)) == items
    home, rest = items[0], items[1:]
    plan_items = parse_plan(format_plan(items))
    assert plan_items[1:] == rest
    assert (plan_items[0].x, plan_items[0].y, plan_items[0].z) == (home.x, home.y, home.z)


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("", "first line must be"),
        ("QGC WPL 100\n", "unsupported WPL version"),
        ("QGC WPL 110\n0\t1\t0\t16\n", "expected 12 columns"),
        ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tabc\t8\t0\t1\n", "bad number"),
        ("QGC WPL 110\n1\t1\t0\t16\t0\t0\t0\t0\t47\t8\t0\t1\n", "item 0 has seq 1"),
    ],
)
def test_bad_wpl(text: str, why: str) -> None:
    with pytest.raises(MissionFileError, match=why):
        parse_wpl(text, "x.waypoints")


def test_bad_wpl_names_the_line() -> None:
    with pytest.raises(MissionFileError, match=r"^m.txt:3: expected 12 columns"):
        parse_wpl(
            MISSION_PLANNER_WPL.splitlines()[0] + "\n" + "0 1 0 16 0 0 0 0 47 8 0 1\n1 2\n", "m.txt"
        )


def _plan(items: list[object]) -> str:
    return json.dumps(
        {"fileType": "Plan", "mission": {"plannedHomePosition": [47, 8, 0], "items": items}}
    )


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("{", "not JSON"),
        ('{"fileType": "Other"}', "not a QGroundControl plan"),
        ('{"fileType": "Plan"}', "mission missing"),
        (_plan([{"type": "ComplexItem", "complexItemType": "survey"}]), "only SimpleItem"),
        (_plan([{"type": "SimpleItem", "params": [0] * 6}]), "list of 7"),
        (_plan([{"type": "SimpleItem", "params": [0] * 7}]), "missing field"),
    ],
)
def test_bad_plan(text: str, why: str) -> None:
    with pytest.raises(MissionFileError, match=why):
        parse_plan(text, "x.plan")


def test_unknown_extension(tmp_path: Path) -> None:
    with pytest.raises(MissionFileError, match="unknown mission file extension"):
        read_mission(tmp_path / "m.kml")


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MissionFileError, match=r"m\.plan"):
        read_mission(tmp_path / "m.plan")
