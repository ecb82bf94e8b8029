"""Pictures of a scenario and a route: a 3-D view and a top view side by side (PNG).

:func:`render_scene` draws a :class:`Scene` (plain values: obstacles, bounds, margin, start
and goal; ``scene_for`` makes one from a scenario) with the obstacles as
solids coloured by height, the start and the goal, and whatever :class:`RouteLayers` it is
given: the planner's raw best path (its node polyline), the smoothed path, and the route the
autopilot flies. For a route that was just planned that is its
:class:`~uavplan.route.PlannedRoute` (:meth:`RouteLayers.from_route`); for a mission file it
is traced from the items (:meth:`RouteLayers.from_mission`). The top view adds each
obstacle's safety margin (dashed outline of the footprint grown by the margin), the bounds
and, if there is one, the geofence.

The 3-D view's vertical scale is stretched when the scene is much wider than it is high
(the factor is printed on the z axis), otherwise a 250 m tall scene 2 km wide is a flat
line. The route is always drawn on top of the obstacles, so it stays visible behind them.

matplotlib is imported inside the functions, with its Agg canvas and no pyplot, so
importing this module costs nothing and needs no display.
"""

from __future__ import annotations

import inspect
import io
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from uavplan.fileio import atomic_write_bytes
from uavplan.geo import EnuFrame
from uavplan.geometry2d import round_offset_outline
from uavplan.mission.builder import mission_polyline_enu
from uavplan.mission.fence import FenceBuild, Footprint, ZoneStatus, footprints_of
from uavplan.mission.items import MissionPlan
from uavplan.obstacles import Bounds, Obstacle
from uavplan.route import PlannedRoute
from uavplan.scenario import Scenario, Site, Surroundings

if TYPE_CHECKING:
    from matplotlib.axes import Axes

#: default picture size (pixels) and resolution
DEFAULT_WIDTH_PX = 1600
DEFAULT_HEIGHT_PX = 800
DEFAULT_DPI = 100
#: the 3-D view's height axis is drawn at least this fraction of its widest horizontal side
MIN_VERTICAL_ASPECT = 0.25
#: obstacle indices are written in the top view when there are at most this many
MAX_LABELLED_OBSTACLES = 40
#: width / height of the 3-D box as drawn (about, for a wide scene), to size it to its panel
_BOX_ASPECT_ON_SCREEN = 1.5
#: sides of a cylinder drawn as a prism
CYLINDER_SIDES = 40

_COLORS = {
    "raw": "#8e44ad",
    "smoothed": "#1f77b4",
    "flown": "#ff7f0e",
    "start": "#2ca02c",
    "goal": "#d62728",
    "via": "#17becf",
    "margin": "#444444",
    "fence_exclusion": "#d62728",
    "fence_inclusion": "#2ca02c",
    "bounds": "#777777",
    "track": "#e377c2",
    "survey": "#2ca02c",
    "photo": "#1f77b4",
}
_OBSTACLE_CMAP = "Greys"
_LIGHT_XY = np.array([-0.55, -0.83])  # walls facing south-west are lit
_OBSTACLE_SHADES = (0.25, 0.7)  # the part of the colour map used, low to high obstacles


@dataclass(frozen=True)
class Scene:
    """What a picture shows besides the route: plain values in one ENU frame (metres).

    ``obstacles``: :mod:`uavplan.obstacles` values or footprints (kept as footprints);
    ``start_enu`` / ``goal_enu``: ``(x, y, z)``. ``scene_for`` makes one
    from a scene.
    """

    name: str
    bounds: Bounds
    obstacles: Sequence[Obstacle | Footprint]
    safety_margin_m: float
    start_enu: tuple[float, float, float]
    goal_enu: tuple[float, float, float]
    #: the ground over the bounds, ``(x (nx,), y (ny,), z (ny, nx))``, or None (flat, z = 0)
    terrain: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None
    #: the route's via points ``(x, y, z)`` in order (the scenario's ``via``)
    via_enu: tuple[tuple[float, float, float], ...] = ()
    #: over terrain: z is metres above this altitude AMSL (the site's datum); the picture
    #: labels heights AMSL, never in the datum
    datum_amsl_m: float | None = None
    #: over terrain: each obstacle's height above the ground it stands on (the scenario's
    #: own values), by obstacle index: what the colours and the colour bar show
    heights_agl_m: tuple[float, ...] | None = None
    #: airspace zones: obstacle index → the label written on it in the top view (the zone's
    #: name, floor and ceiling), on the first solid of each zone
    zone_labels: Mapping[int, str] = field(default_factory=dict)
    #: False for a survey, which starts and ends at the start: no goal is drawn
    has_goal: bool = True

    def __post_init__(self) -> None:
        object.__setattr__(self, "obstacles", footprints_of(self.obstacles))

    @property
    def footprints(self) -> tuple[Footprint, ...]:
        return footprints_of(self.obstacles)

    def shown_height(self, fp: Footprint) -> float:
        """The height an obstacle is coloured by: above the ground it stands on."""
        if self.heights_agl_m is not None and 0 <= fp.index < len(self.heights_agl_m):
            return float(self.heights_agl_m[fp.index])
        return float(fp.height_m)


@dataclass(frozen=True)
class FenceOutline:
    """A geofence zone in the scenario's ENU frame: a polygon ``(k, 2)`` or a circle."""

    inclusion: bool
    polygon_enu: NDArray[np.float64] | None = None
    circle_enu: tuple[float, float, float] | None = None  # x, y, radius


@dataclass(frozen=True)
class RouteLayers:
    """What to draw over the scenario (every layer optional). Points are ENU metres ``(n, 3)``.

    ``raw_path_enu``: the planner's best node polyline; ``smoothed_path_enu``: the final
    smooth curve; ``flown_enu``: the polyline the autopilot flies through the mission items;
    ``waypoints_enu``: the mission's positions (marked along the flown route);
    ``track_enu``: a flown (or simulated) track, sample by sample.
    """

    raw_path_enu: NDArray[np.float64] | None = None
    smoothed_path_enu: NDArray[np.float64] | None = None
    flown_enu: NDArray[np.float64] | None = None
    waypoints_enu: NDArray[np.float64] | None = None
    fence: tuple[FenceOutline, ...] = field(default_factory=tuple)
    track_enu: NDArray[np.float64] | None = None
    #: a survey's area outline ``(k, 2)``, its photos ``(n, 2)`` and their image footprints
    #: on the ground ``(n, 4, 2)`` (top view only)
    survey_area_xy: NDArray[np.float64] | None = None
    photos_xy: NDArray[np.float64] | None = None
    photo_footprints_xy: NDArray[np.float64] | None = None

    @classmethod
    def from_mission(
        cls, plan: MissionPlan, frame: EnuFrame, flown_enu: NDArray[np.float64] | None = None
    ) -> RouteLayers:
        """The route a mission flies (and its geofence), in ``frame``: ``flown_enu`` when
        the caller has it (over terrain it comes with the ground), else the items read over
        flat ground (:func:`~uavplan.mission.builder.mission_polyline_enu`).

        Raises ``ValueError`` if an item's altitude cannot be placed (AMSL without a home).
        """
        items = mission_polyline_enu(plan, frame)
        flown = items if flown_enu is None else flown_enu
        waypoints = _on_waypoints(flown, items)
        waypoints = waypoints[1:] if plan.home is not None else waypoints
        return cls(flown_enu=flown, waypoints_enu=waypoints, fence=_fence_outlines(plan, frame))

    @classmethod
    def from_route(cls, route: PlannedRoute, fence: FenceBuild | None = None) -> RouteLayers:
        """A route that was just planned: its raw and smoothed paths and its flown line (in
        the route's own frame, nothing rebuilt from mission items), and the fence built for
        it (its ENU zones)."""
        return cls(
            raw_path_enu=route.raw_path_enu,
            smoothed_path_enu=route.path_enu,
            flown_enu=route.flown_enu,
            waypoints_enu=_on_waypoints(route.flown_enu, route.waypoints_enu)[1:],
            fence=() if fence is None else _build_outlines(fence),
        )


def _on_waypoints(flown: NDArray[np.float64], waypoints: NDArray[np.float64]) -> Any:
    """The points of a flown line that stand over a waypoint (a leg flown over the ground,
    sampled densely, is marked at its ends only; a line of straight legs at every point)."""
    if len(flown) <= len(waypoints) + 3:
        return flown
    d = np.min(np.linalg.norm(flown[:, None, :2] - waypoints[None, :, :2], axis=2), axis=1)
    return flown[d < 0.01]


def _build_outlines(fence: FenceBuild) -> tuple[FenceOutline, ...]:
    """A fence build's zones in ENU, in the fence's order: polygons first, then circles."""
    zones = [z for z in fence.zones if z.status is ZoneStatus.EXCLUDED]
    out = [FenceOutline(True, polygon_enu=fence.inclusion_enu)]
    out += [
        FenceOutline(False, polygon_enu=z.polygon_enu) for z in zones if z.polygon_enu is not None
    ]
    out += [FenceOutline(False, circle_enu=z.circle_enu) for z in zones if z.circle_enu is not None]
    return tuple(out)


def _fence_outlines(plan: MissionPlan, frame: EnuFrame) -> tuple[FenceOutline, ...]:
    out: list[FenceOutline] = []
    for poly in plan.fence.polygons:
        lat, lon = np.asarray(poly.vertices, dtype=np.float64).T
        out.append(FenceOutline(poly.inclusion, polygon_enu=frame.to_enu_xy(lat, lon)))
    for circle in plan.fence.circles:
        ((x, y),) = frame.to_enu_xy([circle.center[0]], [circle.center[1]])
        out.append(FenceOutline(circle.inclusion, circle_enu=(float(x), float(y), circle.radius_m)))
    return tuple(out)


# ---------------------------------------------------------------------------------------------


def render_scene(
    scene: Scene,
    output: str | os.PathLike[str],
    layers: RouteLayers | None = None,
    *,
    width_px: int = DEFAULT_WIDTH_PX,
    height_px: int = DEFAULT_HEIGHT_PX,
    dpi: int = DEFAULT_DPI,
    title: str | None = None,
    subtitle: str | None = None,
) -> None:
    """Draw ``scene`` (and ``layers``) into the PNG file ``output``, exactly
    ``width_px`` × ``height_px`` pixels.

    Raises ``ValueError`` for a size below 200 × 150 px or a non-positive dpi,
    :class:`~uavplan.fileio.OutputFileError` (an ``OSError``) if the file cannot be written;
    the file is written atomically.
    """
    png = render_png(
        scene, layers, width_px=width_px, height_px=height_px, dpi=dpi, title=title,
        subtitle=subtitle,
    )  # fmt: skip
    atomic_write_bytes(output, png)


def render_png(
    scene: Scene,
    layers: RouteLayers | None = None,
    *,
    width_px: int = DEFAULT_WIDTH_PX,
    height_px: int = DEFAULT_HEIGHT_PX,
    dpi: int = DEFAULT_DPI,
    title: str | None = None,
    subtitle: str | None = None,
) -> bytes:
    """The PNG file :func:`render_scene` writes, as bytes (a command writes it with its
    other outputs, :mod:`uavplan.app.outputs`)."""
    fig = draw_scene(
        scene, layers, width_px=width_px, height_px=height_px, dpi=dpi, title=title,
        subtitle=subtitle,
    )  # fmt: skip
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    return buf.getvalue()


def draw_scene(
    scene: Scene,
    layers: RouteLayers | None = None,
    *,
    width_px: int = DEFAULT_WIDTH_PX,
    height_px: int = DEFAULT_HEIGHT_PX,
    dpi: int = DEFAULT_DPI,
    title: str | None = None,
    subtitle: str | None = None,
) -> Any:
    """The matplotlib Figure :func:`render_scene` saves (see there)."""
    if width_px < 200 or height_px < 150:
        raise ValueError(f"picture size must be at least 200x150 px, got {width_px}x{height_px}")
    if dpi <= 0:
        raise ValueError(f"dpi must be positive, got {dpi}")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    layers = layers or RouteLayers()
    footprints = scene.footprints
    heights = [scene.shown_height(fp) for fp in footprints] or [1.0]
    shade = _HeightShade(min(heights), max(heights))

    fig = Figure(figsize=(width_px / dpi, height_px / dpi), dpi=dpi)
    FigureCanvasAgg(fig)
    # Text and lines follow the picture's size (in inches: --dpi makes them larger).
    scale = min(width_px / dpi / 16.0, height_px / dpi / 8.0) ** 0.5
    px = scale * dpi / 100.0  # pixels per pixel of the 1600x800 design
    header = ((72 if subtitle else 48) * px) / height_px
    side_by_side = width_px / height_px >= 1.5
    columns = 5 if side_by_side else 3
    rows = -(-len(_legend_handles(scene, layers, scale)) // columns)
    # under the top view: its tick labels (8 pt) and x label (9 pt) with their pads, then
    # the legend's rows
    labels_px = ((8.0 + 9.0) * scale + 12.0) * dpi / 72.0
    footer = ((22 + 20 * rows) * px + labels_px) / height_px
    if side_by_side:
        grid = fig.add_gridspec(
            1,
            2,
            width_ratios=(1.3, 1.0),
            left=0.0,
            right=0.92,
            bottom=footer,
            top=1.0 - header,
            wspace=0.3,
        )
        ax3d = fig.add_subplot(grid[0, 0], projection="3d")
        ax2d = fig.add_subplot(grid[0, 1])
    else:  # a tall picture: the 3-D view above the top view
        grid = fig.add_gridspec(
            2,
            1,
            height_ratios=(1.4, 1.0),
            left=0.08,
            right=0.95,
            bottom=footer,
            top=1.0 - header,
            hspace=0.15,
        )
        ax3d = fig.add_subplot(grid[0, 0], projection="3d")
        ax2d = fig.add_subplot(grid[1, 0])
    # mplot3d draws its box in a square of the panel's shorter side; zoom it to fill the
    # panel (its artists are not clipped, so a little overflow into the margins is fine).
    cell = ax3d.get_position(original=True)
    cell_w, cell_h = cell.width * width_px, cell.height * height_px
    side = min(cell_w, cell_h)
    zoom = min(cell_w / side, _BOX_ASPECT_ON_SCREEN * cell_h / side) / 1.05
    _draw_3d(ax3d, scene, footprints, layers, shade, scale, zoom)
    mappable = _draw_top(ax2d, scene, footprints, layers, shade, scale)
    # the colour bar rides on the top view (whatever its aspect leaves of the panel)
    bar = fig.colorbar(mappable, cax=ax2d.inset_axes((1.03, 0.0, 0.03, 1.0)))
    over_terrain = scene.datum_amsl_m is not None
    bar.set_label(
        "obstacle height above the ground (m)" if over_terrain else "obstacle height (m)",
        fontsize=9 * scale,
    )
    bar.ax.tick_params(labelsize=8 * scale)

    handles = _legend_handles(scene, layers, scale)
    fig.legend(
        handles=handles,
        loc="lower center",
        ncol=min(len(handles), columns),
        fontsize=9 * scale,
        frameon=False,
        bbox_to_anchor=(0.5, 0.0),
    )
    fig.text(
        0.5,
        1.0 - 6 * px / height_px,
        title or scene.name,
        ha="center",
        va="top",
        fontsize=14 * scale,
    )
    if subtitle:
        fig.text(
            0.5,
            1.0 - 34 * px / height_px,
            subtitle,
            ha="center",
            va="top",
            fontsize=10 * scale,
        )
    return fig


_TERRAIN_CMAP = "gist_earth"


class _HeightShade:
    """Obstacle colour from its height (a slice of a grey colour map)."""

    def __init__(self, low_m: float, high_m: float) -> None:
        from matplotlib import colormaps
        from matplotlib.colors import LinearSegmentedColormap, Normalize

        base = colormaps[_OBSTACLE_CMAP]
        lo, hi = _OBSTACLE_SHADES
        self.cmap = LinearSegmentedColormap.from_list(
            "obstacles", base(np.linspace(lo, hi, 64)), N=64
        )
        if high_m - low_m < 1e-9:
            low_m, high_m = low_m - 1.0, high_m + 1.0
        self.norm = Normalize(low_m, high_m)

    def __call__(self, height_m: float) -> Any:
        return self.cmap(self.norm(height_m))


def _outline(fp: Footprint) -> NDArray[np.float64]:
    return fp.outline_enu(CYLINDER_SIDES)


def _margin_outline(fp: Footprint, margin_m: float) -> NDArray[np.float64]:
    if fp.is_circle:
        assert fp.center_enu is not None and fp.radius_m is not None
        return Footprint(
            fp.index,
            fp.kind,
            fp.height_m,
            center_enu=fp.center_enu,
            radius_m=fp.radius_m + margin_m,
        ).outline_enu(72)
    # the true rounded offset (a concave footprint keeps its notch); a picture, not a fence
    return round_offset_outline(_outline(fp), margin_m)[0]


def _draw_3d(
    ax: Any,
    scene: Scene,
    footprints: Sequence[Footprint],
    layers: RouteLayers,
    shade: _HeightShade,
    scale: float,
    zoom: float,
) -> None:
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]

    ax.computed_zorder = False  # the route stays visible behind the obstacles
    faces: list[NDArray[np.float64]] = []
    face_colors: list[Any] = []
    edge_colors: list[Any] = []
    outline = (0.17, 0.17, 0.17, 1.0)
    ceiling = scene.bounds.z_m[1]
    for fp in footprints:
        ring = _outline(fp)
        h = min(fp.height_m, ceiling)  # drawn up to the top of the box, coloured by height
        base = np.asarray(shade(scene.shown_height(fp))[:3])
        nxt = np.roll(ring, -1, axis=0)
        side = nxt - ring
        # outward normals of the walls, lit from the south-west
        normals = np.column_stack((side[:, 1], -side[:, 0]))
        normals /= np.maximum(np.hypot(normals[:, 0], normals[:, 1]), 1e-12)[:, None]
        light = np.clip(normals @ _LIGHT_XY, 0.0, 1.0)
        for a, b, lit in zip(ring, nxt, light, strict=True):
            faces.append(
                np.array([[a[0], a[1], 0], [b[0], b[1], 0], [b[0], b[1], h], [a[0], a[1], h]])
            )
            color = (*(base * (0.7 + 0.3 * lit)), 1.0)
            face_colors.append(color)
            edge_colors.append(color if fp.is_circle else outline)  # no seams on cylinders
        faces.append(np.column_stack((ring, np.full(len(ring), h))))
        face_colors.append((*np.minimum(base * 1.1, 1.0), 1.0))
        edge_colors.append(outline)
    if faces:
        # One collection, sorted by depth: obstacles hide each other correctly.
        solids = Poly3DCollection(
            faces, facecolors=face_colors, edgecolors=edge_colors, linewidths=0.35 * scale
        )
        solids.set_zorder(1)
        solids.set_clip_on(False)  # the zoomed box may reach past the axes' frame
        if "autolim" in inspect.signature(ax.add_collection3d).parameters:
            ax.add_collection3d(solids, autolim=False)  # matplotlib >= 3.9
        else:  # 3.8 has no autolim and leaves the 3-D limits alone anyway
            ax.add_collection3d(solids)

    if scene.terrain is not None:
        gx, gy, gz = scene.terrain
        surface = ax.plot_surface(
            *np.meshgrid(gx, gy), gz, cmap=_TERRAIN_CMAP, alpha=0.55, linewidth=0,
            antialiased=False, rcount=60, ccount=60,
        )  # fmt: skip
        surface.set_zorder(0)

    _draw_paths(ax, layers, scale, three_d=True)
    _start_goal(ax, scene, scale, three_d=True)

    (x0, x1), (y0, y1), (z0, z1) = scene.bounds.x_m, scene.bounds.y_m, scene.bounds.z_m
    if scene.terrain is not None:  # from just below the lowest ground
        z0 = max(z0, float(np.min(scene.terrain[2])) - 10.0)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_zlim(z0, z1)
    wide = max(x1 - x0, y1 - y0)
    stretch = max(1.0, MIN_VERTICAL_ASPECT * wide / (z1 - z0))
    ax.set_box_aspect((x1 - x0, y1 - y0, (z1 - z0) * stretch), zoom=zoom)
    ax.view_init(elev=27, azim=-58)
    fs = 8 * scale
    ax.set_xlabel("x east (m)", fontsize=fs, labelpad=2)
    ax.set_ylabel("y north (m)", fontsize=fs, labelpad=2)
    zlabel = "z up (m" if scene.datum_amsl_m is None else "altitude (m AMSL"
    zlabel += ")" if stretch < 1.05 else f", ×{stretch:.1f})"
    ax.set_zlabel(zlabel, fontsize=fs, labelpad=2)
    if scene.datum_amsl_m is not None:  # heights in the datum frame, labelled AMSL
        from matplotlib.ticker import FuncFormatter

        datum = scene.datum_amsl_m
        ax.zaxis.set_major_formatter(FuncFormatter(lambda z, _: f"{z + datum:.0f}"))
    ax.tick_params(labelsize=7 * scale, pad=0)


def _draw_top(
    ax: Axes,
    scene: Scene,
    footprints: Sequence[Footprint],
    layers: RouteLayers,
    shade: _HeightShade,
    scale: float,
) -> Any:
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Circle, Polygon, Rectangle

    (x0, x1), (y0, y1) = scene.bounds.x_m, scene.bounds.y_m
    if scene.terrain is not None:
        gx, gy, gz = scene.terrain
        ax.contourf(gx, gy, gz, levels=16, cmap=_TERRAIN_CMAP, alpha=0.45, zorder=-1)
        datum = scene.datum_amsl_m or 0.0
        lines = ax.contour(gx, gy, gz, levels=8, colors="0.45", linewidths=0.4 * scale, zorder=-1)
        ax.clabel(lines, fontsize=6 * scale, fmt=lambda z: f"{z + datum:.0f}")  # m AMSL
    ax.add_patch(
        Rectangle(
            (x0, y0),
            x1 - x0,
            y1 - y0,
            fill=False,
            ls="--",
            lw=0.8 * scale,
            ec=_COLORS["bounds"],
            zorder=0,
        )
    )
    margin = scene.safety_margin_m
    if footprints:  # collections: hundreds of buildings draw fast
        ax.add_collection(
            PolyCollection(
                [_outline(fp) for fp in footprints],
                facecolors=[shade(scene.shown_height(fp)) for fp in footprints],
                edgecolors="#222222",
                linewidths=0.5 * scale,
                zorder=2,
            ),
            autolim=False,
        )
        if margin > 0:
            ax.add_collection(
                PolyCollection(
                    [_margin_outline(fp, margin) for fp in footprints],
                    facecolors="none",
                    edgecolors=_COLORS["margin"],
                    linestyles=[(0, (3, 2))],
                    linewidths=0.7 * scale,
                    zorder=1,
                ),
                autolim=False,
            )
    if 0 < len(footprints) <= MAX_LABELLED_OBSTACLES:
        from matplotlib import patheffects

        halo = [patheffects.withStroke(linewidth=2.0 * scale, foreground="white")]
        for fp in footprints:
            cx, cy = _outline(fp).mean(axis=0)
            ax.text(
                cx,
                cy,
                str(fp.index),
                ha="center",
                va="center",
                fontsize=7.5 * scale,
                color="black",
                zorder=3,
                path_effects=halo,
            )
    if scene.zone_labels:  # airspace zones: name, floor and ceiling, inside the flight area
        from matplotlib import patheffects

        halo = [patheffects.withStroke(linewidth=2.0 * scale, foreground="white")]
        (bx0, bx1), (by0, by1) = scene.bounds.x_m, scene.bounds.y_m
        for fp in footprints:
            label = scene.zone_labels.get(fp.index)
            if label is None:
                continue
            ring = _outline(fp)
            inside = ring[(ring[:, 0] >= bx0) & (ring[:, 0] <= bx1)]
            inside = inside[(inside[:, 1] >= by0) & (inside[:, 1] <= by1)]
            cx, cy = (inside if len(inside) else ring).mean(axis=0)
            cx, cy = min(max(cx, bx0), bx1), min(max(cy, by0), by1)
            ax.text(
                cx,
                cy,
                label,
                ha="center",
                va="center",
                fontsize=6.5 * scale,
                color="#8b0000",
                zorder=4,
                path_effects=halo,
            )
    for zone in layers.fence:
        color = _COLORS["fence_inclusion" if zone.inclusion else "fence_exclusion"]
        style = {"fill": False, "ec": color, "lw": 0.9 * scale, "ls": "-.", "zorder": 3}
        if zone.polygon_enu is not None:
            ax.add_patch(Polygon(zone.polygon_enu, closed=True, **style))
        elif zone.circle_enu is not None:
            x, y, r = zone.circle_enu
            ax.add_patch(Circle((x, y), r, **style))

    _draw_survey(ax, layers, scale)
    _draw_paths(ax, layers, scale, three_d=False)
    _start_goal(ax, scene, scale, three_d=False)

    pad = 0.02 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)", fontsize=8 * scale)
    ax.set_ylabel("y north (m)", fontsize=8 * scale)
    ax.tick_params(labelsize=7 * scale)
    ax.grid(True, lw=0.3, alpha=0.4)
    ax.set_title(f"top view (dashed: {margin:g} m safety margin)", fontsize=11 * scale)
    mappable = ScalarMappable(norm=shade.norm, cmap=shade.cmap)
    mappable.set_array([])
    return mappable


def _draw_survey(ax: Any, layers: RouteLayers, scale: float) -> None:
    """A survey's area, its photos' footprints and its photo positions (under the route)."""
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Polygon

    if layers.photo_footprints_xy is not None and len(layers.photo_footprints_xy):
        ax.add_collection(
            PolyCollection(
                list(layers.photo_footprints_xy),
                facecolors=_COLORS["photo"],
                edgecolors=_COLORS["photo"],
                alpha=0.06,
                linewidths=0.3 * scale,
                zorder=1,
            )
        )
    if layers.survey_area_xy is not None:
        ax.add_patch(
            Polygon(
                layers.survey_area_xy,
                closed=True,
                fill=False,
                lw=1.6 * scale,
                ec=_COLORS["survey"],
                zorder=4,
            )
        )
    if layers.photos_xy is not None and len(layers.photos_xy):
        ax.scatter(*layers.photos_xy.T, s=2.5 * scale, color=_COLORS["photo"], zorder=4.5)


def _draw_paths(ax: Any, layers: RouteLayers, scale: float, *, three_d: bool) -> None:
    """Raw path, smoothed path, flown route and waypoints, in that order (on top)."""
    dims = 3 if three_d else 2
    lw = 1.0 * scale
    # 3-D artists are not clipped: the zoomed box may reach past the axes' frame
    common: dict[str, Any] = {"clip_on": not three_d}
    if layers.raw_path_enu is not None:
        p = layers.raw_path_enu[:, :dims].T
        ax.plot(*p, ":", color=_COLORS["raw"], lw=1.2 * lw, zorder=5, **common)
    if layers.smoothed_path_enu is not None:
        p = layers.smoothed_path_enu[:, :dims].T
        ax.plot(
            *p,
            "-",
            color=_COLORS["smoothed"],
            lw=4 * lw,
            alpha=0.55,
            zorder=6,
            solid_capstyle="round",
            **common,
        )
    if layers.flown_enu is not None:
        p = layers.flown_enu[:, :dims].T
        ax.plot(*p, "-", color=_COLORS["flown"], lw=1.1 * lw, zorder=7, **common)
    if layers.waypoints_enu is not None and len(layers.waypoints_enu):
        p = layers.waypoints_enu[:, :dims].T
        extra = {"depthshade": False} if three_d else {}
        ax.scatter(*p, s=9 * scale, color=_COLORS["flown"], zorder=8, **common, **extra)
    if layers.track_enu is not None and len(layers.track_enu):
        p = layers.track_enu[:, :dims].T
        ax.plot(*p, "--", color=_COLORS["track"], lw=1.0 * lw, zorder=8.5, **common)


def _start_goal(ax: Any, scene: Scene, scale: float, *, three_d: bool) -> None:
    size = 90 * scale
    for number, point in enumerate(scene.via_enu, start=1):
        coords = point if three_d else point[:2]
        kwargs_via: dict[str, Any] = {"depthshade": False} if three_d else {}
        ax.scatter(
            *[[c] for c in coords],
            marker="D",
            s=size * 0.55,
            color=_COLORS["via"],
            edgecolors="black",
            linewidths=0.6,
            zorder=9,
            clip_on=not three_d,
            **kwargs_via,
        )
        if not three_d:  # numbered in the top view: the order the route takes them
            ax.annotate(
                str(number),
                point[:2],
                xytext=(5 * scale, 5 * scale),
                textcoords="offset points",
                fontsize=8 * scale,
                zorder=10,
            )
    ends = [(scene.start_enu, "^", "start")]
    if scene.has_goal:
        ends.append((scene.goal_enu, "*", "goal"))
    for point, marker, key in ends:
        coords = point if three_d else point[:2]
        kwargs: dict[str, Any] = {"depthshade": False} if three_d else {}
        ax.scatter(
            *[[c] for c in coords],
            marker=marker,
            s=size * (1.6 if marker == "*" else 1.0),
            color=_COLORS[key],
            edgecolors="black",
            linewidths=0.6,
            zorder=9,
            clip_on=not three_d,
            **kwargs,
        )


def _legend_handles(scene: Scene, layers: RouteLayers, scale: float) -> list[Any]:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    lw = 1.0 * scale
    handles: list[Any] = [
        Patch(fc="#9a9a9a", ec="#222222", label="obstacle"),
        *(
            [Line2D([], [], color="0.45", lw=0.6, label="ground contours (m AMSL)")]
            if scene.terrain is not None
            else []
        ),
        Line2D(
            [],
            [],
            ls=(0, (3, 2)),
            color=_COLORS["margin"],
            lw=0.8,
            label=f"safety margin ({scene.safety_margin_m:g} m)",
        ),
    ]
    if layers.raw_path_enu is not None:
        handles.append(
            Line2D(
                [],
                [],
                ls=":",
                color=_COLORS["raw"],
                lw=1.4 * lw,
                label="raw best path (planner nodes)",
            )
        )
    if layers.smoothed_path_enu is not None:
        handles.append(
            Line2D([], [], color=_COLORS["smoothed"], lw=4 * lw, alpha=0.55, label="smoothed path")
        )
    if layers.flown_enu is not None:
        handles.append(
            Line2D(
                [],
                [],
                color=_COLORS["flown"],
                lw=1.1 * lw,
                marker="o",
                markersize=3.5,
                label="mission waypoints (flown route)",
            )
        )
    if layers.track_enu is not None:
        handles.append(
            Line2D([], [], ls="--", color=_COLORS["track"], lw=1.0 * lw, label="flown track")
        )
    if layers.survey_area_xy is not None:
        handles.append(Line2D([], [], color=_COLORS["survey"], lw=1.6 * lw, label="survey area"))
    if layers.photos_xy is not None:
        n = len(layers.photos_xy)
        handles.append(
            Line2D(
                [],
                [],
                ls="",
                marker="o",
                markersize=2.5,
                color=_COLORS["photo"],
                label=f"photos as flown ({n:,})",
            )
        )
    if layers.photo_footprints_xy is not None:
        handles.append(Patch(fc=_COLORS["photo"], alpha=0.25, label="photo footprints"))
    if any(not z.inclusion for z in layers.fence):
        handles.append(
            Line2D(
                [],
                [],
                ls="-.",
                color=_COLORS["fence_exclusion"],
                lw=1.0,
                label="geofence exclusion",
            )
        )
    if any(z.inclusion for z in layers.fence):
        handles.append(
            Line2D(
                [],
                [],
                ls="-.",
                color=_COLORS["fence_inclusion"],
                lw=1.0,
                label="geofence inclusion",
            )
        )
    handles.append(
        Line2D(
            [],
            [],
            ls="",
            marker="^",
            color=_COLORS["start"],
            mec="black",
            markersize=8,
            label="start",
        )
    )
    if scene.via_enu:
        handles.append(
            Line2D(
                [],
                [],
                ls="",
                marker="D",
                color=_COLORS["via"],
                mec="black",
                markersize=6,
                label="via point (in order)",
            )
        )
    if scene.has_goal:
        handles.append(
            Line2D(
                [],
                [],
                ls="",
                marker="*",
                color=_COLORS["goal"],
                mec="black",
                markersize=11,
                label="goal",
            )
        )
    return handles


def route_subtitle(route: PlannedRoute, *, algorithm: str, seed: int, energy: float) -> str:
    """One line describing a planned route (algorithm, seed, length, energy, clearance)."""
    return (
        f"{algorithm}, seed {seed}: {route.length_m:.0f} m from start to goal, "
        f"energy {energy:.1f}, min clearance {route.min_clearance_m:.2f} m "
        f"(margin {route.safety_margin_m:g} m)"
    )


def scene_for(scenario: Scenario) -> Scene:
    """The plain values a picture of ``scenario`` draws (obstacles, bounds, margin, ends)."""
    scene = _scene(scenario.name, scenario.site, scenario.safety_margin_m, scenario.obstacles)
    if scenario.airspace is None:
        return scene
    return replace(scene, zone_labels=scenario.airspace.picture_labels())


def _scene(name: str, site: Site, margin_m: float, written: Sequence[Obstacle]) -> Scene:
    """``written``: the obstacles as the file gives them (over terrain, their heights above
    the ground, which the picture's colour bar shows)."""
    sx, sy, sz = (float(v) for v in site.start_m)
    gx, gy, gz = (float(v) for v in site.goal_m)
    terrain = None
    if site.ground is not None:
        (x0, x1), (y0, y1) = site.bounds.x_m, site.bounds.y_m
        xs, ys = np.linspace(x0, x1, 80), np.linspace(y0, y1, 80)
        grid = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
        terrain = (xs, ys, site.ground.z_at(grid).reshape(len(ys), len(xs)))
    return Scene(
        name=name,
        bounds=site.bounds,
        obstacles=site.obstacles,
        safety_margin_m=margin_m,
        start_enu=(sx, sy, sz),
        goal_enu=(gx, gy, gz),
        terrain=terrain,
        via_enu=tuple((float(x), float(y), float(z)) for x, y, z in site.via_m),
        datum_amsl_m=site.datum_amsl_m,
        heights_agl_m=None if site.ground is None else tuple(float(o.height_m) for o in written),
    )


def scene_around(around: Surroundings) -> Scene:
    """The picture's scene of a scenario file whose route points are not valid (``render
    --no-plan``): its obstacles, bounds and terrain, and the points where the file puts them."""
    from uavplan.scenario.site import flat_site, terrain_site

    assert around.start_m is not None and around.goal_m is not None
    args = (around.origin, around.bounds, around.start_m, around.goal_m, around.via_m)
    if around.terrain is None:
        site = flat_site(*args, around.obstacles, around.safety_margin_m)
    else:
        site = terrain_site(*args, around.obstacles, around.safety_margin_m, around.terrain)
    return _scene(around.name, site, around.safety_margin_m, around.obstacles)
