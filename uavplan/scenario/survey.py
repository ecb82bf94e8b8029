"""The ``survey:`` section of a scenario, checked key by key (one ScenarioError naming the
file, the key path and the reason; exit 2).

```yaml
survey:
  area: [[0, 0], [800, 0], [800, 500], [0, 500]]   # ENU metres; or area_file: field.geojson
  # or a corridor scan: corridor: [[0, 0], [500, 100], ...] and width_m: 60
  exclude: [[[300, 200], [400, 200], [400, 300]]]   # optional no-fly holes (ENU polygons)
  altitude: 60              # height above the ground (m); or gsd_cm with a camera
  lane_spacing_m: 30        # or a camera and the side overlap
  camera: {sensor_width_mm: 13.2, sensor_height_mm: 8.8, image_width_px: 5472,
           image_height_px: 3648, focal_length_mm: 8.8, orientation: landscape}
  gsd_cm: 2.0
  front_overlap_pct: 70
  side_overlap_pct: 70
  angle_deg: auto           # or a lane direction, degrees CCW from east
  trigger: distance         # or hover
```

Either ``lane_spacing_m`` with ``altitude`` (the trigger distance is then the lane spacing),
or a ``camera`` with ``gsd_cm`` or ``altitude`` and the overlaps (QGroundControl's
CameraCalc: :mod:`uavplan.survey.camera`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal, Protocol, TypeVar

import numpy as np
import shapely.geometry.polygon
from shapely.geometry import Polygon

from uavplan.config import short_repr, type_name
from uavplan.obstacles import PrismObstacle
from uavplan.scenario.checker import Checker, join
from uavplan.scenario.limits import MAX_ALTITUDE_M
from uavplan.survey.camera import Camera, Spacing, camera_spacing, plain_spacing

if TYPE_CHECKING:
    from uavplan.obstacles import Bounds, Obstacle
    from uavplan.scenario.settings import ObstacleSources

_KEYS = {
    "area",
    "area_file",
    "corridor",
    "width_m",
    "exclude",
    "altitude",
    "lane_spacing_m",
    "camera",
    "gsd_cm",
    "front_overlap_pct",
    "side_overlap_pct",
    "angle_deg",
    "trigger",
}
_CAMERA_KEYS = {
    "sensor_width_mm",
    "sensor_height_mm",
    "image_width_px",
    "image_height_px",
    "focal_length_mm",
    "orientation",
}
#: at most this many vertices in the area and in each excluded polygon
MAX_POLYGON_POINTS = 10_000
#: at most this many excluded polygons
MAX_EXCLUDES = 1_000

Trigger = Literal["distance", "hover"]


class _Obstructed(Protocol):
    """A Scenario or the Surroundings of one: what :func:`with_no_fly` adds holes to."""

    @property
    def bounds(self) -> Bounds: ...
    @property
    def obstacles(self) -> tuple[Obstacle, ...]: ...
    @property
    def obstacle_sources(self) -> ObstacleSources: ...


_Site = TypeVar("_Site", bound=_Obstructed)
#: reads ``area_file``'s value (key path for messages): the area's outer ring and its holes
#: (ENU m); raises the checker's failure itself
AreaReader = Callable[[Any, str], tuple[tuple[tuple[float, float], ...], list[Any]]]


@dataclass(frozen=True)
class SurveySpec:
    """A checked ``survey:`` section (ENU metres; heights above the ground)."""

    area_m: tuple[tuple[float, float], ...]
    exclude_m: tuple[tuple[tuple[float, float], ...], ...]
    spacing: Spacing
    #: lane direction, degrees CCW from east; None: ``auto`` (the least energy)
    angle_deg: float | None
    trigger: Trigger
    camera: Camera | None = None
    #: a corridor scan: the polyline (ENU m) its lanes follow, and the strip's width (m);
    #: ``area_m`` is then the strip
    corridor_m: tuple[tuple[float, float], ...] | None = None
    width_m: float | None = None

    @property
    def altitude_m(self) -> float:
        return self.spacing.altitude_m


def _points(chk: Checker, raw: Any, key: str, least: int) -> tuple[tuple[float, float], ...]:
    """A list of at least ``least`` (and at most MAX_POLYGON_POINTS) ``[x, y]`` points."""
    if not isinstance(raw, list) or len(raw) < least:
        raise chk.fail(
            key, f"must be a list of at least {least} [x, y] points, got {short_repr(raw)}"
        )
    if len(raw) > MAX_POLYGON_POINTS:
        raise chk.fail(key, f"{len(raw):,} points (at most {MAX_POLYGON_POINTS:,})")
    pts = tuple(chk.point(p, f"{key}[{i}]", 2) for i, p in enumerate(raw))
    return tuple((p[0], p[1]) for p in pts)


def _polygon(chk: Checker, raw: Any, key: str) -> tuple[tuple[float, float], ...]:
    xy = _points(chk, raw, key, 3)
    poly = Polygon(xy)
    if not poly.is_valid or poly.area <= 0:
        raise chk.fail(key, "must be a simple polygon with an area (its edges may not cross)")
    return xy


def _camera(chk: Checker, raw: Any, key: str) -> Camera:
    m = chk.mapping(raw, key, _CAMERA_KEYS, sorted(_CAMERA_KEYS - {"orientation"}))
    values: dict[str, float] = {}
    for name in sorted(_CAMERA_KEYS - {"orientation"}):
        v = chk.number(m[name], join(key, name), minimum=0, strict=True)
        if name.endswith("_px") and v != int(v):
            raise chk.fail(join(key, name), f"must be a whole number of pixels, got {v:g}")
        values[name] = v
    orientation = chk.string(
        m.get("orientation", "landscape"), join(key, "orientation"), ("landscape", "portrait")
    )
    return Camera(
        sensor_width_mm=values["sensor_width_mm"],
        sensor_height_mm=values["sensor_height_mm"],
        image_width_px=int(values["image_width_px"]),
        image_height_px=int(values["image_height_px"]),
        focal_length_mm=values["focal_length_mm"],
        orientation="portrait" if orientation == "portrait" else "landscape",
    )


def read_survey(
    chk: Checker, raw: Any, key: str = "survey", *, read_area: AreaReader | None = None
) -> SurveySpec:
    """The ``survey:`` section ``raw`` of the file ``chk`` reads, checked. ``read_area``
    reads an ``area_file`` (the scenario's loader: it knows the file's folder and the ENU
    frame); without it an ``area_file`` is refused."""
    m = chk.mapping(raw, key, _KEYS, ())
    holes_of_file: list[Any] = []
    given = [k for k in ("area", "area_file", "corridor") if k in m]
    if not given:
        raise chk.fail(
            join(key, "area"), "missing required key (or area_file: a GIS file, or corridor)"
        )
    if len(given) > 1:
        raise chk.fail(join(key, given[1]), f"give one of {' / '.join(given)}, not both")
    corridor, width = None, None
    if "width_m" in m and "corridor" not in m:
        raise chk.fail(join(key, "width_m"), "is a corridor's width: give corridor too")
    if "corridor" in m:
        corridor, width, area = _corridor(chk, m, key)
    elif "area" in m:
        area = _polygon(chk, m["area"], join(key, "area"))
    else:
        if read_area is None:
            raise chk.fail(join(key, "area_file"), "is read only in a scenario file")
        ring, holes_of_file = read_area(m["area_file"], join(key, "area_file"))
        area = _polygon(chk, [list(p) for p in ring], join(key, "area_file"))
    ex_raw = m.get("exclude", [])
    if not isinstance(ex_raw, list):
        raise chk.fail(join(key, "exclude"), f"must be a list of polygons, got {type_name(ex_raw)}")
    if len(ex_raw) > MAX_EXCLUDES:
        raise chk.fail(join(key, "exclude"), f"{len(ex_raw):,} polygons (at most {MAX_EXCLUDES:,})")
    exclude = tuple(_polygon(chk, p, f"{join(key, 'exclude')}[{i}]") for i, p in enumerate(ex_raw))
    # the holes of the file's polygon are no-fly holes like exclude's
    exclude += tuple(
        _polygon(chk, [list(p) for p in h], f"{join(key, 'area_file')} (hole {i + 1})")
        for i, h in enumerate(holes_of_file)
    )

    def number(
        name: str, *, minimum: float = 0, strict: bool = True, maximum: float | None = None
    ) -> float | None:
        if name not in m:
            return None
        return chk.number(m[name], join(key, name), minimum=minimum, strict=strict, maximum=maximum)

    altitude = number("altitude", maximum=MAX_ALTITUDE_M)
    gsd = number("gsd_cm")
    lane = number("lane_spacing_m")
    front = number("front_overlap_pct", strict=False, maximum=99)
    side = number("side_overlap_pct", strict=False, maximum=99)
    camera = _camera(chk, m["camera"], join(key, "camera")) if "camera" in m else None
    if camera is None:
        for name in ("gsd_cm", "front_overlap_pct", "side_overlap_pct"):
            if name in m:
                raise chk.fail(join(key, name), "needs a camera (survey.camera)")
        if altitude is None or lane is None:
            missing = "altitude" if altitude is None else "lane_spacing_m"
            raise chk.fail(
                join(key, missing),
                "missing required key (without a camera a survey needs altitude and "
                "lane_spacing_m)",
            )
        spacing = plain_spacing(altitude, lane)
    else:
        if lane is not None:
            raise chk.fail(
                join(key, "lane_spacing_m"),
                "comes from the camera and side_overlap_pct: give one or the other",
            )
        if (altitude is None) == (gsd is None):
            raise chk.fail(key, "with a camera give exactly one of altitude and gsd_cm")
        spacing = camera_spacing(
            camera,
            altitude_m=altitude,
            gsd_cm=gsd,
            front_overlap_pct=70.0 if front is None else front,
            side_overlap_pct=70.0 if side is None else side,
        )
        if spacing.altitude_m > MAX_ALTITUDE_M:
            raise chk.fail(
                join(key, "gsd_cm"),
                f"needs an altitude of {spacing.altitude_m:.0f} m (at most {MAX_ALTITUDE_M:g})",
            )
    angle: float | None = None
    raw_angle = m.get("angle_deg", "auto")
    if corridor is not None and raw_angle != "auto":
        raise chk.fail(join(key, "angle_deg"), "a corridor's lanes follow the corridor")
    if raw_angle != "auto":
        if isinstance(raw_angle, str):
            raise chk.fail(
                join(key, "angle_deg"), f"must be auto or a number, got {short_repr(raw_angle)}"
            )
        angle = chk.number(raw_angle, join(key, "angle_deg"), minimum=-360, maximum=360)
    trigger = chk.string(m.get("trigger", "distance"), join(key, "trigger"), ("distance", "hover"))
    return SurveySpec(
        area_m=area,
        exclude_m=exclude,
        spacing=spacing,
        angle_deg=angle,
        trigger="hover" if trigger == "hover" else "distance",
        camera=camera,
        corridor_m=corridor,
        width_m=width,
    )


def _corridor(
    chk: Checker, m: Mapping[str, Any], key: str
) -> tuple[tuple[tuple[float, float], ...], float, tuple[tuple[float, float], ...]]:
    """``corridor`` and ``width_m``: the polyline, the width, and the strip's polygon."""
    from shapely.geometry import LineString

    from uavplan.survey.corridor import strip

    k = join(key, "corridor")
    xy = _points(chk, m["corridor"], k, 2)
    steps = np.hypot(*np.diff(np.asarray(xy), axis=0).T)
    if np.any(steps < 1.0):
        i = int(np.argmax(steps < 1.0))
        raise chk.fail(f"{k}[{i + 1}]", "is less than 1 m from the point before it")
    if not LineString(xy).is_simple:
        raise chk.fail(k, "must not cross itself")
    if "width_m" not in m:
        raise chk.fail(join(key, "width_m"), "missing required key (the corridor's width)")
    width = chk.number(m["width_m"], join(key, "width_m"), minimum=0, strict=True)
    poly = strip(xy, width)
    # a mitred strip's area is the line's length times the width; a strip that overlaps
    # itself (legs closer than the width) is smaller by the overlap
    overlaps = poly.area < 0.97 * LineString(xy).length * width
    if overlaps or poly.geom_type != "Polygon" or len(poly.interiors) or not poly.is_valid:
        raise chk.fail(k, f"its {width:g} m strip overlaps itself (a bend tighter than the width)")
    ring = np.asarray(poly.exterior.coords)[:-1]
    return xy, width, tuple((float(x), float(y)) for x, y in ring)


#: how high the ``exclude`` polygons stand as obstacles above the flight volume's top (m)
NO_FLY_ABOVE_M = 1000.0


def with_no_fly(scn: _Site, spec: SurveySpec) -> _Site:
    """``scn`` with the survey's ``exclude`` polygons standing as obstacles from the ground to
    far above the flight volume (named ``survey.exclude[j] (no-fly)``): no lane, transition
    or return may cross a no-fly hole at any height, and the whole-flight verdict checks the
    margin from them as from a building. ``scn``: a Scenario or the Surroundings of one."""
    if not spec.exclude_m:
        return scn
    height = float(scn.bounds.z_m[1]) + NO_FLY_ABOVE_M
    prisms = []
    for poly in spec.exclude_m:
        ring = shapely.geometry.polygon.orient(Polygon(poly), sign=1.0)
        coords = tuple((float(x), float(y)) for x, y in np.asarray(ring.exterior.coords)[:-1])
        prisms.append(PrismObstacle(coords, height))
    names = tuple(f"survey.exclude[{j}] (no-fly)" for j in range(len(prisms)))
    src = scn.obstacle_sources
    if src.zones_from is None:
        src = replace(src, zones_from=len(scn.obstacles), zone_titles=names)
    else:  # the airspace's solids are the last obstacles: the holes follow them
        src = replace(src, zone_titles=(*src.zone_titles, *names))
    return replace(  # type: ignore[type-var]  # both kinds of site are dataclasses
        scn, obstacles=(*scn.obstacles, *prisms), obstacle_sources=src
    )


__all__ = ["AreaReader", "SurveySpec", "Trigger", "read_survey", "with_no_fly"]
