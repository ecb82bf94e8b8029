"""QGroundControl .plan writer/reader; mission.io dispatch and atomic writes (fileio).

``qgc_loader_errors`` and ``mavsdk_parser_errors`` restate, from the reference (§5.6), what
QGroundControl's and MAVSDK's loaders require; every file we write must pass both, and every
file QGC rejects must be rejected by our reader too.
"""

from __future__ import annotations

import copy
import json
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers.mavsdk_offline import mavsdk_mission_raw
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uavplan import fileio
from uavplan.errors import EXIT_INPUT, MissionFileError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.builder import build_mission
from uavplan.mission.io import FORMATS, format_for, load_mission, save_mission
from uavplan.mission.items import (
    Autopilot,
    FenceCircle,
    FencePolygon,
    GeoFence,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
    RallyPoint,
    items_equal,
)
from uavplan.mission.qgc_plan import plan_from_json, plan_to_dict, plan_to_json

# =============================================================================================
# Loader rules (reference §5.6), restated independently of the reader under test


def _is_num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _coord_ok(v: Any, n: int) -> bool:
    return isinstance(v, list) and len(v) == n and all(_is_num(x) or x is None for x in v)


def qgc_loader_errors(doc: Any) -> list[str]:
    """What QGroundControl's PlanMasterController / MissionController / MissionItem /
    GeoFenceController / RallyPointController refuse (empty list: QGC loads it)."""
    errors: list[str] = []
    if not isinstance(doc, dict):
        return ["top level is not an object"]
    if doc.get("fileType") != "Plan":
        errors.append("fileType")
    if not _is_num(doc.get("version")) or doc["version"] != 1:
        errors.append("version")
    if not isinstance(doc.get("groundStation"), str):
        errors.append("groundStation")
    for key in ("mission", "geoFence", "rallyPoints"):
        if not isinstance(doc.get(key), dict):
            errors.append(key)
    if errors:
        return errors

    mission = doc["mission"]
    if not _coord_ok(mission.get("plannedHomePosition"), 3):
        errors.append("mission.plannedHomePosition")
    if not _is_num(mission.get("firmwareType")):
        errors.append("mission.firmwareType")
    items = mission.get("items")
    if not isinstance(items, list):
        return [*errors, "mission.items"]
    jump_ids = {it.get("doJumpId") for it in items if isinstance(it, dict)}
    for i, item in enumerate(items):
        where = f"mission.items[{i}]"
        if not isinstance(item, dict) or item.get("type") not in ("SimpleItem", "ComplexItem"):
            errors.append(f"{where}.type")
            continue
        if item["type"] == "ComplexItem":
            continue
        for key in ("command", "frame"):
            if not _is_num(item.get(key)):
                errors.append(f"{where}.{key}")
        params = item.get("params")
        if not isinstance(params, list) or len(params) != 7:
            errors.append(f"{where}.params")
        elif not all(_is_num(p) or p is None for p in params):
            errors.append(f"{where}.params[]")
        if not isinstance(item.get("autoContinue"), bool):
            errors.append(f"{where}.autoContinue")
        altitude_keys = [k in item for k in ("AltitudeMode", "Altitude", "AMSLAltAboveTerrain")]
        if any(altitude_keys) and not all(altitude_keys):
            errors.append(f"{where}.Altitude*")
        if item.get("command") == 177 and isinstance(params, list) and params:
            if params[0] not in jump_ids:
                errors.append(f"{where}: could not find doJumpId")

    fence = doc["geoFence"]
    if fence.get("version") not in (None, 1):
        if fence.get("version") != 2:
            errors.append("geoFence.version")
        for i, poly in enumerate(fence.get("polygons", None) or []):
            if not (
                isinstance(poly, dict)
                and poly.get("version") == 1
                and isinstance(poly.get("inclusion"), bool)
                and isinstance(poly.get("polygon"), list)
                and all(_coord_ok(v, 2) for v in poly["polygon"])
            ):
                errors.append(f"geoFence.polygons[{i}]")
        for i, circ in enumerate(fence.get("circles", None) or []):
            shape = circ.get("circle") if isinstance(circ, dict) else None
            if not (
                isinstance(shape, dict)
                and circ.get("version") == 1
                and isinstance(circ.get("inclusion"), bool)
                and _coord_ok(shape.get("center"), 2)
                and _is_num(shape.get("radius"))
            ):
                errors.append(f"geoFence.circles[{i}]")
        for key in ("polygons", "circles"):
            if not isinstance(fence.get(key), list):
                errors.append(f"geoFence.{key}")
        if "breachReturn" in fence and not _coord_ok(fence["breachReturn"], 3):
            errors.append("geoFence.breachReturn")
    rally = doc["rallyPoints"]
    if rally.get("version") not in (None, 1):
        if rally.get("version") != 2:
            errors.append("rallyPoints.version")
        points = rally.get("points")
        if not isinstance(points, list) or not all(_coord_ok(p, 3) for p in points):
            errors.append("rallyPoints.points")
    return errors


def mavsdk_parser_errors(doc: dict[str, Any]) -> list[str]:
    """What MAVSDK's MissionImport::parse_json refuses (stricter about versions and the
    fence/rally objects, looser about item fields)."""
    errors: list[str] = []
    if not (isinstance(doc.get("version"), int) and doc["version"] == 1):
        errors.append("version")
    mission = doc.get("mission")
    if not (isinstance(mission, dict) and isinstance(mission.get("version"), int)):
        return [*errors, "mission.version"]
    if mission["version"] != 2:
        errors.append("mission.version")
    for key in ("geoFence", "rallyPoints"):
        obj = doc.get(key)
        if not (isinstance(obj, dict) and obj and obj.get("version") == 2):
            errors.append(key)
        elif isinstance(obj.get("version"), bool) or not isinstance(obj["version"], int):
            errors.append(f"{key}.version")
    home = mission.get("plannedHomePosition")
    if not (isinstance(home, list) and len(home) == 3):
        errors.append("mission.plannedHomePosition")
    for i, item in enumerate(mission.get("items", [])):
        if item.get("type") == "SimpleItem":
            if not all(k in item for k in ("command", "autoContinue", "frame")):
                errors.append(f"mission.items[{i}]")
            if not item.get("params"):
                errors.append(f"mission.items[{i}].params")
    return errors


# =============================================================================================
# Strategies

lats = st.floats(-90.0, 90.0)
lons = st.floats(-180.0, 180.0)
alts = st.floats(-500.0, 10_000.0)
params = st.one_of(st.none(), st.floats(-1e7, 1e7))
geo_points = st.builds(GeoPoint, lats, lons, alts)
homes = st.one_of(st.none(), geo_points.filter(lambda g: (g.lat_deg, g.lon_deg) != (0.0, 0.0)))

positional_items = st.builds(
    MissionItem,
    command=st.sampled_from([16, 17, 19, 21, 22, 31, 82, 201]),
    frame=st.sampled_from(
        [MavFrame.GLOBAL, MavFrame.GLOBAL_RELATIVE_ALT, MavFrame.GLOBAL_TERRAIN_ALT]
    ),
    param1=params,
    param2=params,
    param3=params,
    param4=params,
    x=lats,
    y=lons,
    z=alts,
    autocontinue=st.booleans(),
)
command_items = st.builds(
    MissionItem,
    command=st.sampled_from([20, 112, 178, 183, 206, 2000, 3000]),
    frame=st.just(MavFrame.MISSION),
    param1=params,
    param2=params,
    param3=params,
    param4=params,
    x=st.integers(-1000, 1000).map(float),
    y=st.integers(-1000, 1000).map(float),
    z=st.floats(-1e4, 1e4),
    autocontinue=st.booleans(),
)
polygons = st.builds(
    FencePolygon, st.lists(st.tuples(lats, lons), min_size=3, max_size=6).map(tuple), st.booleans()
)
circles = st.builds(FenceCircle, st.tuples(lats, lons), st.floats(0.5, 1e5), st.booleans())
fences = st.builds(
    GeoFence,
    st.lists(polygons, max_size=3).map(tuple),
    st.lists(circles, max_size=3).map(tuple),
    st.one_of(st.none(), geo_points),
)
rallies = st.lists(st.builds(RallyPoint, lats, lons, alts), max_size=4).map(tuple)


def _slots(autopilot: Autopilot) -> int:
    return 1 if autopilot == Autopilot.ARDUPILOT else 0


@st.composite
def plans(draw: st.DrawFn, *, jumps: bool = True) -> MissionPlan:
    autopilot = draw(st.sampled_from([Autopilot.PX4, Autopilot.ARDUPILOT]))
    items = draw(st.lists(st.one_of(positional_items, command_items), max_size=8))
    if jumps and draw(st.booleans()):
        at = draw(st.integers(0, len(items)))
        target = draw(st.integers(0, len(items)))  # an index in the final list
        jump = MissionItem(
            command=MavCmd.DO_JUMP,
            frame=MavFrame.MISSION,
            param1=float(target + _slots(autopilot)),
            param2=float(draw(st.integers(-1, 20))),
        )
        items.insert(at, jump)
    return MissionPlan(
        items=tuple(items),
        autopilot=autopilot,
        home=draw(homes),
        fence=draw(fences),
        rally=draw(rallies),
        vehicle_type=draw(st.sampled_from([1, 2, 13, 14, 20, 22])),
        cruise_speed_m_s=draw(st.floats(0.5, 50.0)),
        hover_speed_m_s=draw(st.floats(0.5, 20.0)),
    )


ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)
PATH = np.array([[0.0, 0.0, 30.0], [400.0, -80.0, 60.0], [2000.0, 150.0, 40.0]])


def sample_plan(autopilot: Autopilot = Autopilot.PX4) -> MissionPlan:
    base = build_mission(
        PATH, EnuFrame.at(ORIGIN), autopilot=autopilot, cruise_speed_m_s=12.0, takeoff_altitude_m=20
    )
    fence = GeoFence(
        polygons=(
            FencePolygon(((47.39, 8.54), (47.40, 8.54), (47.40, 8.58), (47.39, 8.58)), True),
            FencePolygon(((47.395, 8.55), (47.396, 8.55), (47.396, 8.551)), False),
        ),
        circles=(
            FenceCircle((47.3975, 8.56), 35.0, False),
            FenceCircle((47.3975, 8.56), 3000.0, True),
        ),
        breach_return=GeoPoint(47.3978, 8.5457, 30.0),
    )
    rally = (RallyPoint(47.398, 8.546, 25.0), RallyPoint(47.399, 8.57, 40.0))
    return MissionPlan(
        items=base.items,
        autopilot=autopilot,
        home=base.home,
        fence=fence,
        rally=rally,
        vehicle_type=base.vehicle_type,
        cruise_speed_m_s=base.cruise_speed_m_s,
        hover_speed_m_s=base.hover_speed_m_s,
    )


def strict_json(text: str) -> Any:
    """json.loads that refuses NaN/Infinity literals (which are not JSON)."""

    def refuse(name: str) -> None:
        raise AssertionError(f"{name} literal in the file")

    return json.loads(text, parse_constant=refuse)


# =============================================================================================
# Writer: checklist §5.7


def test_writer_checklist() -> None:
    plan = sample_plan(Autopilot.ARDUPILOT)
    doc = strict_json(plan_to_json(plan))
    assert set(doc) == {
        "fileType",
        "version",
        "groundStation",
        "mission",
        "geoFence",
        "rallyPoints",
    }
    assert (doc["fileType"], doc["version"]) == ("Plan", 1)
    assert isinstance(doc["groundStation"], str)
    mission = doc["mission"]
    assert mission["version"] == 2
    assert mission["firmwareType"] == 3
    assert mission["vehicleType"] == 2
    assert mission["cruiseSpeed"] == 12.0 and mission["hoverSpeed"] == 12.0
    assert mission["globalPlanAltitudeMode"] == 1
    assert plan.home is not None
    assert mission["plannedHomePosition"] == [plan.home.lat_deg, plan.home.lon_deg, plan.home.alt_m]
    assert mission["plannedHomePosition"][2] == pytest.approx(488.0)  # AMSL, not 0
    assert len(mission["items"]) == len(plan.items)  # ArduPilot's home is not an item
    for index, item in enumerate(mission["items"]):
        assert item["type"] == "SimpleItem"
        assert len(item["params"]) == 7
        assert isinstance(item["autoContinue"], bool)
        assert item["doJumpId"] == index + 1
        positional = item["frame"] != MavFrame.MISSION
        for key in ("AltitudeMode", "Altitude", "AMSLAltAboveTerrain"):
            assert (key in item) == positional
        if positional:
            assert item["AltitudeMode"] == 1 and item["Altitude"] == item["params"][6]
    takeoff = mission["items"][0]
    assert takeoff["params"][3] is None  # unset yaw: null, never NaN
    fence, rally = doc["geoFence"], doc["rallyPoints"]
    assert fence["version"] == 2 and rally["version"] == 2
    assert fence["polygons"][0] == {
        "inclusion": True,
        "polygon": [[47.39, 8.54], [47.40, 8.54], [47.40, 8.58], [47.39, 8.58]],
        "version": 1,
    }
    assert fence["circles"][0] == {
        "circle": {"center": [47.3975, 8.56], "radius": 35.0},
        "inclusion": False,
        "version": 1,
    }
    assert fence["breachReturn"] == [47.3978, 8.5457, 30.0]
    assert rally["points"] == [[47.398, 8.546, 25.0], [47.399, 8.57, 40.0]]
    assert qgc_loader_errors(doc) == []
    assert mavsdk_parser_errors(doc) == []


def test_empty_plan_still_has_fence_and_rally_objects() -> None:
    doc = strict_json(plan_to_json(MissionPlan(items=())))
    assert doc["geoFence"] == {"circles": [], "polygons": [], "version": 2}
    assert doc["rallyPoints"] == {"points": [], "version": 2}
    assert doc["mission"]["plannedHomePosition"] == [0.0, 0.0, 0.0]
    assert doc["mission"]["firmwareType"] == 12
    assert doc["mission"]["cruiseSpeed"] == 15.0 and doc["mission"]["hoverSpeed"] == 5.0
    assert qgc_loader_errors(doc) == [] and mavsdk_parser_errors(doc) == []
    assert plan_from_json(plan_to_json(MissionPlan(items=()))).home is None


def test_degrees_keep_full_precision() -> None:
    item = MissionItem(command=16, x=47.123456789012, y=-122.987654321098, z=12.345)
    text = plan_to_json(MissionPlan(items=(item,)))
    assert "47.123456789012" in text and "-122.987654321098" in text
    assert plan_from_json(text).items == (item,)


def test_int_frames_are_written_as_qgc_spells_them() -> None:
    items = tuple(
        MissionItem(command=16, frame=f, x=1.0, y=2.0, z=3.0)
        for f in (
            MavFrame.GLOBAL_INT,
            MavFrame.GLOBAL_RELATIVE_ALT_INT,
            MavFrame.GLOBAL_TERRAIN_ALT_INT,
        )
    )
    doc = plan_to_dict(MissionPlan(items=items))
    assert [i["frame"] for i in doc["mission"]["items"]] == [0, 3, 10]
    assert [i["AltitudeMode"] for i in doc["mission"]["items"]] == [2, 1, 4]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan=plans())
def test_every_written_plan_passes_the_qgc_and_mavsdk_loader_rules(plan: MissionPlan) -> None:
    doc = strict_json(plan_to_json(plan))
    assert qgc_loader_errors(doc) == []
    assert mavsdk_parser_errors(doc) == []


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan=plans())
def test_write_read_round_trip(plan: MissionPlan) -> None:
    assert plan_from_json(plan_to_json(plan)) == plan


# =============================================================================================
# DO_JUMP numbering


def _jump_plan(autopilot: Autopilot) -> MissionPlan:
    wp = [MissionItem(command=16, x=47.0 + i / 1000, y=8.0, z=30.0) for i in range(3)]
    # jump back to the second waypoint (items index 1) three times
    jump = MissionItem(command=177, frame=2, param1=1.0 + _slots(autopilot), param2=3.0)
    return MissionPlan(items=(*wp, jump), autopilot=autopilot)


@pytest.mark.parametrize("autopilot", [Autopilot.PX4, Autopilot.ARDUPILOT])
def test_do_jump_param1_is_the_targets_do_jump_id_in_the_file(autopilot: Autopilot) -> None:
    plan = _jump_plan(autopilot)
    jump = plan_to_dict(plan)["mission"]["items"][3]
    assert jump["params"][:2] == [2.0, 3.0]  # doJumpId 2 = the second item, for any autopilot
    assert plan_from_json(plan_to_json(plan)).items == plan.items


def test_do_jump_targets_follow_the_autopilot_override() -> None:
    text = plan_to_json(_jump_plan(Autopilot.ARDUPILOT))
    assert plan_from_json(text).items[3].param1 == 2.0  # ArduPilot seq (home = 0)
    as_px4 = plan_from_json(text, autopilot=Autopilot.PX4)
    assert as_px4.autopilot == Autopilot.PX4 and as_px4.items[3].param1 == 1.0


def test_a_jump_to_nowhere_is_not_written() -> None:
    bad = MissionPlan(items=(MissionItem(command=177, frame=2, param1=5.0, param2=1.0),))
    with pytest.raises(MissionFileError, match="DO_JUMP target"):
        plan_to_json(bad)
    home_jump = MissionPlan(
        items=(MissionItem(command=177, frame=2, param1=0.0),), autopilot=Autopilot.ARDUPILOT
    )
    with pytest.raises(MissionFileError, match="DO_JUMP target"):
        plan_to_json(home_jump)  # ArduPilot seq 0 is home, not an item


# =============================================================================================
# Reader: rejects what QGC rejects, tolerates what QGC tolerates


def _good_doc() -> dict[str, Any]:
    doc = plan_to_dict(sample_plan())
    doc["mission"]["items"].append(
        {
            "autoContinue": True,
            "command": 177,
            "doJumpId": 99,
            "frame": 2,
            "params": [2, 1, 0, 0, 0, 0, 0],
            "type": "SimpleItem",
        }
    )
    return doc


Mutation = Callable[[dict[str, Any]], None]


def _set(path: str, value: Any) -> Mutation:
    def apply(doc: dict[str, Any]) -> None:
        *parents, last = path.split("/")
        obj: Any = doc
        for part in parents:
            obj = obj[int(part)] if isinstance(obj, list) else obj[part]
        if isinstance(obj, list):
            obj[int(last)] = value
        else:
            obj[last] = value

    return apply


def _delete(path: str) -> Mutation:
    def apply(doc: dict[str, Any]) -> None:
        *parents, last = path.split("/")
        obj: Any = doc
        for part in parents:
            obj = obj[int(part)] if isinstance(obj, list) else obj[part]
        del obj[last]

    return apply


REJECTED: list[tuple[str, Mutation, str]] = [
    ("wrong fileType", _set("fileType", "Mission"), "fileType"),
    ("missing fileType", _delete("fileType"), "fileType"),
    ("version 2", _set("version", 2), "version"),
    ("version as string", _set("version", "1"), "version"),
    ("no groundStation", _delete("groundStation"), "groundStation"),
    ("groundStation not a string", _set("groundStation", 5), "groundStation"),
    ("no mission", _delete("mission"), "mission"),
    ("no geoFence", _delete("geoFence"), "geoFence"),
    ("no rallyPoints", _delete("rallyPoints"), "rallyPoints"),
    ("geoFence not an object", _set("geoFence", []), "geoFence"),
    (
        "no plannedHomePosition",
        _delete("mission/plannedHomePosition"),
        "mission.plannedHomePosition",
    ),
    (
        "home of 2 values",
        _set("mission/plannedHomePosition", [47.0, 8.0]),
        "mission.plannedHomePosition",
    ),
    (
        "home with a string",
        _set("mission/plannedHomePosition", [47, "8", 0]),
        "mission.plannedHomePosition[1]",
    ),
    ("no items", _delete("mission/items"), "mission.items"),
    ("no firmwareType", _delete("mission/firmwareType"), "mission.firmwareType"),
    ("6 params", _set("mission/items/0/params", [0, 0, 0, 0, 47, 8]), "mission.items[0].params"),
    (
        "8 params",
        _set("mission/items/0/params", [0, 0, 0, 0, 47, 8, 30, 0]),
        "mission.items[0].params",
    ),
    ("param1 a string", _set("mission/items/0/params/0", "0"), "mission.items[0].params[0]"),
    ("lat a boolean", _set("mission/items/0/params/4", True), "mission.items[0].params[4]"),
    ("autoContinue 1", _set("mission/items/0/autoContinue", 1), "mission.items[0].autoContinue"),
    ("no autoContinue", _delete("mission/items/0/autoContinue"), "mission.items[0].autoContinue"),
    ("no command", _delete("mission/items/1/command"), "mission.items[1].command"),
    ("no frame", _delete("mission/items/1/frame"), "mission.items[1].frame"),
    ("unknown item type", _set("mission/items/1/type", "missionItem"), "mission.items[1].type"),
    ("item not an object", _set("mission/items/1", [16]), "mission.items[1]"),
    (
        "only one altitude key",
        _delete("mission/items/0/AMSLAltAboveTerrain"),
        "mission.items[0].AMSLAltAboveTerrain",
    ),
    ("unresolved doJumpId", _set("mission/items/6/params/0", 42), "mission.items[6].params[0]"),
    ("fence version 3", _set("geoFence/version", 3), "geoFence.version"),
    ("fence polygons missing", _delete("geoFence/polygons"), "geoFence.polygons"),
    (
        "polygon vertex of 3 values",
        _set("geoFence/polygons/0/polygon/0", [47.39, 8.54, 0]),
        "geoFence.polygons[0].polygon[0]",
    ),
    (
        "polygon inclusion not a bool",
        _set("geoFence/polygons/0/inclusion", "yes"),
        "geoFence.polygons[0].inclusion",
    ),
    ("polygon version 2", _set("geoFence/polygons/0/version", 2), "geoFence.polygons[0].version"),
    (
        "circle without radius",
        _delete("geoFence/circles/0/circle/radius"),
        "geoFence.circles[0].circle.radius",
    ),
    (
        "breachReturn of 2 values",
        _set("geoFence/breachReturn", [47.0, 8.0]),
        "geoFence.breachReturn",
    ),
    ("rally version 3", _set("rallyPoints/version", 3), "rallyPoints.version"),
    ("rally point of 2 values", _set("rallyPoints/points/0", [47.0, 8.0]), "rallyPoints.points[0]"),
]


@pytest.mark.parametrize(("name", "mutate", "key"), REJECTED, ids=[r[0] for r in REJECTED])
def test_reader_rejects_what_qgc_rejects(name: str, mutate: Mutation, key: str) -> None:
    doc = _good_doc()
    assert qgc_loader_errors(doc) == [] and plan_from_json(json.dumps(doc))
    mutate(doc)
    assert qgc_loader_errors(doc) != [], "the checker itself must see the problem"
    with pytest.raises(MissionFileError) as info:
        plan_from_json(json.dumps(doc), file="bad.plan")
    err = info.value
    assert (err.file, err.key) == ("bad.plan", key)
    assert err.exit_code == EXIT_INPUT
    assert str(err).startswith(f"bad.plan: {key}: ")


ALTITUDE_KEYS = ("AltitudeMode", "Altitude", "AMSLAltAboveTerrain")
OPTIONAL_MISSION_KEYS = (
    "vehicleType",
    "cruiseSpeed",
    "hoverSpeed",
    "globalPlanAltitudeMode",
    "version",
)

TOLERATED: list[tuple[str, Mutation]] = [
    ("unknown keys", lambda d: d["mission"].update(extra=1, complexItems=[])),
    ("unknown item key", _set("mission/items/0/Speed", 5)),
    ("frame 6 spelling", _set("mission/items/0/frame", 6)),
    ("frame 5 spelling", _set("mission/items/0/frame", 5)),
    ("no altitude keys", lambda d: [d["mission"]["items"][0].pop(k) for k in ALTITUDE_KEYS]),
    ("null params", _set("mission/items/0/params", [None, None, None, None, 47.3, 8.5, 30])),
    ("null speeds", lambda d: d["mission"].update(cruiseSpeed=None, hoverSpeed=None)),
    ("no optional mission keys", lambda d: [d["mission"].pop(k) for k in OPTIONAL_MISSION_KEYS]),
    ("unknown fence keys", lambda d: d["geoFence"].update(fenceAction=2, maxAltitude=120)),
    ("fence version 1 is ignored", _set("geoFence/version", 1)),
    ("rally without version is ignored", _delete("rallyPoints/version")),
    ("integer numbers", _set("mission/items/0/params", [0, 0, 0, 0, 47, 8, 30])),
    ("no doJumpId on a non-target", _delete("mission/items/0/doJumpId")),
]


@pytest.mark.parametrize(("name", "mutate"), TOLERATED, ids=[t[0] for t in TOLERATED])
def test_reader_tolerates_what_qgc_tolerates(name: str, mutate: Mutation) -> None:
    doc = _good_doc()
    mutate(doc)
    assert qgc_loader_errors(doc) == []
    plan = plan_from_json(json.dumps(doc))
    assert len(plan.items) == len(doc["mission"]["items"])


def test_reader_details_of_tolerated_input() -> None:
    doc = _good_doc()
    doc["mission"]["items"][0]["frame"] = 6
    doc["mission"]["items"][0]["params"] = [None, 1, None, None, 47.3, 8.5, 30]
    doc["geoFence"]["version"] = 1
    doc["mission"]["cruiseSpeed"] = None
    plan = plan_from_json(json.dumps(doc))
    first = plan.items[0]
    assert first.frame == 6 and first.normalised().frame == 3
    assert first.params == (None, 1.0, None, None)
    assert plan.fence == GeoFence()  # QGC silently ignores a version-1 fence
    assert plan.cruise_speed_m_s is None
    assert plan.items[-1].param1 == 1.0  # doJumpId 2 → items[1] → PX4 seq 1


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("{", "invalid JSON"),
        ("", "invalid JSON"),
        ('{"fileType": NaN}', "NaN"),
        ("[1, 2]", "JSON object"),
        ('{"fileType": "Plan", "version": 1e400}', "version"),
    ],
)
def test_invalid_json(text: str, match: str) -> None:
    with pytest.raises(MissionFileError, match=match):
        plan_from_json(text, file="x.plan")


def test_complex_items_we_do_not_fly_are_rejected_clearly() -> None:
    """A StructureScan is refused; a Survey saved without its items too (a Survey with its
    items is read: tests/mission/test_qgc_survey.py)."""
    doc = _good_doc()
    doc["mission"]["items"][2] = {
        "type": "ComplexItem",
        "complexItemType": "survey",
        "version": 5,
        "TransectStyleComplexItem": {"Items": []},
    }
    assert qgc_loader_errors(doc) == []  # QGC can load it; it holds nothing to fly
    with pytest.raises(MissionFileError, match=r"the survey item holds no mission items") as info:
        plan_from_json(json.dumps(doc), file="survey.plan")
    assert info.value.key == "mission.items[2].TransectStyleComplexItem.Items"
    doc["mission"]["items"][2]["complexItemType"] = "StructureScan"
    with pytest.raises(MissionFileError, match=r"ComplexItem \(StructureScan\)") as info:
        plan_from_json(json.dumps(doc), file="scan.plan")
    assert info.value.key == "mission.items[2]"


@pytest.mark.parametrize(
    ("path", "value", "key", "match"),
    [
        ("mission/items/0/params/4", 91.0, "mission.items[0]", "latitude"),
        (
            "mission/plannedHomePosition",
            [47.0, 190.0, 0.0],
            "mission.plannedHomePosition",
            "longitude",
        ),
        (
            "geoFence/polygons/0/polygon",
            [[47.0, 8.0], [47.1, 8.0]],
            "geoFence.polygons[0]",
            "3 vertices",
        ),
        ("geoFence/circles/0/circle/radius", 0, "geoFence.circles[0]", "radius"),
        ("mission/items/0/command", 70000, "mission.items[0].command", "MAV_CMD"),
        ("mission/items/0/frame", 2.5, "mission.items[0].frame", "whole number"),
    ],
)
def test_values_our_model_cannot_hold_are_file_errors(
    path: str, value: Any, key: str, match: str
) -> None:
    doc = _good_doc()
    _set(path, value)(doc)
    with pytest.raises(MissionFileError, match=match) as info:
        plan_from_json(json.dumps(doc))
    assert info.value.key == key


def test_no_home_is_read_as_none() -> None:
    doc = _good_doc()
    doc["mission"]["plannedHomePosition"] = [None, None, None]
    assert plan_from_json(json.dumps(doc)).home is None


# =============================================================================================
# MAVSDK's importer (mavsdk 4.1 native binding) reads our files


def from_mavsdk(raw: Any) -> MissionItem:
    return MissionItem.from_wire(
        command=raw.command,
        frame=raw.frame,
        params=(raw.param1, raw.param2, raw.param3, raw.param4),
        x=raw.x,
        y=raw.y,
        z=raw.z,
        autocontinue=raw.autocontinue,
    )


def assert_same_items(got: list[MissionItem], expected: list[MissionItem]) -> None:
    assert [i.command for i in got] == [i.command for i in expected]
    for a, b in zip(got, expected, strict=True):
        assert items_equal(a, b), (a, b)


@pytest.mark.parametrize("autopilot", [Autopilot.PX4, Autopilot.ARDUPILOT])
def test_mavsdk_imports_our_plan(autopilot: Autopilot, tmp_path: Path) -> None:
    plan = sample_plan(autopilot)
    path = tmp_path / "mission.plan"
    save_mission(plan, path)
    with mavsdk_mission_raw(autopilot) as mission_raw:
        data = mission_raw.import_qgroundcontrol_mission(str(path))
    mission = [from_mavsdk(i) for i in data.mission_items]
    # MAVSDK prepends plannedHomePosition for ArduPilot, exactly as wire_items() does
    assert_same_items(mission, plan.wire_items(MissionType.MISSION))
    assert [i.seq for i in data.mission_items] == list(range(len(mission)))
    assert sum(i.current for i in data.mission_items) == 1
    # MAVSDK ignores breachReturn (reference §5.6)
    fence_without_return = GeoFence(plan.fence.polygons, plan.fence.circles)
    assert_same_items(
        [from_mavsdk(i) for i in data.geofence_items], fence_without_return.wire_items()
    )
    assert_same_items(
        [from_mavsdk(i) for i in data.rally_items], plan.wire_items(MissionType.RALLY)
    )


@pytest.mark.parametrize("autopilot", [Autopilot.PX4, Autopilot.ARDUPILOT])
def test_mavsdk_passes_do_jump_ids_through(autopilot: Autopilot) -> None:
    """MAVSDK copies the file's doJumpId into param1: right for ArduPilot (home = seq 0),
    one too high for PX4. Our own reader converts; MAVSDK-imported PX4 jumps need -1."""
    plan = _jump_plan(autopilot)
    with mavsdk_mission_raw(autopilot) as mission_raw:
        data = mission_raw.import_qgroundcontrol_mission_from_string(plan_to_json(plan))
    jump = data.mission_items[-1]
    assert jump.command == MavCmd.DO_JUMP
    assert jump.param1 == 2.0
    wire_jump = plan.wire_items()[-1].param1
    assert jump.param1 - wire_jump == (0 if autopilot == Autopilot.ARDUPILOT else 1)


def test_mavsdk_refuses_a_plan_without_fence_and_rally_which_we_always_write() -> None:
    from mavsdk.plugins.mission_raw.mission_raw import MissionRawError

    doc = plan_to_dict(sample_plan())
    with mavsdk_mission_raw(Autopilot.PX4) as mission_raw:
        mission_raw.import_qgroundcontrol_mission_from_string(json.dumps(doc))
        del doc["geoFence"]
        with pytest.raises(MissionRawError):
            mission_raw.import_qgroundcontrol_mission_from_string(json.dumps(doc))


# =============================================================================================
# mission.io dispatch and fileio atomic writes


@pytest.mark.parametrize("name", ["m.plan", "m.PLAN", "m.waypoints", "m.txt"])
def test_save_and_load_by_extension(name: str, tmp_path: Path) -> None:
    plan = sample_plan(Autopilot.ARDUPILOT)
    if not name.lower().endswith(".plan"):
        plan = MissionPlan(items=plan.items, autopilot=plan.autopilot, home=plan.home)
    path = tmp_path / name
    save_mission(plan, path)
    loaded = load_mission(path)
    assert loaded.autopilot == Autopilot.ARDUPILOT
    assert [i.command for i in loaded.items] == [i.command for i in plan.items]
    for a, b in zip(loaded.items, plan.items, strict=True):
        assert items_equal(a, b)
    assert [p.name for p in tmp_path.iterdir()] == [name]  # no temporary file left


def test_extension_decides_the_format(tmp_path: Path) -> None:
    plan = sample_plan()
    save_mission(plan, tmp_path / "a.plan")
    save_mission(MissionPlan(items=plan.items, home=plan.home), tmp_path / "a.waypoints")
    assert (tmp_path / "a.plan").read_text().startswith("{")
    assert (tmp_path / "a.waypoints").read_text().startswith("QGC WPL 110\n")
    assert format_for("x.TXT") is FORMATS[".waypoints"]


@pytest.mark.parametrize("name", ["m.json", "m.gpx", "mission"])
def test_unknown_extension_is_a_clear_error(name: str, tmp_path: Path) -> None:
    with pytest.raises(MissionFileError, match="unknown mission file type") as info:
        save_mission(sample_plan(), tmp_path / name)
    assert info.value.file == str(tmp_path / name) and ".plan" in str(info.value)
    with pytest.raises(MissionFileError, match="unknown mission file type"):
        load_mission(tmp_path / name)
    assert list(tmp_path.iterdir()) == []


def test_load_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(MissionFileError, match="cannot read") as info:
        load_mission(tmp_path / "missing.plan")
    assert info.value.file == str(tmp_path / "missing.plan")
    bad = tmp_path / "bad.plan"
    bad.write_bytes(b'{"a": "\xff"}')
    with pytest.raises(MissionFileError, match=r"not UTF-8 text: .*line 1, byte 8"):
        load_mission(bad)
    bad.write_text('{"fileType": "Plan"', encoding="utf-8")
    with pytest.raises(MissionFileError, match="invalid JSON") as info:
        load_mission(bad)
    assert str(info.value).startswith(f"{bad}: invalid JSON")


def test_load_accepts_a_byte_order_mark(tmp_path: Path) -> None:
    path = tmp_path / "bom.plan"
    path.write_bytes(b"\xef\xbb\xbf" + plan_to_json(sample_plan()).encode())
    assert load_mission(path) == sample_plan()


@pytest.mark.parametrize("codec", ["utf-16", "utf-32"])
def test_load_reads_utf16_and_utf32_with_a_byte_order_mark(tmp_path: Path, codec: str) -> None:
    path = tmp_path / "wide.plan"
    path.write_bytes(plan_to_json(sample_plan()).encode(codec))  # Python writes the BOM
    assert load_mission(path) == sample_plan()


def test_load_refuses_utf16_without_a_mark_and_cut_utf16(tmp_path: Path) -> None:
    path = tmp_path / "wide.plan"
    path.write_bytes(plan_to_json(sample_plan()).encode("utf-16-le"))
    with pytest.raises(MissionFileError, match=r"NUL characters .*UTF-16") as info:
        load_mission(path)
    assert info.value.file == str(path)
    path.write_bytes(plan_to_json(sample_plan()).encode("utf-16")[:-1])  # odd byte count
    with pytest.raises(MissionFileError, match="not UTF-16 text: truncated data"):
        load_mission(path)


def test_load_refuses_what_is_not_a_regular_file_or_too_large(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from uavplan.mission import io

    fifo = tmp_path / "pipe.plan"
    os.mkfifo(fifo)
    with pytest.raises(MissionFileError, match="not a regular file"):
        load_mission(fifo)  # does not wait for a writer
    (tmp_path / "folder.plan").mkdir()
    with pytest.raises(MissionFileError, match="not a regular file"):
        load_mission(tmp_path / "folder.plan")
    big = tmp_path / "big.plan"
    big.write_text(plan_to_json(sample_plan()), encoding="utf-8")
    monkeypatch.setattr(io, "MAX_FILE_BYTES", 100)
    with pytest.raises(MissionFileError, match="up to 0 MiB"):
        io.load_mission(big)
    with pytest.raises(MissionFileError, match="NUL byte"):
        load_mission("bad\x00name.plan")


@pytest.mark.parametrize(
    ("doc_text", "message"),
    [
        ('{"fileType": "Plan", "fileType": "Plan"}', "key 'fileType' appears twice"),
        ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
        ('{"version": ' + "9" * 5000 + "}", "invalid JSON: Exceeds the limit"),
        ('{"fileType": "' + "x" * 10_000 + '"}', "file type is 'xxxx"),
    ],
    ids=["duplicate-key", "deep-nesting", "long-integer", "long-string"],
)
def test_hostile_json_is_one_short_message(tmp_path: Path, doc_text: str, message: str) -> None:
    path = tmp_path / "hostile.plan"
    path.write_text(doc_text, encoding="utf-8")
    with pytest.raises(MissionFileError, match=message) as info:
        load_mission(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ") and "\n" not in text and len(text) < 300


def test_a_failed_save_keeps_the_old_file(tmp_path: Path) -> None:
    path = tmp_path / "m.plan"
    save_mission(sample_plan(), path)
    before = path.read_bytes()
    bad = MissionPlan(items=(MissionItem(command=177, frame=2, param1=7.0),))
    with pytest.raises(MissionFileError, match="DO_JUMP") as info:
        save_mission(bad, path)
    assert info.value.file == str(path) and info.value.key == "mission.items[0].params[0]"
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["m.plan"]


def test_save_to_a_missing_directory_is_a_file_error(tmp_path: Path) -> None:
    with pytest.raises(MissionFileError, match="cannot write"):
        save_mission(sample_plan(), tmp_path / "nope" / "m.plan")


def test_atomic_write_interrupted_leaves_old_file_and_no_temp(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "f.txt"
    fileio.atomic_write_text(path, "old\n")

    def broken_replace(src: Any, dst: Any) -> None:
        raise KeyboardInterrupt  # even an interrupt must not leave debris

    monkeypatch.setattr(fileio.os, "replace", broken_replace)
    with pytest.raises(KeyboardInterrupt):
        fileio.atomic_write_text(path, "new\n")
    monkeypatch.undo()
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["f.txt"]


def test_atomic_write_replaces_and_keeps_permissions(tmp_path: Path) -> None:
    path = tmp_path / "f.bin"
    fileio.atomic_write_bytes(path, b"one")
    mode_new = os.stat(path).st_mode & 0o777
    umask = os.umask(0)
    os.umask(umask)
    assert mode_new == 0o666 & ~umask  # not mkstemp's 0600
    os.chmod(path, 0o640)
    fileio.atomic_write_bytes(path, b"two\r\n")
    assert path.read_bytes() == b"two\r\n"  # bytes as given, no newline translation
    assert os.stat(path).st_mode & 0o777 == 0o640
    fileio.atomic_write_text(path, "a\nb\n")
    assert path.read_bytes() == b"a\nb\n"


def test_round_trip_through_files_keeps_everything(tmp_path: Path) -> None:
    plan = sample_plan(Autopilot.ARDUPILOT)
    save_mission(plan, tmp_path / "m.plan")
    again = load_mission(tmp_path / "m.plan")
    assert again == plan
    assert math.isclose(again.items[0].alt_m, 20.0)
    assert copy.deepcopy(again) == plan


# =============================================================================================
# fileio.check_writable and the errors of atomic writes: the user's path, exit 2


def test_check_writable_accepts_a_writable_path_and_leaves_nothing(tmp_path: Path) -> None:
    fileio.check_writable(tmp_path / "new.plan")
    (tmp_path / "old.plan").write_text("x")
    fileio.check_writable(tmp_path / "old.plan")
    assert [p.name for p in tmp_path.iterdir()] == ["old.plan"]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: d / "missing" / "m.plan", "folder .*missing.* does not exist"),
        (lambda d: d, "is a folder, not a file"),
        (lambda d: d / "file.txt" / "m.plan", "is not a folder"),
        (lambda d: d / ("x" * 300 + ".plan"), "too long"),
    ],
    ids=["missing-folder", "a-folder", "parent-is-a-file", "name-too-long"],
)
def test_check_writable_refuses_with_the_users_path(
    tmp_path: Path, make: Callable[[Path], Path], message: str
) -> None:
    (tmp_path / "file.txt").write_text("x")
    path = make(tmp_path)
    with pytest.raises(fileio.OutputFileError, match=message) as info:
        fileio.check_writable(path)
    err = info.value
    assert err.exit_code == EXIT_INPUT and str(err).startswith(f"{path}: ")
    assert isinstance(err, OSError)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]


def test_check_writable_refuses_a_nul_byte() -> None:
    with pytest.raises(fileio.OutputFileError, match="NUL byte"):
        fileio.check_writable("a\x00b.plan")


def test_atomic_write_errors_name_the_target_not_the_temp_file(tmp_path: Path) -> None:
    target = tmp_path / "missing" / "r.json"
    with pytest.raises(fileio.OutputFileError) as info:
        fileio.atomic_write_text(target, "{}")
    text = str(info.value)
    assert text == f"{target}: cannot write: folder {str(target.parent)!r} does not exist"
    assert ".tmp" not in text and info.value.filename == str(target)


def test_atomic_write_a_long_name_uses_a_short_temp_name(tmp_path: Path) -> None:
    target = tmp_path / ("y" * 250 + ".plan")  # the temp name must not pass NAME_MAX
    fileio.atomic_write_text(target, "ok")
    assert target.read_text() == "ok"


# =============================================================================================
# MissionItem refuses what a MISSION_ITEM_INT cannot carry


@pytest.mark.parametrize(
    ("fields", "match"),
    [
        ({"param1": 1e39}, r"param1 1e\+39 is beyond what MAVLink carries \(float32"),
        ({"param4": -3.5e38}, "param4 .*float32"),
        ({"z": 1e39}, "z 1e\\+39 .*float32"),
        ({"frame": 2, "x": 3e9}, "x 3e\\+09 .*int32"),
        ({"frame": 2, "y": -2147483649.0}, "y .*int32"),
        ({"command": 70000}, "command 70000 is out of range"),
        ({"command": 16.5}, "command must be a whole number"),
        ({"frame": 256}, "frame 256 is out of range"),
        ({"frame": float("nan")}, "frame must be a whole number"),
        ({"param2": float("inf")}, "param2 must not be infinite"),
        ({"x": float("nan")}, "x must be finite"),
    ],
)
def test_mission_item_refuses_values_the_wire_cannot_hold(
    fields: dict[str, Any], match: str
) -> None:
    with pytest.raises(ValueError, match=match):
        MissionItem(**{"command": 16, **fields})


def test_mission_item_accepts_the_wire_limits() -> None:
    big = 3.4028234663852886e38  # float32 max
    item = MissionItem(
        command=0xFFFF, frame=2, param1=big, param2=-big, x=2**31 - 1, y=-(2**31), z=big
    )
    assert item.wire_xy() == (2**31 - 1, -(2**31))
    assert MissionItem(command=np.int64(16), frame=np.uint8(3)).command == 16


def test_from_wire_refuses_a_nan_position() -> None:
    with pytest.raises(ValueError, match="finite"):
        MissionItem.from_wire(
            command=16, frame=3, params=(0, 0, 0, 0), x=float("nan"), y=0, z=10.0, autocontinue=1
        )  # type: ignore[arg-type]
