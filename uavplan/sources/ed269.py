"""UAS geographical zones in EUROCAE ED-269 JSON and ED-318 GeoJSON.

**ED-269** (``{"features": [zone, …]}``): each zone has ``identifier``, ``name``,
``restriction`` (``PROHIBITED``, ``REQ_AUTHORISATION``, ``CONDITIONAL``,
``NO_RESTRICTION``), ``applicability`` (periods: ``permanent`` YES/NO, ``startDateTime``,
``endDateTime``, a daily ``schedule``) and ``geometry``, a list of volumes: ``uomDimensions``
(``M`` / ``FT``), ``lowerLimit`` / ``upperLimit`` with ``lowerVerticalReference`` /
``upperVerticalReference`` (``AGL``, ``AMSL``, ``WGS84``) and ``horizontalProjection``
(``{"type": "Polygon", "coordinates": [[[lon, lat], …]]}`` or ``{"type": "Circle",
"center": [lon, lat], "radius": metres}``). Field names follow ED-269 as InterUSS's
``uas_standards.eurocae_ed269`` types them.

**ED-318** (a GeoJSON ``FeatureCollection``): each feature's ``properties`` hold the zone
(``identifier``, ``name`` as text or a list of ``{text, lang}``, ``type``: ``PROHIBITED``,
``REQ_AUTHORIZATION``, ``CONDITIONAL``, ``NO_RESTRICTION``, ``USPACE``;
``limitedApplicability``: periods with an optional ``schedule``), its ``geometry`` a
``Polygon`` / ``MultiPolygon`` or a ``Point`` with ``extent: {subType: Circle, radius}``,
with the vertical ``layer`` (``upper``, ``upperReference``, ``lower``, ``lowerReference``:
``AGL``, ``AMSL``, ``WGS84``; ``uom``: ``m`` / ``ft``), as ``uas_standards.eurocae_ed318``
types them (a ``verticalLayer`` in the properties is accepted too).

A missing floor is the ground and a missing ceiling unlimited (when in doubt, a zone is a
constraint). Holes of a polygon are filled (conservative) and say so in the zone's notes.
Every problem is one :class:`~uavplan.sources.zones.ZoneFileError` naming the file and the
feature (``feature 3 (ID 'EFR10')``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from typing import Any

from uavplan.sources.zones import (
    FOOT_M,
    MAX_FILE_VERTICES,
    MAX_RADIUS_M,
    MAX_ZONE_VERTICES,
    MAX_ZONES,
    WEEKDAYS,
    Activity,
    DailyWindow,
    Limit,
    Period,
    Reference,
    Zone,
    ZoneFileError,
    parse_datetime,
    parse_time_of_day,
)

_REFERENCES = {"AGL": Reference.AGL, "AMSL": Reference.AMSL, "WGS84": Reference.WGS84}

Fail = Callable[[str], ZoneFileError]


def parse_ed_json(text: str, file: str) -> tuple[Zone, ...]:
    """The zones of an ED-269 or ED-318 document (``text``); ``file`` names it."""
    try:
        doc = json.loads(text, parse_constant=_no_constant)
    except RecursionError:
        raise ZoneFileError("JSON nested too deeply", file=file) from None
    except ValueError as err:
        raise ZoneFileError(f"invalid JSON: {err}", file=file) from None
    if not isinstance(doc, dict):
        raise ZoneFileError("an ED-269 / ED-318 file is a JSON object with 'features'", file=file)
    features = doc.get("features")
    if not isinstance(features, list):
        raise ZoneFileError(
            "no 'features' list: not an ED-269 JSON or ED-318 GeoJSON zone file", file=file
        )
    if len(features) > MAX_ZONES:
        raise ZoneFileError(f"more than {MAX_ZONES:,} features", file=file)
    zones: list[Zone] = []
    vertices = 0
    for i, feature in enumerate(features):
        where = f"feature {i}"
        if isinstance(feature, dict) and isinstance(_props(feature).get("identifier"), str | int):
            where += f" (ID {str(_props(feature)['identifier'])[:40]!r})"

        def fail(reason: str, where: str = where) -> ZoneFileError:
            return ZoneFileError(reason, file=file, where=where)

        if not isinstance(feature, dict):
            raise fail("must be a JSON object")
        made = (
            _ed318(feature, file, where, fail)
            if _is_ed318(feature)
            else _ed269(feature, file, where, fail)
        )
        for z in made:
            vertices += len(z.ring_lonlat or ())
        if vertices > MAX_FILE_VERTICES:
            raise fail(f"the file's zones hold more than {MAX_FILE_VERTICES:,} vertices")
        zones.extend(made)
    return tuple(zones)


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a number JSON allows")


def _props(feature: Mapping[str, Any]) -> Mapping[str, Any]:
    p = feature.get("properties")
    if isinstance(p, dict):
        inner = p.get("UASZone")
        return inner if isinstance(inner, dict) else p
    return feature


def _is_ed318(feature: Mapping[str, Any]) -> bool:
    return feature.get("type") == "Feature" or isinstance(feature.get("properties"), dict)


# ---------------------------------------------------------------------------------------------
# ED-269


def _ed269(feature: Mapping[str, Any], file: str, where: str, fail: Fail) -> list[Zone]:
    restriction = _token(feature.get("restriction"), "restriction", fail)
    name = _text(feature.get("name")) or _text(feature.get("identifier")) or where
    activity = _applicability(feature.get("applicability"), fail, ed318=False)
    volumes = feature.get("geometry")
    if not isinstance(volumes, list) or not volumes:
        raise fail("geometry: must be a non-empty list of airspace volumes")
    out = []
    for k, volume in enumerate(volumes):
        key = f"geometry[{k}]"
        if not isinstance(volume, dict):
            raise fail(f"{key}: must be an object")
        uom = volume.get("uomDimensions", "M")
        if not isinstance(uom, str) or uom.upper() not in ("M", "FT"):
            raise fail(f"{key}.uomDimensions: must be M or FT, got {uom!r}")
        scale = FOOT_M if uom.upper() == "FT" else 1.0
        floor = _limit(volume, "lowerLimit", "lowerVerticalReference", scale, False, key, fail)
        ceiling = _limit(volume, "upperLimit", "upperVerticalReference", scale, True, key, fail)
        proj = volume.get("horizontalProjection")
        if not isinstance(proj, dict):
            raise fail(f"{key}.horizontalProjection: must be an object (Circle or Polygon)")
        kind = proj.get("type")
        vol_name = name if len(volumes) == 1 else f"{name} volume {k + 1}"
        common: dict[str, Any] = dict(
            name=vol_name,
            classes=(restriction,),
            label=restriction,
            floor=floor,
            ceiling=ceiling,
            activity=activity,
            file=file,
            where=where,
        )
        if kind == "Circle":
            centre = _position(proj.get("center"), f"{key}.horizontalProjection.center", fail)
            radius = _number(proj.get("radius"), f"{key}.horizontalProjection.radius", fail)
            if not (0 < radius * 1.0 <= MAX_RADIUS_M):
                raise fail(
                    f"{key}.horizontalProjection.radius: must be > 0 m and at most "
                    f"{MAX_RADIUS_M:,.0f} m, got {radius:g}"
                )
            out.append(Zone(**common, circle=(centre[0], centre[1], radius)))
        elif kind == "Polygon":
            ring, notes = _polygon(proj.get("coordinates"), f"{key}.horizontalProjection", fail)
            out.append(Zone(**common, ring_lonlat=ring, notes=notes))
        else:
            raise fail(f"{key}.horizontalProjection.type: must be Circle or Polygon, got {kind!r}")
    return out


# ---------------------------------------------------------------------------------------------
# ED-318


def _ed318(feature: Mapping[str, Any], file: str, where: str, fail: Fail) -> list[Zone]:
    props = _props(feature)
    raw_props = feature.get("properties")
    kind = props.get("type", props.get("restriction"))
    zone_type = _token(kind, "properties.type", fail)
    name = _text(props.get("name")) or _text(props.get("identifier")) or where
    activity = _applicability(props.get("limitedApplicability"), fail, ed318=True)
    geometry = feature.get("geometry")
    if not isinstance(geometry, dict):
        raise fail("geometry: must be a GeoJSON geometry object")
    layer = geometry.get("layer")
    if layer is None and isinstance(raw_props, dict):
        layer = raw_props.get("verticalLayer")
    if not isinstance(layer, dict):
        raise fail(
            "geometry.layer: the vertical layer (upper, lower, their references, uom) is missing"
        )
    uom = layer.get("uom", "m")
    if not isinstance(uom, str) or uom.lower() not in ("m", "ft"):
        raise fail(f"geometry.layer.uom: must be m or ft, got {uom!r}")
    scale = FOOT_M if uom.lower() == "ft" else 1.0
    floor = _limit(layer, "lower", "lowerReference", scale, False, "geometry.layer", fail)
    ceiling = _limit(layer, "upper", "upperReference", scale, True, "geometry.layer", fail)
    common: dict[str, Any] = dict(
        classes=(zone_type,),
        label=zone_type,
        floor=floor,
        ceiling=ceiling,
        activity=activity,
        file=file,
        where=where,
    )
    gtype = geometry.get("type")
    coords = geometry.get("coordinates")
    if gtype == "Point":
        extent = geometry.get("extent")
        if not (isinstance(extent, dict) and extent.get("subType") == "Circle"):
            raise fail("geometry: a Point zone needs extent: {subType: Circle, radius}")
        radius = _number(extent.get("radius"), "geometry.extent.radius", fail)
        if not (0 < radius <= MAX_RADIUS_M):
            raise fail(
                f"geometry.extent.radius: must be > 0 m and at most {MAX_RADIUS_M:,.0f} m, "
                f"got {radius:g}"
            )
        centre = _position(coords, "geometry.coordinates", fail)
        return [Zone(name=name, **common, circle=(centre[0], centre[1], radius))]
    if gtype == "Polygon":
        ring, notes = _polygon(coords, "geometry", fail)
        return [Zone(name=name, **common, ring_lonlat=ring, notes=notes)]
    if gtype == "MultiPolygon":
        if not isinstance(coords, list) or not coords:
            raise fail("geometry.coordinates: a MultiPolygon needs a list of polygons")
        out = []
        for k, poly in enumerate(coords):
            ring, notes = _polygon(poly, f"geometry.coordinates[{k}]", fail)
            part = name if len(coords) == 1 else f"{name} part {k + 1}"
            out.append(Zone(name=part, **common, ring_lonlat=ring, notes=notes))
        return out
    raise fail(f"geometry.type: a zone is a Polygon, MultiPolygon or Point (circle), got {gtype!r}")


# ---------------------------------------------------------------------------------------------
# Shared fields


def _token(value: Any, key: str, fail: Fail) -> str:
    if not isinstance(value, str) or not value.strip():
        raise fail(
            f"{key}: must be a restriction such as PROHIBITED or REQ_AUTHORISATION, got {value!r}"
        )
    return value.strip().upper()


def _text(value: Any) -> str | None:
    """A name: a string, a ``{text, lang}`` object or a list of them (the first)."""
    if isinstance(value, list):
        value = value[0] if value else None
    if isinstance(value, dict):
        value = value.get("text")
    if isinstance(value, int) and not isinstance(value, bool):
        value = str(value)
    if isinstance(value, str) and value.strip():
        return " ".join(value.split())[:200]
    return None


def _number(value: Any, key: str, fail: Fail) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise fail(f"{key}: must be a number, got {value!r}")
    out = float(value)
    if not math.isfinite(out):
        raise fail(f"{key}: must be a finite number, got {value!r}")
    return out


def _limit(
    raw: Mapping[str, Any],
    value_key: str,
    ref_key: str,
    scale: float,
    upper: bool,
    key: str,
    fail: Fail,
) -> Limit:
    value = raw.get(value_key)
    ref_raw = raw.get(ref_key)
    if value is None:
        return Limit.unlimited(f"no {value_key}") if upper else Limit.ground(f"no {value_key}")
    number = _number(value, f"{key}.{value_key}", fail)
    if not isinstance(ref_raw, str) or ref_raw.upper() not in _REFERENCES:
        raise fail(f"{key}.{ref_key}: must be AGL, AMSL or WGS84, got {ref_raw!r}")
    reference = _REFERENCES[ref_raw.upper()]
    unit = "ft" if scale != 1.0 else "m"
    text = f"{number:g} {unit} {reference.value}"
    if reference is Reference.AGL and number == 0:
        return Limit.ground(text)
    try:
        return Limit(number * scale, reference, text)
    except ValueError as err:
        raise fail(f"{key}.{value_key}: {err}") from None


def _position(value: Any, key: str, fail: Fail) -> tuple[float, float]:
    """(lon, lat) of a GeoJSON position."""
    if not isinstance(value, list) or len(value) not in (2, 3):
        raise fail(f"{key}: must be [longitude, latitude], got {_short(value)}")
    lon = _number(value[0], key, fail)
    lat = _number(value[1], key, fail)
    if not (-180.0 <= lon <= 180.0 and -90.0 <= lat <= 90.0):
        raise fail(f"{key}: [{lon:g}, {lat:g}] is not a longitude, latitude (degrees)")
    return lon, lat


def _polygon(
    value: Any, key: str, fail: Fail
) -> tuple[tuple[tuple[float, float], ...], tuple[str, ...]]:
    """The outer ring (lon, lat, not closed) of GeoJSON polygon coordinates; holes are
    filled and noted."""
    if not isinstance(value, list) or not value or not isinstance(value[0], list):
        raise fail(f"{key}.coordinates: must be a list of rings [[[lon, lat], …]]")
    outer = value[0]
    if len(outer) > MAX_ZONE_VERTICES:
        raise fail(f"{key}.coordinates: more than {MAX_ZONE_VERTICES:,} vertices")
    ring = [_position(p, f"{key}.coordinates[0][{j}]", fail) for j, p in enumerate(outer)]
    while len(ring) > 1 and ring[0] == ring[-1]:
        ring.pop()
    distinct = [p for j, p in enumerate(ring) if j == 0 or p != ring[j - 1]]
    if len(distinct) < 3:
        raise fail(f"{key}.coordinates: a polygon needs at least 3 distinct positions")
    notes: tuple[str, ...] = ()
    if len(value) > 1:
        notes = (f"{len(value) - 1} hole(s) filled (the zone is taken as the whole outer ring)",)
    return tuple(distinct), notes


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _applicability(value: Any, fail: Fail, *, ed318: bool) -> Activity:
    key = "limitedApplicability" if ed318 else "applicability"
    if value is None or value == []:
        return Activity()
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list):
        raise fail(f"{key}: must be a list of time periods")
    periods: list[Period] = []
    for i, period in enumerate(value):
        k = f"{key}[{i}]"
        if not isinstance(period, dict):
            raise fail(f"{k}: must be an object")
        permanent = period.get("permanent")
        if isinstance(permanent, str) and permanent.upper() == "YES":
            return Activity()
        start = _datetime(period.get("startDateTime"), f"{k}.startDateTime", fail)
        end = _datetime(period.get("endDateTime"), f"{k}.endDateTime", fail)
        if start is not None and end is not None and end < start:
            raise fail(f"{k}: endDateTime is before startDateTime")
        daily = _schedule(period.get("schedule"), f"{k}.schedule", fail)
        periods.append(Period(start, end, daily))
    return Activity(tuple(periods))


def _datetime(value: Any, key: str, fail: Fail) -> Any:
    if value is None:
        return None
    if not isinstance(value, str):
        raise fail(f"{key}: must be an ISO 8601 date and time, got {_short(value)}")
    try:
        return parse_datetime(value)
    except ValueError as err:
        raise fail(f"{key}: {err}") from None


def _schedule(value: Any, key: str, fail: Fail) -> tuple[DailyWindow, ...]:
    if value is None:
        return ()
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list):
        raise fail(f"{key}: must be a list of daily periods")
    out = []
    for i, entry in enumerate(value):
        k = f"{key}[{i}]"
        if not isinstance(entry, dict):
            raise fail(f"{k}: must be an object")
        days_raw = entry.get("day", ["ANY"])
        if isinstance(days_raw, str):
            days_raw = [days_raw]
        if not isinstance(days_raw, list) or not days_raw:
            raise fail(f"{k}.day: must be a list of MON … SUN or ANY")
        days: set[int] = set()
        for d in days_raw:
            token = d.upper() if isinstance(d, str) else None
            if token == "ANY":
                days.update(range(7))
            elif token in WEEKDAYS:
                days.add(WEEKDAYS[token])
            else:
                raise fail(f"{k}.day: {d!r} is not one of MON … SUN, ANY")
        start_text, end_text = entry.get("startTime"), entry.get("endTime")
        if start_text is None or end_text is None:
            # a daylight event (sunrise, sunset) or nothing: the whole day, conservatively
            start_text, end_text = "00:00Z", "24:00Z"
        if not isinstance(start_text, str) or not isinstance(end_text, str):
            raise fail(f"{k}: startTime and endTime must be times such as 08:00:00.00Z")
        try:
            t0, off0 = parse_time_of_day(start_text)
            t1, off1 = parse_time_of_day(end_text)
        except ValueError as err:
            raise fail(f"{k}: {err}") from None
        offset = off0 if off0 == off1 else None
        out.append(DailyWindow(frozenset(days), t0, t1, offset))
    return tuple(out)
