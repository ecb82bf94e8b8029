"""The way home of a planned scenario, as ``plan`` writes and reports it.

:func:`way_home` proves the autopilot's own return from every point of the route
(:mod:`.proof`); where the mission ends with a planned return (``end: return``), or where no
RTL altitude up to the ceiling is safe (``end: rtl``), it plans the return from the goal home
(:func:`uavplan.planning.plan_return`, keeping a little more than the margin for the
autopilot's tracking) and marks the corners the autopilot must not cut; and it lists the
vehicle parameters the mission relies on (the RTL altitude, PX4's ``RTL_TYPE`` for a mission
landing, with ``--fence`` the fence's ceiling and the fence switched on), which the ``.plan``
keeps and ``upload --set-params`` sets. docs/way-home.md tells the whole story.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from uavplan.autopilot.params import FENCE_TYPE_ALT_MAX, FENCE_TYPE_POLYGON
from uavplan.autopilot.simulate import FlightEnd
from uavplan.flavour import Autopilot
from uavplan.flightcheck import Flight, flight_of_track
from uavplan.mission.items import VehicleParameter
from uavplan.planners.base import ProgressFn
from uavplan.planning import (
    Leg,
    PlannedReturn,
    enu_frame,
    plan_return,
    with_return,
)
from uavplan.rehearsal import CheckSite
from uavplan.route import PlannedRoute
from uavplan.scenario import Scenario
from uavplan.wayhome.proof import (
    ARDUPILOT_FENCE_MARGIN_M,
    RTL_PARAMETERS,
    ReturnSamples,
    RtlProof,
    Where,
    ceiling_above_home,
    firmware_rtl,
    prove_rtl,
)
from uavplan.world import World

if TYPE_CHECKING:
    from uavplan.autopilot.simulate import FlownTrack

__all__ = [
    "LANDING",
    "WayHome",
    "corner_stops",
    "fence_parameters",
    "legal_ceiling_above_home",
    "return_samples_of",
    "rtl_parameter",
    "way_home",
]


@dataclass(frozen=True, eq=False)
class WayHome:
    """How a planned route gets home, as ``plan`` writes and reports it.

    ``route``: the route as the mission flies it (with the planned return when there is
    one); ``proof``: the autopilot's own return checked from every point (None for a
    planned return until :meth:`proven_on` proves the failsafe on the flown mission);
    ``planned_return``: the mission ends with a planned return (``end: return``, or
    ``end: rtl`` where no RTL altitude up to the ceiling, or the legal ceiling, is safe:
    ``switched``); ``parameters``: what the mission relies on (``upload --set-params``)."""

    end: str
    route: PlannedRoute
    proof: RtlProof | None
    fence_ceiling_m: float | None = None
    switched: bool = False
    return_leg: Leg | None = None
    parameters: tuple[VehicleParameter, ...] = ()
    interrupted: bool = False
    failure: str = ""
    #: the fence was asked for (its parameters are kept when the proof is redone)
    fence: bool = False

    @property
    def planned_return(self) -> bool:
        return self.route.return_enu is not None

    @property
    def return_length_m(self) -> float:
        back = self.route.return_enu
        if back is None:
            return 0.0
        return float(np.linalg.norm(np.diff(back, axis=0), axis=1).sum())

    def report(self) -> dict[str, object]:
        proof = {} if self.proof is None else self.proof.report()
        return {
            "rtl_safe_altitude_m": None if self.proof is None else self.proof.safe_altitude_m,
            "way_home": {
                "end": self.end,
                "flown_end": "return" if self.planned_return else self.end,
                "autopilot": None if self.proof is None else self.proof.autopilot.label,
                **proof,
                "planned_return": self.planned_return,
                "return_replaces_rtl": self.switched,
                "return_length_m": self.return_length_m if self.planned_return else None,
                "return_min_clearance_m": (
                    self.return_leg.min_clearance_m if self.return_leg is not None else None
                ),
                "fence_ceiling_m": self.fence_ceiling_m,
                "parameters": [
                    {
                        "name": p.name,
                        "value": p.value,
                        "at_least": p.at_least,
                        "at_most": p.at_most,
                        "unit": p.unit,
                        "reason": p.reason,
                    }
                    for p in self.parameters
                ],
            },
        }

    def lines(self) -> list[str]:
        """What ``plan`` prints about the way home: the proof, the return, the parameters.
        (Whether a failsafe return from the flight is safe with those parameters is the
        whole flight's verdict, :mod:`uavplan.verdict`, which prints any finding as a
        warning.)"""
        out: list[str] = []
        proof = self.proof
        if proof is not None:
            out.append(_proof_line(proof))
        if self.failure and not self.interrupted:
            out.append(f"way home: the return could not be planned: {self.failure}")
        if self.planned_return:
            if not self.switched:
                why = "the mission"
            elif proof is not None and proof.proven:
                why = "no RTL altitude the vehicle may fly brings it home safely, so the mission"
            else:
                why = "no RTL altitude brings it home safely, so the mission"
            clearance = (
                ""
                if self.return_leg is None
                else (f", clearance {self.return_leg.min_clearance_m:.2f} m")
            )
            out.append(
                f"way home: {why} ends with a planned return ({self.return_length_m:.0f} m"
                f"{clearance}) after DO_LAND_START, landing at home"
            )
            if proof is not None and proof.autopilot is Autopilot.PX4 and not proof.usable:
                out.append(
                    "way home: a return during the mission (a failsafe, RTL) flies the mission "
                    "on to its planned landing with RTL_TYPE 2 (upload --set-params sets it)"
                )
        if self.parameters:
            out.append(
                "parameters the mission relies on (upload --set-params sends them): "
                + ", ".join(p.describe() for p in self.parameters)
            )
        return out

    def proven_on(
        self, scenario: Scenario, flown: FlownTrack, site: CheckSite | None = None
    ) -> WayHome:
        """This way home with the failsafe return proven on ``flown`` (the flight model's
        flight of the mission as written, its planned return included) and the parameters
        the mission relies on recomputed from that proof (``site``: the scenario's check
        site, when the caller built it)."""
        if self.proof is None and self.end != "return":
            return self
        autopilot = scenario.mission.autopilot
        if autopilot not in RTL_PARAMETERS:
            return self
        site = site or CheckSite.of_scenario(scenario)
        setting = _Setting.of(scenario, site, self.route, fence=self.fence)
        proof = setting.prove(return_samples_of(scenario, flown))
        params = _parameters(autopilot, proof, self.route, self.end, setting)
        return replace(self, proof=proof, parameters=params)


#: how ``plan`` names each firmware
FIRMWARE_NAMES = {Autopilot.ARDUPILOT: "ArduPilot", Autopilot.PX4: "PX4"}


def _where(b: Where) -> str:
    return b.text()


def _ceilings(proof: RtlProof) -> str:
    legal = proof.legal_ceiling_m
    if legal is None or legal >= proof.ceiling_m - 1e-9:
        return f"ceiling {proof.ceiling_m:.0f} m"
    return f"ceiling {proof.ceiling_m:.0f} m, legal ceiling {legal:.0f} m above home"


def _proof_line(proof: RtlProof) -> str:
    spec = proof.parameter
    default = f"{proof.default_altitude_m:g} m"
    name = FIRMWARE_NAMES[proof.autopilot]
    brake = (
        f" (braking up to {proof.brake_m:.0f} m on before it turns home)"
        if proof.brake_m >= 0.5
        else ""
    )
    if proof.safe_altitude_m is None:
        assert proof.blocked is not None
        return (
            f"way home: no RTL altitude up to the ceiling ({proof.ceiling_m:.0f} m above home) "
            f"keeps the {proof.margin_m:g} m margin from every point of the flight{brake}: "
            f"at the ceiling, the worst: {_where(proof.blocked)}"
        )
    safe = proof.safe_altitude_m
    if not proof.usable:
        assert proof.legal_ceiling_m is not None
        return (
            f"way home: {name}'s return to launch{brake} keeps the {proof.margin_m:g} m margin "
            f"from every point of the flight only at an RTL altitude of {safe:.2f} m or more, "
            f"above the legal ceiling ({proof.legal_ceiling_m:.0f} m above home; "
            "mission.legal_ceiling or plan --legal-ceiling change it): no RTL altitude is "
            "advised"
        )
    value = _rtl_value(proof)
    head = (
        f"way home: {name}'s return to launch{brake} keeps the {proof.margin_m:g} m margin "
        f"from every point of the flight at an RTL altitude of {safe:.2f} m or more (set "
        f"{spec.name} ≥ {value:g} {spec.unit}; {_ceilings(proof)})"
    )
    if proof.default_safe:
        return f"{head}; the default {default} does"
    if proof.default_blocked is None:
        return f"{head}; the default {default} is above the ceiling"
    return f"{head}; the default {default} does not, the worst: {_where(proof.default_blocked)}"


def _rtl_value(proof: RtlProof) -> float:
    """The least RTL parameter value (firmware unit) proven safe, in whole metres."""
    spec = proof.parameter
    assert proof.setting_m is not None
    return proof.setting_m * spec.per_m


def rtl_parameter(proof: RtlProof) -> VehicleParameter | None:
    """The RTL altitude parameter a proven, usable return needs: at least the safe altitude
    (rounded up to a whole metre), at most the ceiling and the legal ceiling; set to the
    firmware's default when that lies between, else to the nearer bound. None where no
    altitude that may be flown is safe."""
    if proof.safe_altitude_m is None or not proof.usable:
        return None
    spec = proof.parameter
    low = _rtl_value(proof)
    high = math.floor(proof.highest_m + 1e-9) * spec.per_m  # >= low: the proof is usable
    value = min(max(proof.default_altitude_m * spec.per_m, low), high)
    legal = (
        ""
        if proof.legal_ceiling_m is None
        else f" and the legal ceiling ({proof.legal_ceiling_m:.0f} m above home)"
    )
    return VehicleParameter(
        spec.name,
        value,
        at_least=low,
        at_most=high,
        unit=spec.unit,
        reason=(
            f"the return to launch keeps the {proof.margin_m:g} m margin from every point of "
            f"the flight at {proof.safe_altitude_m:.2f} m or higher, up to the ceiling{legal}"
        ),
    )


def fence_parameters(autopilot: Autopilot, ceiling_m: float) -> tuple[VehicleParameter, ...]:
    """The altitude fence at ``ceiling_m`` above home, enabled: ArduPilot FENCE_ENABLE 1,
    FENCE_TYPE 5 (maximum altitude and the uploaded polygons and circles; not the circle
    around home of FENCE_RADIUS), FENCE_ALT_MAX; PX4 GF_MAX_VER_DIST, GF_ACTION 1..5 (not
    0, which turns the fence off; 2, Hold, its default)."""
    ceiling = round(float(ceiling_m), 2)
    why = "the mission's ceiling (the flight volume's top above home)"
    if autopilot is Autopilot.PX4:
        return (
            VehicleParameter("GF_MAX_VER_DIST", ceiling, unit="m", reason=why),
            VehicleParameter(
                "GF_ACTION", 2.0, 1.0, 5.0, reason="a fence breach does something (0: no fence)"
            ),
        )
    return (
        VehicleParameter("FENCE_ENABLE", 1.0, reason="the geofence is on"),
        VehicleParameter(
            "FENCE_TYPE",
            float(FENCE_TYPE_ALT_MAX | FENCE_TYPE_POLYGON),
            reason="the ceiling and the uploaded zones (not the circle of FENCE_RADIUS "
            "around home)",
        ),
        VehicleParameter("FENCE_ALT_MAX", ceiling, unit="m", reason=why),
    )


def legal_ceiling_above_home(
    scenario: Scenario, route: PlannedRoute, legal_m: float | None
) -> float | None:
    """The legal ceiling ``legal_m`` (above the ground) as an RTL altitude above home: over
    flat ground the same; over a DEM less how far home stands above the lowest ground of the
    site (a return flies at one altitude above home, so over lower ground it flies higher
    above it). None: no legal limit."""
    if legal_m is None:
        return None
    ground = scenario.site.ground
    if ground is None:
        return float(legal_m)
    home_z = 0.0 if route.waypoint_ground_z_m is None else float(route.waypoint_ground_z_m[0])
    return max(0.0, float(legal_m) - max(0.0, home_z - float(ground.field.zmin)))


def return_samples_of(scenario: Scenario, flown: FlownTrack) -> ReturnSamples:
    """Where a failsafe return may begin on the flight model's flight ``flown`` of a mission
    of ``scenario``: its track in the site's frame, from the top of the take-off climb to
    where the mission's own return to launch begins (or to touchdown), with its velocities."""
    from uavplan.rehearsal import rtl_start, track_of

    site = scenario.site
    track = track_of(flown, "flight model")
    flight = flight_of_track(
        track,
        enu_frame(site),
        datum_amsl_m=site.datum_amsl_m,
        lands=flown.ended is FlightEnd.LANDED,
    )
    return ReturnSamples.of_track(flight, flown.t_s, flown.current_seq, end=rtl_start(flown))


@dataclass(frozen=True)
class _Setting:
    """Where a scenario's returns are proven: the world they must clear, home, the
    ceiling (less ArduPilot's FENCE_MARGIN under the fence) and the legal ceiling."""

    scenario: Scenario
    floor: World
    home: tuple[float, float, float]
    top_m: float
    ceiling_m: float
    legal_m: float | None
    fence: bool

    @classmethod
    def of(
        cls, scenario: Scenario, site: CheckSite, route: PlannedRoute, *, fence: bool
    ) -> _Setting:
        autopilot = scenario.mission.autopilot
        home_z = 0.0 if route.waypoint_ground_z_m is None else float(route.waypoint_ground_z_m[0])
        start = route.waypoints_enu[0]
        top = ceiling_above_home(route, scenario.site.bounds.z_m[1])
        margin = ARDUPILOT_FENCE_MARGIN_M if fence and autopilot is Autopilot.ARDUPILOT else 0.0
        legal = scenario.mission.legal_ceiling_m
        return cls(
            scenario,
            site.floor,
            (float(start[0]), float(start[1]), home_z),
            top,
            top - margin,
            legal_ceiling_above_home(scenario, route, legal),
            fence,
        )

    def prove(self, samples: ReturnSamples) -> RtlProof:
        autopilot = self.scenario.mission.autopilot
        return prove_rtl(
            self.floor,
            home_enu=self.home,
            autopilot=autopilot,
            ceiling_m=self.ceiling_m,
            name_of=self.scenario.obstacle_name,
            samples=samples,
            legal_ceiling_m=self.legal_m,
        )


def _parameters(
    autopilot: Autopilot, proof: RtlProof | None, route: PlannedRoute, end: str, setting: _Setting
) -> tuple[VehicleParameter, ...]:
    """What the mission relies on: the RTL altitude where a usable one is proven, else PX4's
    RTL_TYPE 2 for a mission with a landing (a return flies the mission on to it), and with
    the fence its parameters."""
    parameters: list[VehicleParameter] = []
    rtl = rtl_parameter(proof) if proof is not None else None
    if rtl is not None:
        parameters.append(rtl)
    elif autopilot is Autopilot.PX4 and (route.return_enu is not None or end == "land"):
        parameters.append(
            VehicleParameter(
                "RTL_TYPE",
                2.0,
                reason="no direct return is safe: a return flies the mission on to its landing",
            )
        )
    if setting.fence:
        parameters.extend(fence_parameters(autopilot, setting.top_m))
    return tuple(parameters)


def way_home(
    scenario: Scenario,
    route: PlannedRoute,
    *,
    fence: bool = False,
    progress: ProgressFn | None = None,
    should_stop: Callable[[], bool] | None = None,
    allowance_m: float = 0.0,
    flown: FlownTrack | None = None,
    site: CheckSite | None = None,
) -> WayHome:
    """The way home of ``route`` planned for ``scenario``: the proof of the autopilot's return
    from every point of the flight (:func:`prove_rtl`: of ``flown``, the flight model's
    flight of the route's mission, with its velocities, else of the route's flown line at
    the cruise speed), a planned return where the mission ends with one (``end: return``) or
    where no RTL altitude is safe up to the ceiling and the legal ceiling (``end: rtl``; the
    scenario's ``mission.legal_ceiling`` above the ground),
    and the parameters the mission relies on (the RTL altitude; with ``fence``, the fence's
    ceiling). ``allowance_m``: a planned return keeps this much more than
    :data:`RETURN_ALLOWANCE_M` beyond the margin (where the flight model found the
    autopilot's flight of the return closer than the margin, the caller plans it again with
    more). A planned return's failsafe is proven on the flown mission afterwards
    (:meth:`WayHome.proven_on`). ``site``: the scenario's check site when the caller built
    it (``plan`` builds it once)."""
    autopilot = scenario.mission.autopilot
    end = scenario.mission.end
    if autopilot not in RTL_PARAMETERS:
        return WayHome(end, route, None)
    site = site or CheckSite.of_scenario(scenario)
    world = site.world
    setting = _Setting.of(scenario, site, route, fence=fence)

    def samples_of(line: PlannedRoute) -> ReturnSamples:
        if flown is not None and line is route:
            return return_samples_of(scenario, flown)
        speed = scenario.vehicle.cruise_speed_m_s or firmware_rtl(autopilot).speed_xy_m_s
        flight = Flight.from_polyline(
            line.flown_enu, from_ground=scenario.mission.takeoff, to_ground=line.end in LANDING
        )
        return ReturnSamples.along(flight, speed_m_s=speed)

    proof = None if end == "return" else setting.prove(samples_of(route))
    if should_stop is not None and should_stop():
        return WayHome(end, route, proof, interrupted=True, failure="interrupted", fence=fence)
    switched = False
    leg = None
    if end == "return" or (end == "rtl" and proof is not None and not proof.usable):
        planned = _plan_return(
            scenario, route, world, progress, should_stop, RETURN_ALLOWANCE_M + allowance_m
        )
        if planned.route is None:
            assert planned.failure is not None
            return WayHome(
                end, route, proof, interrupted=planned.interrupted,
                failure=planned.failure.message, fence=fence,
            )  # fmt: skip
        switched = end == "rtl"
        route, leg = planned.route, planned.leg
        assert route.return_enu is not None
        route = replace(route, return_stops=corner_stops(world, route))
        if proof is None:
            proof = setting.prove(samples_of(route))
    return WayHome(
        end,
        route,
        proof,
        fence_ceiling_m=setting.top_m if fence else None,
        switched=switched,
        return_leg=leg,
        parameters=_parameters(autopilot, proof, route, end, setting),
        fence=fence,
    )


#: the planned return keeps this much more than the margin, for the autopilot's tracking (the
#: whole flight's verdict then flies it through the flight model, corners cut as each
#: firmware cuts them)
RETURN_ALLOWANCE_M = 0.5


def _plan_return(
    scenario: Scenario,
    route: PlannedRoute,
    world: World,
    progress: ProgressFn | None,
    should_stop: Callable[[], bool] | None,
    allowance_m: float,
) -> PlannedReturn:
    """The return planned keeping ``allowance_m`` more than the margin, or (when the goal or
    the start is too close to something for that) the margin itself; the route's clearance
    is measured in ``world`` either way."""
    wide = world.with_limits(margin_m=world.margin_m + allowance_m)
    ends = np.vstack([route.waypoints_enu[-1], route.waypoints_enu[0]])
    if wide.segments_free(ends, ends).all():
        planned = plan_return(
            scenario, route, world=wide, progress=progress, should_stop=should_stop
        )
        if planned.route is not None and planned.route.return_enu is not None:
            measured = with_return(scenario, route, planned.route.return_enu, world)
            return replace(planned, route=measured)
        if planned.interrupted:
            return planned
    return plan_return(scenario, route, world=world, progress=progress, should_stop=should_stop)


#: the corner of a planned return is checked with this many segments fanning out from it
CORNER_FAN = 16


def corner_stops(world: World, route: PlannedRoute) -> tuple[int, ...]:
    """The rows of ``route``'s planned return (0: the goal) whose corner the autopilot may
    not cut. Both firmwares cut a corner inside the triangle of the previous waypoint, the
    corner and the next one (ArduPilot's S-curve blends the two legs, PX4 turns once within
    its acceptance radius, a little outside): a corner whose triangle keeps the margin and
    :data:`RETURN_ALLOWANCE_M` more (its far side and :data:`CORNER_FAN` segments from the
    corner to it, :meth:`World.segments_free`) may be cut; the others are flown to a stop."""
    back = route.return_enu
    assert back is not None
    line = np.vstack([route.waypoints_enu[-2:-1], back])  # the leg into the goal, the return
    stops = []
    k = np.linspace(0.0, 1.0, CORNER_FAN + 1)[:, None]
    for row in range(len(back) - 1):  # the last row is followed by the landing: a stop
        a, b, c = line[row], line[row + 1], line[row + 2]
        chord = a + k * (c - a)
        p0 = np.vstack([a[None, :], np.repeat(b[None, :], len(chord), axis=0)])
        p1 = np.vstack([c[None, :], chord])
        if not world.segments_free(p0, p1, world.margin_m + RETURN_ALLOWANCE_M).all():
            stops.append(row)
    return tuple(stops)


#: mission ends whose flown line ends with a landing descent
LANDING = ("land", "return")
