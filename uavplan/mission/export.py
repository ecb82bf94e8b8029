"""Route exports for maps and globes: GeoJSON (RFC 7946) and KML 2.2.

Both take a :class:`MissionPlan`, which is all ``uavplan convert`` has, plus optional
:class:`ExportExtras` that ``uavplan plan`` knows as well: the obstacle footprints, the planned
(smoothed) path and the flown polyline, in the scenario's ENU frame
(:meth:`ExportExtras.for_route` takes them from the :class:`~uavplan.route.PlannedRoute`).

What is drawn:

* the **route**: the polyline the vehicle flies (home on the ground, the takeoff climb,
  straight legs between waypoints, a landing descent): a just-planned route's own
  :attr:`~uavplan.route.PlannedRoute.flown_enu` when the extras carry it, otherwise traced
  from the mission items by :func:`~uavplan.mission.builder.mission_polyline_enu` (the same
  line for a mission built from the route); the RTL leg home is the autopilot's and is not
  drawn;
* the **waypoints**: every mission item with a position, with its sequence number, command
  and altitude; and the home position;
* with extras: the **planned path** (the smooth curve the waypoints were sampled from) and
  the **obstacles** (footprint polygons with their heights; cylinders as 48-gons);
* the mission's **geofence** zones, if it has any (circles as 48-gons).

Altitudes: over flat ground the mission's altitudes are heights above home, which is the
scenario's flat ground, and that is what both formats carry. GeoJSON's third coordinate is
that height in metres (RFC 7946 would have ellipsoidal height; every feature says so in its
``altitude_reference`` property, and the route gives ``home_amsl_m`` to convert). KML uses
``<altitudeMode>relativeToGround</altitudeMode>``, the route is ``<extrude>``\\ d down to the
ground and obstacles are extruded to their heights, so Google Earth shows a 3-D scene.

Over terrain (extras with ``datum_amsl_m``) every coordinate is an altitude AMSL (KML
``absolute``) and says so; a waypoint's ``height_m`` is its altitude in its own frame (above
home, or above the terrain for a terrain-frame item, labelled), an obstacle's ``height_m``
is above the ground it stands on and ``top_amsl_m`` its top. The site's internal datum never
appears.
"""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from uavplan.errors import MissionFileError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.geometry2d import circle_ring, orient_ccw
from uavplan.mission.builder import mission_polyline_enu
from uavplan.mission.fence import Footprint, footprints_of
from uavplan.mission.items import (
    GLOBAL_FRAMES,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    canonical_frame,
)
from uavplan.obstacles import Obstacle
from uavplan.route import PlannedRoute

#: value of every feature's ``altitude_reference`` property
ALTITUDE_REFERENCE = "height above home (the takeoff point on flat ground), metres"
AMSL_REFERENCE = "metres above mean sea level (planned over a terrain model)"
TERRAIN_REFERENCE = "height above the terrain beneath, metres (MAV_FRAME_GLOBAL_TERRAIN_ALT)"
#: decimals kept for degrees (1e-8 deg is about 1 mm) and metres
DEGREE_DECIMALS = 8
METRE_DECIMALS = 3
#: vertices of a circle drawn as a polygon
CIRCLE_SEGMENTS = 48
KML_NAMESPACE = "http://www.opengis.net/kml/2.2"


@dataclass(frozen=True)
class ExportExtras:
    """What an export can show beyond the mission itself (everything optional).

    ``frame``: the ENU frame of the planning; required for ``obstacles`` (:mod:`uavplan.obstacles`
    values or :class:`~uavplan.mission.fence.Footprint`\\ s), ``planned_path_enu`` and
    ``flown_enu`` (``(n, 3)`` ENU metres). ``flown_enu``, when given, is drawn as the route
    instead of tracing it from the mission items. ``properties`` are copied onto the route
    feature / document (scenario name, algorithm, energy...).
    """

    frame: EnuFrame | None = None
    obstacles: Sequence[Obstacle | Footprint] = ()
    planned_path_enu: NDArray[np.float64] | None = None
    flown_enu: NDArray[np.float64] | None = None
    name: str | None = None
    safety_margin_m: float | None = None
    properties: Mapping[str, Any] = field(default_factory=dict)
    #: over terrain: ENU z is metres above this altitude AMSL, and the export gives AMSL
    #: altitudes (KML ``absolute``) instead of heights above flat ground
    datum_amsl_m: float | None = None
    #: over terrain: each obstacle's height above the ground it stands on, by obstacle index
    #: (what ``height_m`` says; the footprints' own heights are tops above the datum)
    heights_agl_m: tuple[float, ...] | None = None
    #: over terrain: the ground's altitude AMSL at (lat, lon) arrays (to place terrain-frame
    #: waypoints at their altitude AMSL)
    ground_amsl_m: (
        Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]] | None
    ) = None
    #: more properties of some obstacles, by index: an airspace zone's name, class, floor and
    #: ceiling as its file writes them (``zone``, ``zone_class``, ``floor``, ``ceiling``)
    obstacle_labels: Mapping[int, Mapping[str, Any]] = field(default_factory=dict)
    #: a survey's area outline ``(k, 2)``, its photos ``(n, 2)`` and their image footprints
    #: on the ground ``(n, 4, 2)`` (ENU metres in ``frame``)
    survey_area_enu: NDArray[np.float64] | None = None
    photos_enu: NDArray[np.float64] | None = None
    photo_footprints_enu: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "obstacles", footprints_of(self.obstacles))
        needs_frame = (
            self.planned_path_enu is not None
            or self.flown_enu is not None
            or self.survey_area_enu is not None
            or self.photos_enu is not None
        )
        if self.frame is None and (self.obstacles or needs_frame):
            raise ValueError("obstacles and planned or flown paths need their ENU frame")
        for name in ("planned_path_enu", "flown_enu"):
            value = getattr(self, name)
            if value is not None:
                path = np.asarray(value, dtype=np.float64)
                if path.ndim != 2 or path.shape[1] != 3:
                    raise ValueError(f"{name} must have shape (n, 3), got {path.shape}")
                object.__setattr__(self, name, path)

    @classmethod
    def for_route(
        cls,
        route: PlannedRoute,
        obstacles: Sequence[Obstacle | Footprint] = (),
        *,
        name: str | None = None,
        properties: Mapping[str, Any] | None = None,
        heights_agl_m: tuple[float, ...] | None = None,
        ground_amsl_m: Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]
        | None = None,
        obstacle_labels: Mapping[int, Mapping[str, Any]] | None = None,
    ) -> ExportExtras:
        """A planned route's frame, smoothed path, flown line and margin, plus obstacles
        (over terrain: their heights above the ground, and the ground's altitude)."""
        return cls(
            frame=route.frame,
            obstacles=obstacles,
            planned_path_enu=route.path_enu,
            flown_enu=route.flown_enu,
            name=name,
            safety_margin_m=route.safety_margin_m,
            properties=dict(properties or {}),
            datum_amsl_m=route.datum_amsl_m,
            heights_agl_m=heights_agl_m,
            ground_amsl_m=ground_amsl_m,
            obstacle_labels=dict(obstacle_labels or {}),
        )

    @property
    def footprints(self) -> tuple[Footprint, ...]:
        """The obstacles as footprints (``__post_init__`` converted them)."""
        return footprints_of(self.obstacles)


# ---------------------------------------------------------------------------------------------
# Geometry shared by both formats


@dataclass(frozen=True)
class _Waypoint:
    seq: int
    index: int
    item: MissionItem
    height_m: float  # above home (above the terrain for a terrain-frame item)
    amsl_m: float | None = None  # over terrain: its altitude AMSL when known


@dataclass(frozen=True)
class _Area:
    kind: str  # "obstacle" | "fence"
    ring_lonlat: NDArray[np.float64]  # (k, 2) counter-clockwise, not closed
    properties: dict[str, Any]
    height_m: float | None = None


@dataclass(frozen=True)
class _Scene:
    name: str
    home: GeoPoint | None
    route_lonlatalt: NDArray[np.float64] | None  # (n, 3)
    planned_lonlatalt: NDArray[np.float64] | None
    waypoints: tuple[_Waypoint, ...]
    areas: tuple[_Area, ...]
    properties: dict[str, Any]
    absolute: bool = False  # altitudes AMSL (over terrain) instead of above flat ground
    photos_lonlat: NDArray[np.float64] | None = None  # a survey's photos (k, 2)


def _scene(plan: MissionPlan, extras: ExportExtras | None) -> _Scene:
    extras = extras or ExportExtras()
    home_alt = plan.home.alt_m if plan.home is not None else None
    waypoints = _waypoints(plan, home_alt)
    datum = extras.datum_amsl_m
    if datum is not None and home_alt is not None:
        ground = extras.ground_amsl_m

        def amsl(wp: _Waypoint) -> float | None:
            if not _terrain_frame(wp.item):
                return home_alt + wp.height_m
            if ground is None:
                return None
            lat, lon = np.array([wp.item.lat_deg]), np.array([wp.item.lon_deg])
            return float(ground(lat, lon)[0]) + wp.height_m

        waypoints = tuple(replace(wp, amsl_m=amsl(wp)) for wp in waypoints)
    route = None
    if extras.flown_enu is not None:  # a planned route's own line: not rebuilt from items
        assert extras.frame is not None
        route_enu = extras.flown_enu
        if len(route_enu) >= 2:
            route = _enu_to_lonlatalt(route_enu, extras.frame, datum)
    else:
        route_enu = _route_enu(plan)
        if len(route_enu) >= 2:
            frame = _route_frame(plan)
            assert frame is not None
            route = _enu_to_lonlatalt(route_enu, frame)
    planned = None
    if extras.planned_path_enu is not None and len(extras.planned_path_enu) >= 2:
        assert extras.frame is not None
        planned = _enu_to_lonlatalt(extras.planned_path_enu, extras.frame, datum)
    areas: list[_Area] = []
    if extras.obstacles:
        assert extras.frame is not None
        for fp in extras.footprints:
            agl = extras.heights_agl_m
            props: dict[str, Any] = {
                "kind": "obstacle",
                "index": fp.index,
                "shape": fp.kind,
                "height_m": fp.height_m if agl is None else agl[fp.index],
            }
            if datum is not None:
                props["height_reference"] = "above the ground at the obstacle's centre"
            if fp.radius_m is not None:
                props["radius_m"] = fp.radius_m
            if extras.safety_margin_m is not None:
                props["safety_margin_m"] = extras.safety_margin_m
            props.update(extras.obstacle_labels.get(fp.index, {}))
            ring = _xy_to_lonlat(fp.outline_enu(CIRCLE_SEGMENTS), extras.frame)
            top = fp.height_m if datum is None else datum + fp.height_m
            if datum is not None:
                props["top_amsl_m"] = round(top, METRE_DECIMALS)
            areas.append(_Area("obstacle", ring, props, top))
    areas.extend(_fence_areas(plan))
    photos = None
    if extras.survey_area_enu is not None:
        assert extras.frame is not None
        ring = orient_ccw(_xy_to_lonlat(np.asarray(extras.survey_area_enu), extras.frame))
        areas.append(_Area("survey_area", ring, {"kind": "survey_area", "name": "survey area"}))
    if extras.photo_footprints_enu is not None:
        assert extras.frame is not None
        for k, fp in enumerate(extras.photo_footprints_enu):
            ring = orient_ccw(_xy_to_lonlat(np.asarray(fp), extras.frame))
            areas.append(_Area("photo_footprint", ring, {"kind": "photo_footprint", "photo": k}))
    if extras.photos_enu is not None and len(extras.photos_enu):
        assert extras.frame is not None
        photos = _xy_to_lonlat(np.asarray(extras.photos_enu), extras.frame)
    length = float(np.linalg.norm(np.diff(route_enu, axis=0), axis=1).sum())
    properties: dict[str, Any] = {
        "autopilot": plan.autopilot.label,
        "mission_items": len(plan.items),
        "route_length_m": round(length, METRE_DECIMALS),
        "altitude_reference": ALTITUDE_REFERENCE if datum is None else AMSL_REFERENCE,
    }
    if plan.home is not None:
        properties["home_amsl_m"] = round(plan.home.alt_m, METRE_DECIMALS)
    if extras.safety_margin_m is not None:
        properties["safety_margin_m"] = extras.safety_margin_m
    properties.update(extras.properties)
    return _Scene(
        name=extras.name or "uavplan mission",
        home=plan.home,
        route_lonlatalt=route,
        planned_lonlatalt=planned,
        waypoints=waypoints,
        areas=tuple(areas),
        properties=properties,
        absolute=datum is not None,
        photos_lonlat=photos,
    )


def _terrain_frame(item: MissionItem) -> bool:
    return canonical_frame(item.frame) == MavFrame.GLOBAL_TERRAIN_ALT


def _route_frame(plan: MissionPlan) -> EnuFrame | None:
    """A frame to trace the flown route in: at home, or at the first positioned item."""
    if plan.home is not None:
        return EnuFrame.at(GeoPoint(plan.home.lat_deg, plan.home.lon_deg, plan.home.alt_m))
    for item in plan.items:
        if item.is_global:
            return EnuFrame.at(GeoPoint(item.lat_deg, item.lon_deg, 0.0))
    return None


def _route_enu(plan: MissionPlan) -> NDArray[np.float64]:
    frame = _route_frame(plan)
    if frame is None:
        return np.empty((0, 3))
    try:
        return mission_polyline_enu(plan, frame)
    except ValueError as err:
        raise MissionFileError(f"cannot trace the route: {err}") from None


def _waypoints(plan: MissionPlan, home_alt_m: float | None) -> tuple[_Waypoint, ...]:
    first_seq = len(plan.wire_items()) - len(plan.items)  # ArduPilot's home takes seq 0
    out = []
    for index, item in enumerate(plan.items):
        if item.frame not in GLOBAL_FRAMES:
            continue
        if canonical_frame(item.frame) == MavFrame.GLOBAL:
            if home_alt_m is None:
                continue  # an AMSL altitude without a home: no height to show
            height = item.alt_m - home_alt_m
        else:
            height = item.alt_m
        out.append(_Waypoint(first_seq + index, index, item, height))
    return tuple(out)


def _enu_to_lonlatalt(
    points_enu: NDArray[np.float64], frame: EnuFrame, datum_amsl_m: float | None = None
) -> NDArray[np.float64]:
    """ENU points → [lon, lat, height]: lat/lon of the ground point below, height = z (over
    terrain: datum + z, metres AMSL)."""
    ground = np.column_stack((points_enu[:, :2], np.zeros(len(points_enu))))
    lat, lon, _ = frame.to_geodetic(ground)
    z = points_enu[:, 2] if datum_amsl_m is None else datum_amsl_m + points_enu[:, 2]
    return np.column_stack((lon, lat, z))


def _xy_to_lonlat(ring_enu: NDArray[np.float64], frame: EnuFrame) -> NDArray[np.float64]:
    lat, lon, _ = frame.to_geodetic(np.column_stack((ring_enu, np.zeros(len(ring_enu)))))
    return np.column_stack((lon, lat))


def _fence_areas(plan: MissionPlan) -> list[_Area]:
    areas = []
    for i, poly in enumerate(plan.fence.polygons):
        ring = np.array([(lon, lat) for lat, lon in poly.vertices])
        props = {"kind": "fence", "shape": "polygon", "inclusion": poly.inclusion, "index": i}
        areas.append(_Area("fence", orient_ccw(ring), props))
    for i, circle in enumerate(plan.fence.circles):
        lat, lon = circle.center
        local = EnuFrame.at(GeoPoint(lat, lon, 0.0))
        ring_enu = circle_ring((0.0, 0.0), circle.radius_m, CIRCLE_SEGMENTS)
        props = {
            "kind": "fence",
            "shape": "circle",
            "inclusion": circle.inclusion,
            "index": i,
            "center": [round(lon, DEGREE_DECIMALS), round(lat, DEGREE_DECIMALS)],
            "radius_m": circle.radius_m,
        }
        areas.append(_Area("fence", _xy_to_lonlat(ring_enu, local), props))
    return areas


def _command_name(command: int) -> str:
    try:
        return MavCmd(command).name
    except ValueError:
        return f"MAV_CMD {command}"


def _position(lon: float, lat: float, alt: float | None = None) -> list[float]:
    out = [round(float(lon), DEGREE_DECIMALS), round(float(lat), DEGREE_DECIMALS)]
    if alt is not None:
        out.append(round(float(alt), METRE_DECIMALS))
    return out


# ---------------------------------------------------------------------------------------------
# GeoJSON


def to_geojson(plan: MissionPlan, extras: ExportExtras | None = None) -> dict[str, Any]:
    """The export as a GeoJSON FeatureCollection (plain JSON-ready values).

    Positions are ``[lon, lat]`` or ``[lon, lat, height]`` (height above home, metres).
    Polygon rings are closed and counter-clockwise (RFC 7946 §3.1.6). Every feature has a
    ``kind`` property: ``route``, ``planned_path``, ``home``, ``waypoint``, ``obstacle``,
    ``fence``, and for a survey ``survey_area``, ``photo_footprint`` and ``photos`` (one
    MultiPoint).
    """
    scene = _scene(plan, extras)
    features: list[dict[str, Any]] = []
    if scene.route_lonlatalt is not None:
        props = {"kind": "route", "name": scene.name, **scene.properties}
        features.append(_feature(_line(scene.route_lonlatalt), props))
    if scene.planned_lonlatalt is not None:
        props = {
            "kind": "planned_path",
            "name": f"{scene.name}: planned path",
            "altitude_reference": AMSL_REFERENCE if scene.absolute else ALTITUDE_REFERENCE,
        }
        features.append(_feature(_line(scene.planned_lonlatalt), props))
    if scene.home is not None:
        props = {
            "kind": "home",
            "name": "home",
            "altitude_amsl_m": round(scene.home.alt_m, METRE_DECIMALS),
            "altitude_reference": AMSL_REFERENCE if scene.absolute else ALTITUDE_REFERENCE,
        }
        home_alt = scene.home.alt_m if scene.absolute else 0.0
        point = _position(scene.home.lon_deg, scene.home.lat_deg, home_alt)
        features.append(_feature({"type": "Point", "coordinates": point}, props))
    for wp in scene.waypoints:
        item = wp.item
        props = {
            "kind": "waypoint",
            "name": f"{wp.seq} {_command_name(item.command)}",
            "seq": wp.seq,
            "item_index": wp.index,
            "command": item.command,
            "command_name": _command_name(item.command),
            "frame": item.frame,
            "height_m": round(wp.height_m, METRE_DECIMALS),
            "altitude_reference": _waypoint_reference(scene, wp),
            "params": list(item.params),
        }
        alt = wp.amsl_m if scene.absolute and wp.amsl_m is not None else wp.height_m
        point = _position(item.lon_deg, item.lat_deg, alt)
        features.append(_feature({"type": "Point", "coordinates": point}, props))
    for area in scene.areas:
        ring = [_position(lon, lat) for lon, lat in area.ring_lonlat]
        ring.append(ring[0])
        features.append(_feature({"type": "Polygon", "coordinates": [ring]}, area.properties))
    if scene.photos_lonlat is not None:
        points = [_position(lon, lat) for lon, lat in scene.photos_lonlat]
        props = {"kind": "photos", "name": "photos", "count": len(points)}
        features.append(_feature({"type": "MultiPoint", "coordinates": points}, props))
    return {"type": "FeatureCollection", "features": features}


def _waypoint_reference(scene: _Scene, wp: _Waypoint) -> str:
    if _terrain_frame(wp.item):
        return TERRAIN_REFERENCE
    return AMSL_REFERENCE if scene.absolute and wp.amsl_m is not None else ALTITUDE_REFERENCE


def _line(points: NDArray[np.float64]) -> dict[str, Any]:
    return {"type": "LineString", "coordinates": [_position(*p) for p in points]}


def _feature(geometry: dict[str, Any], properties: Mapping[str, Any]) -> dict[str, Any]:
    return {"type": "Feature", "geometry": geometry, "properties": dict(properties)}


def geojson_dumps(plan: MissionPlan, extras: ExportExtras | None = None) -> str:
    """The GeoJSON file text: one feature per line (readable and diff-friendly), no NaN."""
    doc = to_geojson(plan, extras)
    features = ",\n".join(json.dumps(f, allow_nan=False) for f in doc["features"])
    return f'{{"type": "FeatureCollection", "features": [\n{features}\n]}}\n'


# ---------------------------------------------------------------------------------------------
# KML


_KML_STYLES = {
    # id: (line colour aabbggrr, line width, fill colour aabbggrr or None)
    "route": ("ff1478ff", 3.0, "401478ff"),
    "planned": ("ffff9933", 2.0, None),
    "obstacle": ("ff505050", 1.0, "c0a0a0a0"),
    "fence-inclusion": ("ff00c000", 2.0, "00000000"),
    "fence-exclusion": ("ff0000e0", 2.0, "400000e0"),
    "survey": ("ff2ca02c", 2.0, "00000000"),
    "footprint": ("40b4771f", 0.5, "18b4771f"),
}


def kml_dumps(plan: MissionPlan, extras: ExportExtras | None = None) -> str:
    """The export as a KML 2.2 document (UTF-8 text with an XML declaration)."""
    scene = _scene(plan, extras)
    ET.register_namespace("", KML_NAMESPACE)
    root = ET.Element(_k("kml"))
    doc = _sub(root, "Document")
    _sub(doc, "name", scene.name)
    _sub(doc, "description", _describe(scene.properties))
    for style_id, (line, width, fill) in _KML_STYLES.items():
        style = _sub(doc, "Style", id=style_id)
        line_style = _sub(style, "LineStyle")
        _sub(line_style, "color", line)
        _sub(line_style, "width", f"{width:g}")
        if fill is not None:
            _sub(_sub(style, "PolyStyle"), "color", fill)
    waypoint_style = _sub(doc, "Style", id="waypoint")
    icon_style = _sub(waypoint_style, "IconStyle")
    _sub(icon_style, "scale", "0.6")
    _sub(
        _sub(icon_style, "Icon"),
        "href",
        "http://maps.google.com/mapfiles/kml/shapes/placemark_circle.png",
    )
    _sub(_sub(waypoint_style, "LabelStyle"), "scale", "0.7")

    route_folder = _folder(doc, "Route")
    if scene.route_lonlatalt is not None:
        mark = _placemark(route_folder, "flown route", "route", _describe(scene.properties))
        _line_string(mark, scene.route_lonlatalt, extrude=True, absolute=scene.absolute)
    if scene.planned_lonlatalt is not None:
        mark = _placemark(route_folder, "planned path", "planned")
        _line_string(mark, scene.planned_lonlatalt, extrude=False, absolute=scene.absolute)

    wp_folder = _folder(doc, "Waypoints")
    if scene.home is not None:
        mark = _placemark(wp_folder, "home", "waypoint", f"{scene.home.alt_m:.2f} m AMSL")
        _point(mark, scene.home.lon_deg, scene.home.lat_deg, 0.0)
    for wp in scene.waypoints:
        name = f"{wp.seq} {_command_name(wp.item.command)}"
        above = "the terrain" if _terrain_frame(wp.item) else "home"
        mark = _placemark(wp_folder, name, "waypoint", f"{wp.height_m:.1f} m above {above}")
        _extended_data(
            mark, {"seq": wp.seq, "command": wp.item.command, "height_m": round(wp.height_m, 3)}
        )
        if scene.absolute and wp.amsl_m is not None:
            _point(mark, wp.item.lon_deg, wp.item.lat_deg, wp.amsl_m, absolute=True)
        else:
            _point(mark, wp.item.lon_deg, wp.item.lat_deg, wp.height_m)

    obstacles = [a for a in scene.areas if a.kind == "obstacle"]
    if obstacles:
        folder = _folder(doc, "Obstacles")
        for area in obstacles:
            props = area.properties
            name = f"obstacle {props['index']} ({props['shape']}, {props['height_m']:g} m)"
            if "zone" in props:  # an airspace zone's solid: its name, class and limits
                name = (
                    f"{props['zone']} ({props['zone_class']}, {props['floor']}–{props['ceiling']})"
                )
            mark = _placemark(folder, name, "obstacle")
            _extended_data(mark, props)
            _polygon(mark, area.ring_lonlat, area.height_m, absolute=scene.absolute)
    fences = [a for a in scene.areas if a.kind == "fence"]
    if fences:
        folder = _folder(doc, "Geofence")
        for area in fences:
            inclusion = bool(area.properties["inclusion"])
            kind = "inclusion" if inclusion else "exclusion"
            name = f"fence {kind} {area.properties['shape']} {area.properties['index']}"
            mark = _placemark(folder, name, f"fence-{kind}")
            _extended_data(mark, area.properties)
            _polygon(mark, area.ring_lonlat, None)

    survey = [a for a in scene.areas if a.kind in ("survey_area", "photo_footprint")]
    if survey or scene.photos_lonlat is not None:
        folder = _folder(doc, "Survey")
        for area in survey:
            if area.kind == "survey_area":
                mark = _placemark(folder, "survey area", "survey")
            else:
                mark = _placemark(
                    folder, f"photo {area.properties['photo']} footprint", "footprint"
                )
            _polygon(mark, area.ring_lonlat, None)
        if scene.photos_lonlat is not None:
            n = len(scene.photos_lonlat)
            mark = _placemark(folder, f"photos ({n})", "waypoint")
            multi = _sub(mark, "MultiGeometry")
            for lon, lat in scene.photos_lonlat:
                point = _sub(multi, "Point")
                _sub(point, "altitudeMode", "clampToGround")
                _sub(point, "coordinates", _coordinates([(lon, lat)]))

    ET.indent(root, space=" ")
    body = ET.tostring(root, encoding="unicode")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + body + "\n"


def _k(tag: str) -> str:
    return f"{{{KML_NAMESPACE}}}{tag}"


def _sub(parent: ET.Element, tag: str, text: str | None = None, **attrib: str) -> ET.Element:
    element = ET.SubElement(parent, _k(tag), attrib)
    if text is not None:
        element.text = text
    return element


def _folder(doc: ET.Element, name: str) -> ET.Element:
    folder = _sub(doc, "Folder")
    _sub(folder, "name", name)
    return folder


def _placemark(
    parent: ET.Element, name: str, style: str, description: str | None = None
) -> ET.Element:
    mark = _sub(parent, "Placemark")
    _sub(mark, "name", name)
    if description:
        _sub(mark, "description", description)
    _sub(mark, "styleUrl", f"#{style}")
    return mark


def _describe(properties: Mapping[str, Any]) -> str:
    return "; ".join(f"{k}: {v}" for k, v in properties.items())


def _extended_data(mark: ET.Element, values: Mapping[str, Any]) -> None:
    data = _sub(mark, "ExtendedData")
    for key, value in values.items():
        _sub(_sub(data, "Data", name=str(key)), "value", str(value))


def _coordinates(points: Sequence[Sequence[float]] | NDArray[np.float64]) -> str:
    return " ".join(",".join(f"{v:.{_decimals(i)}f}" for i, v in enumerate(p)) for p in points)


def _decimals(axis: int) -> int:
    return DEGREE_DECIMALS if axis < 2 else METRE_DECIMALS


def _line_string(
    mark: ET.Element, points: NDArray[np.float64], *, extrude: bool, absolute: bool = False
) -> None:
    line = _sub(mark, "LineString")
    _sub(line, "extrude", "1" if extrude else "0")
    _sub(line, "tessellate", "0")
    _sub(line, "altitudeMode", "absolute" if absolute else "relativeToGround")
    _sub(line, "coordinates", _coordinates(points))


def _point(
    mark: ET.Element, lon: float, lat: float, height_m: float, *, absolute: bool = False
) -> None:
    point = _sub(mark, "Point")
    _sub(point, "altitudeMode", "absolute" if absolute else "relativeToGround")
    _sub(point, "coordinates", _coordinates([(lon, lat, height_m)]))


def _polygon(
    mark: ET.Element,
    ring_lonlat: NDArray[np.float64],
    height_m: float | None,
    *,
    absolute: bool = False,
) -> None:
    """An extruded solid of ``height_m`` above the ground (or, ``absolute``, up to that
    altitude AMSL), or a ground-clamped area."""
    polygon = _sub(mark, "Polygon")
    if height_m is not None:
        _sub(polygon, "extrude", "1")
        _sub(polygon, "altitudeMode", "absolute" if absolute else "relativeToGround")
    else:
        _sub(polygon, "tessellate", "1")
        _sub(polygon, "altitudeMode", "clampToGround")
    ring = np.vstack((ring_lonlat, ring_lonlat[:1]))
    z = np.full((len(ring), 1), 0.0 if height_m is None else height_m)
    outer = _sub(_sub(polygon, "outerBoundaryIs"), "LinearRing")
    _sub(outer, "coordinates", _coordinates(np.hstack((ring, z))))
