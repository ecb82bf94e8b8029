"""The worlds a route is checked in, without the planners: a scenario's (:func:`build_world`
in its :func:`enu_frame`) and a QGroundControl plan's (:func:`fence_world`: its geofence's
zones, and a base scenario's obstacles, as obstacles of a flight volume).

``plan`` and ``reroute`` plan in these worlds; ``fly``, ``simulate``, ``validate`` and the
rehearsal only check in them, so they live below :mod:`uavplan.planning` and
:mod:`uavplan.reroute` and import no planner (tests/architecture/test_layering.py holds the line).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from uavplan.airspace import Airspace, build_airspace, check_volume
from uavplan.errors import InputError
from uavplan.flightcheck import Flight, FlightCheck, check_flight, flight_of_mission
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.ground import Ground
from uavplan.mission.items import MissionPlan
from uavplan.scenario import Scenario, Site, Surroundings
from uavplan.world import World

#: the safety margin when no scenario gives one (the scenario format's default)
DEFAULT_MARGIN_M = 10.0


def build_world(scenario: Scenario | Site) -> World:
    """The scenario's obstacles, flight bounds and safety margin as a :class:`World`, where
    the planner flies it (:attr:`Scenario.site`: over a DEM, the ground's solids built for
    this margin are pieces of the world too)."""
    site = scenario.site if isinstance(scenario, Scenario) else scenario
    b = site.bounds
    return World.build(
        site.obstacles,
        bounds_xyz=(b.x_m, b.y_m, b.z_m),
        margin_m=site.safety_margin_m,
        ground=site.ground,
    )


#: a return may leave the flight volume's sides by this much (m): where a route ends on the
#: volume's edge, the brake before the turn home overshoots it (ArduPilot's stopping point
#: lies a/(2P²) = 1.25 m beyond where its S-curve stops); the return's world
#: (:func:`return_world`) is this much wider than the volume
RETURN_BOUNDS_PAD_M = 2.0
#: ... and open this far above and below (m): the proof bounds the climb itself
RETURN_OPEN_Z_M = 1e7


def return_world(
    world: World, bounds_xy_m: tuple[tuple[float, float], tuple[float, float]]
) -> World:
    """What a return to launch must clear (the way-home proof, the verdict's failsafe
    check) in ``world`` (a site's, built in the box ``bounds_xy_m``): its obstacles and the
    terrain's solids that stand on the ground, keeping its margin, in bounds open above and
    below and :data:`RETURN_BOUNDS_PAD_M` wider than the volume (the ceiling is the proof's
    own bound, and a route point that files or rounding put a hair outside is not a
    return's fault)."""
    ground = world.ground
    if ground is not None:
        ground = replace(ground, ceiling_agl_m=RETURN_OPEN_Z_M)
    (x0, x1), (y0, y1) = bounds_xy_m
    pad, top = RETURN_BOUNDS_PAD_M, RETURN_OPEN_Z_M
    bounds = ((x0 - pad, x1 + pad), (y0 - pad, y1 + pad), (-top, top))
    return world.with_limits(bounds_xyz=bounds, ground=ground)


def padded_world(world: World, scenario: Scenario | Site) -> World:
    """``world`` (built for a scenario of the same obstacles) with ``scenario``'s margin,
    bounds and ground: a scenario planned with a wider margin (``plan``'s widening) gets its
    world without splitting the obstacles again."""
    site = scenario.site if isinstance(scenario, Scenario) else scenario
    b = site.bounds
    return world.with_limits(
        margin_m=site.safety_margin_m, bounds_xyz=(b.x_m, b.y_m, b.z_m), ground=site.ground
    )


def enu_frame(scenario: Scenario | Site) -> EnuFrame:
    """The local ENU frame the scenario is planned in (at its site's origin: over terrain at
    the datum). A frame is a value (equal frames share an origin) and cheap to make once
    pyproj is loaded (some 0.5 ms, its transformer made on first use), so none is kept."""
    return EnuFrame.at((scenario.site if isinstance(scenario, Scenario) else scenario).origin)


@dataclass(frozen=True, eq=False)
class PlanWorld:
    """Where a plan is rerouted: its ENU frame (at home, or at the ``--scenario``'s site
    origin: over terrain the datum), the airspace (the fence's zones and the scenario's
    obstacles, the flight volume), the world built from it (with the scenario's ground), the
    safety margin, and home's position in the frame."""

    frame: EnuFrame
    airspace: Airspace
    world: World
    margin_m: float
    home_xy: tuple[float, float]
    ground: Ground | None = None

    def check(self, flight: Flight) -> FlightCheck:
        """``flight`` (in :attr:`frame`) checked in this world, as the rerouting checks the
        plan it writes (:func:`uavplan.flightcheck.check_flight`)."""
        names = self.airspace.names
        return check_flight(self.world, flight, name_of=lambda i: names[i], margin_m=self.margin_m)

    def flight_of(self, plan: MissionPlan) -> Flight:
        """``plan`` as the autopilot flies it in this world (over the ground, if any)."""
        if self.ground is None:
            return flight_of_mission(plan, self.frame)
        return flight_of_mission(plan, self.frame, self.ground.z_at, self.ground.follow)


def plan_frame(
    plan: MissionPlan, base: Scenario | Surroundings | None, file: str | None
) -> tuple[EnuFrame, Ground | None]:
    """The frame a plan is read in (over terrain the site's, z above its datum) and the
    scenario's ground."""
    if plan.home is None:
        raise InputError("the plan has no planned home position (plannedHomePosition)", file=file)
    if base is None:
        home = plan.home
        return EnuFrame.at(GeoPoint(home.lat_deg, home.lon_deg, home.alt_m)), None
    site = base.site
    return EnuFrame.at(site.origin), site.ground


def world_of_plan(
    plan: MissionPlan,
    points_m: NDArray[np.float64],
    frame: EnuFrame,
    ground: Ground | None,
    base: Scenario | Surroundings | None,
    file: str | None,
) -> PlanWorld:
    assert plan.home is not None
    margin_m = base.safety_margin_m if base is not None else DEFAULT_MARGIN_M
    airspace = build_airspace(plan, points_m, frame, margin_m=margin_m, base=base, file=file)
    check_volume(airspace.bounds, file)
    b = airspace.bounds
    world = World.build(
        airspace.obstacles, bounds_xyz=(b.x_m, b.y_m, b.z_m), margin_m=margin_m, ground=ground
    )
    hxy = frame.to_enu_xy([plan.home.lat_deg], [plan.home.lon_deg])[0]
    return PlanWorld(frame, airspace, world, margin_m, (float(hxy[0]), float(hxy[1])), ground)


def fence_world(
    plan: MissionPlan, *, base: Scenario | Surroundings | None = None, file: str | None = None
) -> tuple[PlanWorld, Flight]:
    """The world the rerouting of ``plan`` plans in (its geofence's zones as obstacles, and
    ``base``'s), spanning the plan's whole flight, and that flight (as the autopilot flies the
    items, :func:`uavplan.flightcheck.flight_of_mission`): what ``validate`` and ``render`` check
    and draw a rerouted plan against when no scenario is given. Raises InputError for a plan
    without a planned home or without a position to fly."""
    frame, ground = plan_frame(plan, base, file)
    try:
        if ground is None:
            flight = flight_of_mission(plan, frame)
        else:
            flight = flight_of_mission(plan, frame, ground.z_at, ground.follow)
    except ValueError as err:
        raise InputError(str(err), file=file) from None
    if len(flight.points_enu) < 2:
        raise InputError("the mission has fewer than two positions to fly", file=file)
    return world_of_plan(plan, flight.points_enu, frame, ground, base, file), flight
