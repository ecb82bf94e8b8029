"""Reading scenario and map files: :func:`load_scenario` and :func:`load_map`.

A scenario may name a map (``map:``), whose origin, bounds, obstacles and terrain it
inherits where it does not set its own, obstacle files (``obstacle_files:``, read by
:mod:`uavplan.sources`) and a DEM (``terrain:``, read by :mod:`uavplan.sources.dem`). Paths
are relative to the file that names them. The values are checked key by key here
(:mod:`uavplan.scenario.fields`) and as a whole when the
:class:`~uavplan.scenario.values.Scenario` is made (:meth:`Scenario.from_file`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.config import PlannerConfig, type_name
from uavplan.fileio import InputFile
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.obstacles import Bounds, Obstacle
from uavplan.scenario.checker import Checker
from uavplan.scenario.fields import (
    bounds as read_bounds,
)
from uavplan.scenario.fields import (
    map_path as read_map_path,
)
from uavplan.scenario.fields import (
    mission as read_mission,
)
from uavplan.scenario.fields import (
    name as read_name,
)
from uavplan.scenario.fields import (
    obstacles as read_obstacles,
)
from uavplan.scenario.fields import (
    origin as read_origin,
)
from uavplan.scenario.fields import (
    planner as read_planner,
)
from uavplan.scenario.fields import (
    vehicle as read_vehicle,
)
from uavplan.scenario.fields import (
    wind as read_wind,
)
from uavplan.scenario.limits import MAX_OBSTACLES, MAX_SAFETY_MARGIN_M, MAX_VIA_POINTS
from uavplan.scenario.settings import MissionConfig, ObstacleSources, VehicleConfig
from uavplan.scenario.yamlfile import read_yaml

if TYPE_CHECKING:
    from uavplan.scenario.survey import SurveySpec
    from uavplan.scenario.zones import ZoneSet
    from uavplan.sources.dem import Terrain

_SCENARIO_KEYS = {
    "name",
    "origin",
    "bounds",
    "start",
    "goal",
    "via",
    "map",
    "obstacles",
    "safety_margin",
    "vehicle",
    "planner",
    "mission",
    "obstacle_files",
    "terrain",
    "wind",
    "airspace",
    "survey",
}
_MAP_KEYS = {"name", "origin", "bounds", "obstacles", "obstacle_files", "terrain"}


def load_map(path: str | Path) -> tuple[GeoPoint | None, Bounds | None, tuple[Obstacle, ...]]:
    """Read a map file: (origin, bounds, obstacles); missing sections are ``None`` / empty."""
    return _read_map(path)[:3]


def _read_map(
    path: str | Path,
) -> tuple[GeoPoint | None, Bounds | None, tuple[Obstacle, ...], Any, list[InputFile]]:
    """:func:`load_map` plus the map's raw ``terrain`` value (None without one) and the
    obstacle files it read."""
    path = Path(path)
    chk = Checker(str(path))
    raw = read_yaml(path, "map")
    chk.mapping(raw, "", _MAP_KEYS)
    if "name" in raw:
        read_name(chk, raw["name"])
    origin = read_origin(chk, raw["origin"]) if "origin" in raw else None
    bounds = read_bounds(chk, raw["bounds"]) if "bounds" in raw else None
    obstacles = read_obstacles(chk, raw.get("obstacles", []))
    files: list[InputFile] = []
    if raw.get("obstacle_files"):
        if origin is None:
            raise chk.fail("obstacle_files", "needs origin in the same map file")
        obstacles += _obstacle_files(chk, raw["obstacle_files"], path, origin, bounds)
        files = _obstacle_file_inputs(raw["obstacle_files"], path)
    return origin, bounds, obstacles, raw.get("terrain"), files


def _obstacle_file_inputs(raw: Any, path: Path) -> list[InputFile]:
    """The files of an ``obstacle_files`` list that was read (so every entry is valid)."""
    from uavplan.sources.base import ObstacleFileSpec

    if not isinstance(raw, list):
        return []
    return [
        InputFile(str(ObstacleFileSpec.from_mapping(item, path.parent).path),
                  f"an obstacle file of {path}")
        for item in raw
    ]  # fmt: skip


def _obstacle_files(
    chk: Checker, raw: Any, path: Path, origin: GeoPoint, bounds: Bounds | None
) -> tuple[Obstacle, ...]:
    """Obstacles of the ``obstacle_files`` list (OSM, GIS files), paths relative to ``path``.
    The readers' package loads here, for a scenario that names such files (6 ms of imports a
    small scenario's ``validate`` does not pay, ``python -X importtime``)."""
    from uavplan.sources import SourceError, obstacles_from_entries

    try:
        return obstacles_from_entries(raw, path.parent, EnuFrame.at(origin), bounds)
    except SourceError as err:
        raise chk.fail(err.key_path("obstacle_files"), err.reason) from None


def _terrain(chk: Checker, raw: Any, path: Path, origin: GeoPoint, bounds: Bounds) -> Terrain:
    """The ``terrain`` DEM, resolved next to ``path`` and checked to cover the bounds.
    numpy, rasterio and pyproj load here, for a scenario that names a DEM."""
    from uavplan.sources.dem import Terrain, TerrainError

    dem = (path.parent / chk.string(raw, "terrain")).resolve()
    try:
        return Terrain.from_file(dem, EnuFrame.at(origin), area_xy_m=(bounds.x_m, bounds.y_m))
    except TerrainError as err:
        raise chk.fail("terrain", f"{dem.name}: {err.reason}") from None


def read_scenario_file(
    path: str | Path, *, route: bool = True, surveys: bool = False
) -> dict[str, Any]:
    """The values of a scenario file (and of the map it names), checked key by key, as the
    keyword arguments of :class:`~uavplan.scenario.values.Scenario`, which checks them as a
    whole. ``route=False``: ``start`` and ``goal`` may be missing (None then); what the file
    gives is checked key by key all the same (the values of a
    :class:`~uavplan.scenario.values.Surroundings`). ``surveys=True``: a ``survey:``
    section is read into ``survey`` (a :class:`~uavplan.scenario.survey.SurveySpec`; the
    caller pops it) and the goal is the area's corner farthest from the start at the survey
    altitude (so the flight volume's grid spans the area); otherwise a survey is refused."""
    path = Path(path)
    chk = Checker(str(path))
    raw = read_yaml(path, "scenario")
    surveyed = isinstance(raw, dict) and "survey" in raw
    required = (("start",) if surveyed else ("start", "goal")) if route else ()
    chk.mapping(raw, "", _SCENARIO_KEYS, required)

    map_origin = map_bounds = None
    map_obstacles: tuple[Obstacle, ...] = ()
    map_terrain: Any = None
    map_path = path
    map_chk = chk
    # every file read, for the outputs' check that none of them is overwritten
    files = [InputFile(str(path), "the scenario")]
    if "map" in raw:
        map_path = read_map_path(chk, raw["map"], path)
        map_origin, map_bounds, map_obstacles, map_terrain, map_files = _read_map(map_path)
        map_chk = Checker(str(map_path))
        files += [InputFile(str(map_path), f"the map of {path}"), *map_files]

    if "origin" in raw:
        origin = read_origin(chk, raw["origin"])
    elif map_origin is not None:
        origin = map_origin
    else:
        raise chk.fail("origin", "missing required key (not set here nor in the map)")
    if "bounds" in raw:
        bounds = read_bounds(chk, raw["bounds"])
    elif map_bounds is not None:
        bounds = map_bounds
    else:
        raise chk.fail("bounds", "missing required key (not set here nor in the map)")

    spec = None
    if surveyed:
        spec, area_files = _survey(chk, raw, surveys, path, origin)
        files += area_files
    terrain = None
    if "terrain" in raw:
        terrain = _terrain(chk, raw["terrain"], path, origin, bounds)
    elif map_terrain is not None:
        terrain = _terrain(map_chk, map_terrain, map_path, origin, bounds)
    if terrain is not None:
        files.append(InputFile(str(terrain.source), "the DEM (terrain) of " + str(path)))
    inline = read_obstacles(chk, raw.get("obstacles", []))
    obstacles = map_obstacles + inline
    if raw.get("obstacle_files"):
        obstacles += _obstacle_files(chk, raw["obstacle_files"], path, origin, bounds)
        files += _obstacle_file_inputs(raw["obstacle_files"], path)
    if len(obstacles) > MAX_OBSTACLES:
        raise chk.fail(
            "obstacles", f"map and scenario hold {len(obstacles):,} (at most {MAX_OBSTACLES:,})"
        )
    margin = 10.0
    if "safety_margin" in raw:
        margin = chk.number(
            raw["safety_margin"], "safety_margin", minimum=0, maximum=MAX_SAFETY_MARGIN_M
        )
    start = chk.point(raw["start"], "start", 3) if "start" in raw else None
    goal = chk.point(raw["goal"], "goal", 3) if "goal" in raw else None
    if spec is not None:
        for i, (x, y) in enumerate(spec.area_m):
            if not bounds.contains((x, y, spec.altitude_m)):
                if spec.corridor_m is not None:
                    raise chk.fail(
                        "survey.corridor",
                        f"its {spec.width_m:g} m strip reaches [{x:.0f}, {y:.0f}], outside "
                        "the bounds",
                    )
                where = "survey.area_file" if "area_file" in raw["survey"] else "survey.area"
                raise chk.fail(
                    f"{where}[{i}]",
                    f"[{x:g}, {y:g}] at the survey altitude {spec.altitude_m:g} m is outside "
                    "the bounds",
                )
    if spec is not None and start is not None:
        far = max(spec.area_m, key=lambda p: (p[0] - start[0]) ** 2 + (p[1] - start[1]) ** 2)
        goal = (far[0], far[1], spec.altitude_m)
    via_raw = raw.get("via", [])
    if not isinstance(via_raw, list):
        raise chk.fail("via", f"must be a list of [x, y, z] points, got {type_name(via_raw)}")
    if len(via_raw) > MAX_VIA_POINTS:
        raise chk.fail("via", f"{len(via_raw):,} points (at most {MAX_VIA_POINTS:,})")
    via = tuple(chk.point(p, f"via[{i}]", 3) for i, p in enumerate(via_raw))
    name = read_name(chk, raw["name"]) if "name" in raw else path.stem
    vehicle = read_vehicle(chk, raw["vehicle"]) if "vehicle" in raw else VehicleConfig()
    planner = read_planner(chk, raw["planner"]) if "planner" in raw else PlannerConfig()
    mission = read_mission(chk, raw["mission"]) if "mission" in raw else MissionConfig()
    wind = read_wind(chk, raw["wind"]) if "wind" in raw else None
    zones = None
    sources = ObstacleSources(len(map_obstacles), raw.get("map"), len(inline))
    if "airspace" in raw:
        zones, solids = _airspace(
            chk, raw["airspace"], path, origin, bounds, margin, terrain, vehicle, len(obstacles)
        )
        obstacles += solids
        if len(obstacles) > MAX_OBSTACLES:
            raise chk.fail(
                "airspace",
                f"the zones' solids bring the obstacles to {len(obstacles):,} "
                f"(at most {MAX_OBSTACLES:,})",
            )
        from uavplan.scenario.zones import titles

        sources = replace(sources, zones_from=zones.first_obstacle, zone_titles=titles(zones))
        files += [InputFile(str(f), f"a zone file of {path}") for f in zones.spec.files]
    return dict(
        name=name,
        origin=origin,
        bounds=bounds,
        start_m=None if start is None else (start[0], start[1], start[2]),
        goal_m=None if goal is None else (goal[0], goal[1], goal[2]),
        via_m=tuple((p[0], p[1], p[2]) for p in via),
        obstacles=obstacles,
        safety_margin_m=margin,
        vehicle=vehicle,
        planner=planner,
        mission=mission,
        source=str(path),
        terrain=terrain,
        obstacle_sources=sources,
        wind=wind,
        files=tuple(files),
        airspace=zones,
        **({} if spec is None else {"survey": spec}),
    )


def _survey(
    chk: Checker, raw: dict[str, Any], allowed: bool, path: Path, origin: GeoPoint
) -> tuple[SurveySpec, list[InputFile]]:
    """A scenario with ``survey:`` instead of ``goal:`` (docs/scenario-format.md): the
    section checked key by key; refused unless ``allowed`` (only ``plan`` flies a survey: a
    survey read as a route by another command would be a pretend one). With the
    ``area_file`` it read."""
    if "goal" in raw:
        raise chk.fail("survey", "a scenario has a goal or a survey, not both")
    if "via" in raw:
        raise chk.fail("via", "a survey has no via points (the lanes give the route)")
    from uavplan.scenario.survey import read_survey

    read: list[InputFile] = []

    def read_area(value: Any, key: str) -> tuple[tuple[tuple[float, float], ...], list[Any]]:
        name = (path.parent / chk.string(value, key)).resolve()
        ring, holes = _area_file(chk, name, key, origin)
        read.append(InputFile(str(name), f"the survey area of {path}"))
        return ring, holes

    spec = read_survey(chk, raw["survey"], read_area=read_area)
    if not allowed:
        raise chk.fail(
            "survey",
            "the section is valid: uavplan plan plans a survey (and validate, simulate, "
            "render --mission and fly take it as --scenario, the site of its mission); this "
            "command plans or checks a route from start to goal: give a goal: instead",
        )
    return spec, read


def _area_file(
    chk: Checker, name: Path, key: str, origin: GeoPoint
) -> tuple[tuple[tuple[float, float], ...], list[Any]]:
    """The survey area in a GIS file (GeoJSON, KML, GeoPackage, Shapefile: pyogrio, any CRS
    it declares), as ENU rings: its polygon features joined into one polygon (its outer ring,
    and its holes as no-fly holes)."""
    import numpy as np
    import shapely

    from uavplan.sources import SourceError
    from uavplan.sources.base import ObstacleFileSpec
    from uavplan.sources.vector import read_vector_features

    if not name.is_file():
        raise chk.fail(key, f"no such file: {name}")
    skipped: Counter[str] = Counter()
    try:
        features = read_vector_features(ObstacleFileSpec(name), skipped, Counter())
    except SourceError as err:
        raise chk.fail(key, err.reason) from None
    if not features:
        raise chk.fail(key, f"{name.name} holds no polygon (the survey area)")
    merged = shapely.union_all([f.geometry for f in features])
    if merged.geom_type != "Polygon":
        parts = len(getattr(merged, "geoms", ()))
        raise chk.fail(
            key,
            f"{name.name} holds {parts} separate polygons: one survey area per scenario "
            "(split the file, or join them)",
        )
    frame = EnuFrame.at(origin)

    def enu(ring: Any) -> tuple[tuple[float, float], ...]:
        lonlat = np.asarray(ring.coords)[:-1]
        xy = np.asarray(frame.to_enu_xy(lonlat[:, 1], lonlat[:, 0])).reshape(-1, 2)
        return tuple((round(float(x), 3), round(float(y), 3)) for x, y in xy)

    return enu(merged.exterior), [enu(r) for r in merged.interiors]


def _airspace(
    chk: Checker,
    raw: Any,
    path: Path,
    origin: GeoPoint,
    bounds: Bounds,
    margin: float,
    terrain: Terrain | None,
    vehicle: VehicleConfig,
    first: int,
) -> tuple[ZoneSet, tuple[Obstacle, ...]]:
    """The ``airspace:`` zones (:mod:`uavplan.scenario.zones`): the zone readers, shapely and
    pyproj load here, for a scenario that names zone files."""
    from uavplan.scenario.zones import build_zones, read_spec

    spec = read_spec(chk, raw, path)
    return build_zones(
        chk,
        spec,
        origin=origin,
        bounds=bounds,
        margin_m=margin,
        terrain=terrain,
        vehicle=vehicle,
        first_obstacle=first,
    )
