"""Airspace zones as their files give them: a horizontal shape in WGS84, a floor and a ceiling
each in its own vertical reference, the class or restriction, and when the zone is active.

The readers (:mod:`~uavplan.sources.openair`, :mod:`~uavplan.sources.ed269`) turn a file into
:class:`Zone` values; :func:`uavplan.sources.zonefiles.read_zone_file` picks the reader by the
file's content (the readers import this module only, so the package has no import cycle). Nothing
here knows a scenario: turning a floor into a height in a scenario's frame (over its DEM,
through the standard atmosphere) is :mod:`uavplan.scenario.zones`' job.

Arcs become polygon vertices here, once, with a stated chord error (:data:`CHORD_ERROR_M`):
a polygon edge never lies more than that outside the true arc, and never inside the zone's
true boundary (a convex arc gets its vertices *outside* the circle with tangent edges, a
concave one its vertices *on* the circle), so the polygon *contains* the zone. Circles stay
circles (centre and radius, exact). Arc points are geodesic (WGS84, ``pyproj.Geod``);
polygon edges are straight in the scenario's local ENU plane.
"""

from __future__ import annotations

import enum
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime, time, timedelta
from typing import Any

from uavplan.errors import InputError

#: the most a polygon edge that stands for an arc strays outside the true arc (metres)
CHORD_ERROR_M = 2.0
#: an international foot and a nautical mile, in metres
FOOT_M = 0.3048
NAUTICAL_MILE_M = 1852.0
#: largest arc or circle radius read (metres): beyond, a file is wrong (a FIR's arcs stay far
#: below it), and the arc's vertices would grow without use
MAX_RADIUS_M = 2_000_000.0
#: vertices of one zone's outline at most (arcs included); a file at most this many in all
MAX_ZONE_VERTICES = 100_000
MAX_FILE_VERTICES = 5_000_000
#: a zone file at most this large (bytes): a national file is a few MB
MAX_FILE_BYTES = 64 * 1024 * 1024
#: zones per file at most
MAX_ZONES = 100_000
#: limits above this (metres) are not airspace a drone meets; a number beyond is an error
MAX_LIMIT_M = 100_000.0


class ZoneFileError(InputError):
    """A zone file cannot be read: ``where`` is the line (``line 12``) or the feature
    (``feature 3 (ID 'EFR10')``), ``reason`` the problem."""

    def __init__(self, reason: str, *, file: str | None = None, where: str | None = None) -> None:
        self.where = where
        super().__init__(reason, file=file, key=where)


class Reference(enum.Enum):
    """The vertical reference of a floor or a ceiling."""

    GND = "GND"  # the ground (or the surface): 0 above it
    AGL = "AGL"  # above the ground beneath
    AMSL = "AMSL"  # above mean sea level
    STD = "STD"  # pressure altitude on the standard setting (flight levels)
    WGS84 = "WGS84"  # above the WGS84 ellipsoid (ED-318)
    UNL = "UNL"  # no upper limit


@dataclass(frozen=True)
class Limit:
    """A floor or a ceiling: ``value_m`` metres in ``reference`` (a flight level is its
    pressure altitude: FL65 is 6,500 ft STD = 1,981.2 m); ``text`` as the file writes it.
    ``UNL`` has ``value_m`` inf, ``GND`` 0."""

    value_m: float
    reference: Reference
    text: str

    def __post_init__(self) -> None:
        if self.reference is Reference.UNL:
            if self.value_m != math.inf:
                raise ValueError("an unlimited ceiling has value inf")
        elif not (math.isfinite(self.value_m) and abs(self.value_m) <= MAX_LIMIT_M):
            raise ValueError(f"a vertical limit must be within ±{MAX_LIMIT_M:g} m")

    @classmethod
    def ground(cls, text: str = "GND") -> Limit:
        return cls(0.0, Reference.GND, text)

    @classmethod
    def unlimited(cls, text: str = "UNL") -> Limit:
        return cls(math.inf, Reference.UNL, text)


# ---------------------------------------------------------------------------------------------
# When a zone is active


@dataclass(frozen=True)
class DailyWindow:
    """Part of a day a zone is active: ``days`` (0 = Monday … 6 = Sunday), from ``start`` to
    ``end`` (times of day; ``end`` <= ``start`` runs past midnight). ``utc_offset`` None:
    the file gives no time zone, so the window is widened by :data:`UNKNOWN_OFFSET` each way
    (any time zone on Earth)."""

    days: frozenset[int]
    start: time
    end: time
    utc_offset: timedelta | None = timedelta(0)


#: a daily window without a time zone may be in any: widened this much each way
UNKNOWN_OFFSET = timedelta(hours=14)


@dataclass(frozen=True)
class Period:
    """An interval of activity (``None`` ends are open), optionally only within
    ``daily`` windows."""

    start: datetime | None = None
    end: datetime | None = None
    daily: tuple[DailyWindow, ...] = ()

    def overlaps(self, t0: datetime, t1: datetime) -> bool:
        """Is the zone active at any time of [t0, t1] under this period?"""
        lo = t0 if self.start is None else max(t0, self.start)
        hi = t1 if self.end is None else min(t1, self.end)
        if lo > hi:
            return False
        if not self.daily:
            return True
        return any(_daily_overlaps(w, lo, hi) for w in self.daily)


def _daily_overlaps(w: DailyWindow, t0: datetime, t1: datetime) -> bool:
    offset = w.utc_offset
    widen = UNKNOWN_OFFSET if offset is None else timedelta(0)
    shift = timedelta(0) if offset is None else offset
    day = (t0 + shift).date() - timedelta(days=2)
    last = (t1 + shift).date() + timedelta(days=1)
    while day <= last:
        if day.weekday() in w.days:
            begin = datetime.combine(day, w.start, tzinfo=UTC) - shift
            stop = datetime.combine(day, w.end, tzinfo=UTC) - shift
            if stop <= begin:
                stop += timedelta(days=1)
            if begin - widen <= t1 and t0 <= stop + widen:
                return True
        day += timedelta(days=1)
    return False


@dataclass(frozen=True)
class Activity:
    """When a zone is active: ``periods`` (any of them), or always (``None``).
    ``unknown``: the file says activation is announced separately (OpenAir ``AA NONE``, a
    NOTAM): taken as active, the report says why."""

    periods: tuple[Period, ...] | None = None
    unknown: bool = False

    @property
    def always(self) -> bool:
        return self.periods is None or self.unknown

    def active_during(self, t0: datetime, t1: datetime) -> bool:
        """Is the zone active at any time of [t0, t1] (UTC)? Unknown activation is active."""
        if self.always:
            return True
        assert self.periods is not None
        return any(p.overlaps(t0, t1) for p in self.periods)

    def describe(self) -> str:
        if self.unknown:
            return "activated by NOTAM (no times in the file)"
        if self.periods is None:
            return "always active"
        parts = []
        for p in self.periods[:3]:
            a = "…" if p.start is None else p.start.strftime("%Y-%m-%dT%H:%MZ")
            b = "…" if p.end is None else p.end.strftime("%Y-%m-%dT%H:%MZ")
            parts.append(f"{a}/{b}" + (" (daily schedule)" if p.daily else ""))
        more = f" and {len(self.periods) - 3} more" if len(self.periods) > 3 else ""
        return "active " + ", ".join(parts) + more


ALWAYS = Activity()

# ---------------------------------------------------------------------------------------------
# Zones


@dataclass(frozen=True)
class Zone:
    """One zone volume of a file.

    ``classes``: the tokens ``airspace.avoid`` matches, upper case (an OpenAir ``AC`` class
    and ``AY`` type, an ED-269 ``restriction``, an ED-318 ``type``). ``label``: how messages
    name the kind (``class D, type CTR``). Exactly one of ``ring_lonlat`` (``(k, 2)``
    longitude, latitude, not closed) and ``circle`` (centre longitude, latitude, radius in
    metres) is set. ``chord_error_m``: how far the ring may stray outside the true boundary
    (0: exact). ``where``: the line or feature it was read from.
    """

    name: str
    classes: tuple[str, ...]
    label: str
    floor: Limit
    ceiling: Limit
    activity: Activity = ALWAYS
    ring_lonlat: tuple[tuple[float, float], ...] | None = None
    circle: tuple[float, float, float] | None = None
    chord_error_m: float = 0.0
    file: str = ""
    where: str = ""
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        if (self.ring_lonlat is None) == (self.circle is None):
            raise ValueError("a zone is a ring or a circle")
        if self.ring_lonlat is not None and len(self.ring_lonlat) < 3:
            raise ValueError("a zone's ring needs at least 3 vertices")

    @property
    def title(self) -> str:
        """``zone 'EDDF CTR' (class D, type CTR)``: how every message names the zone."""
        return f"zone '{self.name}' ({self.label})"

    @property
    def vertical_text(self) -> str:
        return f"{self.floor.text}–{self.ceiling.text}"


# ---------------------------------------------------------------------------------------------
# Text


def decode_text(data: bytes, file: str) -> str:
    """UTF-8 (a byte-order mark accepted), else Latin-1 for an OpenAir file of the older
    national files (their names hold umlauts as single bytes); NUL bytes are refused."""
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise ZoneFileError("UTF-16 text: save it as UTF-8", file=file)
    if b"\x00" in data:
        raise ZoneFileError("binary data (NUL bytes): not a zone file", file=file)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


# ---------------------------------------------------------------------------------------------
# Geometry: arcs as polygon vertices, geodesic


def _geod() -> Any:
    from pyproj import Geod

    return Geod(ellps="WGS84")


@dataclass(frozen=True)
class Arc:
    """An arc around ``centre`` (lon, lat) from bearing ``start_deg`` sweeping ``sweep_deg``
    (positive clockwise, negative counter-clockwise), its radius going from ``r0_m`` to
    ``r1_m`` (equal for a DA arc; a DB arc's two ends may sit at slightly different
    distances). ``end`` (lon, lat): the exact end point, if given (DB)."""

    centre: tuple[float, float]
    start_deg: float
    sweep_deg: float
    r0_m: float
    r1_m: float
    start: tuple[float, float] | None = None
    end: tuple[float, float] | None = None


Piece = tuple[float, float] | Arc


def arc_steps(radius_m: float, sweep_rad: float, outside: bool, error_m: float) -> int:
    """How many steps an arc of ``sweep_rad`` needs to keep its edges within ``error_m``:
    vertices on the circle (``outside`` False: chords inside it, the sagitta
    ``r (1 - cos(step / 2))``), or tangent edges outside it (``r (1 / cos(step / 2) - 1)``)."""
    if radius_m <= error_m:
        return max(1, math.ceil(abs(sweep_rad) / (math.pi / 2)))
    half = (
        math.acos(radius_m / (radius_m + error_m)) if outside else math.acos(1 - error_m / radius_m)
    )
    return max(1, math.ceil(abs(sweep_rad) / (2.0 * half) - 1e-9))


def arc_points(
    arc: Arc, outside: bool, error_m: float = CHORD_ERROR_M
) -> list[tuple[float, float]]:
    """The arc's vertices (lon, lat), its start and end included. ``outside``: the zone lies
    inside the circle here (a convex arc), so the edges must pass outside the circle:
    tangent edges, their vertices at r / cos(half step); else chords, vertices on it."""
    import numpy as np

    sweep = math.radians(arc.sweep_deg)
    r_max = max(arc.r0_m, arc.r1_m)
    n = arc_steps(r_max, sweep, outside, error_m)
    if outside:
        # ends on the circle, between them the tangent edges' crossings at odd half steps
        frac = np.concatenate([[0.0], (2 * np.arange(n) + 1) / (2 * n), [1.0]])
        half = sweep / (2 * n)
        grow = np.concatenate([[1.0], np.full(n, 1.0 / math.cos(half)), [1.0]])
    else:
        frac = np.arange(n + 1) / n
        grow = np.ones(n + 1)
    bearing = arc.start_deg + np.degrees(sweep) * frac
    radius = (arc.r0_m + (arc.r1_m - arc.r0_m) * frac) * grow
    lon, lat, _ = _geod().fwd(
        np.full(len(frac), arc.centre[0]), np.full(len(frac), arc.centre[1]), bearing, radius
    )
    pts = [(float(a), float(b)) for a, b in zip(lon, lat, strict=True)]
    if arc.start is not None:
        pts[0] = arc.start
    if arc.end is not None:
        pts[-1] = arc.end
    return pts


def _signed_area_lonlat(points: Sequence[tuple[float, float]]) -> float:
    """Signed area (positive: counter-clockwise) in an equirectangular view: enough for the
    orientation of a zone's ring."""
    lat0 = math.radians(sum(p[1] for p in points) / len(points))
    c = math.cos(lat0)
    s = 0.0
    n = len(points)
    for i in range(n):
        x0, y0 = points[i][0] * c, points[i][1]
        x1, y1 = points[(i + 1) % n][0] * c, points[(i + 1) % n][1]
        s += x0 * y1 - x1 * y0
    return s / 2.0


def outline(
    pieces: Sequence[Piece], error_m: float = CHORD_ERROR_M
) -> tuple[tuple[tuple[float, float], ...], float]:
    """A ring (lon, lat) from points and arcs, and its chord error (0 without arcs). An arc
    turning the same way as the ring (clockwise in a clockwise ring) bulges out of the zone:
    its edges pass outside the circle; one turning against it bulges in: chords."""
    arcs = [p for p in pieces if isinstance(p, Arc)]
    if not arcs:
        ring = [p for p in pieces if not isinstance(p, Arc)]
        return tuple(_unclosed(ring)), 0.0

    def build(outward: dict[int, bool]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for i, p in enumerate(pieces):
            if isinstance(p, Arc):
                out.extend(arc_points(p, outward.get(i, False), error_m))
            else:
                out.append(p)
        return _unclosed(out)

    first = build({})
    clockwise_ring = _signed_area_lonlat(first) < 0
    outward = {
        i: (p.sweep_deg > 0) == clockwise_ring for i, p in enumerate(pieces) if isinstance(p, Arc)
    }
    return tuple(build(outward)), error_m


def _unclosed(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Drop consecutive repeats and a closing copy of the first point."""
    out: list[tuple[float, float]] = []
    for p in points:
        if not out or abs(p[0] - out[-1][0]) > 1e-12 or abs(p[1] - out[-1][1]) > 1e-12:
            out.append(p)
    while (
        len(out) > 1
        and abs(out[0][0] - out[-1][0]) <= 1e-12
        and abs(out[0][1] - out[-1][1]) <= 1e-12
    ):
        out.pop()
    return out


def corridor(
    a: tuple[float, float], b: tuple[float, float], half_width_m: float
) -> tuple[tuple[float, float], ...]:
    """The rectangle (lon, lat) around the segment a → b, ``half_width_m`` to either side and
    beyond either end: a line zone (a cable) as an area."""
    az, _ = geodesic_inverse(a, b)
    g = _geod()
    out = []
    for (lon, lat), ahead in ((a, az + 180.0), (b, az)):
        lon2, lat2, _ = g.fwd(lon, lat, ahead, half_width_m)
        for side in (-90.0, 90.0) if ahead == az else (90.0, -90.0):
            x, y, _ = g.fwd(lon2, lat2, az + side, half_width_m)
            out.append((float(x), float(y)))
    return tuple(out)


def geodesic_inverse(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """(bearing from a to b in degrees, distance in metres) on WGS84."""
    az, _, dist = _geod().inv(a[0], a[1], b[0], b[1])
    return float(az), float(dist)


# ---------------------------------------------------------------------------------------------
# Times


_DATETIME_RE = re.compile(
    r"^(\d{4})-(\d{2})-(\d{2})[T ](\d{2}):(\d{2})(?::(\d{2})(?:\.\d+)?)?\s*(Z|[+-]\d{2}:?\d{2})?$",
    re.IGNORECASE,
)


def parse_datetime(text: str, *, default_utc: bool = True) -> datetime:
    """An ISO 8601 / RFC 3339 date and time (``2026-12-01T09:00Z``, ``…:00.00+01:00``,
    ``T24:00`` as the next midnight) as an aware UTC datetime; ``ValueError`` otherwise."""
    m = _DATETIME_RE.match(text.strip())
    if not m:
        raise ValueError(f"not an ISO 8601 date and time: {text!r}")
    y, mo, d, hh, mm = (int(m.group(i)) for i in range(1, 6))
    ss = int(m.group(6) or 0)
    extra = timedelta(0)
    if hh == 24 and mm == 0 and ss == 0:
        hh, extra = 0, timedelta(days=1)
    tz = m.group(7)
    if tz is None and not default_utc:
        raise ValueError(f"no time zone in {text!r}")
    offset = timedelta(0)
    if tz and tz.upper() != "Z":
        sign = -1 if tz[0] == "-" else 1
        digits = tz[1:].replace(":", "")
        offset = sign * timedelta(hours=int(digits[:2]), minutes=int(digits[2:]))
    base = datetime(y, mo, d, hh, mm, ss, tzinfo=UTC)  # raises ValueError on a bad date
    return base + extra - offset


_TIME_RE = re.compile(r"^(\d{2}):(\d{2})(?::(\d{2})(?:\.\d+)?)?\s*(Z|[+-]\d{2}:?\d{2})?$", re.I)


def parse_time_of_day(text: str) -> tuple[time, timedelta | None]:
    """``08:00``, ``08:00:00.00Z``, ``08:00+01:00`` → (time, UTC offset or None when not
    given). ``24:00`` is the end of the day."""
    m = _TIME_RE.match(text.strip())
    if not m:
        raise ValueError(f"not a time of day: {text!r}")
    hh, mm, ss = int(m.group(1)), int(m.group(2)), int(m.group(3) or 0)
    if hh == 24 and mm == 0 and ss == 0:
        hh, mm, ss = 23, 59, 59
    t = time(hh, mm, ss)  # raises ValueError when out of range
    tz = m.group(4)
    if tz is None:
        return t, None
    if tz.upper() == "Z":
        return t, timedelta(0)
    sign = -1 if tz[0] == "-" else 1
    digits = tz[1:].replace(":", "")
    return t, sign * timedelta(hours=int(digits[:2]), minutes=int(digits[2:]))


WEEKDAYS = {"MON": 0, "TUE": 1, "WED": 2, "THU": 3, "FRI": 4, "SAT": 5, "SUN": 6}
