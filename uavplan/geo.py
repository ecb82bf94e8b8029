"""Local ENU tangent frame at a WGS84 origin, converted exactly through ECEF with pyproj.

``EnuFrame.at(origin)`` gives a frame with x east, y north, z up (metres), tangent to the
WGS84 ellipsoid at ``origin``. Conversions go ENU ↔ ECEF (a rotation and a shift, done here
in numpy) and ECEF ↔ geodetic (pyproj, EPSG:4978 ↔ EPSG:4979, ``always_xy``), so they are
exact rather than a flat-earth approximation; the round trip is well below 1 mm within
hundreds of kilometres.

Heights: the origin's ``alt_m`` is AMSL in a scenario, and pyproj works with heights above
the ellipsoid. The frame uses the origin altitude *as if* it were an ellipsoidal height; the
AMSL/ellipsoid offset (the geoid undulation, about 48 m at Zurich) is then a constant that
cancels out, so altitudes coming back from :meth:`EnuFrame.to_geodetic` are in the same
reference as ``origin.alt_m`` (AMSL). The geoid's slope over a mission's tens of kilometres
is far below the centimetre level.

All conversions are vectorised: points are ``(n, 3)`` arrays, geodetic values ``(n,)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import threading

    import numpy as np
    from numpy.typing import ArrayLike, NDArray
    from pyproj import Transformer

# numpy is imported where a conversion runs, not here: GeoPoint is plain Python, and reading a
# scenario (`uavplan validate`) should not pay numpy's import (0.1-0.3 s)


def import_in_background(module: str = "pyproj") -> threading.Thread | None:
    """Start importing ``module`` (by default pyproj, the geodetic library the mission writer
    needs: about 0.2 s of imports on a slow machine) on a daemon thread, so that it overlaps
    work that releases the GIL, such as the search's compiled SPSA step, on another core.
    Returns the thread, or None when the module is already imported. A failed import is left
    to the import where the module is used (it reports it there); nothing is printed here."""
    import sys
    import threading

    if module in sys.modules:
        return None
    # An import is Python code that holds the GIL: the entry point (uavplan.__main__) lowers
    # the thread switch interval so the search gets it back sooner; nothing is changed here.

    def run() -> None:
        try:
            __import__(module)
        except Exception:  # reported by the import that needs it
            pass

    thread = threading.Thread(target=run, name=f"import {module}", daemon=True)
    thread.start()
    return thread


def transform_arrays(transformer: Any, *coords: Any, **kwargs: Any) -> tuple[Any, ...]:
    """``transformer.transform(*coords, **kwargs)`` for coordinate arrays, one point as Python
    floats: pyproj before 3.7 tries its single-point path first and converts a one-element
    array to a float there, which NumPy 1.25+ deprecates (a warning per call: tens of
    thousands in a test run with the lowest declared pyproj). Returns arrays."""
    import numpy as np

    arrays = [np.asarray(c, dtype=np.float64) for c in coords]
    if arrays and all(a.size == 1 for a in arrays):
        out = transformer.transform(*(float(a.reshape(-1)[0]) for a in arrays), **kwargs)
        return tuple(np.array([v], dtype=np.float64) for v in out)
    return tuple(transformer.transform(*arrays, **kwargs))


@dataclass(frozen=True)
class GeoPoint:
    """A WGS84 position. ``alt_m`` is AMSL unless a field's doc says otherwise."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lat_deg) and -90.0 <= self.lat_deg <= 90.0):
            raise ValueError(f"latitude {self.lat_deg!r} is not within [-90, 90] degrees")
        if not (math.isfinite(self.lon_deg) and -180.0 <= self.lon_deg <= 180.0):
            raise ValueError(f"longitude {self.lon_deg!r} is not within [-180, 180] degrees")
        if not math.isfinite(self.alt_m):
            raise ValueError(f"altitude {self.alt_m!r} is not finite")


#: geodetic 3-D (lat, lon, ellipsoidal height) and geocentric (ECEF) WGS84
GEODETIC_CRS = "EPSG:4979"
ECEF_CRS = "EPSG:4978"
#: the operation PROJ chooses for GEODETIC_CRS → ECEF_CRS with ``always_xy`` (its
#: ``Transformer.definition``), written out: built from this string the transformer needs no
#: lookup in PROJ's database (13 ms on every plan, most of it reading the database; 0.5 ms
#: without); the same numbers to the last bit (tests/world/test_geo.py compares it with
#: ``from_crs``)
GEODETIC_TO_ECEF = (
    "+proj=pipeline +step +proj=unitconvert +xy_in=deg +z_in=m +xy_out=rad +z_out=m "
    "+step +proj=cart +ellps=WGS84"
)


def _up_vectors(lat_deg: NDArray[np.float64], lon_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit ellipsoid normals (ECEF) at geodetic lat/lon: shape ``(n, 3)``."""
    import numpy as np

    lat = np.radians(lat_deg)
    lon = np.radians(lon_deg)
    return np.column_stack((np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)))


@dataclass(frozen=True)
class EnuFrame:
    """East-north-up frame (metres) tangent to the WGS84 ellipsoid at ``origin``.

    Build it with :meth:`EnuFrame.at`. The pyproj transformer is created on first use and
    kept by the frame, so a frame is cheap to make and fast to reuse.
    """

    origin: GeoPoint

    @classmethod
    def at(cls, origin: GeoPoint) -> EnuFrame:
        """The ENU frame whose origin (0, 0, 0) is ``origin`` (lat/lon degrees, alt metres)."""
        if not isinstance(origin, GeoPoint):
            raise TypeError(f"origin must be a GeoPoint, got {type(origin).__name__}")
        return cls(origin)

    # -- cached pieces ---------------------------------------------------------------------
    @cached_property
    def _transformer(self) -> Transformer:
        from pyproj import Transformer  # deferred: keeps `import uavplan...` fast

        return Transformer.from_pipeline(GEODETIC_TO_ECEF)

    @cached_property
    def _rotation(self) -> NDArray[np.float64]:
        """Rows are the east, north and up unit vectors in ECEF: ``enu = R @ (ecef - o)``."""
        import numpy as np

        lat = math.radians(self.origin.lat_deg)
        lon = math.radians(self.origin.lon_deg)
        sin_lat, cos_lat = math.sin(lat), math.cos(lat)
        sin_lon, cos_lon = math.sin(lon), math.cos(lon)
        return np.array(
            [
                [-sin_lon, cos_lon, 0.0],
                [-sin_lat * cos_lon, -sin_lat * sin_lon, cos_lat],
                [cos_lat * cos_lon, cos_lat * sin_lon, sin_lat],
            ]
        )

    @cached_property
    def origin_ecef_m(self) -> NDArray[np.float64]:
        """The origin in ECEF metres, shape ``(3,)``."""
        import numpy as np

        x, y, z = self._transformer.transform(
            self.origin.lon_deg, self.origin.lat_deg, self.origin.alt_m
        )
        return np.array([x, y, z], dtype=np.float64)

    # -- conversions -------------------------------------------------------------------------
    def to_ecef(self, points_enu: ArrayLike) -> NDArray[np.float64]:
        """ENU points ``(n, 3)`` (or one point ``(3,)``) → ECEF metres ``(n, 3)``."""
        enu = _as_points(points_enu, "points_enu")
        return enu @ self._rotation + self.origin_ecef_m

    def from_ecef(self, points_ecef: ArrayLike) -> NDArray[np.float64]:
        """ECEF metres ``(n, 3)`` → ENU points ``(n, 3)``."""
        ecef = _as_points(points_ecef, "points_ecef")
        return (ecef - self.origin_ecef_m) @ self._rotation.T

    def to_geodetic(
        self, points_enu: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """ENU points ``(n, 3)`` → ``(lat_deg, lon_deg, alt_m)``, each of shape ``(n,)``.

        ``alt_m`` is in the origin altitude's reference (AMSL for a scenario origin);
        longitudes are in [-180, 180]. The origin itself, ``(0, 0, 0)``, is the frame's
        origin exactly (through ECEF it comes back a few ulps off: a home at the origin was
        written as 47.397742000000015).
        """
        import numpy as np

        ecef = self.to_ecef(points_enu)
        lon_deg, lat_deg, alt_m = transform_arrays(
            self._transformer, ecef[:, 0], ecef[:, 1], ecef[:, 2], direction="INVERSE"
        )
        lat = np.array(lat_deg, dtype=np.float64).reshape(-1)
        lon = np.array(lon_deg, dtype=np.float64).reshape(-1)
        alt = np.array(alt_m, dtype=np.float64).reshape(-1)
        at_origin = ~np.asarray(points_enu, dtype=np.float64).reshape(-1, 3).any(axis=1)
        if at_origin.any():
            o = self.origin
            lat[at_origin], lon[at_origin], alt[at_origin] = o.lat_deg, o.lon_deg, o.alt_m
        return lat, lon, alt

    def to_enu(
        self, lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike
    ) -> NDArray[np.float64]:
        """Geodetic positions (scalars or arrays, broadcast together) → ENU points ``(n, 3)``."""
        import numpy as np

        lat, lon, alt = _as_geodetic(lat_deg, lon_deg, alt_m)
        x, y, z = transform_arrays(self._transformer, lon, lat, alt)
        ecef = np.column_stack(
            (np.asarray(x).reshape(-1), np.asarray(y).reshape(-1), np.asarray(z).reshape(-1))
        )
        return self.from_ecef(ecef)

    def to_enu_xy(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> NDArray[np.float64]:
        """Where the ellipsoid normal through (lat, lon) meets the ground plane z = 0: ``(n, 2)``.

        This is the exact inverse of the horizontal part of ``to_geodetic([x, y, 0])``: a
        mission item at relative altitude ``h`` above flat ground is the ENU point
        ``(*to_enu_xy(lat, lon), h)`` in the scenario's flat-ground model.
        """
        import numpy as np

        lat, lon, _ = _as_geodetic(lat_deg, lon_deg, 0.0)
        on_ellipsoid = self.to_enu(lat, lon, np.zeros_like(lat))
        direction = _up_vectors(lat, lon) @ self._rotation.T  # normals in ENU, (n, 3)
        # The normal is a straight line in ECEF, so the crossing is a closed-form step.
        t = -on_ellipsoid[:, 2] / direction[:, 2]
        return on_ellipsoid[:, :2] + t[:, None] * direction[:, :2]

    # -- one point at a time -------------------------------------------------------------
    # The same steps as the array conversions above in scalar arithmetic (pyproj answers one
    # point in about 2 µs, against some 40 µs of numpy overhead per one-point array): for
    # callers that ask a point at a time, a simulated flight's ground under the vehicle.
    # They agree with the array forms to about 1e-9 m (tests/world/test_geo.py).
    @cached_property
    def _rows(self) -> tuple[tuple[float, float, float], ...]:
        r = self._rotation
        return tuple((float(row[0]), float(row[1]), float(row[2])) for row in r)

    @cached_property
    def _origin_ecef(self) -> tuple[float, float, float]:
        o = self.origin_ecef_m
        return float(o[0]), float(o[1]), float(o[2])

    def to_geodetic_point(self, x: float, y: float, z: float) -> tuple[float, float, float]:
        """One ENU point → ``(lat_deg, lon_deg, alt_m)`` (see :meth:`to_geodetic`)."""
        if x == 0.0 and y == 0.0 and z == 0.0:
            o = self.origin
            return o.lat_deg, o.lon_deg, o.alt_m
        (e0, e1, e2), (n0, n1, n2), (u0, u1, u2) = self._rows
        ox, oy, oz = self._origin_ecef
        ex = x * e0 + y * n0 + z * u0 + ox
        ey = x * e1 + y * n1 + z * u1 + oy
        ez = x * e2 + y * n2 + z * u2 + oz
        lon, lat, alt = self._transformer.transform(ex, ey, ez, direction="INVERSE")
        return float(lat), float(lon), float(alt)

    def to_enu_xy_point(self, lat_deg: float, lon_deg: float) -> tuple[float, float]:
        """One geodetic position → ENU ``(x, y)`` on the ground plane (see :meth:`to_enu_xy`)."""
        (e0, e1, e2), (n0, n1, n2), (u0, u1, u2) = self._rows
        ox, oy, oz = self._origin_ecef
        cx, cy, cz = self._transformer.transform(lon_deg, lat_deg, 0.0)
        dx, dy, dz = cx - ox, cy - oy, cz - oz
        px = dx * e0 + dy * e1 + dz * e2
        py = dx * n0 + dy * n1 + dz * n2
        pz = dx * u0 + dy * u1 + dz * u2
        lat, lon = math.radians(lat_deg), math.radians(lon_deg)
        ux, uy, uz = math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon), math.sin(lat)
        qx = ux * e0 + uy * e1 + uz * e2
        qy = ux * n0 + uy * n1 + uz * n2
        qz = ux * u0 + uy * u1 + uz * u2
        t = -pz / qz
        return px + t * qx, py + t * qy


def _as_points(points: ArrayLike, name: str) -> NDArray[np.float64]:
    import numpy as np

    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3), got {np.shape(points)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    return arr


def _as_geodetic(
    lat_deg: ArrayLike, lon_deg: ArrayLike, alt_m: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    import numpy as np

    lat, lon, alt = np.broadcast_arrays(
        np.asarray(lat_deg, dtype=np.float64),
        np.asarray(lon_deg, dtype=np.float64),
        np.asarray(alt_m, dtype=np.float64),
    )
    lat, lon, alt = lat.reshape(-1), lon.reshape(-1), alt.reshape(-1)
    if not (np.all(np.isfinite(lat)) and np.all(np.isfinite(lon)) and np.all(np.isfinite(alt))):
        raise ValueError("geodetic coordinates must be finite")
    if np.any(np.abs(lat) > 90.0):
        raise ValueError("latitude must be within [-90, 90] degrees")
    return lat, lon, alt
