"""OpenAir airspace files: the 2.x format (Naviter's specification, ``AC`` class + ``AY``
type, ``AA`` activation windows) and the older dialects national files still use (``AC R``,
``AC CTR``, altitudes such as ``2500ft MSL``, ``1000 ft GND``, ``3000 STD``, ``FL 65``).

Records read: ``AC`` (class; a legacy type token such as ``R``, ``Q``, ``P``, ``CTR`` is
kept as a class token too), ``AY`` (type), ``AN`` (name), ``AL`` / ``AH`` (floor and
ceiling), ``AA`` (activation window; several are a union; ``AA NONE`` means activated by
NOTAM), ``V X=`` (centre), ``V D=+`` / ``V D=-`` (arc direction, clockwise by default;
reset at each ``AC``), ``DP`` (polygon point), ``DA`` (arc: radius in NM, start and end
bearing), ``DB`` (arc between two points), ``DC`` (circle, radius in NM), comments (``*``
to the end of a line). Ignored, as labels for displays: ``AF``, ``AG``, ``AX``, ``AT``,
``SP``, ``SB``, ``V W=``, ``V Z=``, a header's ``*`` lines. ``DY`` (airway segments) is
refused with its line: it is not read.

Any other problem is one :class:`~uavplan.sources.zones.ZoneFileError` naming the file and
the line. Coordinates: ``DD:MM:SS[.s] N``, ``DD:MM.mmm N`` or ``DD.ddd N`` (spaces and a
comma between latitude and longitude accepted).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any

from uavplan.sources.zones import (
    CHORD_ERROR_M,
    FOOT_M,
    MAX_FILE_VERTICES,
    MAX_RADIUS_M,
    MAX_ZONE_VERTICES,
    MAX_ZONES,
    NAUTICAL_MILE_M,
    Activity,
    Arc,
    Limit,
    Period,
    Piece,
    Reference,
    Zone,
    ZoneFileError,
    corridor,
    geodesic_inverse,
    outline,
    parse_datetime,
)

_COORD_RE = re.compile(
    r"(?P<deg>\d{1,3}(?:\.\d+)?)"
    r"(?::(?P<min>\d{1,2}(?:\.\d+)?))?"
    r"(?::(?P<sec>\d{1,2}(?:\.\d+)?))?"
    r"\s*(?P<hem>[NSEW])",
    re.IGNORECASE,
)

_ALT_RE = re.compile(
    r"^(?:(?P<fl>FL)\s*(?P<flv>\d+(?:\.\d+)?)"
    r"|(?P<num>\d+(?:\.\d+)?)\s*(?P<unit>FT|F|FEET|FOOT|M|METERS?|METRES?)?\s*"
    r"(?P<ref>AMSL|MSL|ALT|AGL|AGND|GND|SFC|ASFC|STD|QNE)?)$"
)

#: ``AC`` tokens of the legacy dialect that are a type, not a class (also kept as classes)
LEGACY_TYPES = {
    "R": "restricted",
    "Q": "danger",
    "P": "prohibited",
    "CTR": "control zone",
    "GP": "glider prohibited",
    "W": "wave window",
    "TMZ": "transponder mandatory",
    "RMZ": "radio mandatory",
}


@dataclass
class _Draft:
    """A zone as its records come in."""

    line: int
    classes: list[str]
    name: str | None = None
    type: str | None = None
    floor: Limit | None = None
    ceiling: Limit | None = None
    periods: list[Period] = field(default_factory=list)
    activation_unknown: bool = False
    pieces: list[Piece] = field(default_factory=list)
    circle: tuple[float, float, float] | None = None
    centre: tuple[float, float] | None = None
    clockwise: bool = True


def parse_openair(text: str, file: str) -> tuple[Zone, ...]:
    """The zones of an OpenAir file's ``text`` (``file`` names it in messages)."""
    zones: list[Zone] = []
    draft: _Draft | None = None
    vertices = 0

    def fail(line: int, reason: str) -> ZoneFileError:
        return ZoneFileError(reason, file=file, where=f"line {line}")

    def finish(d: _Draft) -> None:
        nonlocal vertices
        zone = _finish(d, file, fail)
        vertices += len(zone.ring_lonlat or ())
        if vertices > MAX_FILE_VERTICES:
            raise fail(d.line, f"the file's zones hold more than {MAX_FILE_VERTICES:,} vertices")
        zones.append(zone)
        if len(zones) > MAX_ZONES:
            raise fail(d.line, f"more than {MAX_ZONES:,} zones in one file")

    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("*") or line.startswith("#"):
            continue
        head, _, rest = line.partition(" ")
        head = head.upper()
        if len(head) > 2 and head[:2] in ("AC", "AN", "AL", "AH", "DP", "DC", "DA", "DB", "AY"):
            # "AH3000ft" and friends: a record glued to its value
            head, rest = head[:2], line[2:]
        if head != "AN":
            rest = rest.split("*", 1)[0]
        rest = rest.strip()
        if head == "AC":
            if draft is not None:
                finish(draft)
            token = rest.upper()
            if not token:
                raise fail(number, "AC needs a class (A … G, UNC) or a legacy type (R, Q, P, CTR)")
            draft = _Draft(number, [token])
            continue
        if head in ("SP", "SB", "AT", "AF", "AG", "AX"):
            continue
        if draft is None:
            raise fail(number, f"{head} before the first AC: every zone starts with AC")
        d = draft
        if head == "AN":
            d.name = rest.strip() or None
        elif head == "AY":
            token = rest.upper()
            if not token:
                raise fail(number, "AY needs a type (CTR, R, P, Q, TMA, …)")
            d.type = token
            d.classes.append(token)
        elif head in ("AL", "AH"):
            try:
                limit = parse_altitude(rest)
            except ValueError as err:
                raise fail(number, f"{head}: {err}") from None
            if head == "AL":
                if limit.reference is Reference.UNL:
                    raise fail(number, "AL: a floor cannot be unlimited (UNL)")
                d.floor = limit
            else:
                d.ceiling = limit
        elif head == "AA":
            _activation(d, rest, number, fail)
        elif head == "V":
            _variable(d, rest, number, fail)
        elif head == "DP":
            if d.circle is not None:
                raise fail(number, "DP after DC: a zone is a polygon or a circle, not both")
            d.pieces.append(_coord_pair(rest, number, fail))
        elif head == "DA":
            d.pieces.append(_da(d, rest, number, fail))
        elif head == "DB":
            d.pieces.append(_db(d, rest, number, fail))
        elif head == "DC":
            if d.pieces:
                raise fail(number, "DC after DP / DA / DB: a zone is a polygon or a circle")
            if d.centre is None:
                raise fail(number, "DC needs a centre: a V X= record before it")
            radius = _radius(rest, number, fail, "DC")
            d.circle = (d.centre[0], d.centre[1], radius)
        elif head == "DY":
            raise fail(number, "DY (airway segment) is not read: give the airway as DP points")
        else:
            raise fail(number, f"unknown record {head!r}")
    if draft is not None:
        finish(draft)
    return tuple(zones)


def _finish(d: _Draft, file: str, fail: object) -> Zone:
    assert callable(fail)
    name = d.name or f"unnamed zone of line {d.line}"
    if d.floor is None:
        raise fail(d.line, f"zone {name!r} (AC at line {d.line}) has no floor (AL)")
    if d.ceiling is None:
        raise fail(d.line, f"zone {name!r} (AC at line {d.line}) has no ceiling (AH)")
    ac = d.classes[0]
    if d.type is not None:
        label = f"class {ac}, type {d.type}"
    elif ac in LEGACY_TYPES:
        label = f"{ac}, {LEGACY_TYPES[ac]}"
    else:
        label = f"class {ac}"
    activity = Activity(tuple(d.periods) if d.periods else None, d.activation_unknown)
    common: dict[str, Any] = dict(
        name=name,
        classes=tuple(dict.fromkeys(d.classes)),
        label=label,
        floor=d.floor,
        ceiling=d.ceiling,
        activity=activity,
        file=file,
        where=f"line {d.line}",
    )
    if d.circle is not None:
        return Zone(**common, circle=d.circle)
    if not d.pieces:
        raise fail(d.line, f"zone {name!r} (AC at line {d.line}) has no shape (DP, DA, DB or DC)")
    ring, error = outline(d.pieces)
    notes: tuple[str, ...] = ()
    if len(ring) == 2:  # a cable or a line obstacle (Swiss files): a narrow corridor
        ring = corridor(ring[0], ring[1], CHORD_ERROR_M)
        error = max(error, CHORD_ERROR_M)
        notes = (f"a line, not an area: taken as a corridor {2 * CHORD_ERROR_M:g} m wide",)
    if len(ring) < 3:
        raise fail(
            d.line,
            f"zone {name!r} (AC at line {d.line}) has {len(ring)} distinct point(s): a polygon "
            "needs at least 3",
        )
    if len(ring) > MAX_ZONE_VERTICES:
        raise fail(d.line, f"zone {name!r} has more than {MAX_ZONE_VERTICES:,} vertices")
    return Zone(**common, ring_lonlat=ring, chord_error_m=error, notes=notes)


def parse_altitude(text: str) -> Limit:
    """An OpenAir floor or ceiling as written: ``GND``, ``SFC``, ``UNL``, ``FL65``,
    ``2500ft MSL``, ``1500 m AMSL``, ``1000ft AGL`` (also ``1000 ft GND`` / ``SFC``),
    ``3000 STD``; a number without a unit is feet, without a reference AMSL."""
    raw = " ".join(text.split())
    t = raw.upper()
    if t in ("GND", "SFC", "0", "SURFACE", "GROUND"):
        return Limit.ground(raw)
    if t in ("UNL", "UNLIM", "UNLIMITED", "UNLTD"):
        return Limit.unlimited(raw)
    if t == "MSL":
        return Limit(0.0, Reference.AMSL, raw)
    m = _ALT_RE.match(t)
    if not m:
        raise ValueError(
            f"cannot read the altitude {raw!r} (GND, SFC, UNL, FL65, 2500ft AMSL, 1500m MSL, "
            "1000ft AGL, 3000ft STD)"
        )
    if m.group("fl"):
        value = float(m.group("flv")) * 100.0 * FOOT_M
        return _limit(value, Reference.STD, raw)
    value = float(m.group("num"))
    unit = (m.group("unit") or "FT")[0]
    value_m = value * (FOOT_M if unit == "F" else 1.0)
    ref = m.group("ref") or "AMSL"
    reference = {
        "AMSL": Reference.AMSL,
        "MSL": Reference.AMSL,
        "ALT": Reference.AMSL,
        "AGL": Reference.AGL,
        "AGND": Reference.AGL,
        "GND": Reference.AGL,
        "SFC": Reference.AGL,
        "ASFC": Reference.AGL,
        "STD": Reference.STD,
        "QNE": Reference.STD,
    }[ref]
    if reference is Reference.AGL and value_m == 0.0:
        return Limit.ground(raw)
    return _limit(value_m, reference, raw)


def _limit(value_m: float, reference: Reference, raw: str) -> Limit:
    try:
        return Limit(value_m, reference, raw)
    except ValueError as err:
        raise ValueError(f"{raw!r}: {err}") from None


def _activation(d: _Draft, rest: str, number: int, fail: object) -> None:
    assert callable(fail)
    text = rest.split(";", 1)[0].strip()
    if text.upper() == "NONE":
        d.activation_unknown = True
        return
    first, sep, second = text.partition("/")
    if not sep:
        raise fail(number, f"AA: {text!r} is not an interval (start/end, ISO 8601, UTC)")
    try:
        start = None if first.strip().upper() == "NONE" else parse_datetime(first)
        end = None if second.strip().upper() == "NONE" else parse_datetime(second)
    except ValueError as err:
        raise fail(number, f"AA: {err}") from None
    if start is not None and end is not None and end < start:
        raise fail(number, "AA: the window ends before it starts")
    d.periods.append(Period(start, end))


def _variable(d: _Draft, rest: str, number: int, fail: object) -> None:
    assert callable(fail)
    name, sep, value = rest.partition("=")
    name = name.strip().upper()
    value = value.strip()
    if not sep:
        raise fail(number, f"V: {rest!r} is not an assignment (V X=…, V D=+ or V D=-)")
    if name == "X":
        d.centre = _coord_pair(value, number, fail)
    elif name == "D":
        if value not in ("+", "-"):
            raise fail(
                number, f"V D= must be + (clockwise) or - (counter-clockwise), got {value!r}"
            )
        d.clockwise = value == "+"
    elif name in ("W", "Z", "T"):
        return
    else:
        raise fail(number, f"V: unknown variable {name!r} (X, D)")


def _coord_pair(text: str, number: int, fail: object) -> tuple[float, float]:
    """(lon, lat) of ``47:30:00N 008:30:00E``."""
    assert callable(fail)
    found = list(_COORD_RE.finditer(text))
    rest = _COORD_RE.sub("", text).replace(",", "").strip()
    if len(found) != 2 or rest:
        raise fail(number, f"cannot read the position {text.strip()!r} (47:30:00N 008:30:00E)")
    values: dict[str, float] = {}
    for m in found:
        hem = m.group("hem").upper()
        deg = float(m.group("deg"))
        minutes = float(m.group("min") or 0)
        seconds = float(m.group("sec") or 0)
        # 60 is written for 59.99… rounded up in real files (France: 001:25:60 E)
        if (m.group("min") and "." in m.group("deg")) or minutes > 60 or seconds > 60:
            raise fail(number, f"cannot read the position {text.strip()!r}: minutes or seconds")
        value = deg + minutes / 60 + seconds / 3600
        axis = "lat" if hem in "NS" else "lon"
        if axis in values:
            raise fail(number, f"the position {text.strip()!r} has two {axis}itudes")
        limit = 90.0 if axis == "lat" else 180.0
        if value > limit:
            raise fail(number, f"{axis}itude {value:g} beyond ±{limit:g} in {text.strip()!r}")
        values[axis] = -value if hem in "SW" else value
    if set(values) != {"lat", "lon"}:
        raise fail(number, f"the position {text.strip()!r} needs a latitude and a longitude")
    return values["lon"], values["lat"]


def _radius(text: str, number: int, fail: object, record: str) -> float:
    assert callable(fail)
    try:
        nm = float(text.strip())
    except ValueError:
        raise fail(number, f"{record}: the radius {text.strip()!r} is not a number (NM)") from None
    radius = nm * NAUTICAL_MILE_M
    if not (math.isfinite(radius) and 0 < radius <= MAX_RADIUS_M):
        raise fail(
            number,
            f"{record}: the radius must be > 0 and at most {MAX_RADIUS_M / NAUTICAL_MILE_M:,.0f} "
            f"NM, got {text.strip()}",
        )
    return radius


def _angle(text: str, number: int, fail: object) -> float:
    assert callable(fail)
    try:
        value = float(text.strip())
    except ValueError:
        raise fail(number, f"DA: the bearing {text.strip()!r} is not a number") from None
    if not (math.isfinite(value) and -360.0 <= value <= 720.0):
        raise fail(number, f"DA: the bearing {text.strip()} is not within 0 … 360")
    return value


def _da(d: _Draft, rest: str, number: int, fail: object) -> Arc:
    assert callable(fail)
    if d.circle is not None:
        raise fail(number, "DA after DC: a zone is a polygon or a circle")
    if d.centre is None:
        raise fail(number, "DA needs a centre: a V X= record before it")
    parts = rest.split(",")
    if len(parts) != 3:
        raise fail(number, f"DA needs radius, start bearing, end bearing; got {rest!r}")
    radius = _radius(parts[0], number, fail, "DA")
    start, end = _angle(parts[1], number, fail), _angle(parts[2], number, fail)
    sweep = _sweep(start, end, d.clockwise)
    return Arc(d.centre, start, sweep, radius, radius)


def _db(d: _Draft, rest: str, number: int, fail: object) -> Arc:
    assert callable(fail)
    if d.circle is not None:
        raise fail(number, "DB after DC: a zone is a polygon or a circle")
    if d.centre is None:
        raise fail(number, "DB needs a centre: a V X= record before it")
    coords = list(_COORD_RE.finditer(rest))
    if len(coords) != 4:
        raise fail(number, f"DB needs two positions (start, end); got {rest.strip()!r}")
    split = coords[1].end()
    a = _coord_pair(rest[:split], number, fail)
    b = _coord_pair(rest[split:].lstrip(" ,"), number, fail)
    az0, r0 = geodesic_inverse(d.centre, a)
    az1, r1 = geodesic_inverse(d.centre, b)
    for r in (r0, r1):
        if not (0 < r <= MAX_RADIUS_M):
            raise fail(number, "DB: an end of the arc is at its centre, or too far from it")
    sweep = _sweep(az0, az1, d.clockwise)
    return Arc(d.centre, az0, sweep, r0, r1, start=a, end=b)


def _sweep(start: float, end: float, clockwise: bool) -> float:
    """The signed sweep from bearing ``start`` to ``end`` (clockwise positive); equal
    bearings are a full turn."""
    if clockwise:
        s = (end - start) % 360.0
        return s if s > 1e-9 else 360.0
    s = (start - end) % 360.0
    return -(s if s > 1e-9 else 360.0)
