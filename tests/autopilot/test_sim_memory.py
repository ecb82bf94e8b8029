"""A long simulated flight is recorded packed (issue 26: peak memory <= 200 MB everywhere;
``plan`` flies every planned mission through the flight model, a 25 km terrain crossing some
60,000 steps): the track's rows cost a few tens of bytes each while they are recorded, not
the hundreds a list of tuples of Python floats held (and left behind in the allocator)."""

from __future__ import annotations

import tracemalloc

import numpy as np

from uavplan.autopilot.simulate import TRACK_COLUMNS, simulate
from uavplan.flavour import Autopilot
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.builder import build_mission

HOME = GeoPoint(47.4, 8.5, 400.0)


def test_a_long_flight_is_recorded_in_a_few_dozen_bytes_a_step() -> None:
    # a 6 km zigzag at 12 m/s: about 6,000 steps of 0.1 s
    xy = np.array([[0.0, 0.0], [1500.0, 300.0], [0.0, 600.0], [1500.0, 900.0], [0.0, 1200.0]])
    waypoints = np.column_stack([xy, np.full(len(xy), 40.0)])
    plan = build_mission(
        waypoints,
        EnuFrame.at(HOME),
        autopilot=Autopilot.ARDUPILOT,
        end="land",
        takeoff_altitude_m=None,
        cruise_speed_m_s=12,
    )
    simulate(plan)  # the model's modules and caches loaded outside the measure
    tracemalloc.start()
    try:
        track = simulate(plan)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    rows = len(track.t_s)
    assert track.ended == "landed" and rows > 4000
    # the packed rows (grown as they come) and the track's arrays: 250 bytes a step; with
    # the list of tuples of Python floats, 500
    per_row = peak / rows
    assert per_row < 300, f"{per_row:.0f} bytes a step"
    # what was recorded is what the track gives
    assert TRACK_COLUMNS == 9
    assert np.all(np.diff(track.t_s) > 0) and track.current_seq.dtype == np.int64
