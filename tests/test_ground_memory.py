"""The exact height field of a large terrain area is built a block of rows at a time
(issue 26: peak memory <= 200 MB everywhere; the 20 x 20 km area's million-cell field took
243 MB of temporaries): the field is the same whatever the block, and its construction's
peak stays within a small multiple of the field itself."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from uavplan import ground


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


FIELDS = ("xy", "z", "subdivision", "twist_gap_m", "warp_m", "lattice", "slack", "per_m", "cell")


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
    size = field.xy.nbytes + field.z.nbytes + field.cell.nbytes
    assert field.z.size > 400_000
    # every array of the field plus a few blocks' temporaries; all at once held 5.5 times it
    assert peak < 2.5 * size, f"peak {peak / 2**20:.0f} MiB for a field of {size / 2**20:.0f} MiB"
