"""A mission read the way the flight model flies it (:mod:`uavplan.autopilot.nav`): the one
reading that ``simulate``, the simulated vehicle and ``fly`` share."""

from __future__ import annotations

import numpy as np

from uavplan.autopilot.nav import nav_items, planned_legs
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.items import MavCmd, MavFrame, MissionItem

HOME = GeoPoint(47.0, 8.0, 400.0)


def test_a_take_off_where_the_vehicle_is_keeps_its_altitude_without_a_nan_marker() -> None:
    lat, lon = EnuFrame.at(HOME).to_geodetic(np.array([[100.0, 50.0, 0.0]]))[:2]
    items = [
        MissionItem(int(MavCmd.NAV_TAKEOFF), z=30.0),  # lat/lon 0: here
        MissionItem(int(MavCmd.NAV_WAYPOINT), x=float(lat[0]), y=float(lon[0]), z=40.0),
        MissionItem(
            int(MavCmd.NAV_WAYPOINT),
            int(MavFrame.GLOBAL),
            x=float(lat[0]),
            y=float(lon[0]),
            z=HOME.alt_m + 45.0,
        ),
        MissionItem(int(MavCmd.NAV_LAND)),
    ]
    nav = nav_items(items, HOME)
    take_off = nav[0]
    assert take_off.position is None and not take_off.is_position
    assert take_off.here_alt_m == 30.0 and take_off.altitude_m == 30.0
    assert nav[2].altitude_m is not None and abs(nav[2].altitude_m - 45.0) < 1e-6  # AMSL read
    points, seqs = planned_legs(nav)
    assert not np.isnan(points).any()
    assert seqs.tolist() == [-1, 0, 1, 2]
    np.testing.assert_allclose(points[:2], [[0, 0, 0], [0, 0, 30]])
    np.testing.assert_allclose(points[2], [100.0, 50.0, 40.0], atol=1e-3)
