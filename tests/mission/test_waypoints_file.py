"""QGC WPL 110 (.waypoints) writer/reader, checked against pymavlink's mavwp and MAVSDK."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers.mavsdk_offline import mavsdk_mission_raw
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uavplan.errors import MissionFileError
from uavplan.geo import EnuFrame
from uavplan.mission.builder import build_mission
from uavplan.mission.io import load_mission, save_mission
from uavplan.mission.items import (
    Autopilot,
    FenceCircle,
    GeoFence,
    GeoPoint,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    RallyPoint,
)
from uavplan.mission.waypoints_file import waypoints_from_text, waypoints_to_text

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)
PATH = np.array([[0.0, 0.0, 30.0], [400.0, -80.0, 60.0], [2000.0, 150.0, 40.0]])


def sample_plan(autopilot: Autopilot = Autopilot.ARDUPILOT) -> MissionPlan:
    return build_mission(
        PATH,
        EnuFrame.at(ORIGIN),
        autopilot=autopilot,
        end="land",
        cruise_speed_m_s=12.0,
        takeoff_altitude_m=20.0,
    )


def _slots(autopilot: Autopilot) -> int:
    return 1 if autopilot == Autopilot.ARDUPILOT else 0


# =============================================================================================
# Writer


def test_exact_layout() -> None:
    plan = MissionPlan(
        items=(
            MissionItem(
                command=22, param1=0.0, param2=0.0, param3=0.0, x=47.3977419, y=8.5455938, z=20.0
            ),
            MissionItem(command=178, frame=2, param1=1.0, param2=12.5, param3=-1.0, param4=0.0),
            MissionItem(command=16, x=-33.123456789, y=-151.5, z=45.25, autocontinue=False),
            MissionItem(command=20, frame=2, param1=0.0, param2=0.0, param3=0.0, param4=0.0),
        ),
        autopilot=Autopilot.ARDUPILOT,
        home=GeoPoint(47.3977419, 8.5455938, 488.25),
    )
    assert waypoints_to_text(plan) == (
        "QGC WPL 110\n"
        "0\t1\t0\t16\t0\t0\t0\t0\t47.39774190\t8.54559380\t488.250000\t1\n"
        "1\t0\t3\t22\t0.00000000\t0.00000000\t0.00000000\tNaN\t47.39774190\t8.54559380\t20.000000\t1\n"
        "2\t0\t2\t178\t1.00000000\t12.50000000\t-1.00000000\t0.00000000\t0.00000000\t0.00000000\t0.000000\t1\n"
        "3\t0\t3\t16\tNaN\tNaN\tNaN\tNaN\t-33.12345679\t-151.50000000\t45.250000\t0\n"
        "4\t0\t2\t20\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.00000000\t0.000000\t1\n"
    )


def test_format_rules_on_a_built_mission() -> None:
    text = waypoints_to_text(sample_plan())
    assert "\r" not in text and "#" not in text
    assert text.endswith("\n") and not text.endswith("\n\n")
    lines = text.split("\n")[:-1]
    assert lines[0] == "QGC WPL 110"
    assert not any(" " in line for line in lines[1:])
    for seq, line in enumerate(lines[1:]):
        cols = line.split("\t")
        assert len(cols) == 12
        assert int(cols[0]) == seq
        assert cols[1] == ("1" if seq == 0 else "0")
        for col in (cols[8], cols[9]):
            assert len(col.split(".")[1]) == 8  # 8 decimals for degrees
        assert "," not in line


def test_unknown_home_is_written_as_zeros_and_read_back_as_none() -> None:
    plan = MissionPlan(items=(MissionItem(command=16, x=1.0, y=2.0, z=3.0),))
    text = waypoints_to_text(plan)
    assert text.split("\n")[1] == "0\t1\t0\t16\t0\t0\t0\t0\t0.00000000\t0.00000000\t0.000000\t1"
    assert waypoints_from_text(text).home is None


def test_no_negative_zero() -> None:
    item = MissionItem(command=16, param1=-0.0, x=-0.0, y=-1e-12, z=-0.0)
    line = waypoints_to_text(MissionPlan(items=(item,))).split("\n")[2]
    assert "-0.0" not in line


def test_fence_and_rally_cannot_be_written_silently() -> None:
    fenced = MissionPlan(items=(), fence=GeoFence(circles=(FenceCircle((1.0, 2.0), 10.0, True),)))
    rally = MissionPlan(items=(), rally=(RallyPoint(1.0, 2.0, 3.0),))
    for plan in (fenced, rally):
        with pytest.raises(MissionFileError, match="cannot hold a geofence or rally"):
            waypoints_to_text(plan)
        assert waypoints_to_text(plan, ignore_fence_and_rally=True).startswith("QGC WPL 110\n")


# =============================================================================================
# Round trips

lats = st.floats(-90.0, 90.0)
lons = st.floats(-180.0, 180.0)
params = st.one_of(st.none(), st.floats(-1e5, 1e5))
items = st.one_of(
    st.builds(
        MissionItem,
        command=st.sampled_from([16, 17, 19, 21, 22, 82]),
        frame=st.sampled_from([0, 3, 5, 6, 10]),
        param1=params,
        param2=params,
        param3=params,
        param4=params,
        x=lats,
        y=lons,
        z=st.floats(-500.0, 10_000.0),
        autocontinue=st.booleans(),
    ),
    st.builds(
        MissionItem,
        command=st.sampled_from([20, 178, 183, 206]),
        frame=st.just(2),
        param1=params,
        param2=params,
        param3=params,
        param4=params,
        autocontinue=st.booleans(),
    ),
)


@st.composite
def plans(draw: st.DrawFn) -> MissionPlan:
    autopilot = draw(st.sampled_from([Autopilot.PX4, Autopilot.ARDUPILOT]))
    listed = draw(st.lists(items, max_size=10))
    if draw(st.booleans()):
        at = draw(st.integers(0, len(listed)))
        target = draw(st.integers(0, len(listed)))
        listed.insert(
            at,
            MissionItem(
                command=177,
                frame=2,
                param1=float(target + _slots(autopilot)),
                param2=float(draw(st.integers(-1, 9))),
            ),
        )
    home = draw(
        st.one_of(
            st.none(),
            st.builds(GeoPoint, lats, lons, st.floats(-400.0, 9000.0)).filter(
                lambda g: (round(g.lat_deg, 8), round(g.lon_deg, 8)) != (0.0, 0.0)
            ),
        )
    )
    return MissionPlan(items=tuple(listed), autopilot=autopilot, home=home)


def assert_close_items(got: tuple[MissionItem, ...], expected: tuple[MissionItem, ...]) -> None:
    assert len(got) == len(expected)
    for a, b in zip(got, expected, strict=True):
        assert (a.command, a.frame, a.autocontinue) == (b.command, b.frame, b.autocontinue)
        for pa, pb in zip(a.params, b.params, strict=True):
            assert (pa is None) == (pb is None)
            if pa is not None and pb is not None:
                assert pa == pytest.approx(pb, abs=5.1e-9)
        assert a.x == pytest.approx(b.x, abs=5.1e-9)  # 8 decimals
        assert a.y == pytest.approx(b.y, abs=5.1e-9)
        assert a.z == pytest.approx(b.z, abs=5.1e-7)  # 6 decimals


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(plan=plans())
def test_write_read_round_trip(plan: MissionPlan) -> None:
    back = waypoints_from_text(waypoints_to_text(plan), autopilot=plan.autopilot)
    assert back.autopilot == plan.autopilot
    assert_close_items(back.items, plan.items)
    if plan.home is None:
        assert back.home is None
    else:
        assert back.home is not None
        assert back.home.lat_deg == pytest.approx(plan.home.lat_deg, abs=5.1e-9)
        assert back.home.lon_deg == pytest.approx(plan.home.lon_deg, abs=5.1e-9)
        assert back.home.alt_m == pytest.approx(plan.home.alt_m, abs=5.1e-7)


def test_built_mission_round_trips_through_a_file(tmp_path: Path) -> None:
    plan = sample_plan()
    save_mission(plan, tmp_path / "m.waypoints")
    back = load_mission(tmp_path / "m.waypoints")
    assert back.autopilot == Autopilot.ARDUPILOT  # the format's native layout
    assert_close_items(back.items, plan.items)
    as_px4 = load_mission(tmp_path / "m.waypoints", autopilot=Autopilot.PX4)
    assert as_px4.autopilot == Autopilot.PX4 and as_px4.home == back.home
    assert_close_items(as_px4.items, plan.items)


# =============================================================================================
# Reader tolerance and DO_JUMP numbering


def test_reader_accepts_crlf_spaces_comments_and_blank_lines() -> None:
    text = waypoints_to_text(sample_plan())
    lines = text.split("\n")
    messy = "\r\n".join(
        [lines[0], "# exported by hand", "", lines[1].replace("\t", "  "), "   ", *lines[2:]]
    )
    assert waypoints_from_text(messy) == waypoints_from_text(text)
    assert waypoints_from_text("\ufeff" + text) == waypoints_from_text(text)


def test_line_zero_is_home_for_both_autopilots() -> None:
    text = waypoints_to_text(sample_plan())
    for autopilot in (Autopilot.ARDUPILOT, Autopilot.PX4):
        plan = waypoints_from_text(text, autopilot=autopilot)
        assert plan.home is not None and plan.home.alt_m == pytest.approx(488.0)
        assert plan.items[0].command == MavCmd.NAV_TAKEOFF
        assert plan.autopilot == autopilot


def test_do_jump_targets_by_autopilot() -> None:
    text = (
        "QGC WPL 110\n"
        "0\t1\t0\t16\t0\t0\t0\t0\t47.0\t8.0\t400.0\t1\n"
        "1\t0\t3\t22\t0\t0\t0\t0\t47.0\t8.0\t20.0\t1\n"
        "2\t0\t3\t16\t0\t0\t0\t0\t47.001\t8.0\t20.0\t1\n"
        "3\t0\t3\t16\t0\t0\t0\t0\t47.002\t8.0\t20.0\t1\n"
        "4\t0\t2\t177\t2\t3\t0\t0\t0\t0\t0\t1\n"
    )
    ardupilot = waypoints_from_text(text)  # the format's native layout
    assert ardupilot.items[3].param1 == 2.0  # seq 2 with home at seq 0
    assert ardupilot.wire_items()[2].lat_deg == 47.001
    px4 = waypoints_from_text(text, autopilot=Autopilot.PX4)
    assert px4.items[3].param1 == 1.0  # PX4 has no home slot
    assert px4.wire_items()[1].lat_deg == 47.001
    assert waypoints_to_text(px4) == waypoints_to_text(ardupilot)


@pytest.mark.parametrize("target", ["0", "5", "1.5", "NaN"])
def test_do_jump_to_nowhere_is_rejected(target: str) -> None:
    text = (
        "QGC WPL 110\n"
        "0\t1\t0\t16\t0\t0\t0\t0\t47.0\t8.0\t400.0\t1\n"
        "1\t0\t3\t16\t0\t0\t0\t0\t47.0\t8.0\t20.0\t1\n"
        f"2\t0\t2\t177\t{target}\t3\t0\t0\t0\t0\t0\t1\n"
    )
    with pytest.raises(MissionFileError, match="DO_JUMP target") as info:
        waypoints_from_text(text, file="j.waypoints")
    assert info.value.key == "line 4"


# =============================================================================================
# Bad files

HOME = "0\t1\t0\t16\t0\t0\t0\t0\t47.0\t8.0\t400.0\t1"
ITEM = "1\t0\t3\t16\t0\t0\t0\t0\t47.1\t8.1\t30.0\t1"


def with_item_column(column: int, text: str) -> str:
    """A file whose one item has ``text`` in 0-based ``column``."""
    cols = ITEM.split("\t")
    cols[column] = text
    return f"QGC WPL 110\n{HOME}\n" + "\t".join(cols)


@pytest.mark.parametrize(
    ("text", "key", "match"),
    [
        ("", "line 1", "empty header"),
        ("\n" + HOME, "line 1", "empty header"),
        ("QGC WPL 100\n" + HOME, "line 1", "bad header"),
        ("QGC WPL 120\n" + HOME, "line 1", "bad header"),
        ('{"fileType": "Plan"}', "line 1", "bad header"),
        (f"QGC WPL 110\n{HOME}\n{ITEM.rsplit(chr(9), 1)[0]}", "line 3", "12 columns"),
        (f"QGC WPL 110\n{HOME}\n{ITEM}\t0", "line 3", "12 columns"),
        (with_item_column(8, "north"), "line 3, column 9 (x/lat)", "not a number"),
        (with_item_column(8, "47,1"), "line 3, column 9 (x/lat)", "not a number"),
        (with_item_column(4, "1_0"), "line 3, column 5 (param1)", "not a number"),
        (with_item_column(10, "inf"), "line 3, column 11 (z/alt)", "not a number"),
        (with_item_column(10, "NaN"), "line 3, column 11 (z/alt)", "NaN"),
        (with_item_column(10, "1e999"), "line 3, column 11 (z/alt)", "out of range"),
        (with_item_column(3, "16.0"), "line 3, column 4 (command)", "whole number"),
        (with_item_column(3, "70000"), "line 3, column 4 (command)", "out of range"),
        (with_item_column(11, "yes"), "line 3, column 12 (autocontinue)", "whole number"),
        (with_item_column(0, "3"), "line 3", "seq 3 out of order"),
        (with_item_column(8, "95.0"), "line 3", "latitude"),
        (f"QGC WPL 110\n{HOME.replace('8.0', '200.0')}\n{ITEM}", "line 2", "home: longitude"),
        # values a MISSION_ITEM_INT cannot carry: refused at load, not at upload
        (with_item_column(4, "1e39"), "line 3", "param1 1e\\+39 is beyond .*float32"),
        (with_item_column(10, "1e39"), "line 3", "z 1e\\+39 is beyond .*float32"),
        (f"QGC WPL 110\n{HOME}\n1\t0\t2\t31000\t0\t0\t0\t0\t3e9\t0\t0\t1", "line 3", "int32"),
        (f"QGC WPL 110\n{HOME.replace('400.0', '1e39')}\n{ITEM}", "line 2", "home: .*float32"),
        # hostile tokens: one short message, no crash on Python's integer-string limit
        (with_item_column(3, "9" * 5000), "line 3, column 4 (command)", "out of range"),
        (with_item_column(3, "\u0661\u0666"), "line 3, column 4 (command)", "whole number"),
        (with_item_column(8, "\u0664\u0667"), "line 3, column 9 (x/lat)", "not a number"),
        (with_item_column(8, "x" * 5000), "line 3, column 9 (x/lat)", "not a number"),
    ],
)
def test_bad_files_are_rejected(text: str, key: str, match: str) -> None:
    with pytest.raises(MissionFileError, match=match) as info:
        waypoints_from_text(text, file="bad.waypoints")
    assert (info.value.file, info.value.key) == ("bad.waypoints", key)
    assert str(info.value).startswith(f"bad.waypoints: {key}: ")
    assert len(str(info.value)) < 300 and "\n" not in str(info.value)


def test_line_numbers_count_only_real_line_breaks() -> None:
    """CR, LF and CRLF break lines; a form feed or U+2028 inside a line does not (so the
    line number in a message is the one an editor shows)."""
    text = f"QGC WPL 110\r{HOME}\r\n{ITEM}\u2028\n1\t0\t3\t16\t0\t0\t0\t0\t47.1\t8.1\tx\t1\n"
    with pytest.raises(MissionFileError) as info:
        waypoints_from_text(text, file="w.waypoints")
    assert info.value.key == "line 4, column 11 (z/alt)"  # splitlines() would say line 5


def test_header_with_trailing_whitespace_is_tolerated() -> None:
    plan = waypoints_from_text(f"QGC WPL 110  \r\n{HOME}\r\n{ITEM}\r\n")
    assert len(plan.items) == 1 and plan.home == GeoPoint(47.0, 8.0, 400.0)


def test_header_only_is_an_empty_mission() -> None:
    plan = waypoints_from_text("QGC WPL 110\n")
    assert plan.items == () and plan.home is None


# =============================================================================================
# Other readers load our files: pymavlink's mavwp and MAVSDK's importer


def test_pymavlink_mavwp_loads_the_same_items(tmp_path: Path) -> None:
    from pymavlink import mavwp

    plan = sample_plan()
    path = tmp_path / "m.waypoints"
    save_mission(plan, path)
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(path)) == len(plan.items) + 1
    wps = [loader.wp(i) for i in range(loader.count())]
    assert plan.home is not None
    assert (wps[0].seq, wps[0].command, wps[0].frame, wps[0].current) == (0, 16, 0, 1)
    assert (wps[0].x, wps[0].y, wps[0].z) == pytest.approx(
        (plan.home.lat_deg, plan.home.lon_deg, plan.home.alt_m), abs=1e-8
    )
    for seq, (wp, item) in enumerate(zip(wps[1:], plan.items, strict=True), start=1):
        assert (wp.seq, wp.command, wp.frame, wp.current, wp.autocontinue) == (
            seq,
            item.command,
            item.frame,
            0,
            1,
        )
        for got, want in zip(
            (wp.param1, wp.param2, wp.param3, wp.param4), item.params, strict=True
        ):
            assert math.isnan(got) if want is None else got == pytest.approx(want, abs=1e-8)
        assert (wp.x, wp.y, wp.z) == pytest.approx((item.x, item.y, item.z), abs=1e-8)


def raw_tuple(raw: Any) -> tuple[Any, ...]:
    """A MAVSDK item as comparable values: NaN params as None, float32 and 1e-7 rounding
    tolerated (the file has 8 decimals, so x/y may differ by one unit of 1e-7°)."""
    params = tuple(
        None if math.isnan(p) else pytest.approx(p, abs=1e-5)
        for p in (raw.param1, raw.param2, raw.param3, raw.param4)
    )
    return (
        raw.command,
        raw.frame,
        *params,
        pytest.approx(raw.x, abs=1),
        pytest.approx(raw.y, abs=1),
        pytest.approx(raw.z, abs=1e-4),
    )


def wire_tuple(item: MissionItem) -> tuple[Any, ...]:
    x, y = item.wire_xy()
    return (item.command, item.frame, *item.params, x, y, item.z)


@pytest.mark.parametrize("autopilot", [Autopilot.PX4, Autopilot.ARDUPILOT])
def test_mavsdk_imports_our_waypoints(autopilot: Autopilot, tmp_path: Path) -> None:
    """MAVSDK reads every line as an item, the home line included; for ArduPilot it then
    prepends a copy of the first line as home (reference §6). Our items follow intact."""
    plan = sample_plan(autopilot)
    path = tmp_path / "m.waypoints"
    save_mission(plan, path)
    with mavsdk_mission_raw(autopilot) as mission_raw:
        data = mission_raw.import_mission_planner_mission(str(path))
    assert [r.seq for r in data.mission_items] == list(range(len(data.mission_items)))
    got = [raw_tuple(r) for r in data.mission_items]
    home_line = MissionPlan(items=(), home=plan.home).home_item()  # line 0: NAV_WAYPOINT, frame 0
    expected = [wire_tuple(home_line), *(wire_tuple(i) for i in plan.items)]
    if autopilot == Autopilot.ARDUPILOT:
        prepended = data.mission_items[0]
        assert prepended.command == MavCmd.NAV_WAYPOINT
        assert prepended.frame == MavFrame.GLOBAL_INT
        assert (prepended.x, prepended.y) == home_line.wire_xy()
        got = got[1:]
    assert len(got) == len(plan.items) + 1
    assert got == expected
