"""The flight of a flown track: where the take-off ends and the landing begins."""

from __future__ import annotations

import numpy as np

from uavplan.flightcheck import LANDED_NOISE_M, flight_of_track
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mission.track import Track

HOME = GeoPoint(47.397742, 8.545594, 488.0)


def _track(z: list[float], x: list[float]) -> Track:
    frame = EnuFrame.at(HOME)
    lat, lon, _ = frame.to_geodetic(np.column_stack((x, np.zeros(len(x)), np.zeros(len(x)))))
    n = len(z)
    return Track(
        np.arange(n, dtype=float),
        lat,
        lon,
        HOME.alt_m + np.asarray(z),
        np.asarray(z, dtype=float),
        np.zeros(n),
        np.zeros(n, dtype=np.int64),
    )


def test_a_landed_vehicles_wandering_altitude_is_the_landing_not_the_flight() -> None:
    # up, along, down to the ground, then the estimate wanders below home while it settles
    z = [0.0, 5.0, 10.0, 10.0, 10.0, 5.0, 0.0, -0.3, -0.5, -0.45, -0.48]
    x = [0.0, 0.0, 0.0, 20.0, 40.0, 40.0, 40.0, 40.0, 40.0, 40.0, 40.0]
    flight = flight_of_track(_track(z, x), EnuFrame.at(HOME), lands=True)
    first, last = flight.airborne
    assert first == 2 and last == 4  # the descent and the settling are the landing


def test_a_climb_after_touching_down_stays_in_the_flight() -> None:
    # down to the ground, then more than the noise back up where the track ends: that is
    # flying, and the touchdown before it stays in the checked flight
    z = [0.0, 10.0, 10.0, 0.0, LANDED_NOISE_M + 1.0, LANDED_NOISE_M + 1.0]
    x = [0.0, 0.0, 20.0, 20.0, 20.0, 20.0]
    flight = flight_of_track(_track(z, x), EnuFrame.at(HOME), lands=True)
    assert flight.airborne[1] == 4
