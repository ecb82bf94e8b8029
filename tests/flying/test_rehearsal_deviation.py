"""The rehearsal's largest deviation of a flown track from its planned legs
(:func:`uavplan.rehearsal.max_deviation_m`): the value of the all-pairs measure, in memory
that does not grow with the number of legs times the number of track points (issue 26: a
50 km plan peaked at 4 GB measuring it)."""

from __future__ import annotations

import itertools
import tracemalloc

import numpy as np
import pytest

from uavplan.autopilot.simulate import distance_to_polyline
from uavplan.rehearsal import DEVIATION_CHUNK, max_deviation_m


def _track_along(legs: np.ndarray, rng: np.random.Generator, per_leg: int, noise_m: float):
    """Points along ``legs`` with a sideways error, as a flown track is."""
    parts = []
    for a, b in itertools.pairwise(legs):
        u = np.linspace(0.0, 1.0, per_leg, endpoint=False)[:, None]
        parts.append(a + u * (b - a))
    pts = np.vstack(parts)
    return pts + rng.normal(0.0, noise_m, pts.shape)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_equals_the_all_pairs_maximum(seed: int) -> None:
    rng = np.random.default_rng(seed)
    # a route that doubles back on itself (hairpins): a point's nearest leg is often not the
    # one it flies, so a window around the current leg would not do
    legs = np.cumsum(rng.normal(0.0, 80.0, (60, 3)), axis=0)
    legs[20:40] = legs[20:40][::-1] + 5.0
    track = _track_along(legs, rng, 37, 6.0)
    track[500] += (40.0, -30.0, 10.0)  # one large excursion
    want = float(distance_to_polyline(track, legs).max())
    assert max_deviation_m(track, legs) == want
    # runs shorter than a chunk, a single leg, a single point of polyline
    assert max_deviation_m(track[: DEVIATION_CHUNK // 3], legs) == float(
        distance_to_polyline(track[: DEVIATION_CHUNK // 3], legs).max()
    )
    assert max_deviation_m(track, legs[:2]) == float(distance_to_polyline(track, legs[:2]).max())
    assert max_deviation_m(track, legs[:1]) == float(distance_to_polyline(track, legs[:1]).max())
    assert max_deviation_m(track[:0], legs) == 0.0


def test_memory_does_not_grow_with_points_times_legs() -> None:
    # 12,000 points against 1,500 legs: the all-pairs arrays are 432 MB each
    rng = np.random.default_rng(7)
    legs = np.column_stack(
        [np.arange(1500) * 40.0, rng.normal(0.0, 30.0, 1500), 60.0 + rng.normal(0.0, 5.0, 1500)]
    )
    track = _track_along(legs, rng, 8, 2.0)
    tracemalloc.start()
    try:
        value = max_deviation_m(track, legs)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 16 * 2**20, f"peak {peak / 2**20:.0f} MiB"
    assert value < 20.0
