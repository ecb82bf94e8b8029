"""The picture's layout: the legend never covers the top view's axis labels, whatever the
picture's size and shape, and via points are drawn and named in the legend."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uavplan.render import RouteLayers, draw_scene, scene_for
from uavplan.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]
SIZES = [(400, 600), (600, 700), (700, 1200), (800, 900), (1000, 1000), (1600, 800), (2400, 800)]


@pytest.mark.parametrize("size", SIZES, ids=[f"{w}x{h}" for w, h in SIZES])
def test_the_legend_leaves_the_top_views_labels_alone(size: tuple[int, int]) -> None:
    scn = load_scenario(ROOT / "missions" / "via-tour.yaml")
    ends = np.array([scn.start_m, scn.goal_m])
    layers = RouteLayers(raw_path_enu=ends, smoothed_path_enu=ends, flown_enu=ends)
    fig = draw_scene(scene_for(scn), layers, width_px=size[0], height_px=size[1])
    fig.canvas.draw()  # the top view's aspect is applied while drawing
    renderer = fig.canvas.get_renderer()
    legend = fig.legends[0].get_window_extent(renderer)
    top_view = next(ax for ax in fig.axes if ax.name != "3d" and ax.get_xlabel())
    labels = [top_view.xaxis.label] + [t for t in top_view.get_xticklabels() if t.get_text()]
    for label in labels:
        box = label.get_window_extent(renderer)
        assert not legend.overlaps(box), (label.get_text(), legend, box)


def test_via_points_are_marked_in_order() -> None:
    scn = load_scenario(ROOT / "missions" / "via-tour.yaml")
    assert len(scn.via_m) == 3
    fig = draw_scene(scene_for(scn))
    labels = [h.get_label() for h in fig.legends[0].legend_handles]
    assert "via point (in order)" in labels
    top_view = next(ax for ax in fig.axes if ax.name != "3d" and ax.get_xlabel())
    from matplotlib.text import Annotation

    numbers = [t.get_text() for t in top_view.texts if isinstance(t, Annotation)]
    assert numbers == ["1", "2", "3"]
    via_rgb = np.array([0x17, 0xBE, 0xCF]) / 255
    marked = []
    for c in top_view.collections:
        face, offsets = c.get_facecolor(), c.get_offsets()
        if len(face) == 1 and len(offsets) == 1 and np.allclose(face[0][:3], via_rgb):
            marked.append(offsets[0])
    np.testing.assert_allclose(np.array(marked), np.array(scn.via_m)[:, :2])


def test_no_via_point_no_legend_entry() -> None:
    scn = load_scenario(ROOT / "missions" / "paper-env1.yaml")
    fig = draw_scene(scene_for(scn))
    assert "via point (in order)" not in [h.get_label() for h in fig.legends[0].legend_handles]
