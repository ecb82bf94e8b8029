"""The mission model: autopilot-neutral plan items, independent of files and of the wire.

A :class:`MissionPlan` holds what QGroundControl's ``.plan`` holds: the planned home, the
mission items (never a home item), the geofence and the rally points. The autopilot flavour
decides how that maps onto MAVLink sequence numbers (:meth:`MissionPlan.wire_items`):
ArduPilot puts home at mission seq 0, PX4 has no home slot (reference §4.1).

Positions of items in a global frame are plain degrees and metres (``lat_deg``, ``lon_deg``,
``alt_m``); on the wire they become ``int32`` degrees × 1e7 (rounded, not truncated). For
frame ``MAV_FRAME_MISSION`` (2) the three fields carry the raw x / y / z values.

``None`` in a param means "unset" (NaN on the wire, ``null`` in a ``.plan`` file).
"""

from __future__ import annotations

import enum
import math
import operator
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace

from uavplan.flavour import Autopilot
from uavplan.geo import GeoPoint

# ---------------------------------------------------------------------------------------------
# MAVLink enum values this project uses (common.xml). Kept here so the mission layer needs
# no pymavlink import.


class MavFrame(enum.IntEnum):
    GLOBAL = 0
    MISSION = 2
    GLOBAL_RELATIVE_ALT = 3
    GLOBAL_INT = 5
    GLOBAL_RELATIVE_ALT_INT = 6
    GLOBAL_TERRAIN_ALT = 10
    GLOBAL_TERRAIN_ALT_INT = 11


class MavCmd(enum.IntEnum):
    NAV_WAYPOINT = 16
    NAV_LOITER_UNLIM = 17
    NAV_RETURN_TO_LAUNCH = 20
    NAV_LAND = 21
    NAV_TAKEOFF = 22
    DO_JUMP = 177
    DO_CHANGE_SPEED = 178
    DO_LAND_START = 189
    DO_SET_CAM_TRIGG_DIST = 206
    IMAGE_START_CAPTURE = 2000
    NAV_FENCE_RETURN_POINT = 5000
    NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
    NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
    NAV_FENCE_CIRCLE_INCLUSION = 5003
    NAV_FENCE_CIRCLE_EXCLUSION = 5004
    NAV_RALLY_POINT = 5100


class MissionType(enum.IntEnum):
    MISSION = 0
    FENCE = 1
    RALLY = 2
    ALL = 255


#: frames whose x/y are latitude / longitude
GLOBAL_FRAMES = frozenset(
    {
        MavFrame.GLOBAL,
        MavFrame.GLOBAL_RELATIVE_ALT,
        MavFrame.GLOBAL_INT,
        MavFrame.GLOBAL_RELATIVE_ALT_INT,
        MavFrame.GLOBAL_TERRAIN_ALT,
        MavFrame.GLOBAL_TERRAIN_ALT_INT,
    }
)

#: synonymous frame pairs; downloads normalise INT spellings to the plain ones (reference §4.5)
_FRAME_CANONICAL = {
    int(MavFrame.GLOBAL_INT): int(MavFrame.GLOBAL),
    int(MavFrame.GLOBAL_RELATIVE_ALT_INT): int(MavFrame.GLOBAL_RELATIVE_ALT),
    int(MavFrame.GLOBAL_TERRAIN_ALT_INT): int(MavFrame.GLOBAL_TERRAIN_ALT),
}


def canonical_frame(frame: int) -> int:
    """Map the ``_INT`` frame spellings onto their synonyms (5→0, 6→3, 11→10)."""
    return _FRAME_CANONICAL.get(int(frame), int(frame))


def deg_to_e7(value_deg: float) -> int:
    """Degrees → int32 degrees × 1e7, rounded half away from zero (as PX4/QGC/MAVSDK)."""
    scaled = value_deg * 1e7
    return int(math.floor(scaled + 0.5)) if scaled >= 0 else -int(math.floor(-scaled + 0.5))


def e7_to_deg(value_e7: int) -> float:
    return value_e7 / 1e7


# ---------------------------------------------------------------------------------------------


#: the largest finite float32: params and z travel as float32 in MISSION_ITEM_INT
FLOAT32_MAX = 3.4028234663852886e38
#: x / y of a non-global frame travel as int32 in MISSION_ITEM_INT
INT32_MIN = -(2**31)
INT32_MAX = 2**31 - 1
#: command is a uint16 and frame a uint8 in MISSION_ITEM_INT
UINT16_MAX = 0xFFFF
UINT8_MAX = 0xFF


def _param(name: str, value: float | None) -> float | None:
    if value is None:
        return None
    value = float(value)
    if math.isnan(value):
        return None
    if math.isinf(value):
        raise ValueError(f"mission item {name} must not be infinite")
    if abs(value) > FLOAT32_MAX:
        raise ValueError(
            f"mission item {name} {value:g} is beyond what MAVLink carries (float32, "
            f"|value| <= {FLOAT32_MAX:.4g})"
        )
    return value


def _whole(name: str, value: object, limit: int) -> int:
    """A uint field of the wire (command, frame) as an int within 0..limit."""
    try:
        number = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        as_float = float(value)  # type: ignore[arg-type]
        if not as_float.is_integer():
            raise ValueError(f"mission item {name} must be a whole number, got {value!r}") from None
        number = int(as_float)
    if not 0 <= number <= limit:
        raise ValueError(f"mission item {name} {number} is out of range (0..{limit})")
    return number


@dataclass(frozen=True)
class MissionItem:
    """One MAVLink mission item (any mission type), without its sequence number.

    ``x``/``y``/``z``: latitude deg / longitude deg / altitude m for global frames; the raw
    values for ``MAV_FRAME_MISSION``. Params 1-4 are ``None`` when unset.
    """

    command: int
    frame: int = int(MavFrame.GLOBAL_RELATIVE_ALT)
    param1: float | None = None
    param2: float | None = None
    param3: float | None = None
    param4: float | None = None
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    autocontinue: bool = True

    def __post_init__(self) -> None:
        # Everything a MISSION_ITEM_INT cannot carry is refused here, so a plan that holds
        # the item can always be sent.
        object.__setattr__(self, "command", _whole("command", self.command, UINT16_MAX))
        object.__setattr__(self, "frame", _whole("frame", self.frame, UINT8_MAX))
        for name in ("param1", "param2", "param3", "param4"):
            object.__setattr__(self, name, _param(name, getattr(self, name)))
        for name in ("x", "y", "z"):
            value = float(getattr(self, name))
            if not math.isfinite(value):
                raise ValueError(f"mission item {name} must be finite, got {value!r}")
            object.__setattr__(self, name, value)
        if abs(self.z) > FLOAT32_MAX:
            raise ValueError(
                f"mission item z {self.z:g} is beyond what MAVLink carries (float32, "
                f"|z| <= {FLOAT32_MAX:.4g})"
            )
        if self.is_global:
            if not -90.0 <= self.x <= 90.0:
                raise ValueError(f"latitude {self.x!r} is not within [-90, 90] degrees")
            if not -180.0 <= self.y <= 180.0:
                raise ValueError(f"longitude {self.y!r} is not within [-180, 180] degrees")
        else:
            for name in ("x", "y"):
                value = round(getattr(self, name))
                if not INT32_MIN <= value <= INT32_MAX:
                    raise ValueError(
                        f"mission item {name} {getattr(self, name):g} is beyond what MAVLink "
                        f"carries in frame {self.frame} (int32, {INT32_MIN}..{INT32_MAX})"
                    )
        object.__setattr__(self, "autocontinue", bool(self.autocontinue))

    @property
    def is_global(self) -> bool:
        return self.frame in GLOBAL_FRAMES

    @property
    def lat_deg(self) -> float:
        return self.x

    @property
    def lon_deg(self) -> float:
        return self.y

    @property
    def alt_m(self) -> float:
        return self.z

    @property
    def params(self) -> tuple[float | None, float | None, float | None, float | None]:
        return (self.param1, self.param2, self.param3, self.param4)

    # -- wire representation ------------------------------------------------------------
    def wire_xy(self) -> tuple[int, int]:
        """x/y as MISSION_ITEM_INT carries them: deg × 1e7 for global frames, else raw ints."""
        if self.is_global:
            return deg_to_e7(self.x), deg_to_e7(self.y)
        return int(round(self.x)), int(round(self.y))

    @classmethod
    def from_wire(
        cls,
        *,
        command: int,
        frame: int,
        params: Sequence[float],
        x: int,
        y: int,
        z: float,
        autocontinue: int | bool,
    ) -> MissionItem:
        """Build from MISSION_ITEM_INT fields (NaN params become ``None``)."""
        global_frame = int(frame) in GLOBAL_FRAMES
        return cls(
            command=command,
            frame=frame,
            param1=params[0],
            param2=params[1],
            param3=params[2],
            param4=params[3],
            x=e7_to_deg(x) if global_frame else float(x),
            y=e7_to_deg(y) if global_frame else float(y),
            z=float(z),
            autocontinue=bool(autocontinue),
        )

    def normalised(self) -> MissionItem:
        """The same item with its frame in canonical spelling (for comparisons)."""
        return replace(self, frame=canonical_frame(self.frame))


# ---------------------------------------------------------------------------------------------
# Geofence and rally points, structured as QGroundControl's .plan holds them.


@dataclass(frozen=True)
class FencePolygon:
    """An inclusion or exclusion polygon; ``vertices`` are (lat_deg, lon_deg)."""

    vertices: tuple[tuple[float, float], ...]
    inclusion: bool

    def __post_init__(self) -> None:
        verts = tuple((float(lat), float(lon)) for lat, lon in self.vertices)
        if len(verts) < 3:
            raise ValueError("a fence polygon needs at least 3 vertices")
        for lat, lon in verts:
            GeoPoint(lat, lon)
        object.__setattr__(self, "vertices", verts)


@dataclass(frozen=True)
class FenceCircle:
    center: tuple[float, float]
    radius_m: float
    inclusion: bool

    def __post_init__(self) -> None:
        lat, lon = (float(v) for v in self.center)
        GeoPoint(lat, lon)
        if not (math.isfinite(self.radius_m) and self.radius_m > 0):
            raise ValueError(f"fence circle radius must be > 0 m, got {self.radius_m!r}")
        object.__setattr__(self, "center", (lat, lon))
        object.__setattr__(self, "radius_m", float(self.radius_m))


@dataclass(frozen=True)
class GeoFence:
    polygons: tuple[FencePolygon, ...] = ()
    circles: tuple[FenceCircle, ...] = ()
    breach_return: GeoPoint | None = None  # altitude relative to home

    @property
    def is_empty(self) -> bool:
        return not self.polygons and not self.circles and self.breach_return is None

    def wire_items(self) -> list[MissionItem]:
        """Fence items in QGC's upload order: polygon vertices, circles, return point."""
        items: list[MissionItem] = []
        for poly in self.polygons:
            cmd = (
                MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION
                if poly.inclusion
                else MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION
            )
            n = float(len(poly.vertices))
            for lat, lon in poly.vertices:
                items.append(
                    MissionItem(
                        command=cmd,
                        frame=MavFrame.GLOBAL,
                        param1=n,
                        param2=0.0,  # inclusion group; reserved params are 0, as QGC sends
                        param3=0.0,
                        param4=0.0,
                        x=lat,
                        y=lon,
                        z=0.0,
                    )
                )
        for circle in self.circles:
            cmd = (
                MavCmd.NAV_FENCE_CIRCLE_INCLUSION
                if circle.inclusion
                else MavCmd.NAV_FENCE_CIRCLE_EXCLUSION
            )
            items.append(
                MissionItem(
                    command=cmd,
                    frame=MavFrame.GLOBAL,
                    param1=circle.radius_m,
                    param2=0.0,
                    param3=0.0,
                    param4=0.0,
                    x=circle.center[0],
                    y=circle.center[1],
                    z=0.0,
                )
            )
        if self.breach_return is not None:
            items.append(
                MissionItem(
                    command=MavCmd.NAV_FENCE_RETURN_POINT,
                    frame=MavFrame.GLOBAL_RELATIVE_ALT,
                    param1=0.0,
                    param2=0.0,
                    param3=0.0,
                    param4=0.0,
                    x=self.breach_return.lat_deg,
                    y=self.breach_return.lon_deg,
                    z=self.breach_return.alt_m,
                )
            )
        return items

    @classmethod
    def from_wire_items(cls, items: Iterable[MissionItem]) -> GeoFence:
        """Rebuild polygons (by their vertex-count param), circles and the return point."""
        polygons: list[FencePolygon] = []
        circles: list[FenceCircle] = []
        breach: GeoPoint | None = None
        pending: list[tuple[float, float]] = []
        pending_cmd: int | None = None
        pending_n = 0
        poly_cmds = (
            MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
            MavCmd.NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
        )
        for item in items:
            if item.command in poly_cmds:
                if pending_cmd is None:
                    pending_cmd, pending_n = item.command, int(round(item.param1 or 0))
                    if pending_n < 3:
                        raise ValueError("fence polygon vertex with a count below 3")
                elif item.command != pending_cmd:
                    raise ValueError("fence polygon vertices of different kinds interleave")
                pending.append((item.x, item.y))
                if len(pending) == pending_n:
                    polygons.append(
                        FencePolygon(
                            tuple(pending),
                            inclusion=pending_cmd == MavCmd.NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                        )
                    )
                    pending, pending_cmd, pending_n = [], None, 0
                continue
            if pending:
                raise ValueError("fence polygon ends before its vertex count is reached")
            if item.command in (
                MavCmd.NAV_FENCE_CIRCLE_INCLUSION,
                MavCmd.NAV_FENCE_CIRCLE_EXCLUSION,
            ):
                circles.append(
                    FenceCircle(
                        (item.x, item.y),
                        float(item.param1 or 0.0),
                        inclusion=item.command == MavCmd.NAV_FENCE_CIRCLE_INCLUSION,
                    )
                )
            elif item.command == MavCmd.NAV_FENCE_RETURN_POINT:
                breach = GeoPoint(item.x, item.y, item.z)
            else:
                raise ValueError(f"command {item.command} is not a fence command")
        if pending:
            raise ValueError("fence polygon ends before its vertex count is reached")
        return cls(tuple(polygons), tuple(circles), breach)


@dataclass(frozen=True)
class RallyPoint:
    lat_deg: float
    lon_deg: float
    alt_m: float  # relative to home

    def __post_init__(self) -> None:
        GeoPoint(self.lat_deg, self.lon_deg, self.alt_m)

    def wire_item(self) -> MissionItem:
        return MissionItem(
            command=MavCmd.NAV_RALLY_POINT,
            frame=MavFrame.GLOBAL_RELATIVE_ALT,
            param1=0.0,  # reserved params are 0 on the wire, as QGroundControl sends them
            param2=0.0,
            param3=0.0,
            param4=0.0,
            x=self.lat_deg,
            y=self.lon_deg,
            z=self.alt_m,
        )


@dataclass(frozen=True)
class VehicleParameter:
    """A vehicle parameter the mission relies on, in the firmware's own name and unit
    (ArduPilot ``RTL_ALT`` in cm, PX4 ``RTL_RETURN_ALT`` in m, ...): ``upload --set-params``
    keeps the vehicle's value when it lies within ``at_least`` .. ``at_most`` (a bound left
    None is open; both None: it must equal ``value``) and sets ``value`` otherwise.
    ``reason``: why the mission needs it, in words."""

    name: str
    value: float
    at_least: float | None = None
    at_most: float | None = None
    unit: str = ""
    reason: str = ""

    def __post_init__(self) -> None:
        if not (1 <= len(self.name) <= 16 and self.name.isascii() and self.name.isprintable()):
            raise ValueError(f"parameter name {self.name!r} must be 1..16 printable ASCII")
        for label, number in (("value", self.value), ("atLeast", self.at_least)):
            if number is not None and not math.isfinite(number):
                raise ValueError(f"parameter {self.name} {label} must be finite")
        if self.at_most is not None and not math.isfinite(self.at_most):
            raise ValueError(f"parameter {self.name} atMost must be finite")
        low = -math.inf if self.at_least is None else self.at_least
        high = math.inf if self.at_most is None else self.at_most
        if not low <= self.value <= high:
            raise ValueError(
                f"parameter {self.name} {self.value:g} is outside its own range "
                f"{self.at_least}..{self.at_most}"
            )
        object.__setattr__(self, "value", float(self.value))

    def describe(self) -> str:
        """``RTL_ALT 4500 cm (or more)``."""
        unit = f" {self.unit}" if self.unit else ""
        if self.at_least is not None and self.at_most is not None:
            span = f" (keeps {self.at_least:g}..{self.at_most:g})"
        elif self.at_least is not None:
            span = " (or more)"
        elif self.at_most is not None:
            span = " (or less)"
        else:
            span = ""
        return f"{self.name} {self.value:g}{unit}{span}"


# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MissionPlan:
    """Everything a ``.plan`` file or a vehicle holds.

    ``items`` never contains ArduPilot's home item; ``home`` is the planned home
    (AMSL altitude), or ``None`` when unknown.
    """

    items: tuple[MissionItem, ...]
    autopilot: Autopilot = Autopilot.PX4
    home: GeoPoint | None = None
    fence: GeoFence = field(default_factory=GeoFence)
    rally: tuple[RallyPoint, ...] = ()
    vehicle_type: int = 2  # MAV_TYPE_QUADROTOR
    cruise_speed_m_s: float | None = None
    hover_speed_m_s: float | None = None
    #: vehicle parameters the mission relies on (``upload --set-params`` sends them)
    parameters: tuple[VehicleParameter, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "items", tuple(self.items))
        object.__setattr__(self, "rally", tuple(self.rally))
        object.__setattr__(self, "parameters", tuple(self.parameters))
        names = [p.name for p in self.parameters]
        if len(set(names)) != len(names):
            raise ValueError(f"a parameter is named twice: {', '.join(names)}")

    def home_item(self) -> MissionItem:
        """ArduPilot's seq-0 placeholder: NAV_WAYPOINT, frame 0, planned home (or zeros)."""
        home = self.home or GeoPoint(0.0, 0.0, 0.0)
        return MissionItem(
            command=MavCmd.NAV_WAYPOINT,
            frame=MavFrame.GLOBAL,
            param1=0.0,
            param2=0.0,
            param3=0.0,
            param4=0.0,
            x=home.lat_deg,
            y=home.lon_deg,
            z=home.alt_m,
        )

    def wire_items(self, mission_type: MissionType = MissionType.MISSION) -> list[MissionItem]:
        """The items as they go on the wire for ``mission_type``, seq = list index."""
        if mission_type == MissionType.MISSION:
            if self.autopilot == Autopilot.ARDUPILOT:
                return [self.home_item(), *self.items]
            return list(self.items)
        if mission_type == MissionType.FENCE:
            return self.fence.wire_items()
        if mission_type == MissionType.RALLY:
            return [p.wire_item() for p in self.rally]
        raise ValueError(f"no items for mission type {mission_type!r}")

    @staticmethod
    def split_wire_mission(
        items: Sequence[MissionItem], autopilot: Autopilot
    ) -> tuple[GeoPoint | None, tuple[MissionItem, ...]]:
        """Inverse of :meth:`wire_items` for the mission type: (home, items)."""
        if autopilot == Autopilot.ARDUPILOT and items:
            first = items[0]
            home = None
            if first.is_global and (first.x, first.y) != (0.0, 0.0):
                home = GeoPoint(first.x, first.y, first.z)
            return home, tuple(items[1:])
        return None, tuple(items)


def items_equal(
    a: MissionItem,
    b: MissionItem,
    *,
    pos_tol_deg: float = 1.5e-7,
    alt_tol_m: float = 0.01,
    param_rel_tol: float = 1e-6,
) -> bool:
    """Compare two items as a read-back check does: synonymous frames, float32 params,
    lat/lon to about 1e-7 degrees and altitude to 1 cm (ArduPilot stores centimetres)."""
    if a.command != b.command or canonical_frame(a.frame) != canonical_frame(b.frame):
        return False
    for pa, pb in zip(a.params, b.params, strict=True):
        if pa is None or pb is None:
            if not ((pa is None or pa == 0.0) and (pb is None or pb == 0.0)) and pa != pb:
                return False
            continue
        if not math.isclose(pa, pb, rel_tol=param_rel_tol, abs_tol=1e-6):
            return False
    xy_tol = pos_tol_deg if a.is_global else 0.5
    if abs(a.x - b.x) > xy_tol or abs(a.y - b.y) > xy_tol:
        return False
    return abs(a.z - b.z) <= alt_tol_m
