"""QGroundControl ``.plan`` files for ``auv-gcs`` (groundstation/mission_files.py): read as the vehicle reads
the items, every unsupported part refused in one line naming the file and the place, written with the keys
QGC requires, and the round trips plan / WPL / YAML."""

from __future__ import annotations

import copy
import json
import math
from dataclasses import astuple
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mission_items as enc
from groundstation import __main__ as gcs
from groundstation import mission_files as mf
from groundstation.mavclient import Item
from onboard.adapters.mavlink.mission_protocol import (
    TYPE_FENCE,
    TYPE_MISSION,
    MissionItem,
    MissionLimits,
    check_item,
    goal_items,
    is_home_item,
    item_position,
)

EXAMPLE = Path(__file__).parents[2] / "data" / "qgc_example.plan"
WAYPOINT = mavlink.MAV_CMD_NAV_WAYPOINT
EXCLUSION = mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT
SUFFIX = {"plan": ".plan", "wpl": ".waypoints", "yaml": ".yaml"}
SETTINGS = settings(
    max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


def key(items: list[Item]) -> list[tuple[str, ...]]:
    """A comparison key in which NaN equals NaN and -0.0 differs from 0.0."""
    return [tuple(repr(v) for v in astuple(it)) for it in items]


def example() -> dict[str, Any]:
    return json.loads(EXAMPLE.read_text())


def write(tmp_path: Path, data: dict[str, Any] | str, name: str = "m.plan") -> Path:
    p = tmp_path / name
    p.write_text(data if isinstance(data, str) else json.dumps(data, indent=4))
    return p


def round_trip(
    tmp_path: Path, fmt: str, goals: list[Item], fences: list[Item]
) -> tuple[list[Item], list[Item]]:
    p = tmp_path / f"m{SUFFIX[fmt]}"
    p.write_text(mf.dump(fmt, goals, fences))
    return mf.load(p)


def vehicle_item(it: Item) -> MissionItem:
    return MissionItem(**it.__dict__)


# ---- the example QGC writes ---------------------------------------------------------------------------
def test_the_qgc_example_reads_as_the_vehicle_flies_it() -> None:
    # GIVEN a plan as QGC writes it: three waypoints at altitude -2 / -3 m relative to home, one exclusion
    # circle
    goals, fences = mf.load(EXAMPLE)
    # THEN the waypoints are the mission, in the file's frame, yaw NaN (planner's choice) unless set
    assert [(g.frame, g.command, g.autocontinue) for g in goals] == [(REL, WAYPOINT, 1)] * 3
    assert [math.isnan(g.param4) for g in goals] == [True, True, False] and goals[2].param4 == 90.0
    assert [(g.x, g.y, g.z) for g in goals] == [
        (351001797, 1290400000, -2.0),
        (351001797, 1290401647, -3.0),
        (351000000, 1290401647, -2.0),
    ]
    # AND the circle is the fence item QGC uploads for it (the home position is no goal)
    assert key(fences) == key([mf.fence_circle_item(35.1000898, 129.0400878, 3.0)])
    # AND the vehicle takes every item and reads them where the file means: metres from its origin, depth
    # 2 / 3 m
    limits = MissionLimits()  # origin 35.1 N 129.04 E, altitude 0, as the example's home
    assert all(check_item(vehicle_item(g), TYPE_MISSION, limits, seq=i) == 0 for i, g in enumerate(goals))
    assert check_item(vehicle_item(fences[0]), TYPE_FENCE, limits) == 0
    at = [item_position(vehicle_item(it), limits) for it in [*goals, *fences]]
    want = [(20.0, 0.0, 2.0), (20.0, 15.0, 3.0), (0.0, 15.0, 2.0), (10.0, 8.0, -0.0)]
    for got, exp in zip(at, want, strict=True):
        assert got == pytest.approx(exp, abs=0.02)  # QGC's 7 decimals of a degree: 1 cm


def test_qgc_older_simple_item_form_with_a_coordinate_reads_the_same(tmp_path: Path) -> None:
    # GIVEN the example's first waypoint in QGC's older form (SectionTest.plan): 4 params and a coordinate
    data = example()
    item = data["mission"]["items"][0]
    item["coordinate"] = item["params"][4:]
    item["params"] = item["params"][:4]
    # THEN it is the same item
    assert key(mf.load(write(tmp_path, data))[0]) == key(mf.load(EXAMPLE)[0])


def test_a_first_waypoint_in_an_amsl_frame_gets_the_planned_home_in_front(tmp_path: Path) -> None:
    # GIVEN a plan whose first waypoint is in MAV_FRAME_GLOBAL (QGC's "absolute" altitude), which the vehicle
    # would take as its home placeholder and not fly
    data = example()
    data["mission"]["items"][0]["frame"] = mavlink.MAV_FRAME_GLOBAL
    goals, _ = mf.load(write(tmp_path, data))
    # THEN the planned home goes in front as the placeholder, and the vehicle flies all three waypoints
    assert key(goals[:1]) == key([mf.home_item(35.1, 129.04, 0.0)])
    items = tuple(vehicle_item(g) for g in goals)
    assert is_home_item(items[0], 0) and len(goal_items(items)) == 3
    assert goal_items(items)[0].frame == mavlink.MAV_FRAME_GLOBAL


# ---- refusals: one line, the file and the place --------------------------------------------------------
def _set(path: str, value: Any) -> Any:
    """A mutation of the example: set the value at a dotted path (``items.0.frame``)."""

    def mutate(data: dict[str, Any]) -> None:
        *head, last = path.split(".")
        node: Any = data
        for part in head:
            node = node[int(part)] if part.isdigit() else node[part]
        if value is _DELETE:
            del node[int(last) if last.isdigit() else last]
        else:
            node[int(last) if last.isdigit() else last] = copy.deepcopy(value)

    return mutate


_DELETE = object()
SURVEY = {"type": "ComplexItem", "complexItemType": "survey", "version": 5, "polygon": []}
POLYGON = [[35.1, 129.04], [35.1002, 129.04], [35.1002, 129.0402]]


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (
            _set("geoFence.circles.0.inclusion", True),
            "geoFence.circles[0]: an inclusion circle is not supported",
        ),
        (
            _set("geoFence.polygons", [{"inclusion": True, "polygon": POLYGON, "version": 1}]),
            "geoFence.polygons[0]: an inclusion polygon is not supported",
        ),
        (
            _set("geoFence.polygons", [{"inclusion": False, "polygon": POLYGON, "version": 1}]),
            "geoFence.polygons[0]: an exclusion polygon is not supported",
        ),
        (_set("geoFence.breachReturn", [35.1, 129.04, 0]), "geoFence.breachReturn: a fence return point"),
        (
            _set("geoFence.circles.0.circle.radius", "3"),
            "geoFence.circles[0].circle: radius must be a number",
        ),
        (_set("geoFence.circles.0.circle.center", [35.1]), "geoFence.circles[0].circle.center: expected"),
        (_set("geoFence.version", 1), "geoFence: a version 1 fence is not supported"),
        (
            _set("rallyPoints.points", [[35.1, 129.04, 0]]),
            "rallyPoints.points: rally points are not supported",
        ),
        (_set("mission.items.2", SURVEY), "mission.items[2]: ComplexItem 'survey' is not supported"),
        (_set("mission.items.0.type", "Waypoint"), "mission.items[0]: unknown item type 'Waypoint'"),
        (
            _set("mission.items.0.command", mavlink.MAV_CMD_NAV_TAKEOFF),
            "mission.items[0]: command 22 (MAV_CMD_NAV_TAKEOFF) is not supported",
        ),
        (
            _set("mission.items.1.command", mavlink.MAV_CMD_DO_CHANGE_SPEED),
            "mission.items[1]: command 178 (MAV_CMD_DO_CHANGE_SPEED) is not supported",
        ),
        (
            _set("mission.items.2.command", mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION),
            "mission.items[2]: command 5003 (MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION) is not supported",
        ),
        (
            _set("mission.items.2.frame", mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT),
            "mission.items[2]: frame 10 (MAV_FRAME_GLOBAL_TERRAIN_ALT) is not supported",
        ),
        (
            _set("mission.items.1.params", [0, 0, 0, None, 35.1, 129.04]),
            "items[1]: params must hold 7 values",
        ),
        (_set("mission.items.1.params.4", None), "items[1]: params[4] (latitude) must be a number"),
        (_set("mission.items.1.params.0", "0"), "items[1]: params[0] must be a number or null"),
        (_set("mission.items.0.autoContinue", _DELETE), "mission.items[0]: missing 'autoContinue'"),
        (_set("mission.items.0.autoContinue", 1), "mission.items[0]: autoContinue must be true or false"),
        (_set("mission.items.0", [1, 2]), "mission.items[0]: expected an object"),
        (_set("mission.plannedHomePosition", _DELETE), "mission: missing 'plannedHomePosition'"),
        (
            _set("mission.plannedHomePosition", [35.1, 129.04]),
            "mission.plannedHomePosition: expected [lat, lon",
        ),
        (_set("mission.plannedHomePosition", [95.0, 129.04, 0]), "mission.plannedHomePosition: latitude"),
        (_set("mission.firmwareType", _DELETE), "mission: missing 'firmwareType'"),
        (_set("mission.items", {}), "mission: items must be an array"),
        (_set("mission.version", 1), "mission: version 1 is not supported"),
        (_set("mission", _DELETE), "missing 'mission'"),
        (_set("version", 2), "version 2 is not supported"),
        (_set("fileType", "GeoFence"), 'fileType is "GeoFence", not "Plan"'),
    ],
)
def test_what_the_vehicle_cannot_take_is_refused_in_one_line(tmp_path: Path, mutate: Any, match: str) -> None:
    data = example()
    mutate(data)
    p = write(tmp_path, data)
    with pytest.raises(mf.MissionFileError) as err:
        mf.load(p)
    assert match in str(err.value)
    assert str(err.value).startswith(f"{p}: ") and "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("goals: []\n", "not valid JSON (line 1, column 1: Expecting value)"),
        ('{"fileType": "Plan", "version": 1,\n  "mission": {', "not valid JSON (line 2, column"),
        ('{"fileType": "Plan", "version": Infinity}', "not valid JSON (Infinity is not a number"),
        ("[1, 2]", "expected a JSON object"),
    ],
)
def test_a_plan_file_that_is_no_json_plan(tmp_path: Path, text: str, match: str) -> None:
    p = write(tmp_path, text)
    with pytest.raises(mf.MissionFileError) as err:
        mf.load(p)
    assert match in str(err.value)
    assert str(err.value).startswith(f"{p}: ") and "\n" not in str(err.value)


DEEP = "[" * 100_000 + "]" * 100_000  # 100000 nested lists: past Python's recursion limit


@pytest.mark.parametrize(
    ("name", "text"),
    [
        ("deep.plan", DEEP),  # a .plan file: the plan reader
        ("deep.json", '{"fileType": "Plan", "mission": ' + DEEP + "}"),  # JSON told a plan by its content
        ("deep.yaml", DEEP),  # YAML (a flow sequence)
    ],
)
def test_a_file_nested_too_deep_is_one_line_not_a_traceback(tmp_path: Path, name: str, text: str) -> None:
    # GIVEN a file of 100000 nested lists
    p = write(tmp_path, text, name)
    # WHEN it is read
    with pytest.raises(mf.MissionFileError) as err:
        mf.load(p)
    # THEN one line names the file and says why (no RecursionError escapes)
    assert "nested too deep" in str(err.value)
    assert str(err.value).startswith(f"{p}: ") and "\n" not in str(err.value)


def test_upload_of_a_plan_nested_too_deep_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    p = write(tmp_path, DEEP, "deep.plan")
    assert gcs.main(["--json", "--tlog-dir", str(tmp_path), "upload", str(p)]) == 2
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 and not json.loads(lines[0])["ok"] and "nested too deep" in lines[0]


WPL_HOME = "0\t1\t0\t16\t0\t0\t0\t0\t35.1\t129.04\t0\t1"


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("1\t0\t1\t16\t0\t0\t0\t0\t1e300\t0\t1\t1", ":3: x = 1e+300 does not fit MISSION_ITEM_INT"),
        ("1\t0\t1\t16\t0\t0\t0\t0\t0\t-214748.3649\t1\t1", ":3: y = -214748.3649 does not fit"),
        ("1\t0\t3\t16\t0\t0\t0\t0\t1e300\t129\t-2\t1", ":3: x (latitude) = 1e+300 does not fit"),
        ("1\t0\t3\t16\t0\t0\t0\t0\t35\t215\t-2\t1", ":3: y (longitude) = 215.0 does not fit"),
        ("1\t0\t1\t16\t0\t0\t0\t0\tinf\t0\t1\t1", ":3: x must be a number, got Infinity"),
        ("1\t0\t1\t16\t0\t0\t0\t0\t0\tnan\t1\t1", ":3: y must be a number, got NaN"),
    ],
)
def test_a_wpl_position_that_does_not_fit_an_int32_is_refused_with_its_line(
    tmp_path: Path, line: str, match: str
) -> None:
    # GIVEN a WPL file whose item's x or y, scaled (1e4 local, 1e7 global), is no int32 (the upload would
    # die packing it)
    p = write(tmp_path, f"QGC WPL 110\n{WPL_HOME}\n{line}\n", "m.waypoints")
    # THEN the same check as the plan reader's refuses it, naming the file and the line
    with pytest.raises(mf.MissionFileError) as err:
        mf.load(p)
    assert str(err.value).startswith(f"{p}:3: ") and match in str(err.value)


def test_a_wpl_position_at_the_int32_limits_reads(tmp_path: Path) -> None:
    line = "1\t0\t1\t16\t0\t0\t0\t0\t214748.3647\t-214748.3648\t1\t1"
    goals, _ = mf.load(write(tmp_path, f"QGC WPL 110\n{WPL_HOME}\n{line}\n", "m.waypoints"))
    assert [(g.x, g.y) for g in goals] == [(enc.INT32_MAX, -enc.INT32_MAX - 1)]


def test_the_format_is_told_by_content(tmp_path: Path) -> None:
    # GIVEN a plan under another name, a JSON file of another kind, and a YAML flow mapping
    plan = write(tmp_path, EXAMPLE.read_text(), "from-qgc.json")
    other = write(tmp_path, '{"fileType": "Mission", "version": 2}', "old.json")
    flow = write(tmp_path, "{goals: [{x_m: 1, y_m: 0, depth_m: 2}]}\n", "m.yaml")
    # THEN the plan reads as one, the other JSON is a wrong fileType, and the YAML stays YAML
    assert key(mf.load(plan)[0]) == key(mf.load(EXAMPLE)[0])
    with pytest.raises(mf.MissionFileError, match='fileType is "Mission", not "Plan"'):
        mf.load(other)
    assert key(mf.load(flow)[0]) == key([mf.goal_item(1.0, 0.0, 2.0, None)])


# ---- writing -------------------------------------------------------------------------------------------
def test_a_written_plan_has_every_key_qgc_requires() -> None:
    # GIVEN a downloaded plan: local goals and obstacle, and a global goal and exclusion circle
    goals = [
        mf.goal_item(20.0, 5.0, 2.0, 90.0),
        Item(REL, WAYPOINT, 0.0, 0.0, 0.0, math.nan, 351e6, 1290e6, -3.0),
    ]
    fences = [mf.obstacle_item(10.0, 2.0, 3.0), mf.fence_circle_item(35.1001, 129.0401, 2.5)]
    plan = json.loads(mf.to_plan(goals, fences))
    # THEN the keys QGC validates (MissionController::_loadJsonMissionFileV2, MissionItem::load,
    # GeoFenceController::load, QGCFenceCircle::loadFromJson) are there with their JSON types
    assert (plan["fileType"], plan["version"], plan["mission"]["version"]) == ("Plan", 1, 2)
    mission = plan["mission"]
    assert isinstance(mission["firmwareType"], int) and isinstance(mission["items"], list)
    assert len(mission["plannedHomePosition"]) == 3
    assert mission["vehicleType"] == mavlink.MAV_TYPE_SUBMARINE
    for n, item in enumerate(mission["items"], start=1):
        assert item["type"] == "SimpleItem" and item["doJumpId"] == n
        assert isinstance(item["frame"], int) and isinstance(item["command"], int)
        assert isinstance(item["autoContinue"], bool) and len(item["params"]) == 7
    assert mission["items"][1]["params"][3] is None  # NaN is null (a free yaw)
    assert mission["items"][0]["params"][1] == 0.0  # param2, the acceptance radius: 0 = the vehicle's default
    # AND the local obstacle is a SimpleItem (a QGC circle is lat/lon only), the QGC circle a circle
    assert [(i["command"], i["frame"]) for i in mission["items"]] == [(16, 1), (16, REL), (EXCLUSION, 1)]
    fence = plan["geoFence"]
    assert fence["version"] == 2 and fence["polygons"] == []
    assert fence["circles"] == [
        {"circle": {"center": [35.1001, 129.0401], "radius": 2.5}, "inclusion": False, "version": 1}
    ]
    assert plan["rallyPoints"] == {"points": [], "version": 2}


HOME_ITEM = mf.home_item(35.2, 129.1, 3.5)
GLOBAL_GOAL = Item(REL, WAYPOINT, 0.0, 0.0, 0.0, math.nan, 351000000, 1290400000, -2.0)


@pytest.mark.parametrize(
    ("goals", "fences", "home", "planned"),
    [
        ([GLOBAL_GOAL], [], (36.0, 128.0, 12.0), [36.0, 128.0, 12.0]),  # the vehicle's home, given
        ([HOME_ITEM, GLOBAL_GOAL], [], None, [35.2, 129.1, 3.5]),  # the vehicle's home placeholder
        ([mf.goal_item(1.0, 2.0, 3.0, None), GLOBAL_GOAL], [], None, [35.1, 129.04, 0.0]),  # the first global
        ([], [mf.fence_circle_item(35.3, 129.2, 2.0)], None, [35.3, 129.2, 0.0]),  # a fence item counts too
        ([mf.goal_item(1.0, 2.0, 3.0, None)], [], None, [0.0, 0.0, 0.0]),  # local only: unknown
    ],
)
def test_the_planned_home_position(
    goals: list[Item], fences: list[Item], home: Any, planned: list[float]
) -> None:
    mission = json.loads(mf.to_plan(goals, fences, home))["mission"]
    assert mission["plannedHomePosition"] == planned
    assert len(mission["items"]) == len(goals) - (HOME_ITEM in goals[:1])  # the placeholder is no goal


@pytest.mark.parametrize(
    ("path", "fmt"),
    [
        (None, "yaml"),
        (Path("m.plan"), "plan"),
        (Path("M.PLAN"), "plan"),
        (Path("m.waypoints"), "wpl"),
        (Path("m.txt"), "wpl"),
        (Path("m.yaml"), "yaml"),
        (Path("m.yml"), "yaml"),
        (Path("m.mission"), "yaml"),
    ],
)
def test_the_format_of_a_file_name(path: Path | None, fmt: str) -> None:
    assert mf.format_for(path) == fmt


def test_an_unknown_format_is_an_error() -> None:
    with pytest.raises(ValueError, match="unknown mission file format 'kml'"):
        mf.dump("kml", [], [])


class _Plans:
    """What a download returns (the mission and the fence plan), for the download sub-command's handler."""

    def __init__(self, goals: list[Item], fences: list[Item]) -> None:
        self.plans = {mavlink.MAV_MISSION_TYPE_MISSION: goals, mavlink.MAV_MISSION_TYPE_FENCE: fences}
        self.mission = self  # the client's mission client (groundstation.mission_client)

    def download(self, mission_type: int) -> list[Item]:
        return self.plans[mission_type]


@pytest.mark.parametrize(
    ("name", "option", "fmt"),
    [
        ("m.plan", [], "plan"),
        ("m.waypoints", [], "wpl"),
        ("m.yaml", [], "yaml"),
        ("m.plan", ["--format", "wpl"], "wpl"),
    ],
)
def test_download_writes_the_format_of_its_file_or_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, option: list[str], fmt: str
) -> None:
    goals, fences = mf.load(EXAMPLE)
    target = tmp_path / name
    args = gcs._parser().parse_args(["--json", "download", str(target), *option])
    assert gcs._run(args, _Plans(goals, fences), gcs._Out(True), [], [], tmp_path / "t.tlog") == 0  # type: ignore[arg-type]
    out = json.loads(capsys.readouterr().out)
    assert (out["format"], out["goals"], out["obstacles"]) == (fmt, 3, 1)
    assert target.read_text() == mf.dump(fmt, goals, fences)
    if fmt != "yaml":  # YAML holds local items only; the example is global
        assert key(mf.load(target)[0]) == key(goals) and key(mf.load(target)[1]) == key(fences)


def test_download_to_stdout_prints_the_file_text_as_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    goals, fences = mf.load(EXAMPLE)
    args = gcs._parser().parse_args(["download", "--format", "plan"])
    assert gcs._run(args, _Plans(goals, fences), gcs._Out(False), [], [], tmp_path / "t.tlog") == 0  # type: ignore[arg-type]
    assert capsys.readouterr().out == mf.to_plan(goals, fences)  # no wrapping or markup


def test_download_refuses_an_unknown_format() -> None:
    with pytest.raises(SystemExit):
        gcs._parser().parse_args(["download", "m.plan", "--format", "kml"])


# ---- round trips ---------------------------------------------------------------------------------------
finite = st.floats(allow_nan=False, allow_infinity=False, width=32)  # MAVLink's float fields
param = st.one_of(st.just(math.nan), finite)
lat_e7 = st.integers(-900_000_000, 900_000_000)
lon_e7 = st.integers(-1_800_000_000, 1_800_000_000)
local_e4 = st.integers(-(2**31), 2**31 - 1)
micro = st.integers(-100_000_000, 100_000_000).map(lambda n: n / 1e6)  # what YAML's 6 decimals keep


@st.composite
def raw_item(draw: st.DrawFn, command: int, frames: tuple[int, ...] = mf.VEHICLE_FRAMES) -> Item:
    frame = draw(st.sampled_from(frames))
    xy = (local_e4, local_e4) if frame == mavlink.MAV_FRAME_LOCAL_NED else (lat_e7, lon_e7)
    p1, p2, p3, p4, z = (draw(param) for _ in range(5))
    return Item(frame, command, p1, p2, p3, p4, draw(xy[0]), draw(xy[1]), z, draw(st.integers(0, 1)))


qgc_circle = st.builds(lambda x, y, r: mf.fence_circle_item(x / 1e7, y / 1e7, r), lat_e7, lon_e7, finite)
raw_goals = st.lists(raw_item(WAYPOINT), max_size=6).filter(lambda g: not mf.is_home_placeholder(g))
raw_fences = st.lists(st.one_of(raw_item(EXCLUSION), qgc_circle), max_size=5)
local_goals = st.lists(
    st.builds(
        lambda x, y, d, yaw: mf.goal_item(x / 1e4, y / 1e4, d, yaw),
        local_e4,
        local_e4,
        micro,
        st.one_of(st.none(), micro.map(lambda v: v % 360.0 - 180.0).map(lambda v: round(v, 6))),
    ),
    max_size=6,
)
local_fences = st.lists(
    st.builds(lambda x, y, r: mf.obstacle_item(x / 1e4, y / 1e4, r), local_e4, local_e4, finite), max_size=4
)


@SETTINGS
@given(goals=local_goals, fences=local_fences, fmt=st.sampled_from(mf.FORMATS))
def test_local_missions_read_back_the_same_in_every_format(
    tmp_path: Path, goals: list[Item], fences: list[Item], fmt: str
) -> None:
    got_goals, got_fences = round_trip(tmp_path, fmt, goals, fences)
    assert key(got_goals) == key(goals) and key(got_fences) == key(fences)
    assert (got_goals, got_fences) == (goals, fences)  # NaN is one object: == holds too


@SETTINGS
@given(goals=raw_goals, fences=raw_fences, fmt=st.sampled_from(("plan", "wpl")))
def test_any_frame_params_and_nan_read_back_the_same_in_plan_and_wpl(
    tmp_path: Path, goals: list[Item], fences: list[Item], fmt: str
) -> None:
    got_goals, got_fences = round_trip(tmp_path, fmt, goals, fences)
    assert key(got_goals) == key(goals) and key(got_fences) == key(fences)


@SETTINGS
@given(
    home=st.builds(lambda x, y, z: mf.home_item(x / 1e7, y / 1e7, z), lat_e7, lon_e7, finite),
    first=raw_item(WAYPOINT, enc.AMSL_FRAMES),
    rest=st.lists(raw_item(WAYPOINT), max_size=3),
    fmt=st.sampled_from(("plan", "wpl")),
)
def test_a_home_placeholder_before_an_amsl_waypoint_reads_back(
    tmp_path: Path, home: Item, first: Item, rest: list[Item], fmt: str
) -> None:
    # GIVEN the vehicle's home placeholder before a waypoint it would otherwise take as its home
    goals = [home, first, *rest]
    # THEN the file keeps it as its home, and it comes back in front of the goals
    assert key(round_trip(tmp_path, fmt, goals, [])[0]) == key(goals)


@SETTINGS
@given(
    home=raw_item(WAYPOINT, (mavlink.MAV_FRAME_GLOBAL,)).filter(lambda it: math.isfinite(it.z)),
    rest=st.lists(raw_item(WAYPOINT, (mavlink.MAV_FRAME_LOCAL_NED, *enc.RELATIVE_FRAMES)), max_size=3),
    fmt=st.sampled_from(("plan", "wpl")),
)
def test_a_home_placeholder_the_goals_do_not_need_is_the_files_home_only(
    tmp_path: Path, home: Item, rest: list[Item], fmt: str
) -> None:
    # GIVEN the vehicle's home placeholder before goals in a local or relative frame
    got = round_trip(tmp_path, fmt, [home, *rest], [])[0]
    # THEN the goals read back, and the placeholder (never flown) stays the file's home
    assert key(got) == key(rest)


# ---- the vehicle's projection --------------------------------------------------------------------------
ORIGIN = mf.Origin(35.1, 129.04, 12.0)


@pytest.mark.parametrize(
    ("lat_deg", "lon_deg", "origin", "want"),
    [
        (35.101, 129.04, ORIGIN, (111.31949079327357, 0.0)),  # 0.001 deg north = radians(0.001) * R
        (35.1, 129.041, ORIGIN, (0.0, 91.07600993641427)),  # 0.001 deg east, times cos(35.1 deg)
        (35.0995, 129.0395, ORIGIN, (-55.65974539663679, -45.538004968207135)),
        (0.0, -179.999, mf.Origin(0.0, 179.999, 0.0), (0.0, 222.63898158654715)),  # across the date line
    ],
)
def test_global_to_local_is_the_flat_earth_projection_about_the_origin(
    lat_deg: float, lon_deg: float, origin: mf.Origin, want: tuple[float, float]
) -> None:
    assert enc.global_to_local(lat_deg, lon_deg, origin) == pytest.approx(want, abs=1e-6)


@SETTINGS
@given(
    item=st.one_of(raw_item(WAYPOINT), raw_item(EXCLUSION)),
    origin=st.builds(mf.Origin, st.floats(-80, 80), st.floats(-180, 180), st.floats(-100, 100)),
)
def test_local_ned_of_an_item_is_where_the_vehicle_takes_it(item: Item, origin: mf.Origin) -> None:
    # GIVEN an item in any frame the vehicle takes, and the vehicle's origin
    limits = MissionLimits(origin_lat_deg=origin.lat_deg, origin_lon_deg=origin.lon_deg,
                           origin_alt_m=origin.alt_m)  # fmt: skip
    got = mf.local_ned(item, origin)
    # THEN the ground station puts it where the vehicle does (onboard item_position)
    want = item_position(vehicle_item(item), limits)
    assert got is not None and got == pytest.approx(want, abs=1e-9, nan_ok=True)
    # AND without the origin a global item has no place
    assert (mf.local_ned(item, None) is None) is (item.frame != mavlink.MAV_FRAME_LOCAL_NED)


@pytest.mark.parametrize("suffix", [".plan", ".waypoints", ".yaml"])
def test_a_number_beyond_float32_is_refused_with_the_place(tmp_path: Path, suffix: str) -> None:
    g = [mf.goal_item(10.0, 0.0, 1.0, 1e300)]  # yaw 1e300: MAVLink's float32 cannot carry it
    p = tmp_path / f"m{suffix}"
    p.write_text(mf.dump(mf.format_for(p), g, []), encoding="utf-8")
    with pytest.raises(mf.MissionFileError, match=r"goal 0: param4 = 1e\+300 does not fit MAVLink's float32"):
        mf.load(p)


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("{x_m: .inf, y_m: 0, depth_m: 1}", "goals[0]: x must be a number, got inf"),
        ("{x_m: 0, y_m: .nan, depth_m: 1}", "goals[0]: y must be a number, got nan"),
        ("{x_m: 300000, y_m: 0, depth_m: 1}", "goals[0]: x = 300000.0 does not fit MISSION_ITEM_INT"),
        ("{x_m: 1" + "0" * 400 + ", y_m: 0, depth_m: 1}", "goals[0].x_m: 1" + "0" * 400 + " is too large"),
    ],
)
def test_a_yaml_position_no_mission_item_carries_is_one_line_not_a_traceback(
    tmp_path: Path, line: str, match: str
) -> None:
    # GIVEN a YAML goal whose x or y MISSION_ITEM_INT cannot carry (the shared encoding's rule)
    p = tmp_path / "m.yaml"
    p.write_text(f"goals:\n  - {line}\n")
    # THEN loading it is a MissionFileError naming the file and the goal (it was an OverflowError)
    with pytest.raises(mf.MissionFileError) as err:
        mf.load(p)
    assert str(err.value) == f"{p}: {match}"
