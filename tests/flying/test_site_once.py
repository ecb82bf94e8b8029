"""``plan`` builds its site once (issue 36: one World, one frame, one check site): the search,
the widening, the way home and the verdict share its world, derived where the limits differ.
Each derived world answers as the world built afresh for those limits did."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from uavplan.flown_safe import padded_scenario
from uavplan.rehearsal import CheckSite
from uavplan.scenario import load_scenario
from uavplan.world import World
from uavplan.worlds import RETURN_BOUNDS_PAD_M, RETURN_OPEN_Z_M, build_world, padded_world

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def _segments(world: World, n: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(11)
    x1, x0, y1, y0 = world.hp[0, 2], -world.hp[1, 2], world.hp[2, 2], -world.hp[3, 2]
    z0, z1 = np.clip(world.zlim, -50.0, 1000.0)
    lo = np.array([max(x0, -2e3), max(y0, -2e3), z0])
    hi = np.array([min(x1, 2e3), min(y1, 2e3), z1 + 30.0])
    p0 = rng.uniform(lo, hi, size=(n, 3))
    return p0, p0 + rng.normal(0.0, 40.0, size=p0.shape)


def _same_answers(a: World, b: World) -> None:
    assert a.margin_m == b.margin_m
    assert (a.ground is None) == (b.ground is None)
    if a.ground is not None and b.ground is not None:
        for name in ("datum_amsl_m", "ceiling_agl_m", "margin_m", "floor_agl_m"):
            assert getattr(a.ground, name) == getattr(b.ground, name), name
        assert a.ground.field is b.ground.field  # one height field, shared
    assert np.array_equal(a.hp, b.hp) and np.array_equal(a.zlim, b.zlim)
    p0, p1 = _segments(b)
    free = b.segments_free(p0, p1)
    assert 0 < free.mean() < 1
    assert np.array_equal(a.segments_free(p0, p1), free)
    ends = p1[::3]  # every third end: the clearance over terrain is the slow answer
    assert np.allclose(a.points_clearance(ends)[0], b.points_clearance(ends)[0])


@pytest.mark.parametrize("name", ["paper-env3", "jacksboro-ridge"])
def test_a_widened_world_is_the_world_of_the_widened_scenario(name: str) -> None:
    scn = load_scenario(MISSIONS / f"{name}.yaml")
    site = CheckSite.of_scenario(scn)
    for pad in (0.35, 2.0):
        padded = padded_scenario(scn, pad)
        derived = padded_world(site.world, padded)
        assert derived.poly_xy is site.world.poly_xy
        _same_answers(derived, build_world(padded))


@pytest.mark.parametrize("name", ["paper-env3", "jacksboro-ridge"])
def test_the_return_world_is_the_site_open_above_and_below_and_a_little_wider(
    name: str,
) -> None:
    """The way-home proof and the verdict's failsafe check both read ``CheckSite.floor``
    (they built it twice, each its own way, before): the site's obstacles and ground without
    the ceiling over the ground, in bounds open above and below and a pad wider."""
    scn = load_scenario(MISSIONS / f"{name}.yaml")
    site = CheckSite.of_scenario(scn)
    assert site.floor is site.floor  # built once
    b = scn.site.bounds
    pad, top = RETURN_BOUNDS_PAD_M, RETURN_OPEN_Z_M
    ground = scn.site.ground
    if ground is not None:
        ground = replace(ground, ceiling_agl_m=top)
    built = World.build(
        scn.site.obstacles,
        bounds_xyz=(
            (b.x_m[0] - pad, b.x_m[1] + pad),
            (b.y_m[0] - pad, b.y_m[1] + pad),
            (-top, top),
        ),
        margin_m=scn.safety_margin_m,
        ground=ground,
    )
    _same_answers(site.floor, built)
