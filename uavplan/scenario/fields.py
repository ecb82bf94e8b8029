"""The sections of a scenario or map file, key by key: each reader takes the raw value and
returns the project's value or raises one :class:`~uavplan.errors.ScenarioError` naming the
key path. :func:`obstacle_fast` builds a plain obstacle without the per-key checker (a large
generated map validates in a fraction of a second); :func:`obstacle` decides whenever it
declines, so both accept the same obstacles and build equal values
(tests/scenario/test_fast_yaml.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.config import (
    ALTITUDE_MODES,
    END_ACTIONS,
    FITNESS_MODES,
    PLANNER_KEYS,
    PLANNERS,
    ConfigError,
    EnergyWeights,
    GridSpec,
    PlannerConfig,
    PostParams,
    SearchParams,
    build,
    build_params,
    key_text,
    planner_entry,
    short_repr,
    type_name,
)
from uavplan.flavour import Autopilot
from uavplan.geo import GeoPoint
from uavplan.obstacles import Bounds, BoxObstacle, CylinderObstacle, Obstacle, PrismObstacle
from uavplan.scenario.checker import Checker, join
from uavplan.scenario.limits import (
    MAX_ALTITUDE_M,
    MAX_CRUISE_SPEED_M_S,
    MAX_HORIZONTAL_M,
    MAX_NAME_CHARS,
    MAX_OBSTACLES,
    MAX_ORIGIN_LAT_DEG,
    MAX_PATH_CHARS,
    MAX_PATH_PART_CHARS,
    MAX_POLYGON_VERTICES,
    MAX_SIZE_M,
    ORIGIN_ALT_RANGE_M,
    SPACING_RANGE_M,
)
from uavplan.scenario.settings import MissionConfig, VehicleConfig

if TYPE_CHECKING:
    from uavplan.airframe.wind import Wind


def polygon_area_and_crossing(poly: list[tuple[float, float]]) -> tuple[float, bool]:
    """(signed area, do two edges cross) of a prism's ring, by :mod:`uavplan.geometry2d`.
    Imported here, on the first prism: geometry2d needs numpy, which a scenario of boxes and
    cylinders never loads (``uavplan validate`` starts about 0.13 s sooner)."""
    from uavplan.geometry2d import self_intersects, signed_area

    return signed_area(poly), self_intersects(poly, touching=False)


def obstacle(chk: Checker, raw: Any, key: str) -> Obstacle:
    if not isinstance(raw, Mapping):
        raise chk.fail(key, f"must be a mapping, got {type_name(raw)}")
    kind = raw.get("type")
    if kind is None:
        raise chk.fail(join(key, "type"), "missing required key (box, cylinder or prism)")
    kind = chk.string(kind, join(key, "type"), ("box", "cylinder", "prism"))
    if kind == "box":
        chk.mapping(
            raw, key, {"type", "center", "size", "height", "yaw"}, ("center", "size", "height")
        )
        center = chk.point(raw["center"], join(key, "center"), 2)
        size = chk.vector(raw["size"], join(key, "size"), 2)
        for i, v in enumerate(size):
            if not 0 < v <= MAX_SIZE_M:
                raise chk.fail(f"{key}.size[{i}]", f"must be > 0 and <= {MAX_SIZE_M:g}, got {v:g}")
        height = _height(chk, raw["height"], join(key, "height"))
        yaw = chk.number(raw.get("yaw", 0.0), join(key, "yaw"), minimum=-360.0, maximum=360.0)
        return BoxObstacle((center[0], center[1]), (size[0], size[1]), height, yaw)
    if kind == "cylinder":
        chk.mapping(
            raw, key, {"type", "center", "radius", "height"}, ("center", "radius", "height")
        )
        center = chk.point(raw["center"], join(key, "center"), 2)
        radius = chk.number(
            raw["radius"], join(key, "radius"), minimum=0, strict=True, maximum=MAX_SIZE_M
        )
        height = _height(chk, raw["height"], join(key, "height"))
        return CylinderObstacle((center[0], center[1]), radius, height)
    chk.mapping(raw, key, {"type", "polygon", "height"}, ("polygon", "height"))
    poly_raw = raw["polygon"]
    pkey = join(key, "polygon")
    if not isinstance(poly_raw, list) or len(poly_raw) < 3:
        raise chk.fail(
            pkey, f"must be a list of at least 3 [x, y] points, got {short_repr(poly_raw)}"
        )
    if len(poly_raw) > MAX_POLYGON_VERTICES + 1:
        raise chk.fail(pkey, f"has {len(poly_raw)} points (at most {MAX_POLYGON_VERTICES})")
    poly = [chk.point(p, f"{pkey}[{i}]", 2) for i, p in enumerate(poly_raw)]
    if len(poly) > 3 and poly[0] == poly[-1]:
        poly = poly[:-1]  # tolerate a closed ring
    if len(poly) > MAX_POLYGON_VERTICES:
        raise chk.fail(pkey, f"has {len(poly)} points (at most {MAX_POLYGON_VERTICES})")
    area, crossing = polygon_area_and_crossing(poly)  # type: ignore[arg-type]
    if abs(area) < 1e-6:
        raise chk.fail(pkey, "polygon has zero area")
    if crossing:
        raise chk.fail(pkey, "polygon edges cross each other")
    if area < 0:
        poly = poly[::-1]
    height = _height(chk, raw["height"], join(key, "height"))
    return PrismObstacle(tuple((p[0], p[1]) for p in poly), height)


def _height(chk: Checker, raw: Any, key: str) -> float:
    return chk.number(raw, key, minimum=0, strict=True, maximum=MAX_ALTITUDE_M)


def origin(chk: Checker, raw: Any) -> GeoPoint:
    chk.mapping(raw, "origin", {"lat", "lon", "alt"}, ("lat", "lon"))
    lat = chk.number(raw["lat"], "origin.lat")
    lon = chk.number(raw["lon"], "origin.lon")
    alt = chk.number(raw.get("alt", 0.0), "origin.alt")
    if not -90.0 <= lat <= 90.0:
        raise chk.fail("origin.lat", f"must be within [-90, 90] degrees, got {lat:g}")
    if abs(lat) > MAX_ORIGIN_LAT_DEG:
        raise chk.fail("origin.lat", "too close to a pole for a local ENU frame")
    if not -180.0 <= lon <= 180.0:
        raise chk.fail("origin.lon", f"must be within [-180, 180] degrees, got {lon:g}")
    if not ORIGIN_ALT_RANGE_M[0] <= alt <= ORIGIN_ALT_RANGE_M[1]:
        raise chk.fail("origin.alt", f"must be within [-500, 10000] m AMSL, got {alt:g}")
    return GeoPoint(lat, lon, alt)


def bounds(chk: Checker, raw: Any) -> Bounds:
    chk.mapping(raw, "bounds", {"x", "y", "z"}, ("x", "y", "z"))
    out = []
    for axis in ("x", "y", "z"):
        lo, hi = chk.vector(raw[axis], f"bounds.{axis}", 2)
        limit = MAX_ALTITUDE_M if axis == "z" else MAX_HORIZONTAL_M
        for v in (lo, hi):
            if abs(v) > limit:
                raise chk.fail(f"bounds.{axis}", f"must be within ±{limit:g} m, got {v:g}")
        if not lo < hi:
            raise chk.fail(f"bounds.{axis}", f"needs min < max, got [{lo:g}, {hi:g}]")
        out.append((lo, hi))
    if out[2][0] < 0:
        raise chk.fail("bounds.z", "must not go below the ground (z = 0)")
    return Bounds(*out)


#: ``planner:`` keys that fill :class:`SearchParams`
_SEARCH_KEYS = (
    "population",
    "iterations",
    "seed",
    "t_max",
    "init_half_window",
    "fitness_smoothing",
    "stall_iterations",
    "restart_stall_iterations",
)


def planner(chk: Checker, raw: Any) -> PlannerConfig:
    """The ``planner:`` section: shared search values at its top level, ``grid``, ``energy``,
    ``post``, and one section per planner named after it (``spsa:``, ``de:``, ...). The old
    ``options:`` key is the section of ``algorithm``."""
    allowed = set(PLANNER_KEYS) | set(PLANNERS)
    chk.mapping(raw, "planner", allowed)
    try:
        algorithm = "spsa"
        if "algorithm" in raw:
            value = raw["algorithm"]
            if not isinstance(value, str):
                raise ConfigError(f"must be a string, got {type_name(value)}", key="algorithm")
            algorithm = planner_entry(value, "algorithm").name
        search = build(SearchParams, {k: raw[k] for k in _SEARCH_KEYS if k in raw}, "")
        # no grid: the grid is fitted to the flight volume (Scenario.grid)
        grid = build(GridSpec, raw["grid"], "grid") if "grid" in raw else None
        energy, fitness = _energy(raw.get("energy", {}))
        post = build(PostParams, raw.get("post", {}), "post")
        sections: dict[str, Any] = {}
        for name in PLANNERS:
            if name in raw:
                params = build_params(name, raw[name], name)
                if params is not None and params != PLANNERS[name].params():  # type: ignore[misc]
                    sections[name] = params
        if "options" in raw:
            if algorithm in raw:
                raise ConfigError(
                    f"give the {algorithm} parameters in planner.{algorithm} or in "
                    "planner.options, not both",
                    key="options",
                )
            params = build_params(algorithm, raw["options"], "options")
            if params is not None and params != PLANNERS[algorithm].params():  # type: ignore[misc]
                sections[algorithm] = params
    except ConfigError as err:
        raise chk.config(err.under("planner")) from None
    return PlannerConfig(algorithm, search, grid, energy, post, sections, fitness)


def _energy(raw: Any) -> tuple[EnergyWeights, str]:
    """``planner.energy``: the fitness by name (``paper``, the default, or ``physical``: Wh
    of the power model, wind included), or the paper fitness's weights as a mapping."""
    if isinstance(raw, str):
        if raw not in FITNESS_MODES:
            raise ConfigError(
                f"must be one of {', '.join(FITNESS_MODES)} or a mapping of the paper "
                f"fitness's weights, got {short_repr(raw)}",
                key="energy",
            )
        return EnergyWeights(), raw
    return build(EnergyWeights, raw, "energy"), "paper"


#: ``vehicle:`` keys that are the mission's, not the power model's (short, unit-free keys)
_MISSION_VEHICLE_KEYS = ("cruise_speed", "takeoff_altitude")


def vehicle(chk: Checker, raw: Any) -> VehicleConfig:
    """``vehicle:``: ``cruise_speed`` and ``takeoff_altitude`` (what the mission commands),
    ``profile`` (a bundled vehicle) and any field of the power model's vehicle profile
    (``mass_kg``, ``battery_wh``, ...; units in the names). The profile's fields are checked
    by the profile itself (numpy loads only for a scenario that names them)."""
    if not isinstance(raw, Mapping):
        raise chk.fail("vehicle", f"must be a mapping, got {type_name(raw)}")
    spec = {k: v for k, v in raw.items() if k not in _MISSION_VEHICLE_KEYS}
    if spec:
        spec = _vehicle_profile(chk, spec)
    speed = raw.get("cruise_speed")
    if speed is not None:
        speed = chk.number(
            speed, "vehicle.cruise_speed", minimum=0, strict=True, maximum=MAX_CRUISE_SPEED_M_S
        )
    takeoff = raw.get("takeoff_altitude")
    if takeoff is not None:
        takeoff = chk.number(
            takeoff, "vehicle.takeoff_altitude", minimum=0, strict=True, maximum=MAX_ALTITUDE_M
        )
    return VehicleConfig(speed, takeoff, tuple(spec.items()))


def _vehicle_profile(chk: Checker, spec: Mapping[Any, Any]) -> dict[str, Any]:
    """The power model's part of ``vehicle:``, resolved once to check it (ScenarioError naming
    ``vehicle.<field>``)."""
    from uavplan.airframe.profile import VehicleProfile
    from uavplan.airframe.profiles import resolve
    from uavplan.errors import InputError

    for k in spec:
        if not isinstance(k, str):
            raise chk.fail("vehicle", f"keys must be strings, got {short_repr(k)}")
    allowed = {"profile", *VehicleProfile.field_names()} - {"name"}
    for k in spec:
        if k not in allowed:
            names = ", ".join(sorted(allowed | set(_MISSION_VEHICLE_KEYS)))
            raise chk.fail(join("vehicle", key_text(k)), f"unknown key (allowed: {names})")
    if "cruise_speed_m_s" in spec and "cruise_power_w" not in spec:
        raise chk.fail(
            "vehicle.cruise_speed_m_s",
            "is the speed cruise_power_w was measured at; the speed the mission flies is "
            "vehicle.cruise_speed",
        )
    try:
        resolve(spec)
    except InputError as err:
        raise chk.fail(join("vehicle", err.key or ""), err.reason) from None
    return dict(spec)


def wind(chk: Checker, raw: Any) -> Wind:
    """``wind: {speed: m/s, from: deg}`` with an optional ``profile`` by height
    (:meth:`uavplan.airframe.wind.Wind.from_mapping`; numpy loads here, for a scenario with
    wind)."""
    from uavplan.airframe.wind import Wind
    from uavplan.errors import InputError

    try:
        return Wind.from_mapping(raw)
    except InputError as err:
        key = err.key or "wind"
        raise chk.fail(key if key.startswith("wind") else join("wind", key), err.reason) from None


def mission(chk: Checker, raw: Any) -> MissionConfig:
    chk.mapping(
        raw, "mission", {"autopilot", "spacing", "end", "altitude", "max_items", "legal_ceiling"}
    )
    autopilot = MissionConfig.autopilot
    if "autopilot" in raw:
        name = chk.string(raw["autopilot"], "mission.autopilot", ("px4", "ardupilot"))
        autopilot = Autopilot.from_name(name)
    spacing = MissionConfig.spacing_m
    if "spacing" in raw:
        spacing = chk.number(
            raw["spacing"],
            "mission.spacing",
            minimum=SPACING_RANGE_M[0],
            maximum=SPACING_RANGE_M[1],
        )
    end = MissionConfig.end
    if "end" in raw:
        end = chk.string(raw["end"], "mission.end", END_ACTIONS)
    altitude = MissionConfig.altitude
    if "altitude" in raw:
        altitude = chk.string(raw["altitude"], "mission.altitude", ALTITUDE_MODES)
    max_items = None
    if "max_items" in raw:
        value = raw["max_items"]
        if isinstance(value, bool) or not isinstance(value, int):
            raise chk.fail("mission.max_items", f"must be a whole number, got {type_name(value)}")
        max_items = int(chk.number(value, "mission.max_items", minimum=1, maximum=65534))
    legal = MissionConfig.legal_ceiling_m
    if "legal_ceiling" in raw:
        value = raw["legal_ceiling"]
        if value is None:
            legal = None  # no legal limit (a closed site, a permit)
        else:
            legal = chk.number(value, "mission.legal_ceiling", minimum=0.0, strict=True)
    return MissionConfig(
        autopilot, spacing, end, altitude, max_items=max_items, legal_ceiling_m=legal
    )


def obstacles(chk: Checker, raw: Any) -> tuple[Obstacle, ...]:
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise chk.fail("obstacles", f"must be a list, got {type_name(raw)}")
    if len(raw) > MAX_OBSTACLES:
        raise chk.fail("obstacles", f"has {len(raw):,} obstacles (at most {MAX_OBSTACLES:,})")
    out = []
    for i, item in enumerate(raw):
        fast = obstacle_fast(item)
        out.append(fast if fast is not None else obstacle(chk, item, f"obstacles[{i}]"))
    return tuple(out)


_NUMBER_TYPES = (int, float)
_BOX_KEYS = frozenset(("type", "center", "size", "height", "yaw"))
_CYLINDER_KEYS = frozenset(("type", "center", "radius", "height"))
_PRISM_KEYS = frozenset(("type", "polygon", "height"))


def _xy_fast(value: Any) -> tuple[float, float] | None:
    """``value`` as an (x, y) point when it plainly is one (two ints or floats within
    ±MAX_HORIZONTAL_M), else None."""
    if type(value) is not list or len(value) != 2:
        return None
    x, y = value
    if (
        type(x) in _NUMBER_TYPES
        and type(y) in _NUMBER_TYPES
        and -MAX_HORIZONTAL_M <= x <= MAX_HORIZONTAL_M
        and -MAX_HORIZONTAL_M <= y <= MAX_HORIZONTAL_M
    ):
        return float(x), float(y)
    return None


def obstacle_fast(raw: Any) -> Obstacle | None:
    """The obstacle :func:`_obstacle` builds from ``raw`` when ``raw`` plainly is a valid one
    (no key paths built, no per-number calls: 20,000 obstacles validate in a fraction of a
    second); None whenever anything is unusual, and :func:`_obstacle` then decides and says
    what is wrong. Both accept the same obstacles and build equal values
    (tests/scenario/test_fast_yaml.py)."""
    if type(raw) is not dict:
        return None
    kind: Any = raw.get("type")
    height: Any = raw.get("height")
    if type(height) not in _NUMBER_TYPES or not 0 < height <= MAX_ALTITUDE_M:
        return None
    if kind == "box" and type(kind) is str:
        if not raw.keys() <= _BOX_KEYS or len(raw) < 4:
            return None
        center = _xy_fast(raw.get("center"))
        size = raw.get("size")
        yaw = raw.get("yaw", 0.0)
        if center is None or type(size) is not list or len(size) != 2:
            return None
        sx, sy = size
        if (
            type(sx) in _NUMBER_TYPES
            and type(sy) in _NUMBER_TYPES
            and 0 < sx <= MAX_SIZE_M
            and 0 < sy <= MAX_SIZE_M
            and type(yaw) in _NUMBER_TYPES
            and -360.0 <= yaw <= 360.0
        ):
            return BoxObstacle(center, (float(sx), float(sy)), float(height), float(yaw))
        return None
    if kind == "cylinder" and type(kind) is str:
        if raw.keys() != _CYLINDER_KEYS:
            return None
        center = _xy_fast(raw["center"])
        radius = raw["radius"]
        if center is None or type(radius) not in _NUMBER_TYPES or not 0 < radius <= MAX_SIZE_M:
            return None
        return CylinderObstacle(center, float(radius), float(height))
    if kind == "prism" and type(kind) is str:
        if raw.keys() != _PRISM_KEYS:
            return None
        ring = raw["polygon"]
        if type(ring) is not list or not 3 <= len(ring) <= MAX_POLYGON_VERTICES + 1:
            return None
        poly = [_xy_fast(p) for p in ring]
        if None in poly:
            return None
        if len(poly) > 3 and poly[0] == poly[-1]:
            poly = poly[:-1]  # tolerate a closed ring
        if len(poly) > MAX_POLYGON_VERTICES:
            return None
        area, crossing = polygon_area_and_crossing(poly)  # type: ignore[arg-type]
        if abs(area) < 1e-6 or crossing:
            return None
        if area < 0:
            poly = poly[::-1]
        return PrismObstacle(tuple(poly), float(height))  # type: ignore[arg-type]
    return None


def name(chk: Checker, raw: Any) -> str:
    name = chk.string(raw, "name")
    if not name.strip() or len(name) > MAX_NAME_CHARS:
        raise chk.fail("name", f"must be 1 to {MAX_NAME_CHARS} characters")
    if any(ord(c) < 32 or c == "\x7f" for c in name):
        raise chk.fail("name", "must not contain control characters")
    return name


def map_path(chk: Checker, raw: Any, scenario: Path) -> Path:
    ref = chk.string(raw, "map")
    if not ref or "\x00" in ref:
        raise chk.fail("map", "must be a file path (not empty, no NUL character)")
    if len(ref) > MAX_PATH_CHARS or any(len(p) > MAX_PATH_PART_CHARS for p in ref.split("/")):
        raise chk.fail(
            "map",
            f"path is too long (at most {MAX_PATH_CHARS} characters, "
            f"{MAX_PATH_PART_CHARS} per name)",
        )
    map_path = scenario.parent / ref
    try:
        if not map_path.is_file():
            raise chk.fail(
                "map", f"map file {short_repr(ref)} not found (looked at {map_path.resolve()})"
            )
        return map_path.resolve()
    except (OSError, ValueError) as err:
        reason = getattr(err, "strerror", None) or str(err)
        raise chk.fail("map", f"cannot open map file {short_repr(ref)}: {reason}") from None
