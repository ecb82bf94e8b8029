"""The ``airspace:`` key: zone files read (:mod:`uavplan.sources.zones`), each zone decided
to be a constraint of the flight or not, and the constraints turned into obstacles of the
scenario (prisms and cylinders standing on the ground, named after their zone).

```yaml
airspace:
  files: [zones.txt, ed269.json]      # relative to the scenario file
  avoid: [CTR, R, P, D, PROHIBITED, REQ_AUTHORISATION]   # optional; default DEFAULT_AVOID
  at: 2026-12-01T09:00:00Z            # optional planned take-off time (UTC)
```

A zone is a **constraint** when all of these hold (each "no" is a reason the report gives):

1. it reaches the flight area: its shape comes within the safety margin of the bounds
   (pieces beyond that cannot come within the margin of any point of the flight);
2. one of its tokens (OpenAir class or type, ED-269 restriction, ED-318 type) is in
   ``avoid``;
3. it is active at some time of the flight: without ``at`` always; with ``at``, during
   [``at``, ``at`` + the longest the vehicle's battery can keep it in the air]
   (:func:`endurance_s`: the battery's whole energy at the power of the most economical
   level speed, at sea-level air);
4. its floor, at its lowest (:func:`floor_range`), is below the flight volume's top over the
   zone plus the safety margin.

Vertical references (heights in metres; the scenario's heights are above the ground):

* ``GND`` / ``SFC``: the ground. ``AGL``: above the ground beneath (flat: z; over a DEM the
  DEM's posts). ``AMSL``: directly (the scenario's frame is the origin's altitude AMSL over
  flat ground, the DEM's metres AMSL over terrain).
* ``FL`` / ``STD`` (pressure altitude, standard setting): the true altitude depends on the
  QNH, unknown at planning time. Through the ICAO standard atmosphere, a pressure altitude
  lies between ``PA - h(QNH_MIN_HPA)`` and ``PA - h(QNH_MAX_HPA)`` AMSL (h: the pressure
  altitude of a pressure): a floor is taken at its lowest (540 m lower for 950 hPa), a
  ceiling at its highest (302 m higher for 1050 hPa). Temperature is not modelled.
* ``WGS84`` (ED-318: above the ellipsoid): AMSL = h − N, the geoid undulation N within
  [:data:`GEOID_MIN_M`, :data:`GEOID_MAX_M`] (EGM96): a floor 86 m lower, a ceiling 107 m
  higher.

**The model of a constraint**: a solid from the ground to the zone's ceiling, whatever its
floor (the world's solids stand on the ground, and the way-home proof relies on it: flying
*under* a zone is not modelled, so a zone whose floor is inside the flight band blocks from
the ground; the report says so). A zone with an AGL ceiling can be flown over where the
flight volume's ceiling allows it; over a DEM such a zone is cut into tiles (at most
:data:`AGL_TILES` × :data:`AGL_TILES`) whose tops stand at the highest ground under the
tile plus the ceiling (never below the true ceiling). A ceiling higher than the flight
volume's top plus the margin is cut at :data:`TOP_PAD_M` above that (the route cannot reach
it anyway). Polygons are clipped to the flight area grown by the margin.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, date, datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.config import type_name
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.limits import MAX_POLYGON_VERTICES
from uavplan.obstacles import Bounds, CylinderObstacle, Obstacle, PrismObstacle
from uavplan.scenario.checker import Checker
from uavplan.sources.zones import Limit, Reference, Zone, ZoneFileError, parse_datetime

if TYPE_CHECKING:
    from uavplan.scenario.settings import VehicleConfig
    from uavplan.sources.dem import Terrain

#: what a drone may not enter without permission, by default: controlled airspace classes
#: (A-D: ATC clearance), control and traffic zones, restricted, prohibited and danger areas,
#: temporary reservations and restrictions; ED-269 / ED-318 zones that prohibit flight or
#: need an authorisation, a condition or U-space services
DEFAULT_AVOID = (
    "A",
    "B",
    "C",
    "D",
    "CTR",
    "ATZ",
    "MATZ",
    "HTZ",
    "R",
    "P",
    "Q",
    "TRA",
    "TSA",
    "TFR",
    "ADIZ",
    "PROHIBITED",
    "REQ_AUTHORISATION",
    "REQ_AUTHORIZATION",
    "CONDITIONAL",
    "USPACE",
)
#: the QNH range the flight-level conversion allows for (hPa): a deep depression to a strong
#: anticyclone at sea level
QNH_MIN_HPA = 950.0
QNH_MAX_HPA = 1050.0
#: EGM96's geoid undulation range (metres): ellipsoid height minus this is AMSL
GEOID_MIN_M = -107.0
GEOID_MAX_M = 86.0
#: a constraint's solid stops this far above the flight volume's top plus the margin
TOP_PAD_M = 10.0
#: an AGL ceiling over a DEM: at most this many tiles along each axis of the zone's piece,
#: each at least AGL_TILE_MIN_M wide
AGL_TILES = 8
AGL_TILE_MIN_M = 200.0
#: at most this many zone files
MAX_FILES = 64

_KEYS = {"files", "avoid", "at"}


def pressure_height_m(pressure_hpa: float) -> float:
    """The ICAO standard atmosphere's pressure altitude (metres) of a pressure (troposphere):
    ``44330.77 (1 - (p / 1013.25)^0.190263)``."""
    return 44330.77 * (1.0 - (pressure_hpa / 1013.25) ** 0.190263)


#: how much lower / higher than its pressure altitude a flight level may be AMSL
STD_FLOOR_DROP_M = pressure_height_m(QNH_MIN_HPA)
STD_CEILING_RISE_M = -pressure_height_m(QNH_MAX_HPA)


class ZoneUse(enum.Enum):
    """What the scenario does with a zone (the report's ``use``)."""

    CONSTRAINT = "constraint"
    OUTSIDE = "outside the flight area"
    NOT_AVOIDED = "not avoided"
    INACTIVE = "inactive during the flight"
    ABOVE = "floor above the flight volume"
    BELOW = "below the ground"


@dataclass(frozen=True)
class AirspaceSpec:
    """The ``airspace:`` key as written: files (resolved), the avoided tokens, the take-off
    time (UTC) or None."""

    files: tuple[Path, ...]
    avoid: frozenset[str]
    at: datetime | None = None
    avoid_default: bool = True


@dataclass(frozen=True)
class ZoneDecision:
    """One zone and what became of it: ``use`` and ``reason``; for a constraint the indices
    of its solids in the scenario's obstacles; the floor's lowest and the ceiling's highest
    altitude AMSL the conversion allows (None: at the ground; inf: unlimited)."""

    zone: Zone
    use: ZoneUse
    reason: str
    floor_amsl_m: float | None = None
    ceiling_amsl_m: float | None = None
    obstacles: tuple[int, ...] = ()

    @property
    def is_constraint(self) -> bool:
        return self.use is ZoneUse.CONSTRAINT

    def entry(self) -> dict[str, Any]:
        """The report's entry for the zone."""
        z = self.zone
        return {
            "name": z.name,
            "kind": z.label,
            "file": Path(z.file).name,
            "where": z.where,
            "floor": z.floor.text,
            "ceiling": z.ceiling.text,
            "floor_amsl_m": _json_number(self.floor_amsl_m),
            "ceiling_amsl_m": _json_number(self.ceiling_amsl_m),
            "activity": z.activity.describe(),
            "constraint": self.is_constraint,
            "use": self.use.value,
            "reason": self.reason,
            "obstacles": list(self.obstacles),
            "chord_error_m": z.chord_error_m,
        }


def _json_number(v: float | None) -> float | str | None:
    if v is None:
        return None
    if math.isinf(v):
        return "unlimited"
    return round(v, 1)


@dataclass(frozen=True)
class ZoneSet:
    """A scenario's airspace: the spec, every zone's decision (in file order), the flight's
    time window (with ``at``) and the first obstacle index of the zones' solids."""

    spec: AirspaceSpec
    decisions: tuple[ZoneDecision, ...]
    window: tuple[datetime, datetime] | None = None
    first_obstacle: int = 0
    obstacle_zone: tuple[int, ...] = field(default=())  # per zone solid: its decision's index

    @property
    def constraints(self) -> tuple[ZoneDecision, ...]:
        return tuple(d for d in self.decisions if d.is_constraint)

    def decision_of(self, obstacle_index: int) -> ZoneDecision | None:
        """The zone whose solid is obstacle ``obstacle_index`` of the scenario (None: not a
        zone's)."""
        k = obstacle_index - self.first_obstacle
        if 0 <= k < len(self.obstacle_zone):
            return self.decisions[self.obstacle_zone[k]]
        return None

    def solid_groups(self) -> list[tuple[int, ...]]:
        """The obstacle indices of each constraint's solids."""
        return [d.obstacles for d in self.constraints]

    def labels(self) -> dict[int, dict[str, Any]]:
        """Per solid's obstacle index: its zone's name, kind and limits as written (what the
        map exports add to the obstacle)."""
        out: dict[int, dict[str, Any]] = {}
        for d in self.constraints:
            for i in d.obstacles:
                out[i] = {
                    "zone": d.zone.name,
                    "zone_class": d.zone.label,
                    "floor": d.zone.floor.text,
                    "ceiling": d.zone.ceiling.text,
                    "zone_file": Path(d.zone.file).name,
                }
        return out

    def picture_labels(self) -> dict[int, str]:
        """Per constraint, on its first solid: ``NAME`` and ``floor–ceiling`` (two lines)."""
        return {
            d.obstacles[0]: f"{d.zone.name}\n{d.zone.vertical_text}"
            for d in self.constraints
            if d.obstacles
        }

    def fence_groups(self) -> list[tuple[str, tuple[int, ...]]]:
        """Each constraint's title and the indices of its solids (for the fence's lines)."""
        return [(zone_title(d), d.obstacles) for d in self.constraints]

    def report(self) -> dict[str, Any]:
        """The report's ``airspace`` section: the settings and every zone considered."""
        counts: dict[str, int] = {}
        for d in self.decisions:
            counts[d.use.value] = counts.get(d.use.value, 0) + 1
        return {
            "files": [str(p) for p in self.spec.files],
            "avoid": sorted(self.spec.avoid),
            "avoid_default": self.spec.avoid_default,
            "at": None if self.spec.at is None else _iso(self.spec.at),
            "flight_window": None
            if self.window is None
            else [_iso(self.window[0]), _iso(self.window[1])],
            "zones_read": len(self.decisions),
            "constraints": len(self.constraints),
            "by_use": counts,
            "zones": [d.entry() for d in self.decisions],
            "allowances": {
                "flight_level_floor_lower_m": round(STD_FLOOR_DROP_M, 1),
                "flight_level_ceiling_higher_m": round(STD_CEILING_RISE_M, 1),
                "qnh_range_hpa": [QNH_MIN_HPA, QNH_MAX_HPA],
                "wgs84_floor_lower_m": GEOID_MAX_M,
                "wgs84_ceiling_higher_m": -GEOID_MIN_M,
            },
        }

    def summary_lines(self, *, limit: int = 12) -> list[str]:
        """What a command prints: one line of counts, then one line per zone near the flight
        (constraints first; zones outside the flight area only counted)."""
        near = [d for d in self.decisions if d.use is not ZoneUse.OUTSIDE]
        outside = len(self.decisions) - len(near)
        files = ", ".join(p.name for p in self.spec.files)
        head = (
            f"airspace: {len(self.decisions)} zone(s) read from {files}; "
            f"{len(self.constraints)} constraint(s)"
        )
        if outside:
            head += f", {outside} outside the flight area"
        lines = [head]
        ordered = sorted(near, key=lambda d: (not d.is_constraint,))
        for d in ordered[:limit]:
            mark = "constraint" if d.is_constraint else "not a constraint"
            lines.append(f"  {d.zone.title} {d.zone.vertical_text}: {mark}: {d.reason}")
        if len(ordered) > limit:
            lines.append(f"  … and {len(ordered) - limit} more (the report lists every zone)")
        return lines


def _iso(t: datetime) -> str:
    return t.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


# ---------------------------------------------------------------------------------------------
# The key


def read_spec(chk: Checker, raw: Any, base: Path) -> AirspaceSpec:
    """``airspace:`` checked key by key; files resolved next to ``base`` (the scenario)."""
    value = chk.mapping(raw, "airspace", _KEYS, ("files",))
    files_raw = value["files"]
    if isinstance(files_raw, str):
        files_raw = [files_raw]
    if not isinstance(files_raw, list) or not files_raw:
        raise chk.fail(
            "airspace.files", f"must be a list of zone files, got {type_name(files_raw)}"
        )
    if len(files_raw) > MAX_FILES:
        raise chk.fail("airspace.files", f"{len(files_raw)} files (at most {MAX_FILES})")
    files = []
    for i, f in enumerate(files_raw):
        if not isinstance(f, str) or not f.strip() or "\x00" in f or len(f) > 4096:
            raise chk.fail(f"airspace.files[{i}]", f"must be a file name, got {type_name(f)}")
        p = Path(f).expanduser()
        files.append(p if p.is_absolute() else (base.parent / p))
    avoid_default = "avoid" not in value
    if avoid_default:
        avoid = frozenset(DEFAULT_AVOID)
    else:
        raw_avoid = value["avoid"]
        if isinstance(raw_avoid, str):
            raw_avoid = [raw_avoid]
        if not isinstance(raw_avoid, list):
            raise chk.fail("airspace.avoid", "must be a list of classes, types or restrictions")
        tokens = []
        for i, t in enumerate(raw_avoid):
            if isinstance(t, bool) or not isinstance(t, str | int) or not str(t).strip():
                raise chk.fail(f"airspace.avoid[{i}]", f"must be a class or type, got {t!r}")
            tokens.append(str(t).strip().upper())
        avoid = frozenset(tokens)
    at = None
    if "at" in value and value["at"] is not None:
        at = _at(chk, value["at"])
    return AirspaceSpec(tuple(files), avoid, at, avoid_default)


def _at(chk: Checker, raw: Any) -> datetime:
    if isinstance(raw, datetime):
        return raw.replace(tzinfo=UTC) if raw.tzinfo is None else raw.astimezone(UTC)
    if isinstance(raw, date):
        raise chk.fail("airspace.at", "needs a time of day too: 2026-12-01T09:00:00Z (UTC)")
    if not isinstance(raw, str):
        raise chk.fail("airspace.at", f"must be a date and time in UTC, got {type_name(raw)}")
    try:
        return parse_datetime(raw)
    except ValueError as err:
        raise chk.fail("airspace.at", f"{err} (write 2026-12-01T09:00:00Z)") from None


def endurance_s(vehicle: VehicleConfig) -> float:
    """The longest the vehicle can stay in the air: its battery's whole energy at the power
    of its most economical level airspeed, at sea-level density (the least power: at
    altitude it needs more). A flight is never longer."""
    import numpy as np

    from uavplan.airframe.power import electrical_power_w

    profile = vehicle.profile
    speeds = np.linspace(0.0, profile.max_airspeed_m_s, 201)
    least = float(np.min(electrical_power_w(profile, speeds)))
    return profile.battery_wh * 3600.0 / least


# ---------------------------------------------------------------------------------------------
# Zones → decisions and solids


@dataclass(frozen=True)
class _Place:
    """Where the zones are turned into solids: the scenario's frame, bounds and margin, and
    over a DEM its posts (ENU, metres AMSL), the datum and the ground under a point."""

    frame: EnuFrame
    origin_alt_m: float
    bounds: Bounds
    margin_m: float
    posts_xy: Any = None  # (n, 2)
    posts_z: Any = None  # (n,) metres AMSL
    spacing_m: float = 0.0
    datum_m: float = 0.0
    ground_fn: Any = None  # ENU (n, 2) -> ground z above the datum (the site's own)

    @property
    def terrain(self) -> bool:
        return self.posts_xy is not None

    def window(self) -> tuple[float, float, float, float]:
        m = self.margin_m
        (x0, x1), (y0, y1) = self.bounds.x_m, self.bounds.y_m
        return x0 - m, y0 - m, x1 + m, y1 + m

    def ground_range(self, box: tuple[float, float, float, float]) -> tuple[float, float]:
        """Lowest and highest ground (metres AMSL) over ``box`` (x0, y0, x1, y1): the posts of
        every quad touching it (the bilinear surface lies between them)."""
        if not self.terrain:
            return self.origin_alt_m, self.origin_alt_m
        s = self.spacing_m
        xy = self.posts_xy
        sel = (
            (xy[:, 0] >= box[0] - s)
            & (xy[:, 0] <= box[2] + s)
            & (xy[:, 1] >= box[1] - s)
            & (xy[:, 1] <= box[3] + s)
        )
        z = self.posts_z[sel] if sel.any() else self.posts_z
        return float(z.min()), float(z.max())


def build_zones(
    chk: Checker,
    spec: AirspaceSpec,
    *,
    origin: GeoPoint,
    bounds: Bounds,
    margin_m: float,
    terrain: Terrain | None,
    vehicle: VehicleConfig,
    first_obstacle: int,
) -> tuple[ZoneSet, tuple[Obstacle, ...]]:
    """Read ``spec``'s files and decide each zone (module doc); the constraints' solids in
    the scenario's frame (heights above the ground at their centre, as a file gives them),
    to be appended to the scenario's obstacles from index ``first_obstacle``."""
    from uavplan.sources.zonefiles import read_zone_file

    zones: list[Zone] = []
    for i, path in enumerate(spec.files):
        try:
            zones.extend(read_zone_file(path))
        except ZoneFileError as err:
            raise chk.fail(f"airspace.files[{i}]", str(err)) from None
    place = _place(origin, bounds, margin_m, terrain)
    window = None
    if spec.at is not None:
        window = (spec.at, spec.at + timedelta(seconds=endurance_s(vehicle)))
    decisions: list[ZoneDecision] = []
    solids: list[Obstacle] = []
    owner: list[int] = []
    for zone in zones:
        decision, made = _decide(zone, spec, window, place, first_obstacle + len(solids))
        owner.extend([len(decisions)] * len(made))
        solids.extend(made)
        decisions.append(decision)
    zset = ZoneSet(spec, tuple(decisions), window, first_obstacle, tuple(owner))
    return zset, tuple(solids)


def _place(origin: GeoPoint, bounds: Bounds, margin_m: float, terrain: Terrain | None) -> _Place:
    frame = EnuFrame.at(origin)
    if terrain is None:
        return _Place(frame, origin.alt_m, bounds, margin_m)
    from uavplan.ground import datum_below

    xy, z, _ = terrain.posts_around(bounds.x_m, bounds.y_m, margin_m)
    datum = datum_below(terrain)
    on_datum = terrain.in_frame(EnuFrame.at(GeoPoint(origin.lat_deg, origin.lon_deg, datum)))

    def ground(points_xy: Any) -> Any:  # as uavplan.ground.build_ground's z_at
        return on_datum.height_m(points_xy) - datum

    return _Place(
        frame,
        origin.alt_m,
        bounds,
        margin_m,
        posts_xy=xy.reshape(-1, 2),
        posts_z=z.reshape(-1),
        spacing_m=float(terrain.post_spacing_m),
        datum_m=datum,
        ground_fn=ground,
    )


def floor_range(limit: Limit) -> float | None:
    """The lowest a floor can be, metres AMSL (None: ``GND``/``AGL``, which follow the
    ground; see the module doc for the allowances)."""
    ref = limit.reference
    if ref in (Reference.GND, Reference.AGL):
        return None
    if ref is Reference.STD:
        return limit.value_m - STD_FLOOR_DROP_M
    if ref is Reference.WGS84:
        return limit.value_m - GEOID_MAX_M
    return limit.value_m


def ceiling_amsl(limit: Limit) -> float | None:
    """The highest a ceiling can be, metres AMSL (None: AGL, which follows the ground; inf:
    unlimited)."""
    ref = limit.reference
    if ref is Reference.UNL:
        return math.inf
    if ref in (Reference.GND, Reference.AGL):
        return None
    if ref is Reference.STD:
        return limit.value_m + STD_CEILING_RISE_M
    if ref is Reference.WGS84:
        return limit.value_m - GEOID_MIN_M
    return limit.value_m


def _footprint(zone: Zone, place: _Place) -> Any:
    """The zone's shape in ENU metres: a shapely geometry (polygons) or a (cx, cy, r)."""
    import numpy as np

    if zone.circle is not None:
        lon, lat, r = zone.circle
        c = place.frame.to_enu_xy([lat], [lon])[0]
        return (float(c[0]), float(c[1]), float(r))
    ring = np.asarray(zone.ring_lonlat, dtype=np.float64)
    return place.frame.to_enu_xy(ring[:, 1], ring[:, 0])


def _decide(
    zone: Zone,
    spec: AirspaceSpec,
    window: tuple[datetime, datetime] | None,
    place: _Place,
    next_index: int,
) -> tuple[ZoneDecision, list[Obstacle]]:
    import shapely

    fp = _footprint(zone, place)
    wx0, wy0, wx1, wy1 = place.window()
    box = shapely.box(wx0, wy0, wx1, wy1)
    circle = isinstance(fp, tuple)
    if circle:
        cx, cy, r = fp
        dx = max(wx0 - cx, 0.0, cx - wx1)
        dy = max(wy0 - cy, 0.0, cy - wy1)
        away = math.hypot(dx, dy) - r
        shape = None
    else:
        shape = shapely.make_valid(shapely.Polygon(fp))
        away = float(shapely.distance(shape, box)) if not shape.intersects(box) else 0.0
    floor_lo = floor_range(zone.floor)
    ceil_hi = ceiling_amsl(zone.ceiling)
    base: dict[str, Any] = dict(floor_amsl_m=floor_lo, ceiling_amsl_m=ceil_hi)
    if away > 0.0:
        return ZoneDecision(
            zone, ZoneUse.OUTSIDE, f"{away / 1000:,.1f} km from the flight area", **base
        ), []
    hits = [t for t in zone.classes if t in spec.avoid]
    if not hits:
        listed = "the default list" if spec.avoid_default else "airspace.avoid"
        return ZoneDecision(
            zone,
            ZoneUse.NOT_AVOIDED,
            f"{'/'.join(zone.classes)} is not in {listed}",
            **base,
        ), []
    if window is not None and not zone.activity.active_during(*window):
        return ZoneDecision(
            zone,
            ZoneUse.INACTIVE,
            f"{zone.activity.describe()}; inactive from {_iso(window[0])} to "
            f"{_iso(window[1])} (take-off at airspace.at, the longest flight the battery allows)",
            **base,
        ), []

    # the clipped shape: what of the zone can matter to the flight
    if circle:
        cx, cy, r = fp
        extent = (max(cx - r, wx0), max(cy - r, wy0), min(cx + r, wx1), min(cy + r, wy1))
    else:
        assert shape is not None
        shape = shape.intersection(box)
        bx0, by0, bx1, by1 = (float(v) for v in shape.bounds)
        extent = (bx0, by0, bx1, by1)
    g_lo, g_hi = place.ground_range(extent)
    zmax = place.bounds.z_m[1]
    margin = place.margin_m
    # the flight volume's top over the zone, metres AMSL (over a DEM: the highest ground
    # under the zone's piece plus the ceiling above the ground)
    flight_top = g_hi + zmax
    floor_text = zone.floor.text
    if zone.floor.reference is Reference.AGL:
        if zone.floor.value_m >= zmax + margin:
            return ZoneDecision(
                zone,
                ZoneUse.ABOVE,
                f"floor {floor_text} is above the flight volume's ceiling {zmax:g} m above the "
                f"ground plus the {margin:g} m margin",
                **base,
            ), []
    elif floor_lo is not None and floor_lo >= flight_top + margin:
        allowance = _allowance_text(zone.floor, floor=True)
        return ZoneDecision(
            zone,
            ZoneUse.ABOVE,
            f"floor {floor_text} (at least {floor_lo:,.0f} m AMSL{allowance}) is above the "
            f"flight volume's top, {flight_top:,.0f} m AMSL here, plus the {margin:g} m margin",
            **base,
        ), []

    top_cap = flight_top + margin + TOP_PAD_M  # metres AMSL; no need to reach higher
    made = _solids(zone, fp, shape, place, ceil_hi, top_cap)
    if not made:
        return ZoneDecision(
            zone,
            ZoneUse.BELOW,
            f"ceiling {zone.ceiling.text} is below the ground everywhere in the flight area",
            **base,
        ), []
    parts = [_overlap_text(zone, flight_top, g_lo, zmax)]
    if floor_lo is not None or (zone.floor.reference is Reference.AGL and zone.floor.value_m > 0):
        parts.append(
            f"its floor {floor_text} is inside the flight band: modelled from the ground "
            "(flying under a zone is not modelled)"
        )
    if zone.activity.unknown:
        parts.append("activation by NOTAM, times unknown: taken as active")
    elif window is None and not zone.activity.always:
        parts.append(f"{zone.activity.describe()}; no airspace.at: taken as active")
    if zone.chord_error_m:
        parts.append(f"arcs as polygon edges up to {zone.chord_error_m:g} m outside the arc")
    parts.extend(zone.notes)
    indices = tuple(range(next_index, next_index + len(made)))
    return ZoneDecision(zone, ZoneUse.CONSTRAINT, "; ".join(parts), obstacles=indices, **base), made


def _allowance_text(limit: Limit, *, floor: bool) -> str:
    if limit.reference is Reference.STD:
        return f" with a QNH of {QNH_MIN_HPA:g} hPa" if floor else f" with {QNH_MAX_HPA:g} hPa"
    if limit.reference is Reference.WGS84:
        return " with the largest geoid undulation"
    return ""


def _overlap_text(zone: Zone, flight_top: float, ground_lo: float, zmax: float) -> str:
    return (
        f"{zone.vertical_text} overlaps the flight band (the ground to {zmax:g} m above it, "
        f"up to {flight_top:,.0f} m AMSL here)"
    )


def _solids(
    zone: Zone,
    fp: Any,
    shape: Any,
    place: _Place,
    ceil_hi: float | None,
    top_cap: float,
) -> list[Obstacle]:
    """The constraint's solids, standing on the ground, in the scenario's file frame."""
    import numpy as np

    agl_ceiling = ceil_hi is None
    agl_value = zone.ceiling.value_m if agl_ceiling else 0.0
    if not place.terrain:
        top = place.origin_alt_m + agl_value if agl_ceiling else float(ceil_hi or 0.0)
        height = min(top, top_cap) - place.origin_alt_m
        if height <= 0:
            return []
        if isinstance(fp, tuple):
            cx, cy, r = fp
            return [CylinderObstacle((cx, cy), r, height)]
        return [PrismObstacle(ring, height) for ring in _rings(shape)]

    # over a DEM: tops in metres AMSL, heights above the ground at each solid's centre
    pieces: list[tuple[Any, float]] = []  # (shape or circle, top AMSL)
    if agl_ceiling:
        import shapely

        whole = shape
        if isinstance(fp, tuple):
            cx, cy, r = fp
            whole = shapely.Point(cx, cy).buffer(r / math.cos(math.pi / 256), quad_segs=64)
            whole = whole.intersection(shapely.box(*place.window()))
        for tile in _tiles(whole):
            tx0, ty0, tx1, ty1 = (float(v) for v in tile.bounds)
            _, hi = place.ground_range((tx0, ty0, tx1, ty1))
            pieces.append((tile, min(hi + agl_value, top_cap)))
    else:
        assert ceil_hi is not None
        top = min(ceil_hi, top_cap)
        pieces.append((fp if isinstance(fp, tuple) else shape, top))
    out: list[Obstacle] = []
    for piece, top_amsl in pieces:
        if isinstance(piece, tuple):
            cx, cy, r = piece
            lo, _ = place.ground_range((cx - r, cy - r, cx + r, cy + r))
            if top_amsl <= lo:
                continue
            g = float(place.ground_fn(np.array([[cx, cy]]))[0])
            height = max(top_amsl - place.datum_m - g, 0.1)
            out.append(CylinderObstacle((cx, cy), r, height))
            continue
        for ring in _rings(piece):
            xs, ys = zip(*ring, strict=True)
            lo, _ = place.ground_range((min(xs), min(ys), max(xs), max(ys)))
            if top_amsl <= lo:
                continue
            centre = np.array([[sum(xs) / len(xs), sum(ys) / len(ys)]])
            g = float(place.ground_fn(centre)[0])
            height = max(top_amsl - place.datum_m - g, 0.1)
            out.append(PrismObstacle(ring, height))
    return out


def _tiles(shape: Any) -> list[Any]:
    """``shape`` cut by a grid of at most AGL_TILES × AGL_TILES cells."""
    import shapely

    x0, y0, x1, y1 = (float(v) for v in shape.bounds)
    nx = max(1, min(AGL_TILES, math.ceil((x1 - x0) / AGL_TILE_MIN_M)))
    ny = max(1, min(AGL_TILES, math.ceil((y1 - y0) / AGL_TILE_MIN_M)))
    out = []
    for i in range(nx):
        for j in range(ny):
            cell = shapely.box(
                x0 + (x1 - x0) * i / nx,
                y0 + (y1 - y0) * j / ny,
                x0 + (x1 - x0) * (i + 1) / nx,
                y0 + (y1 - y0) * (j + 1) / ny,
            )
            piece = shape.intersection(cell)
            if not piece.is_empty and piece.area > 1e-6:
                out.append(piece)
    return out


def _rings(shape: Any) -> list[tuple[tuple[float, float], ...]]:
    """Simple counter-clockwise rings covering ``shape`` (holes cut away by splitting, at
    most MAX_POLYGON_VERTICES vertices each), vertices rounded to the millimetre as a map
    file stores them."""
    import numpy as np

    from uavplan.geometry2d import orient_ccw, polygon_problem

    out = []
    for piece in _simple(shape):
        coords = np.asarray(piece.exterior.coords)[:-1]
        ring = orient_ccw(coords)
        rounded = np.round(ring, 3)
        if polygon_problem(rounded) is not None:
            from uavplan.geometry2d import convex_hull

            rounded = np.round(convex_hull(ring), 3)
        out.append(tuple((float(x), float(y)) for x, y in rounded))
    return out


def _simple(shape: Any) -> list[Any]:
    """Polygons without holes and with at most MAX_POLYGON_VERTICES vertices covering
    ``shape`` exactly: pieces with a hole or too many vertices are cut in two through their
    middle (through a hole's representative point), until none is left."""
    import shapely
    from shapely.ops import split

    todo = list(getattr(shape, "geoms", [shape]))
    done = []
    while todo:
        piece = todo.pop()
        if piece.geom_type in ("MultiPolygon", "GeometryCollection"):
            todo.extend(piece.geoms)
            continue
        if piece.geom_type != "Polygon" or piece.area < 1e-4:
            continue
        if not piece.interiors and len(piece.exterior.coords) - 1 <= MAX_POLYGON_VERTICES - 8:
            done.append(piece)
            continue
        x0, y0, x1, y1 = piece.bounds
        if piece.interiors:
            cut_x = shapely.Polygon(piece.interiors[0]).representative_point().x
        else:
            cut_x = (x0 + x1) / 2.0
        if not piece.interiors and (y1 - y0) > (x1 - x0):
            cy = (y0 + y1) / 2.0
            cut = shapely.LineString([(x0 - 1.0, cy), (x1 + 1.0, cy)])
        else:
            cut = shapely.LineString([(cut_x, y0 - 1.0), (cut_x, y1 + 1.0)])
        todo.extend(split(piece, cut).geoms)
    return done


def zone_title(decision: ZoneDecision) -> str:
    """How messages name a zone's solid: ``zone 'EDDF CTR' (class D, type CTR) of
    zones.txt``."""
    return f"{decision.zone.title} of {Path(decision.zone.file).name}"


def titles(zset: ZoneSet) -> tuple[str, ...]:
    """The name of every zone solid, in obstacle order."""
    return tuple(zone_title(zset.decisions[k]) for k in zset.obstacle_zone)


def infringements(
    zset: ZoneSet, site_obstacles: Sequence[Obstacle], points_enu: Any, margin_m: float
) -> list[tuple[ZoneDecision, float]]:
    """Every constraint the polyline ``points_enu`` ``(n, 3)`` (in the site's frame, where
    the solids stand) comes closer to than ``margin_m``, with its distance (0: enters it):
    the exact distance from each point, on the polyline sampled every metre, to the zone's
    solids (a solid standing on the ground: the horizontal distance to its footprint and the
    height above its top)."""
    import numpy as np

    from uavplan.geometry2d import points_polygon_distance

    pts = np.asarray(points_enu, dtype=np.float64)
    if len(pts) >= 2:
        seg = np.diff(pts, axis=0)
        n = np.maximum(np.ceil(np.linalg.norm(seg, axis=1)), 1).astype(int)
        t = np.concatenate([np.arange(k) / k for k in n])
        base = np.repeat(pts[:-1], n, axis=0)
        pts = np.vstack([base + np.repeat(seg, n, axis=0) * t[:, None], pts[-1:]])
    out = []
    for d in zset.constraints:
        best = math.inf
        for i in d.obstacles:
            o = site_obstacles[i]
            if isinstance(o, CylinderObstacle):
                dh = np.hypot(pts[:, 0] - o.center_m[0], pts[:, 1] - o.center_m[1]) - o.radius_m
            else:
                ring = np.asarray(o.footprint(), dtype=np.float64)
                lo, hi = ring.min(axis=0) - margin_m, ring.max(axis=0) + margin_m
                near = np.all((pts[:, :2] >= lo) & (pts[:, :2] <= hi), axis=1)
                dh = np.full(len(pts), np.inf)
                if near.any():
                    dh[near] = points_polygon_distance(pts[near, :2], ring)
            dz = np.maximum(pts[:, 2] - o.height_m, 0.0)
            dist = np.hypot(np.maximum(dh, 0.0), dz)
            best = min(best, float(dist.min()))
        if best < margin_m - 1e-6:
            out.append((d, best))
    return out


def infringement_text(scenario: Any, points_enu: Any) -> str:
    """``; airspace: zone 'X' (R, restricted) of zones.txt entered, …`` for a message (empty
    when the flight keeps the margin from every zone). ``scenario``: a
    :class:`~uavplan.scenario.Scenario` with an airspace; ``points_enu`` in its site."""
    zset = scenario.airspace
    if zset is None:
        return ""
    hits = infringements(zset, scenario.site.obstacles, points_enu, scenario.safety_margin_m)
    if not hits:
        return ""
    parts = [
        f"{zone_title(d)} {'entered' if dist <= 0 else f'{dist:.1f} m away'}" for d, dist in hits
    ]
    return f"; airspace infringed: {'; '.join(parts)}"
