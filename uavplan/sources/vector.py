"""Obstacles from GIS vector files with pyogrio (GDAL): GeoJSON, GeoPackage, Shapefile, KML, ...

Every polygon or multipolygon feature of the chosen layer (the first one when ``layer`` is not
given) is a building footprint. Its height is the ``height_attribute`` value (a number, or a
string such as ``"12 m"`` or ``"40'"``), else the entry's ``default_height``; a missing or
unreadable value falls back to ``default_height`` and is counted. Coordinates in any CRS the
file declares are taken to longitude/latitude with pyproj (``always_xy``), then to the
scenario's ENU frame. Points and lines have no footprint and are skipped (counted). Z values
(KML) are dropped: heights come from the attribute.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from uavplan.geo import transform_arrays
from uavplan.sources.base import Feature, ObstacleFileSpec, SourceError, parse_height_m


def _layers(path: str) -> list[str]:
    import pyogrio

    return [str(row[0]) for row in pyogrio.list_layers(path)]


def read_vector_features(
    spec: ObstacleFileSpec, skipped: Counter[str], notes: Counter[str]
) -> list[Feature]:
    """Polygon features of one layer as lon/lat :class:`Feature` values (see module doc)."""
    import numpy as np
    import pyogrio
    import pyogrio.raw
    import shapely
    from pyogrio.errors import DataLayerError, DataSourceError, FieldError

    path = str(spec.path)
    try:
        layers = _layers(path)
    except (DataSourceError, DataLayerError, OSError, RuntimeError) as err:
        raise SourceError(f"cannot read {spec.path.name}: {_first_line(err)}", key="file") from None
    if not layers:
        raise SourceError(f"{spec.path.name} has no layers", key="file")
    if spec.layer is not None and spec.layer not in layers:
        raise SourceError(
            f"no layer {spec.layer!r} in {spec.path.name} (layers: {', '.join(layers)})",
            key="layer",
        )
    layer = spec.layer if spec.layer is not None else layers[0]
    try:
        info = pyogrio.read_info(path, layer=layer)
    except (DataSourceError, DataLayerError, OSError, RuntimeError) as err:
        raise SourceError(f"cannot read {spec.path.name}: {_first_line(err)}", key="file") from None
    fields = [str(f) for f in info["fields"]]
    if spec.height_attribute is not None and spec.height_attribute not in fields:
        raise SourceError(
            f"no attribute {spec.height_attribute!r} in layer {layer!r} of {spec.path.name} "
            f"(attributes: {', '.join(fields) or 'none'})",
            key="height_attribute",
        )
    crs = info.get("crs")
    if not crs:
        raise SourceError(
            f"{spec.path.name} declares no coordinate reference system (a missing .prj?)",
            key="file",
        )
    columns = [spec.height_attribute] if spec.height_attribute else []
    try:
        _meta, _fids, geometries, field_data = pyogrio.raw.read(path, layer=layer, columns=columns)
    except (DataSourceError, DataLayerError, FieldError, OSError, RuntimeError) as err:
        raise SourceError(f"cannot read {spec.path.name}: {_first_line(err)}", key="file") from None

    to_lonlat = _to_lonlat(crs, spec)
    # a ring of fewer than four points, or one not closed, is no geometry GEOS can hold
    geoms = shapely.from_wkb(geometries, on_invalid="ignore")
    invalid = shapely.is_missing(geoms) & np.array([g is not None for g in geometries], bool)
    if invalid.any():
        skipped["invalid geometry (a ring that is not closed or has too few points)"] += int(
            invalid.sum()
        )
    heights: Any = field_data[0] if columns else None
    features: list[Feature] = []
    for i, geom in enumerate(geoms):
        if geom is None or geom.is_empty:
            if not invalid[i]:
                skipped["no geometry"] += 1
            continue
        geom = shapely.force_2d(geom)
        if geom.geom_type not in ("Polygon", "MultiPolygon"):
            if geom.geom_type == "GeometryCollection":
                polys = [g for g in geom.geoms if g.geom_type in ("Polygon", "MultiPolygon")]
                if polys:
                    geom = shapely.union_all(polys)
            if geom.geom_type not in ("Polygon", "MultiPolygon"):
                skipped[f"{geom.geom_type.lower()} geometry (no footprint)"] += 1
                continue
        height, source = spec.default_height_m, "default"
        if heights is not None:
            value = heights[i]
            if isinstance(value, np.generic):
                value = value.item()
            parsed = parse_height_m(value)
            if parsed is not None:
                height, source = parsed, "attribute"
            elif value is not None and not (isinstance(value, float) and np.isnan(value)):
                notes[f"{spec.height_attribute} unreadable: default height used"] += 1
        if to_lonlat is not None:
            geom = shapely.transform(geom, to_lonlat)
        kind = f"polygon of layer {layer}"
        features.append(Feature(geom, height, source, kind, base_m=spec.min_height_m or 0.0))
    return features


def _to_lonlat(crs: str, spec: ObstacleFileSpec) -> Any:
    """A vectorised (n, 2) → (n, 2) transform from ``crs`` to lon/lat, or None if it is lon/lat."""
    import numpy as np
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError

    try:
        src = CRS.from_user_input(crs)
    except CRSError as err:
        raise SourceError(f"unknown coordinate reference system: {err}", key="file") from None
    wgs84 = CRS.from_epsg(4326)
    if src.equals(wgs84, ignore_axis_order=True):
        return None
    transformer = Transformer.from_crs(src, wgs84, always_xy=True)

    def fn(coords: Any) -> Any:
        lon, lat = transform_arrays(transformer, coords[:, 0], coords[:, 1])
        out = np.column_stack((lon, lat))
        if not np.all(np.isfinite(out)):
            raise SourceError(
                f"{spec.path.name}: coordinates outside the area of its CRS", key="file"
            )
        return out

    return fn


def _first_line(err: BaseException) -> str:
    text = str(err).strip()
    return text.splitlines()[0] if text else type(err).__name__
