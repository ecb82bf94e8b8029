"""Scenario and map files (SPEC §2): the only YAML reader of the project.

:meth:`Scenario.from_file` loads a scenario, merges the map it names, checks every key and
returns frozen, validated values. Any problem raises :class:`~uavplan.errors.ScenarioError`
naming the file, the key path (``obstacles[2].radius``) and the reason.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import yaml

from uavplan.errors import ScenarioError
from uavplan.geo import GeoPoint
from uavplan.mission.items import Autopilot
from uavplan.obstacles import (
    Bounds,
    BoxObstacle,
    CylinderObstacle,
    Obstacle,
    PrismObstacle,
)
from uavplan.planners.params import (
    ALGORITHMS,
    EnergyWeights,
    GridSpec,
    PostParams,
    SearchParams,
    SpsaParams,
    field_names,
)


@dataclass(frozen=True)
class VehicleConfig:
    cruise_speed_m_s: float | None = None
    takeoff_altitude_m: float | None = None  # None: the start point's height


@dataclass(frozen=True)
class MissionConfig:
    autopilot: Autopilot = Autopilot.ARDUPILOT
    spacing_m: float = 60.0
    end: str = "rtl"  # rtl | land | none


@dataclass(frozen=True)
class PlannerConfig:
    algorithm: str = "spsa"
    search: SearchParams = field(default_factory=SearchParams)
    grid: GridSpec = field(default_factory=GridSpec)
    energy: EnergyWeights = field(default_factory=EnergyWeights)
    spsa: SpsaParams = field(default_factory=SpsaParams)
    post: PostParams = field(default_factory=PostParams)
    options: Mapping[str, Any] = field(default_factory=dict)  # other algorithms' options


@dataclass(frozen=True)
class Scenario:
    name: str
    origin: GeoPoint
    bounds: Bounds
    start_m: tuple[float, float, float]
    goal_m: tuple[float, float, float]
    obstacles: tuple[Obstacle, ...]
    safety_margin_m: float = 10.0
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    source: str | None = None
    #: points the route passes through, in order, between start and goal (ENU m)
    via_m: tuple[tuple[float, float, float], ...] = ()
    terrain_file: str | None = None  # a DEM GeoTIFF, checked to cover the bounds (issue 10)

    @classmethod
    def from_file(cls, path: str | Path) -> Scenario:
        return load_scenario(path)

    def with_planner(self, **changes: Any) -> Scenario:
        """A copy whose planner config has ``changes`` (CLI overrides)."""
        return replace(self, planner=replace(self.planner, **changes))


# ---------------------------------------------------------------------------------------------
# Loading


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
}
_MAP_KEYS = {"name", "origin", "bounds", "obstacles", "obstacle_files"}


class _Checker:
    """Small typed accessors that raise ScenarioError with file and key path."""

    def __init__(self, file: str) -> None:
        self.file = file

    def fail(self, key: str, reason: str) -> ScenarioError:
        return ScenarioError(reason, file=self.file, key=key or "(top level)")

    def mapping(self, value: Any, key: str, allowed: set[str], required: set[str] = frozenset()):
        if not isinstance(value, Mapping):
            raise self.fail(key, f"must be a mapping, got {_type_name(value)}")
        for k in value:
            if not isinstance(k, str):
                raise self.fail(key, f"keys must be strings, got {k!r}")
            if k not in allowed:
                hint = f" (allowed: {', '.join(sorted(allowed))})"
                raise self.fail(_join(key, k), f"unknown key{hint}")
        for k in sorted(required):
            if k not in value:
                raise self.fail(_join(key, k), "missing required key")
        return value

    def number(
        self,
        value: Any,
        key: str,
        *,
        minimum: float | None = None,
        strict: bool = False,
        maximum: float | None = None,
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {_type_name(value)}")
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(key, "must be a finite number")
        if minimum is not None:
            if strict and value <= minimum:
                raise self.fail(key, f"must be > {minimum:g}, got {value:g}")
            if not strict and value < minimum:
                raise self.fail(key, f"must be >= {minimum:g}, got {value:g}")
        if maximum is not None and value > maximum:
            raise self.fail(key, f"must be <= {maximum:g}, got {value:g}")
        return value

    def integer(self, value: Any, key: str, *, minimum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"must be an integer, got {_type_name(value)}")
        if minimum is not None and value < minimum:
            raise self.fail(key, f"must be >= {minimum}, got {value}")
        return int(value)

    def boolean(self, value: Any, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(key, f"must be true or false, got {_type_name(value)}")
        return value

    def string(self, value: Any, key: str, choices: Sequence[str] | None = None) -> str:
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string, got {_type_name(value)}")
        if choices is not None and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}, got {value!r}")
        return value

    def vector(self, value: Any, key: str, n: int) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != n:
            raise self.fail(key, f"must be a list of {n} numbers, got {_short(value)}")
        return tuple(self.number(v, f"{key}[{i}]") for i, v in enumerate(value))


def _join(key: str, sub: str) -> str:
    return f"{key}.{sub}" if key else sub


def _type_name(value: Any) -> str:
    if value is None:
        return "nothing (null)"
    return {
        bool: "a boolean",
        int: "an integer",
        float: "a number",
        str: "a string",
        list: "a list",
        dict: "a mapping",
    }.get(type(value), type(value).__name__)


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _read_yaml(path: Path, what: str) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ScenarioError(f"{what} file not found", file=str(path)) from None
    except (OSError, UnicodeDecodeError) as err:
        raise ScenarioError(f"cannot read {what} file: {err}", file=str(path)) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ScenarioError(f"invalid YAML: {where}{problem}", file=str(path)) from None
    if data is None:
        raise ScenarioError(f"the {what} file is empty", file=str(path))
    return data


def _obstacle(chk: _Checker, raw: Any, key: str) -> Obstacle:
    if not isinstance(raw, Mapping):
        raise chk.fail(key, f"must be a mapping, got {_type_name(raw)}")
    kind = raw.get("type")
    if kind is None:
        raise chk.fail(_join(key, "type"), "missing required key (box, cylinder or prism)")
    kind = chk.string(kind, _join(key, "type"), ("box", "cylinder", "prism"))
    if kind == "box":
        chk.mapping(
            raw, key, {"type", "center", "size", "height", "yaw"}, {"center", "size", "height"}
        )
        center = chk.vector(raw["center"], _join(key, "center"), 2)
        size = chk.vector(raw["size"], _join(key, "size"), 2)
        for i, v in enumerate(size):
            if v <= 0:
                raise chk.fail(f"{key}.size[{i}]", f"must be > 0, got {v:g}")
        height = chk.number(raw["height"], _join(key, "height"), minimum=0, strict=True)
        yaw = chk.number(raw.get("yaw", 0.0), _join(key, "yaw"))
        return BoxObstacle((center[0], center[1]), (size[0], size[1]), height, yaw)
    if kind == "cylinder":
        chk.mapping(
            raw, key, {"type", "center", "radius", "height"}, {"center", "radius", "height"}
        )
        center = chk.vector(raw["center"], _join(key, "center"), 2)
        radius = chk.number(raw["radius"], _join(key, "radius"), minimum=0, strict=True)
        height = chk.number(raw["height"], _join(key, "height"), minimum=0, strict=True)
        return CylinderObstacle((center[0], center[1]), radius, height)
    chk.mapping(raw, key, {"type", "polygon", "height"}, {"polygon", "height"})
    poly_raw = raw["polygon"]
    pkey = _join(key, "polygon")
    if not isinstance(poly_raw, list) or len(poly_raw) < 3:
        raise chk.fail(pkey, f"must be a list of at least 3 [x, y] points, got {_short(poly_raw)}")
    poly = [chk.vector(p, f"{pkey}[{i}]", 2) for i, p in enumerate(poly_raw)]
    if len(poly) > 3 and poly[0] == poly[-1]:
        poly = poly[:-1]  # tolerate a closed ring
    area = _signed_area(poly)
    if abs(area) < 1e-6:
        raise chk.fail(pkey, "polygon has zero area")
    if _self_intersects(poly):
        raise chk.fail(pkey, "polygon edges cross each other")
    if area < 0:
        poly = poly[::-1]
    height = chk.number(raw["height"], _join(key, "height"), minimum=0, strict=True)
    return PrismObstacle(tuple((p[0], p[1]) for p in poly), height)


def _signed_area(poly: Sequence[Sequence[float]]) -> float:
    n = len(poly)
    return 0.5 * sum(
        poly[i][0] * poly[(i + 1) % n][1] - poly[(i + 1) % n][0] * poly[i][1] for i in range(n)
    )


def _self_intersects(poly: Sequence[Sequence[float]]) -> bool:
    n = len(poly)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        for j in range(i + 1, n):
            if j == i or (j + 1) % n == i or j == (i + 1) % n:
                continue
            c, d = poly[j], poly[(j + 1) % n]
            d1, d2 = cross(c, d, a), cross(c, d, b)
            d3, d4 = cross(a, b, c), cross(a, b, d)
            if ((d1 > 0) != (d2 > 0)) and ((d3 > 0) != (d4 > 0)) and d1 * d2 < 0 and d3 * d4 < 0:
                return True
    return False


def _origin(chk: _Checker, raw: Any) -> GeoPoint:
    chk.mapping(raw, "origin", {"lat", "lon", "alt"}, {"lat", "lon"})
    lat = chk.number(raw["lat"], "origin.lat")
    lon = chk.number(raw["lon"], "origin.lon")
    alt = chk.number(raw.get("alt", 0.0), "origin.alt")
    if not -90.0 <= lat <= 90.0:
        raise chk.fail("origin.lat", f"must be within [-90, 90] degrees, got {lat:g}")
    if abs(lat) > 89.9:
        raise chk.fail("origin.lat", "too close to a pole for a local ENU frame")
    if not -180.0 <= lon <= 180.0:
        raise chk.fail("origin.lon", f"must be within [-180, 180] degrees, got {lon:g}")
    if not -500.0 <= alt <= 10000.0:
        raise chk.fail("origin.alt", f"must be within [-500, 10000] m AMSL, got {alt:g}")
    return GeoPoint(lat, lon, alt)


def _bounds(chk: _Checker, raw: Any) -> Bounds:
    chk.mapping(raw, "bounds", {"x", "y", "z"}, {"x", "y", "z"})
    out = []
    for axis in ("x", "y", "z"):
        lo, hi = chk.vector(raw[axis], f"bounds.{axis}", 2)
        if not lo < hi:
            raise chk.fail(f"bounds.{axis}", f"needs min < max, got [{lo:g}, {hi:g}]")
        out.append((lo, hi))
    if out[2][0] < 0:
        raise chk.fail("bounds.z", "must not go below the ground (z = 0)")
    return Bounds(*out)


def _dataclass_section(chk: _Checker, raw: Any, key: str, cls: type, renames: Mapping[str, str]):
    """Build ``cls`` from a mapping whose keys are ``renames`` keys or field names."""
    allowed = set(renames) | set(field_names(cls))
    chk.mapping(raw, key, allowed)
    kwargs = {renames.get(k, k): v for k, v in raw.items()}
    defaults = cls()
    for name, value in kwargs.items():
        default = getattr(defaults, name)
        sub = next((k for k, v in renames.items() if v == name), name)
        if isinstance(default, bool):
            chk.boolean(value, _join(key, sub))
        elif isinstance(default, int):
            chk.integer(value, _join(key, sub))
        elif isinstance(default, float):
            kwargs[name] = chk.number(value, _join(key, sub))
        elif isinstance(default, str):
            chk.string(value, _join(key, sub))
    try:
        return cls(**kwargs)
    except ValueError as err:
        # name the key the user wrote: "dx_m must be ..." -> planner.grid.dx: "must be ..."
        message = str(err)
        for field_name in sorted(field_names(cls), key=len, reverse=True):
            if message.startswith(field_name + " must"):
                user_key = next((k for k, v in renames.items() if v == field_name), field_name)
                raise chk.fail(_join(key, user_key), message[len(field_name) + 1 :]) from None
        raise chk.fail(key, message) from None


def _planner(chk: _Checker, raw: Any) -> PlannerConfig:
    allowed = {
        "algorithm",
        "population",
        "iterations",
        "seed",
        "grid",
        "energy",
        "t_max",
        "init_half_window",
        "fitness_smoothing",
        "spsa",
        "post",
        "options",
    }
    chk.mapping(raw, "planner", allowed)
    algorithm = "spsa"
    if "algorithm" in raw:
        algorithm = chk.string(raw["algorithm"], "planner.algorithm", ALGORITHMS)
    search_raw = {
        k: raw[k]
        for k in (
            "population",
            "iterations",
            "seed",
            "t_max",
            "init_half_window",
            "fitness_smoothing",
        )
        if k in raw
    }
    search = _dataclass_section(chk, search_raw, "planner", SearchParams, {})
    grid = GridSpec()
    if "grid" in raw:
        grid = _dataclass_section(
            chk, raw["grid"], "planner.grid", GridSpec, {"dx": "dx_m", "dy": "dy_m", "dz": "dz_m"}
        )
    energy = EnergyWeights()
    if "energy" in raw:
        energy = _dataclass_section(chk, raw["energy"], "planner.energy", EnergyWeights, {})
    spsa = SpsaParams()
    if "spsa" in raw:
        spsa = _dataclass_section(chk, raw["spsa"], "planner.spsa", SpsaParams, {})
    post = PostParams()
    if "post" in raw:
        post = _dataclass_section(chk, raw["post"], "planner.post", PostParams, {})
    options: Mapping[str, Any] = {}
    if "options" in raw:
        opts = raw["options"]
        if not isinstance(opts, Mapping):
            raise chk.fail("planner.options", f"must be a mapping, got {_type_name(opts)}")
        options = dict(chk.mapping(opts, "planner.options", {str(k) for k in opts}))
        from uavplan.planners.registry import make_options  # parameter classes only

        try:
            make_options(algorithm, options)
        except (TypeError, ValueError) as err:
            raise chk.fail("planner.options", str(err)) from None
    return PlannerConfig(algorithm, search, grid, energy, spsa, post, options)


def _vehicle(chk: _Checker, raw: Any) -> VehicleConfig:
    chk.mapping(raw, "vehicle", {"cruise_speed", "takeoff_altitude"})
    speed = raw.get("cruise_speed")
    if speed is not None:
        speed = chk.number(speed, "vehicle.cruise_speed", minimum=0, strict=True, maximum=100)
    takeoff = raw.get("takeoff_altitude")
    if takeoff is not None:
        takeoff = chk.number(takeoff, "vehicle.takeoff_altitude", minimum=0, strict=True)
    return VehicleConfig(speed, takeoff)


def _mission(chk: _Checker, raw: Any) -> MissionConfig:
    chk.mapping(raw, "mission", {"autopilot", "spacing", "end"})
    autopilot = MissionConfig.autopilot
    if "autopilot" in raw:
        name = chk.string(raw["autopilot"], "mission.autopilot", ("px4", "ardupilot"))
        autopilot = Autopilot.from_name(name)
    spacing = MissionConfig.spacing_m
    if "spacing" in raw:
        spacing = chk.number(raw["spacing"], "mission.spacing", minimum=1.0)
    end = MissionConfig.end
    if "end" in raw:
        end = chk.string(raw["end"], "mission.end", ("rtl", "land", "none"))
    return MissionConfig(autopilot, spacing, end)


def load_map(path: str | Path) -> tuple[GeoPoint | None, Bounds | None, tuple[Obstacle, ...]]:
    """Read a map file: (origin, bounds, obstacles); missing sections are ``None`` / empty."""
    path = Path(path)
    chk = _Checker(str(path))
    raw = _read_yaml(path, "map")
    chk.mapping(raw, "", _MAP_KEYS)
    origin = _origin(chk, raw["origin"]) if "origin" in raw else None
    bounds = _bounds(chk, raw["bounds"]) if "bounds" in raw else None
    obstacles = _obstacles(chk, raw.get("obstacles", []))
    if raw.get("obstacle_files"):
        if origin is None:
            raise chk.fail("obstacle_files", "needs origin in the same map file")
        obstacles += _obstacle_files(chk, raw["obstacle_files"], path, origin, bounds)
    return origin, bounds, obstacles


def _obstacle_files(
    chk: _Checker, raw: Any, path: Path, origin: GeoPoint, bounds: Bounds | None
) -> tuple[Obstacle, ...]:
    """Obstacles of the ``obstacle_files`` list (OSM, GIS files), paths relative to ``path``."""
    from uavplan.geo import EnuFrame
    from uavplan.sources import SourceError, obstacles_from_entries

    try:
        return obstacles_from_entries(raw, path.parent, EnuFrame.at(origin), bounds)
    except SourceError as err:
        raise chk.fail(err.key_path("obstacle_files"), err.reason) from None


def _terrain(chk: _Checker, raw: Any, path: Path, origin: GeoPoint, bounds: Bounds) -> str:
    """The ``terrain`` DEM, resolved next to ``path`` and checked to cover the bounds."""
    from uavplan.geo import EnuFrame
    from uavplan.sources.dem import Terrain, TerrainError

    dem = (path.parent / chk.string(raw, "terrain")).resolve()
    try:
        Terrain.from_file(dem, EnuFrame.at(origin), area_xy_m=(bounds.x_m, bounds.y_m))
    except TerrainError as err:
        raise chk.fail("terrain", f"{dem.name}: {err.reason}") from None
    # the DEM is read and checked, but the planner does not follow it yet: planning over flat
    # ground while the file names a terrain would be a silent lie
    raise chk.fail(
        "terrain",
        f"{dem.name} covers the bounds, but the planner does not follow terrain yet; remove "
        "the key to plan over flat ground (z = heights above the origin's altitude)",
    )


def _obstacles(chk: _Checker, raw: Any) -> tuple[Obstacle, ...]:
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise chk.fail("obstacles", f"must be a list, got {_type_name(raw)}")
    return tuple(_obstacle(chk, item, f"obstacles[{i}]") for i, item in enumerate(raw))


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file (and the map it names)."""
    path = Path(path)
    chk = _Checker(str(path))
    raw = _read_yaml(path, "scenario")
    chk.mapping(raw, "", _SCENARIO_KEYS, {"start", "goal"})

    map_origin = map_bounds = None
    map_obstacles: tuple[Obstacle, ...] = ()
    if "map" in raw:
        ref = chk.string(raw["map"], "map")
        map_path = (path.parent / ref).resolve()
        if not map_path.is_file():
            raise chk.fail("map", f"map file {ref!r} not found (looked at {map_path})")
        map_origin, map_bounds, map_obstacles = load_map(map_path)

    if "origin" in raw:
        origin = _origin(chk, raw["origin"])
    elif map_origin is not None:
        origin = map_origin
    else:
        raise chk.fail("origin", "missing required key (not set here nor in the map)")
    if "bounds" in raw:
        bounds = _bounds(chk, raw["bounds"])
    elif map_bounds is not None:
        bounds = map_bounds
    else:
        raise chk.fail("bounds", "missing required key (not set here nor in the map)")

    terrain_file = _terrain(chk, raw["terrain"], path, origin, bounds) if "terrain" in raw else None
    obstacles = map_obstacles + _obstacles(chk, raw.get("obstacles", []))
    if raw.get("obstacle_files"):
        obstacles += _obstacle_files(chk, raw["obstacle_files"], path, origin, bounds)
    margin = 10.0
    if "safety_margin" in raw:
        margin = chk.number(raw["safety_margin"], "safety_margin", minimum=0)
    start = chk.vector(raw["start"], "start", 3)
    goal = chk.vector(raw["goal"], "goal", 3)
    via_raw = raw.get("via", [])
    if not isinstance(via_raw, list):
        raise chk.fail("via", f"must be a list of [x, y, z] points, got {_type_name(via_raw)}")
    via = tuple(chk.vector(p, f"via[{i}]", 3) for i, p in enumerate(via_raw))
    name = chk.string(raw["name"], "name") if "name" in raw else path.stem
    vehicle = _vehicle(chk, raw["vehicle"]) if "vehicle" in raw else VehicleConfig()
    planner = _planner(chk, raw["planner"]) if "planner" in raw else PlannerConfig()
    mission = _mission(chk, raw["mission"]) if "mission" in raw else MissionConfig()

    scenario = Scenario(
        name=name,
        origin=origin,
        bounds=bounds,
        start_m=(start[0], start[1], start[2]),
        goal_m=(goal[0], goal[1], goal[2]),
        via_m=tuple((p[0], p[1], p[2]) for p in via),
        obstacles=obstacles,
        safety_margin_m=margin,
        vehicle=vehicle,
        planner=planner,
        mission=mission,
        source=str(path),
        terrain_file=terrain_file,
    )
    n_inline = len(raw.get("obstacles") or [])
    _check_geometry(chk, scenario, len(map_obstacles), raw.get("map"), n_inline)
    return scenario


def _check_geometry(
    chk: _Checker, scn: Scenario, n_map: int, map_ref: str | None, n_inline: int | None = None
) -> None:
    """Start and goal inside the bounds, clear of every obstacle plus the margin, and the
    vertical take-off climb (and the landing descent with ``end: land``) clear too."""
    import numpy as np

    from uavplan.world import World  # the world layer knows nothing of YAML

    def name(index: int) -> str:
        if index < n_map:
            return f"obstacle #{index} of map {map_ref}"
        if n_inline is not None and index >= n_map + n_inline:
            return f"obstacle #{index - n_map - n_inline} of obstacle_files"
        return f"obstacles[{index - n_map}]"

    ends = [("start", scn.start_m), *((f"via[{i}]", p) for i, p in enumerate(scn.via_m))]
    ends.append(("goal", scn.goal_m))
    for key, point in ends:
        if point[2] <= 0:
            raise chk.fail(key, f"{list(point)} is not above the ground (z must be > 0)")
        if not scn.bounds.contains(point):
            raise chk.fail(key, f"{list(point)} is outside the bounds")
    for (_, a), (key, b) in itertools.pairwise(ends):
        if math.hypot(b[0] - a[0], b[1] - a[1]) < 1.0:
            raise chk.fail(key, "must be at least 1 m away from the point before it horizontally")
    world = World.from_scenario(scn)
    margin = scn.safety_margin_m
    for key, point in ends:
        clearance, index = world.nearest_obstacle(point)
        if index >= 0 and clearance < margin - 1e-9:
            inside = "inside" if clearance <= 0 else f"{clearance:.1f} m from"
            raise chk.fail(
                key, f"{list(point)} is {inside} {name(index)} (needs {margin:g} m safety margin)"
            )
    columns = [("start", scn.start_m, "take-off climb")]
    if scn.mission.end == "land":
        columns.append(("goal", scn.goal_m, "landing descent"))
    for key, point, what in columns:
        top = np.array([point], dtype=float)
        ground = top.copy()
        ground[0, 2] = 0.0
        dist, which = world.segments_clearance(ground, top)
        if which[0] >= 0 and dist[0] < margin - 1e-9:
            raise chk.fail(
                key,
                f"the {what} above {list(point[:2])} passes {dist[0]:.1f} m from "
                f"{name(int(which[0]))} (needs {margin:g} m safety margin)",
            )
