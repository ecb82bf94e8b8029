"""The scenario's values: frozen, and checked when they are made.

:class:`Scenario` checks itself in ``__post_init__``: every value within its documented
limits, the route points inside the flight volume and above the ground, the planning
problem within the size limits (:func:`problem_size`), and the geometry (start, via points
and goal clear of every obstacle and of the terrain by the safety margin, the take-off climb
and the landing descent clear too). A scenario read from a file, one the rerouting of a
QGroundControl plan builds, and one copied with other settings (``dataclasses.replace``,
:meth:`Scenario.with_planner`) all pass the same checks; a problem is one
:class:`~uavplan.errors.ScenarioError` naming the file (``source``) and the key.

Heights are the file's: above the ground beneath each point. Over a DEM (``terrain``) the
planner flies the scenario's :attr:`Scenario.site`, derived from these values and the DEM.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.config import (
    ConfigError,
    GridSpec,
    PlannerConfig,
    as_dict,
    build_params,
    override,
    planner_entry,
    resolved_planner,
)
from uavplan.errors import InputError, ScenarioError, UavplanError
from uavplan.fileio import InputFile
from uavplan.geo import GeoPoint
from uavplan.obstacles import Bounds, Obstacle
from uavplan.scenario.checker import Checker
from uavplan.scenario.clearance import column_clearance, point_clearance
from uavplan.scenario.limits import (
    MAX_ALTITUDE_M,
    MAX_GRID_CELLS,
    MAX_HORIZONTAL_M,
    MAX_OBSTACLES,
    MAX_ORIGIN_LAT_DEG,
    MAX_ROUTE_SAMPLES,
    MAX_SAFETY_MARGIN_M,
    MAX_SEARCH_WORK,
    MAX_VIA_POINTS,
    ORIGIN_ALT_RANGE_M,
)
from uavplan.scenario.load import read_scenario_file
from uavplan.scenario.settings import MissionConfig, ObstacleSources, VehicleConfig
from uavplan.scenario.site import Site, flat_site, terrain_site
from uavplan.scenario.size import DEFAULT_GRID, fitted_grid, path_grid

if TYPE_CHECKING:
    from uavplan.airframe.wind import Wind
    from uavplan.ground import Surface
    from uavplan.scenario.survey import SurveySpec
    from uavplan.scenario.zones import ZoneSet

Point3 = tuple[float, float, float]


@dataclass(frozen=True)
class Scenario:
    """A checked scenario (see the module doc). Heights are above the ground beneath each
    point; ``terrain`` is the DEM named by the file (None: flat ground at z = 0)."""

    name: str
    origin: GeoPoint
    bounds: Bounds
    start_m: Point3
    goal_m: Point3
    obstacles: tuple[Obstacle, ...]
    safety_margin_m: float = 10.0
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    #: the file it was read from (messages name it), or None
    source: str | None = None
    #: points the route passes through, in order, between start and goal (ENU m)
    via_m: tuple[Point3, ...] = ()
    #: the DEM named by ``terrain`` (its reader's value), or None over flat ground
    terrain: Surface | None = None
    #: where the obstacles came from (for messages)
    obstacle_sources: ObstacleSources = field(default_factory=ObstacleSources)
    #: ``wind:`` (None: calm), for the flight estimates and the physical fitness
    wind: Wind | None = None
    #: every file it was read from (the scenario, its map, obstacle files, DEM): no output
    #: of a command may overwrite one (:meth:`uavplan.app.outputs.OutputSet.reads`)
    files: tuple[InputFile, ...] = field(default=(), compare=False)
    #: ``airspace:``: every zone read and what became of it (its constraints' solids are the
    #: last obstacles); None without the key
    airspace: ZoneSet | None = None

    def __post_init__(self) -> None:
        _check(self)

    @classmethod
    def from_file(cls, path: str | Path) -> Scenario:
        """Read and check a scenario file (and the map, obstacle files and DEM it names)."""
        return cls(**read_scenario_file(path))

    @property
    def terrain_file(self) -> str | None:
        """The DEM's file (resolved path), or None over flat ground."""
        return None if self.terrain is None else str(self.terrain.source)

    @cached_property
    def grid(self) -> GridSpec:
        """The grid the planner uses: ``planner.grid`` when the scenario sets one, else the
        default grid fitted to the flight volume (:func:`uavplan.scenario.size.fitted_grid`:
        the default steps unless the route or the volume is too large for them)."""
        if self.planner.grid is not None:
            return self.planner.grid
        band = self.bounds.z_m[1] - self.bounds.z_m[0]  # over a DEM: above the ground
        return fitted_grid(self.volume, _route_points_xy(self), band)

    @property
    def grid_fitted(self) -> bool:
        """Was :attr:`grid` fitted to the flight volume (the scenario sets no grid)? It is
        the default grid unless the volume is too large for it (:attr:`grid_coarsened`)."""
        return self.planner.grid is None

    @property
    def grid_coarsened(self) -> bool:
        """Was :attr:`grid` fitted coarser than the default, for a large volume?"""
        return self.grid_fitted and self.grid != DEFAULT_GRID

    @property
    def volume(self) -> Bounds:
        """The flight volume the planner searches: the bounds, over a DEM from the datum to
        the highest ground plus the ceiling (:attr:`site`'s bounds)."""
        return self.bounds if self.terrain is None else self.site.bounds

    @cached_property
    def site(self) -> Site:
        """The scenario where the planner flies it (see :mod:`uavplan.scenario.site`): its
        own values over flat ground, moved onto the DEM over terrain. Derived, never stored:
        a copy with another margin or other bounds has its own."""
        args = (self.origin, self.bounds, self.start_m, self.goal_m, self.via_m, self.obstacles)
        if self.terrain is None:
            return flat_site(*args, self.safety_margin_m)
        return terrain_site(*args, self.safety_margin_m, self.terrain)

    def __getstate__(self) -> dict[str, Any]:
        # the site is derived (and over terrain holds a function): pickles carry the values
        return {k: v for k, v in self.__dict__.items() if k not in ("site", "grid")}

    def obstacle_name(self, index: int) -> str:
        """How messages name obstacle ``index`` (``obstacles[2]``, ``obstacle #4 of map
        m.yaml``, ...)."""
        return self.obstacle_sources.name(index)

    def with_planner(self, **changes: Any) -> Scenario:
        """A copy whose planner config has ``changes`` (CLI overrides): any
        :class:`PlannerConfig` field, plus ``spsa=SpsaParams(...)`` (SPSA's section) and
        ``options={...}`` (the section of the resulting algorithm, validated)."""
        cfg = self.planner
        spsa = changes.pop("spsa", None)
        options = changes.pop("options", None)
        if "algorithm" in changes:
            planner_entry(changes["algorithm"], "--algorithm")
        cfg = replace(cfg, **changes)
        if spsa is not None:
            cfg = cfg.with_params("spsa", spsa)
        if options is not None:
            params = build_params(cfg.algorithm, dict(options), cfg.algorithm)
            cfg = cfg.with_params(cfg.algorithm, params) if params is not None else cfg
        return replace(self, planner=cfg)


def load_survey_scenario(path: str | Path) -> tuple[Scenario, SurveySpec]:
    """Read and check a scenario with a ``survey:`` section: the scenario (its goal the
    area's far corner at the survey altitude, see :func:`read_scenario_file`) and the
    survey. A file without one is refused (``goal`` names the missing key)."""
    kwargs = read_scenario_file(path, surveys=True)
    spec = kwargs.pop("survey", None)
    if spec is None:
        raise ScenarioError(
            "a survey scenario needs a survey: section", file=str(path), key="survey"
        )
    return Scenario(**kwargs), spec


def is_survey_file(path: str | Path) -> bool:
    """Does the YAML file ``path`` hold a top-level ``survey:`` section? False for anything
    unreadable: the ordinary loader then says what is wrong with it."""
    from uavplan.scenario.yamlfile import read_yaml

    try:
        raw = read_yaml(Path(path), "scenario")
    except (UavplanError, OSError, ValueError):
        return False
    return isinstance(raw, dict) and "survey" in raw


def load_scenario(path: str | Path) -> Scenario:
    """Read and check a scenario file (:meth:`Scenario.from_file`)."""
    return Scenario.from_file(path)


def load_site(path: str | Path) -> Scenario:
    """A scenario file to check a mission against (``--scenario`` of ``validate``,
    ``simulate``, ``fly``, ``convert``, ``render --mission``): a route scenario as it is; a
    survey scenario (planned by ``plan``) as the site ``plan`` judged its mission in: its
    ``exclude`` polygons no-fly obstacles, its goal the area's far corner (a route scenario
    must have one; nothing here plans to it)."""
    kwargs = read_scenario_file(path, surveys=True)
    spec = kwargs.pop("survey", None)
    if spec is None:
        return Scenario(**kwargs)
    from uavplan.scenario.survey import with_no_fly

    return with_no_fly(Scenario(**kwargs), spec)


@dataclass(frozen=True)
class Surroundings:
    """What a scenario file says about where a route is flown, without the route: origin,
    flight volume, obstacles (and DEM), margin and settings, checked as a scenario's are.
    ``start_m``, ``goal_m`` and ``via_m`` are the file's as written (checked key by key, not
    against the obstacles; None / empty when the file has none): the rerouting of a
    QGroundControl plan takes its route from the plan, and ``render --no-plan`` draws them
    where they are even when a scenario could not start there."""

    name: str
    origin: GeoPoint
    bounds: Bounds
    obstacles: tuple[Obstacle, ...]
    safety_margin_m: float = 10.0
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    source: str | None = None
    terrain: Surface | None = None
    obstacle_sources: ObstacleSources = field(default_factory=ObstacleSources)
    start_m: Point3 | None = None
    goal_m: Point3 | None = None
    via_m: tuple[Point3, ...] = ()
    wind: Wind | None = None
    #: every file it was read from (:attr:`Scenario.files`)
    files: tuple[InputFile, ...] = field(default=(), compare=False)
    airspace: ZoneSet | None = None

    def __post_init__(self) -> None:
        _check_surroundings(Checker(self.source or self.name), self)

    @classmethod
    def from_file(cls, path: str | Path) -> Surroundings:
        """Read and check a scenario or map file; ``start`` and ``goal`` are optional. A
        survey scenario's surroundings are its site: no goal, its ``exclude`` polygons
        no-fly obstacles (:func:`uavplan.scenario.survey.with_no_fly`)."""
        kwargs = read_scenario_file(path, route=False, surveys=True)
        spec = kwargs.pop("survey", None)
        if spec is None:
            return cls(**kwargs)
        from uavplan.scenario.survey import with_no_fly

        return with_no_fly(cls(**{**kwargs, "goal_m": None}), spec)

    def obstacle_name(self, index: int) -> str:
        """How messages name obstacle ``index`` (as :meth:`Scenario.obstacle_name`)."""
        return self.obstacle_sources.name(index)

    @cached_property
    def site(self) -> Site:
        """Where a route through these surroundings is flown (:attr:`Scenario.site`): the
        origin (over terrain the datum), the bounds, the obstacles standing on the ground and
        the ground itself. Without a route of their own, the file's start and goal (or the
        middle of the volume) hold the site's route points, which a user of the site (the
        rerouting of a plan) replaces by its own."""
        b = self.bounds
        middle = ((b.x_m[0] + b.x_m[1]) / 2, (b.y_m[0] + b.y_m[1]) / 2, (b.z_m[0] + b.z_m[1]) / 2)
        start = self.start_m if self.start_m is not None else middle
        goal = self.goal_m if self.goal_m is not None else middle
        args = (self.origin, b, start, goal, self.via_m, self.obstacles)
        if self.terrain is None:
            return flat_site(*args, self.safety_margin_m)
        return terrain_site(*args, self.safety_margin_m, self.terrain)

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k != "site"}


def load_surroundings(path: str | Path) -> Surroundings:
    """Read and check a scenario or map file without requiring a route
    (:meth:`Surroundings.from_file`)."""
    return Surroundings.from_file(path)


def with_search(scenario: Scenario, changes: Mapping[str, Any], key: str = "") -> Scenario:
    """``scenario`` with command-line overrides of its search values (``{"iterations": 5}``),
    validated by :func:`uavplan.config.override` (ConfigError naming ``key``, e.g.
    ``--iterations``); the copy is checked like any scenario (the size limits included)."""
    changes = {k: v for k, v in changes.items() if v is not None}
    if not changes:
        return scenario
    try:
        search = override(scenario.planner.search, changes)
    except ConfigError as err:
        raise ConfigError(err.reason, key=key or err.key) from None
    return scenario.with_planner(search=search)


def resolved_config(scenario: Scenario | PlannerConfig, algorithm: str | None = None) -> dict:
    """The whole resolved configuration of a run of ``algorithm`` (default: the configured
    one), JSON-able: every search value (with the effective fitness smoothing), the
    algorithm's own parameters, grid, energy, post-processing, margin and margin pad, and for a
    scenario its geometry summary (where the planner flies it: over terrain heights above
    the datum) and mission settings — enough to reproduce the run."""
    if isinstance(scenario, PlannerConfig):
        return {"planner": resolved_planner(scenario, algorithm)}
    scn = scenario
    site = scn.site
    return {
        "scenario": scn.name,
        "source": scn.source,
        "origin": {
            "lat": site.origin.lat_deg,
            "lon": site.origin.lon_deg,
            "alt": site.origin.alt_m,
        },
        "bounds": {
            "x": list(site.bounds.x_m),
            "y": list(site.bounds.y_m),
            "z": list(site.bounds.z_m),
        },
        "start": list(site.start_m),
        "goal": list(site.goal_m),
        "obstacles": len(scn.obstacles),
        "safety_margin_m": scn.safety_margin_m,
        "planner": {
            **resolved_planner(scn.planner, algorithm),
            "grid": as_dict(scn.grid),
            "grid_fitted": scn.grid_fitted,
        },
        "vehicle": {
            "cruise_speed_m_s": scn.vehicle.cruise_speed_m_s,
            "takeoff_altitude_m": scn.vehicle.takeoff_altitude_m,
            "profile": dict(scn.vehicle.profile_spec) or None,
        },
        "wind": None if scn.wind is None else wind_dict(scn.wind),
        "mission": {
            "autopilot": scn.mission.autopilot.name.lower(),
            "spacing_m": scn.mission.spacing_m,
            "end": scn.mission.end,
        },
    }


def wind_dict(wind: Wind) -> dict[str, Any]:
    """``wind`` as the report echoes it (the scenario's keys)."""
    out: dict[str, Any] = {"from": wind.from_deg}
    if wind.heights_m is not None and wind.speeds_m_s is not None:
        out["profile"] = {"heights": list(wind.heights_m), "speeds": list(wind.speeds_m_s)}
        return out
    out["speed"] = wind.speed_m_s
    if wind.shear_exponent:
        out["profile"] = {
            "exponent": wind.shear_exponent,
            "reference_height": wind.reference_height_m,
        }
    return out


# ---------------------------------------------------------------------------------------------
# The checks


def _check(scn: Scenario) -> None:
    """Every check of a scenario, in the order a file's reader reports them."""
    chk = Checker(scn.source or scn.name)
    _check_values(chk, scn)
    _check_points(chk, scn)
    if scn.terrain is not None:
        _check_above_terrain(chk, scn)  # builds the site: the volume the size is of
    _check_problem_size(chk, scn)
    _check_geometry(chk, scn.site, scn)


def _check_values(chk: Checker, scn: Scenario) -> None:
    """The values a file's reader checks key by key, for a scenario made any other way."""
    _check_surroundings(chk, scn)
    if len(scn.via_m) > MAX_VIA_POINTS:
        raise chk.fail("via", f"{len(scn.via_m):,} points (at most {MAX_VIA_POINTS:,})")
    for key, point in _route_points(scn):
        chk.point(point, key, 3)


def _check_surroundings(chk: Checker, scn: Scenario | Surroundings) -> None:
    """The values of a scenario but its route points."""
    if not scn.name.strip():
        raise chk.fail("name", "must not be empty")
    lat = scn.origin.lat_deg
    if abs(lat) > MAX_ORIGIN_LAT_DEG:
        raise chk.fail("origin.lat", "too close to a pole for a local ENU frame")
    lo, hi = ORIGIN_ALT_RANGE_M
    if not lo <= scn.origin.alt_m <= hi:
        raise chk.fail("origin.alt", f"must be within [{lo:g}, {hi:g}] m AMSL")
    for axis, (a, b) in zip("xyz", (scn.bounds.x_m, scn.bounds.y_m, scn.bounds.z_m), strict=True):
        limit = MAX_ALTITUDE_M if axis == "z" else MAX_HORIZONTAL_M
        if not (math.isfinite(a) and math.isfinite(b) and -limit <= a < b <= limit):
            raise chk.fail(f"bounds.{axis}", f"needs min < max within ±{limit:g} m")
    if scn.bounds.z_m[0] < 0:
        raise chk.fail("bounds.z", "must not go below the ground (z = 0)")
    if not (math.isfinite(scn.safety_margin_m) and 0 <= scn.safety_margin_m <= MAX_SAFETY_MARGIN_M):
        raise chk.fail("safety_margin", f"must be within [0, {MAX_SAFETY_MARGIN_M:g}] m")
    if len(scn.obstacles) > MAX_OBSTACLES:
        raise chk.fail(
            "obstacles", f"map and scenario hold {len(scn.obstacles):,} (at most {MAX_OBSTACLES:,})"
        )
    if scn.wind is not None:
        _check_wind(chk, scn.wind, scn.vehicle, scn.bounds.z_m[1])


def _check_wind(chk: Checker, wind: Wind, vehicle: VehicleConfig, ceiling_m: float) -> None:
    """The wind must leave the vehicle able to hold its position at every height it may fly
    (up to the ceiling, above the ground): a wind as fast as its top airspeed stops it."""
    import numpy as np

    heights = np.linspace(0.0, max(ceiling_m, 0.0), 257)
    if wind.heights_m is not None:
        heights = np.concatenate([heights, [h for h in wind.heights_m if h <= ceiling_m]])
    speeds = wind.speed_at(heights)
    worst = int(np.argmax(speeds))
    profile = vehicle.profile
    if speeds[worst] >= profile.max_airspeed_m_s:
        raise chk.fail(
            "wind.speed",
            f"{float(speeds[worst]):.1f} m/s at {float(heights[worst]):.0f} m above the ground "
            f"is more than {profile.name} can fly against (max airspeed "
            f"{profile.max_airspeed_m_s:g} m/s)",
        )


def _route_points(scn: Scenario | Site) -> list[tuple[str, Point3]]:
    """(key, point) of the start, every via point and the goal, in route order."""
    points = [("start", scn.start_m), *((f"via[{i}]", p) for i, p in enumerate(scn.via_m))]
    return [*points, ("goal", scn.goal_m)]


def _check_points(chk: Checker, scn: Scenario) -> None:
    """Start, via points and goal inside the bounds and above the ground, each at least 1 m
    from the one before horizontally; the take-off altitude under the ceiling."""
    points = _route_points(scn)
    for key, point in points:
        if point[2] <= 0.0:
            if key == "start":
                hint = "the mission adds the take-off climb from the ground below it"
            elif key == "goal":
                hint = "to land there, use mission.end: land"
            else:
                hint = "a via point is a waypoint in the air"
            raise chk.fail(
                f"{key}[2]", f"must be above the ground (z > 0), got {point[2]:g}: {hint}"
            )
        if not scn.bounds.contains(point):
            raise chk.fail(key, f"{list(point)} is outside the bounds")
    for (_, a), (key, b) in itertools.pairwise(points):
        if math.hypot(b[0] - a[0], b[1] - a[1]) < 1.0:
            raise chk.fail(key, "must be at least 1 m away from the point before it horizontally")
    takeoff = scn.vehicle.takeoff_altitude_m
    ceiling = scn.bounds.z_m[1]
    if takeoff is not None and takeoff > ceiling + 1e-9:
        raise chk.fail(
            "vehicle.takeoff_altitude",
            f"{takeoff:g} m is above the ceiling of the flight volume (bounds.z max {ceiling:g})",
        )


def problem_size(scn: Scenario) -> dict[str, float]:
    """Estimates of what planning ``scn`` needs on its grid (:attr:`Scenario.grid`), each
    checked against its documented limit: ``grid_cells`` (for the largest leg: path-frame
    columns × lateral × vertical nodes over the flight volume, :attr:`Scenario.volume`),
    ``search_work`` (population × iterations × the path columns of all legs),
    ``route_samples`` (twice the legs' length / post.sample_step_m) and ``columns``."""
    cfg = scn.planner
    cells, columns, length = path_grid(scn.volume, _route_points_xy(scn), scn.grid)
    return {
        "columns": float(columns),
        "grid_cells": float(cells),
        "search_work": float(cfg.search.population * cfg.search.iterations * columns),
        "route_samples": 2.0 * length / cfg.post.sample_step_m,
    }


def _route_points_xy(scn: Scenario) -> list[tuple[float, float]]:
    return [(p[0], p[1]) for _, p in _route_points(scn)]


_SIZE_LIMITS = {
    "grid_cells": (MAX_GRID_CELLS, "planner.grid", "path grid cells over the flight volume"),
    "search_work": (
        MAX_SEARCH_WORK,
        "planner.iterations",
        "node updates (population × iterations × path columns)",
    ),
    "route_samples": (MAX_ROUTE_SAMPLES, "planner.post.sample_step_m", "route samples"),
}


def check_limits(scn: Scenario) -> None:
    """Refuse ``scn`` (ScenarioError naming its file) when planning it would exceed a
    documented size limit (:func:`problem_size`). Every scenario is checked when it is made;
    this is the same check on its own."""
    _check_problem_size(Checker(scn.source or scn.name), scn)


def _check_problem_size(chk: Checker, scn: Scenario) -> None:
    size = problem_size(scn)
    for what, (limit, key, text) in _SIZE_LIMITS.items():
        if size[what] > limit:
            hint = "coarsen the grid, shrink the bounds or lower the search effort"
            if what == "grid_cells":
                hint = (
                    f"coarsen the grid ({_steps(scn.grid)} now) or leave planner.grid out to "
                    "have one fitted to the flight volume, or shrink the bounds"
                )
            raise chk.fail(
                key,
                f"the scenario is too large to plan: about {size[what]:.3g} {text}, "
                f"the limit is {limit:.3g} ({hint})",
            )


def _steps(grid: GridSpec) -> str:
    return f"{grid.dx_m:g} × {grid.dy_m:g} × {grid.dz_m:g} m"


def _check_geometry(chk: Checker, site: Site, scn: Scenario) -> None:
    """Start, via points and goal clear of every obstacle plus the margin, and the vertical
    take-off climb (and the landing descent with ``end: land``) clear too. Exact distances
    (:mod:`uavplan.scenario.clearance`), where the planner flies them (the site)."""
    margin = scn.safety_margin_m
    for key, point in _route_points(site):
        clearance, index = point_clearance(site.obstacles, point, within_m=margin)
        if index >= 0 and clearance < margin - 1e-9:
            inside = "inside" if clearance <= 0 else f"{clearance:.1f} m from"
            raise chk.fail(
                key,
                f"{list(point)} is {inside} {scn.obstacle_name(index)} "
                f"(needs {margin:g} m safety margin)",
            )
    columns = []
    if scn.mission.takeoff:
        columns.append(("start", site.start_m, "take-off climb"))
    if scn.mission.end == "land":
        columns.append(("goal", site.goal_m, "landing descent"))
    for key, point, what in columns:
        dist, index = column_clearance(site.obstacles, point[:2], within_m=margin)
        if index >= 0 and dist < margin - 1e-9:
            raise chk.fail(
                key,
                f"the {what} above {list(point[:2])} passes {dist:.1f} m from "
                f"{scn.obstacle_name(index)} (needs {margin:g} m safety margin)",
            )


def _check_above_terrain(chk: Checker, scn: Scenario) -> None:
    """The site over the DEM can be built (the DEM covers the bounds and the points), and
    every route point keeps the margin from the terrain (the exact distance to the DEM's
    surface, see :mod:`uavplan.ground`) and from the ceiling above the ground: a clear error
    naming the point and where the terrain comes closest."""
    try:
        site = scn.site
    except InputError as err:  # the DEM's own error (TerrainError)
        raise chk.fail("terrain", err.reason) from None
    g = site.ground
    assert g is not None
    margin = scn.safety_margin_m
    points = [point for _, point in _route_points(site)]
    dist, kind, where = g.clearance(points)
    for (key, point), z_ground, d, k, xy in zip(
        _route_points(site), site.ground_under_m, dist, kind, where, strict=True
    ):
        agl = point[2] - float(z_ground)
        if d >= margin - 1e-9:
            continue
        at = f"({xy[0]:.0f}, {xy[1]:.0f})"
        if k == 0:
            raise chk.fail(
                key,
                f"{agl:.1f} m above the ground there is {max(float(d), 0.0):.1f} m from the "
                f"terrain at {at} (needs {margin:g} m safety margin): fly higher or move the "
                "point",
            )
        raise chk.fail(
            key,
            f"{agl:.1f} m above the ground there is too close to the ceiling over {at} "
            f"(bounds.z max {g.ceiling_agl_m:g} m above the ground, kept with the {margin:g} m "
            "safety margin): fly lower or raise bounds.z",
        )
