"""The exact height field of a large terrain area is built a block of rows at a time
(issue 26: peak memory <= 200 MB everywhere; the 20 x 20 km area's million-cell field took
243 MB of temporaries): the field is the same whatever the block, and its construction's
peak stays within a small multiple of the field itself."""

from __future__ import annotations

import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from uavplan import ground
from uavplan.flown_safe import padded_scenario
from uavplan.scenario import load_scenario


def _posts(rows: int, cols: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A slightly rotated, slightly irregular lattice of posts over rolling hills."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(rows, dtype=float), np.arange(cols, dtype=float), indexing="ij")
    th = 0.2
    x = 90.0 * j * np.cos(th) - 92.0 * i * np.sin(th)
    y = 90.0 * j * np.sin(th) + 92.0 * i * np.cos(th)
    xy = np.stack([x, y], axis=-1) + rng.normal(0.0, 0.05, (rows, cols, 2))
    z = 300.0 + 80.0 * np.sin(x / 700.0) * np.cos(y / 900.0) + rng.normal(0.0, 2.0, (rows, cols))
    centres = 0.25 * (xy[:-1, :-1] + xy[:-1, 1:] + xy[1:, :-1] + xy[1:, 1:])
    return xy, z, centres


FIELDS = ("xy", "z", "subdivision", "twist_gap_m", "warp_m", "lattice", "slack", "per_m", "slope")


def test_the_field_does_not_depend_on_the_block(monkeypatch: pytest.MonkeyPatch) -> None:
    xy, z, centres = _posts(23, 31)
    monkeypatch.setattr(ground, "BLOCK_CELLS", 10**9)  # everything in one block
    whole = ground.HeightField.from_posts(xy, z, centres)
    assert whole.subdivision > 1  # the sub-quads are interpolated too
    for block in (2, 7, 500):
        monkeypatch.setattr(ground, "BLOCK_CELLS", block)
        blocked = ground.HeightField.from_posts(xy, z, centres)
        for name in FIELDS:
            assert np.array_equal(getattr(blocked, name), getattr(whole, name)), (block, name)


def test_building_a_large_field_peaks_near_its_own_size() -> None:
    xy, z, centres = _posts(700, 600)
    tracemalloc.start()
    try:
        field = ground.HeightField.from_posts(xy, z, centres, max_cells=420_000)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    size = field.xy.nbytes + field.z.nbytes + field.slope.nbytes
    assert field.z.size > 400_000
    # every array of the field plus a few blocks' temporaries; all at once held 5.5 times it
    assert peak < 2.5 * size, f"peak {peak / 2**20:.0f} MiB for a field of {size / 2**20:.0f} MiB"


RIDGE = Path(__file__).resolve().parents[2] / "missions" / "jacksboro-ridge.yaml"


def test_a_wider_margin_over_the_same_posts_shares_the_field() -> None:
    """``plan`` plans again with a wider margin (flown_safe.padded_scenario) while the first
    scenario is still held: its ground is built of the same posts, so it holds the same
    field instead of a second one beside it (the 20 x 20 km ridge: 55 MB more at the peak)."""
    scn = load_scenario(RIDGE)
    padded = padded_scenario(scn, 0.6)
    a, b = scn.site.ground, padded.site.ground
    assert a is not None and b is not None
    assert b.margin_m == pytest.approx(a.margin_m + 0.6)  # a ground of its own ...
    assert b.field is a.field  # ... over the one field
    # a field of other posts is its own (the bounds narrowed by a few post spacings)
    y0, y1 = scn.bounds.y_m
    narrowed = replace(scn, bounds=replace(scn.bounds, y_m=(y0 + 300.0, y1)))
    c = narrowed.site.ground
    assert c is not None and c.field is not a.field
    assert c.field.shape != a.field.shape


def test_a_shared_field_is_the_one_built_alone() -> None:
    scn = load_scenario(RIDGE)
    shared = padded_scenario(scn, 0.6).site.ground
    assert shared is not None
    ground._FIELDS.clear()  # nothing to share: built again from the posts
    alone = padded_scenario(load_scenario(RIDGE), 0.6).site.ground
    assert alone is not None and alone.field is not shared.field
    for name in FIELDS:
        assert np.array_equal(getattr(alone.field, name), getattr(shared.field, name)), name
