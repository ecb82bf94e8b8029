"""OpenStreetMap obstacles with pyosmium: buildings and tall structures.

What is read (``.osm`` XML, ``.osm.pbf``, compressed XML; anything libosmium reads):

* buildings: closed ways and ``type=multipolygon`` relations tagged ``building=*`` (except
  ``building=no``) and ``building:part=*``. Parts are kept as well as outlines: a part taller
  than its outline's tags then still stands in the world. Courtyards (inner rings) are kept as
  open air; the outline is split into hole-free prisms (see :mod:`uavplan.sources.common`).
* tall structures: :data:`TALL_MAN_MADE` values of ``man_made`` (and ``power=tower|portal``,
  wind turbines) as nodes (a cylinder of the ``diameter`` tag, else :data:`DEFAULT_RADIUS_M`)
  or as closed ways / multipolygons (a prism of the footprint).

Height: ``height`` (metres; "12 m", "40'", "40 ft" and "12'6\\"" understood), else
``building:levels`` (+ ``roof:levels``) × 3 m, else the entry's ``default_height``. A lifted
base (``min_height``, ``building:min_level`` × 3 m, else the entry's ``min_height``) is
reported and modelled down to the ground (conservative).

Skipped, with the reason counted: ``building=no``, underground structures
(``location=underground`` / ``indoor``), building ways that are not closed, geometry with nodes
missing from the extract, multipolygons that do not assemble, features outside the bounds.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from uavplan.sources.base import (
    LEVEL_HEIGHT_M,
    Feature,
    ObstacleFileSpec,
    SourceError,
    parse_height_m,
    parse_levels,
)

#: ``man_made`` values that are tall enough to matter to a drone
TALL_MAN_MADE = frozenset(
    {
        "tower",
        "mast",
        "chimney",
        "communications_tower",
        "water_tower",
        "lighthouse",
        "silo",
        "crane",
        "flagpole",
        "antenna",
        "storage_tank",
        "windmill",
    }
)
#: cylinder radius of a tall structure mapped as a node without a ``diameter`` tag (metres)
DEFAULT_RADIUS_M = {
    "tower": 5.0,
    "mast": 2.0,
    "chimney": 3.0,
    "communications_tower": 5.0,
    "water_tower": 8.0,
    "lighthouse": 4.0,
    "silo": 4.0,
    "crane": 30.0,  # the jib swings
    "flagpole": 0.5,
    "antenna": 1.0,
    "storage_tank": 10.0,
    "windmill": 10.0,
    "power=tower": 4.0,
    "power=portal": 4.0,
    "wind turbine": 60.0,  # rotor
}


def _tall_kind(tags: Any) -> str | None:
    mm = tags.get("man_made")
    if mm in TALL_MAN_MADE:
        return str(mm)
    power = tags.get("power")
    if power in ("tower", "portal"):
        return f"power={power}"
    if power == "generator" and tags.get("generator:source") == "wind":
        return "wind turbine"
    return None


def _is_building(tags: Any) -> bool:
    b = tags.get("building")
    return (b is not None and b != "no") or tags.get("building:part") not in (None, "no")


def _height(tags: Any, spec: ObstacleFileSpec, notes: Counter[str]) -> tuple[float, str]:
    raw = tags.get("height")
    if raw is not None:
        h = parse_height_m(raw)
        if h is not None:
            return h, "height"
        notes["height tag unreadable (ignored)"] += 1
    levels = parse_levels(tags.get("building:levels"))
    if levels is not None:
        roof = parse_levels(tags.get("roof:levels")) or 0.0
        return (levels + roof) * LEVEL_HEIGHT_M, "levels"
    return spec.default_height_m, "default"


def _base(tags: Any, spec: ObstacleFileSpec) -> float:
    h = parse_height_m(tags.get("min_height"))
    if h is not None:
        return h
    lv = parse_levels(tags.get("building:min_level"))
    if lv is not None:
        return lv * LEVEL_HEIGHT_M
    return spec.min_height_m or 0.0


def read_osm_features(
    spec: ObstacleFileSpec,
    skipped: Counter[str],
    window_lonlat: tuple[float, float, float, float] | None,
    notes: Counter[str] | None = None,
) -> list[Feature]:
    """Buildings and tall structures of an OSM file as lon/lat features (see module doc)."""
    import osmium
    import shapely

    notes = notes if notes is not None else Counter()
    wkb = osmium.geom.WKBFactory()
    features: list[Feature] = []
    building_relations: set[int] = set()
    assembled_relations: set[int] = set()
    blobs: list[str] = []  # outlines as hex WKB, decoded together after the file pass
    pending: list[tuple[float, str, str, float]] = []  # height, its source, kind, base
    if window_lonlat is not None:
        w0, s0, e0, n0 = window_lonlat

    def inside(lon_min: float, lat_min: float, lon_max: float, lat_max: float) -> bool:
        if window_lonlat is None:
            return True
        return not (lon_max < w0 or lon_min > e0 or lat_max < s0 or lat_min > n0)

    def skip_reason(tags: Any) -> str | None:
        if tags.get("building") == "no" and tags.get("building:part") in (None, "no"):
            return "building=no"
        if tags.get("location") in ("underground", "indoor") or tags.get("indoor") not in (
            None,
            "no",
        ):
            return "underground or indoor"
        return None

    try:
        processor = (
            osmium.FileProcessor(str(spec.path))
            .with_locations()
            .with_areas()
            # in C++, after locations and areas: Python sees only the tagged candidates
            .with_filter(osmium.filter.KeyFilter("building", "building:part", "man_made", "power"))
        )
        for obj in processor:
            tags = obj.tags
            if isinstance(obj, osmium.osm.Node):
                kind = _tall_kind(tags)
                if kind is None:
                    continue
                if skip_reason(tags):
                    skipped[f"{kind} (node): {skip_reason(tags)}"] += 1
                    continue
                lon, lat = obj.location.lon, obj.location.lat
                if not inside(lon, lat, lon, lat):
                    skipped["outside the bounds"] += 1
                    continue
                height, source = _height(tags, spec, notes)
                radius = parse_height_m(tags.get("diameter"))
                radius = radius / 2.0 if radius else DEFAULT_RADIUS_M.get(kind, 2.0)
                features.append(
                    Feature(
                        shapely.Point(lon, lat),
                        height,
                        source,
                        f"{kind} (node)",
                        base_m=_base(tags, spec),
                        radius_m=radius,
                    )
                )
            elif isinstance(obj, osmium.osm.Way):
                if (_is_building(tags) or tags.get("building") == "no") and not obj.is_closed():
                    skipped["building way not closed (not an outline)"] += 1
            elif isinstance(obj, osmium.osm.Relation):
                if tags.get("type") == "multipolygon" and (
                    _is_building(tags) or _tall_kind(tags) is not None
                ):
                    building_relations.add(obj.id)
            elif isinstance(obj, osmium.osm.Area):
                building = _is_building(tags) or tags.get("building") == "no"
                tall = _tall_kind(tags)
                if not building and tall is None:
                    continue
                from_way = obj.from_way()
                if not from_way:
                    assembled_relations.add(obj.orig_id())
                if building:
                    kind = "building:part" if tags.get("building") is None else "building"
                else:
                    kind = str(tall)
                kind += " (way)" if from_way else " (multipolygon relation)"
                reason = skip_reason(tags)
                if reason:
                    skipped[reason] += 1
                    continue
                try:
                    blob = wkb.create_multipolygon(obj)
                except osmium.InvalidLocationError:
                    skipped["incomplete (nodes missing from the extract)"] += 1
                    continue
                except RuntimeError:  # libosmium: "invalid area" (rings touch or cross)
                    skipped["invalid outline (rings touch or cross)"] += 1
                    continue
                height, source = _height(tags, spec, notes)
                blobs.append(blob)
                pending.append((height, source, kind, _base(tags, spec)))
    except osmium.InvalidLocationError as err:  # the parser met a coordinate such as "nan"
        raise SourceError(
            f"cannot read OpenStreetMap file {spec.path.name}: a node's location is not a "
            f"valid longitude/latitude ({_first_line(err)})",
            key="file",
        ) from None
    except (RuntimeError, ValueError, OSError) as err:
        raise SourceError(
            f"cannot read OpenStreetMap file {spec.path.name}: {_first_line(err)}", key="file"
        ) from None
    # one vectorised WKB decode and bounding-box test for all outlines
    geoms = shapely.from_wkb(blobs) if blobs else []
    boxes = shapely.bounds(geoms) if blobs else []
    for geom, box, (height, source, kind, base) in zip(geoms, boxes, pending, strict=True):
        if not inside(*box):
            skipped["outside the bounds"] += 1
            continue
        features.append(Feature(geom, height, source, kind, base_m=base))
    broken = len(building_relations - assembled_relations)
    if broken:
        skipped["multipolygon relation did not assemble (members missing or broken)"] += broken
    return features


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0][:200] if text else type(err).__name__
