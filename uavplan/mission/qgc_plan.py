"""QGroundControl ``.plan`` (JSON) writer and reader for :class:`MissionPlan`.

Writer: the checklist of reference §5.7, so that QGroundControl and MAVSDK's
``import_qgroundcontrol_mission`` both load the file: all six top-level keys, ``geoFence``
and ``rallyPoints`` (version 2) always present, mission version 2, ``firmwareType`` 12/3,
vehicle type, speeds, ``globalPlanAltitudeMode``, the planned home with its AMSL altitude,
and only ``SimpleItem``\\ s with exactly 7 params (``null`` where unset), a boolean
``autoContinue``, a 1-based ``doJumpId`` and the three altitude keys on positional items.
Numbers keep full double precision; NaN and Infinity are never written. Frames are written
in QGC's own spelling (5→0, 6→3, 11→10: synonyms on the wire).

Reader: as tolerant as QGroundControl (unknown keys ignored, frames 5/6 accepted, null
numbers) and as strict: whatever QGC's loader rejects (§5.6) raises
:class:`~uavplan.errors.MissionFileError` naming the file, the key path and the reason.
A Survey or CorridorScan ``ComplexItem`` is read as the mission items QGroundControl saved
with it (``TransectStyleComplexItem.Items``: what QGC uploads while the pattern is not
edited); other complex items (StructureScan) are rejected. uavplan writes SimpleItems only,
so a plan read with a survey is written back with the survey's items as SimpleItems.

DO_JUMP: in the file, param1 is the target's ``doJumpId``; in a :class:`MissionPlan` it is
the target's wire sequence number for the plan's autopilot (ArduPilot counts its home slot
as seq 0, PX4 does not). Both directions convert.
"""

from __future__ import annotations

import enum
import json
import math
from dataclasses import replace
from typing import Any, NoReturn

from uavplan.errors import MissionFileError
from uavplan.geo import GeoPoint
from uavplan.mission.items import (
    Autopilot,
    FenceCircle,
    FencePolygon,
    GeoFence,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    RallyPoint,
    VehicleParameter,
    canonical_frame,
)

FILE_TYPE = "Plan"
PLAN_VERSION = 1
MISSION_VERSION = 2
FENCE_VERSION = 2
#: the ComplexItems whose saved mission items are read (QGroundControl's complexItemType)
TRANSECT_ITEM_TYPES = ("survey", "CorridorScan")
RALLY_VERSION = 2
#: version of each polygon / circle object inside ``geoFence``
FENCE_SHAPE_VERSION = 1
#: QGC writes its own name; any string is accepted, this one by every loader we know of
GROUND_STATION = "QGroundControl"
#: written when the plan has no speed (QGroundControl's own defaults)
DEFAULT_CRUISE_SPEED_M_S = 15.0
DEFAULT_HOVER_SPEED_M_S = 5.0
#: read when a file has no vehicleType (MAV_TYPE_QUADROTOR, MissionPlan's default)
DEFAULT_VEHICLE_TYPE = 2
#: our top-level key for the vehicle parameters a mission relies on (written only when there
#: are some; loaders that do not know it ignore it, reference §5.4 / §5.6)
PARAMETERS_KEY = "parameters"
PARAMETERS_VERSION = 1


class AltitudeMode(enum.IntEnum):
    """QGroundControl's per-item ``AltitudeMode`` (reference §5.3)."""

    MIXED = 0
    RELATIVE = 1
    ABSOLUTE = 2
    CALC_ABOVE_TERRAIN = 3
    TERRAIN_FRAME = 4
    NONE = 5


_ALTITUDE_MODE_OF_FRAME = {
    int(MavFrame.GLOBAL_RELATIVE_ALT): AltitudeMode.RELATIVE,
    int(MavFrame.GLOBAL): AltitudeMode.ABSOLUTE,
    int(MavFrame.GLOBAL_TERRAIN_ALT): AltitudeMode.TERRAIN_FRAME,
}
_ALTITUDE_KEYS = ("AltitudeMode", "Altitude", "AMSLAltAboveTerrain")


def _plan_altitude_mode(plan: MissionPlan) -> AltitudeMode:
    """The plan-wide mode QGC shows: that of the positional items when they share one frame
    (relative, AMSL or terrain), mixed when they differ, relative without any."""
    modes = {
        _ALTITUDE_MODE_OF_FRAME.get(int(item.frame), AltitudeMode.RELATIVE)
        for item in plan.items
        if item.is_global
    }
    if len(modes) > 1:
        return AltitudeMode.MIXED
    return modes.pop() if modes else AltitudeMode.RELATIVE


_FIRMWARE_TYPES = {a.value: a for a in Autopilot}
#: MISSION_ITEM_INT field widths: command is a uint16, frame a uint8
_MAX_COMMAND = 0xFFFF
_MAX_FRAME = 0xFF
#: HEARTBEAT's MAV_TYPE is a uint8
_MAX_VEHICLE_TYPE = 0xFF
#: MISSION_COUNT's count is a uint16: the most items one mission type can hold on the wire
MAX_WIRE_ITEMS = 0xFFFF


def _home_slots(autopilot: Autopilot) -> int:
    """Wire seqs taken before the first item: ArduPilot's home is seq 0 (reference §4.1)."""
    return 1 if autopilot == Autopilot.ARDUPILOT else 0


# =============================================================================================
# Writer


def plan_to_dict(plan: MissionPlan) -> dict[str, Any]:
    """The ``.plan`` document as plain JSON-ready Python values.

    Raises :class:`MissionFileError` (no file set) for a DO_JUMP whose target is not an
    item of the plan: QGC would refuse such a file.
    """
    slots = _home_slots(plan.autopilot)
    items = [_item_to_json(item, index, plan, slots) for index, item in enumerate(plan.items)]
    home = plan.home
    return {
        "fileType": FILE_TYPE,
        "geoFence": _fence_to_json(plan.fence),
        "groundStation": GROUND_STATION,
        "mission": {
            "cruiseSpeed": _or_default(plan.cruise_speed_m_s, DEFAULT_CRUISE_SPEED_M_S),
            "firmwareType": plan.autopilot.value,
            "globalPlanAltitudeMode": int(_plan_altitude_mode(plan)),
            "hoverSpeed": _or_default(plan.hover_speed_m_s, DEFAULT_HOVER_SPEED_M_S),
            "items": items,
            "plannedHomePosition": (
                [home.lat_deg, home.lon_deg, home.alt_m] if home is not None else [0.0, 0.0, 0.0]
            ),
            "vehicleType": int(plan.vehicle_type),
            "version": MISSION_VERSION,
        },
        "rallyPoints": {
            "points": [[p.lat_deg, p.lon_deg, p.alt_m] for p in plan.rally],
            "version": RALLY_VERSION,
        },
        "version": PLAN_VERSION,
        **({PARAMETERS_KEY: _parameters_to_json(plan)} if plan.parameters else {}),
    }


def _parameters_to_json(plan: MissionPlan) -> dict[str, Any]:
    """The parameters the mission relies on (our key: QGroundControl and MAVSDK ignore it)."""
    return {
        "firmwareType": plan.autopilot.value,
        "items": [
            {
                "atLeast": p.at_least,
                "atMost": p.at_most,
                "name": p.name,
                "reason": p.reason,
                "unit": p.unit,
                "value": p.value,
            }
            for p in plan.parameters
        ],
        "version": PARAMETERS_VERSION,
    }


def plan_to_json(plan: MissionPlan) -> str:
    """The ``.plan`` file text: indented JSON, keys sorted as QGC writes them."""
    return json.dumps(plan_to_dict(plan), indent=4, sort_keys=True, allow_nan=False) + "\n"


def _or_default(value: float | None, default: float) -> float:
    return float(value) if value is not None else default


def _item_to_json(item: MissionItem, index: int, plan: MissionPlan, slots: int) -> dict[str, Any]:
    params: list[float | None] = list(item.params)
    if item.command == MavCmd.DO_JUMP:
        target = _jump_target_index(item.param1, slots, len(plan.items))
        if target is None:
            raise MissionFileError(
                f"DO_JUMP target {item.param1!r} is not an item of the mission "
                f"(seq {slots}..{slots + len(plan.items) - 1} on {plan.autopilot.label})",
                key=f"mission.items[{index}].params[0]",
            )
        params[0] = float(target + 1)  # the target's doJumpId
    frame = canonical_frame(item.frame)
    out: dict[str, Any] = {
        "autoContinue": item.autocontinue,
        "command": item.command,
        "doJumpId": index + 1,
        "frame": frame,
        "params": [*params, item.x, item.y, item.z],
        "type": "SimpleItem",
    }
    if item.is_global:
        mode = _ALTITUDE_MODE_OF_FRAME.get(frame, AltitudeMode.RELATIVE)
        out["AltitudeMode"] = int(mode)
        out["Altitude"] = item.z
        out["AMSLAltAboveTerrain"] = None
    return out


def _jump_target_index(param1: float | None, slots: int, n_items: int) -> int | None:
    """Index in ``plan.items`` of a DO_JUMP's target wire seq, or None if there is none."""
    if param1 is None or not float(param1).is_integer():
        return None
    index = int(param1) - slots
    return index if 0 <= index < n_items else None


def _fence_to_json(fence: GeoFence) -> dict[str, Any]:
    out: dict[str, Any] = {
        "circles": [
            {
                "circle": {"center": [c.center[0], c.center[1]], "radius": c.radius_m},
                "inclusion": c.inclusion,
                "version": FENCE_SHAPE_VERSION,
            }
            for c in fence.circles
        ],
        "polygons": [
            {
                "inclusion": p.inclusion,
                "polygon": [[lat, lon] for lat, lon in p.vertices],
                "version": FENCE_SHAPE_VERSION,
            }
            for p in fence.polygons
        ],
        "version": FENCE_VERSION,
    }
    if fence.breach_return is not None:
        b = fence.breach_return
        out["breachReturn"] = [b.lat_deg, b.lon_deg, b.alt_m]
    return out


# =============================================================================================
# Reader


def plan_from_json(
    text: str, *, file: str | None = None, autopilot: Autopilot | None = None
) -> MissionPlan:
    """Parse ``.plan`` text. ``autopilot`` overrides the file's ``firmwareType`` (it decides
    how DO_JUMP targets map onto wire seqs). ``file`` only labels error messages."""
    return _PlanReader(file).read(text, autopilot)


class _PlanReader:
    def __init__(self, file: str | None) -> None:
        self.file = file

    def fail(self, key: str | None, reason: str) -> NoReturn:
        raise MissionFileError(reason, file=self.file, key=key)

    # -- typed access ------------------------------------------------------------------------
    def require(self, obj: dict[str, Any], name: str, path: str) -> Any:
        if name not in obj:
            self.fail(_join(path, name), "missing required key")
        return obj[name]

    def object(self, obj: dict[str, Any], name: str, path: str) -> dict[str, Any]:
        value = self.require(obj, name, path)
        if not isinstance(value, dict):
            self.fail(_join(path, name), f"must be a JSON object, not {_json_type(value)}")
        return value

    def array(self, obj: dict[str, Any], name: str, path: str) -> list[Any]:
        value = self.require(obj, name, path)
        if not isinstance(value, list):
            self.fail(_join(path, name), f"must be an array, not {_json_type(value)}")
        return value

    def boolean(self, obj: dict[str, Any], name: str, path: str) -> bool:
        value = self.require(obj, name, path)
        if not isinstance(value, bool):
            self.fail(_join(path, name), f"must be true or false, not {_json_type(value)}")
        return value

    def number(self, value: Any, key: str, *, nullable: bool = False) -> float | None:
        if value is None and nullable:
            return None
        if not _is_number(value):
            if isinstance(value, int | float) and not isinstance(value, bool):
                self.fail(key, f"{_number_text(value)} is out of range (beyond a double)")
            expected = "a number or null" if nullable else "a number"
            self.fail(key, f"must be {expected}, not {_json_type(value)}")
        return float(value)

    def integer(self, value: Any, key: str) -> int:
        number = self.number(value, key)
        assert number is not None
        if not number.is_integer():
            self.fail(key, f"must be a whole number, not {number!r}")
        return int(number)

    def optional_number(self, obj: dict[str, Any], name: str, path: str) -> float | None:
        return self.number(obj.get(name), _join(path, name), nullable=True)

    def version(self, obj: dict[str, Any], path: str, expected: int) -> None:
        key = _join(path, "version")
        found = self.integer(self.require(obj, "version", path), key)
        if found != expected:
            self.fail(key, f"unsupported version {found} (expected {expected})")

    def coordinate(self, value: Any, key: str, size: int, *, nullable: bool) -> list[float | None]:
        if not isinstance(value, list) or len(value) != size:
            what = "[lat, lon]" if size == 2 else "[lat, lon, alt]"
            self.fail(key, f"must be an array of {size} numbers {what}")
        return [self.number(v, f"{key}[{i}]", nullable=nullable) for i, v in enumerate(value)]

    # -- document ----------------------------------------------------------------------------
    def read(self, text: str, autopilot: Autopilot | None) -> MissionPlan:
        doc = self.parse(text)
        if not isinstance(doc, dict):
            self.fail(None, f"a .plan file holds a JSON object, not {_json_type(doc)}")
        file_type = self.require(doc, "fileType", "")
        if file_type != FILE_TYPE:
            self.fail("fileType", f"file type is {_short(file_type)}, expected {FILE_TYPE!r}")
        self.version(doc, "", PLAN_VERSION)
        if not isinstance(self.require(doc, "groundStation", ""), str):
            self.fail("groundStation", "must be a string")
        mission = self.object(doc, "mission", "")
        fence_json = self.object(doc, "geoFence", "")
        rally_json = self.object(doc, "rallyPoints", "")

        firmware = self.integer(
            self.require(mission, "firmwareType", "mission"), "mission.firmwareType"
        )
        if autopilot is None:
            autopilot = _FIRMWARE_TYPES.get(firmware, Autopilot.GENERIC)
        home = self.home(self.require(mission, "plannedHomePosition", "mission"))
        items = self.items(self.array(mission, "items", "mission"), autopilot)

        vehicle_type = mission.get("vehicleType")
        plan = MissionPlan(
            items=items,
            autopilot=autopilot,
            home=home,
            fence=self.fence(fence_json),
            rally=self.rally(rally_json),
            vehicle_type=(
                DEFAULT_VEHICLE_TYPE
                if vehicle_type is None
                else self.bounded(vehicle_type, "mission.vehicleType", _MAX_VEHICLE_TYPE)
            ),
            cruise_speed_m_s=self.optional_number(mission, "cruiseSpeed", "mission"),
            hover_speed_m_s=self.optional_number(mission, "hoverSpeed", "mission"),
            parameters=self.parameters(doc.get(PARAMETERS_KEY), autopilot),
        )
        self.check_wire(plan)
        return plan

    def parameters(self, value: Any, autopilot: Autopilot) -> tuple[VehicleParameter, ...]:
        """Our ``parameters`` section (absent: none)."""
        if value is None:
            return ()
        if not isinstance(value, dict):
            self.fail(PARAMETERS_KEY, f"must be an object, not {_json_type(value)}")
        self.version(value, PARAMETERS_KEY, PARAMETERS_VERSION)
        firmware = value.get("firmwareType")
        named = _FIRMWARE_TYPES.get(firmware) if isinstance(firmware, int) else None
        if named is not None and named is not autopilot:
            self.fail(
                f"{PARAMETERS_KEY}.firmwareType",
                f"the parameters are {named.label}'s, the mission is read as {autopilot.label}'s",
            )
        out: list[VehicleParameter] = []
        for i, entry in enumerate(self.array(value, "items", PARAMETERS_KEY)):
            key = f"{PARAMETERS_KEY}.items[{i}]"
            if not isinstance(entry, dict):
                self.fail(key, f"must be an object, not {_json_type(entry)}")
            name = self.require(entry, "name", key)
            if not isinstance(name, str):
                self.fail(f"{key}.name", "must be a string")
            number = self.number(self.require(entry, "value", key), f"{key}.value")
            low = self.number(entry.get("atLeast"), f"{key}.atLeast", nullable=True)
            high = self.number(entry.get("atMost"), f"{key}.atMost", nullable=True)
            texts = [entry.get(k, "") for k in ("unit", "reason")]
            for k, text in zip(("unit", "reason"), texts, strict=True):
                if not isinstance(text, str):
                    self.fail(f"{key}.{k}", "must be a string")
            out.append(
                self.model(key, VehicleParameter, name, number, low, high, texts[0], texts[1])
            )
        names = [p.name for p in out]
        for i, name in enumerate(names):
            if name in names[:i]:
                self.fail(f"{PARAMETERS_KEY}.items[{i}].name", f"{name} is named twice")
        return tuple(out)

    def bounded(self, value: Any, key: str, limit: int) -> int:
        number = self.integer(value, key)
        if not 0 <= number <= limit:
            self.fail(key, f"{number} is out of range (0..{limit})")
        return number

    def check_wire(self, plan: MissionPlan) -> None:
        """Every value of the plan fits its MAVLink field and every list its uint16 count."""
        if plan.home is not None:
            self.model("mission.plannedHomePosition", plan.home_item)
        for i, point in enumerate(plan.rally):
            self.model(f"rallyPoints.points[{i}]", point.wire_item)
        fence = plan.fence
        for i, circle in enumerate(fence.circles):
            self.model(f"geoFence.circles[{i}]", GeoFence((), (circle,)).wire_items)
        if fence.breach_return is not None:
            self.model("geoFence.breachReturn", GeoFence((), (), fence.breach_return).wire_items)
        counts = {
            "mission.items": len(plan.items) + _home_slots(plan.autopilot),
            "geoFence": sum(len(p.vertices) for p in fence.polygons)
            + len(fence.circles)
            + (fence.breach_return is not None),
            "rallyPoints.points": len(plan.rally),
        }
        for key, count in counts.items():
            if count > MAX_WIRE_ITEMS:
                self.fail(
                    key,
                    f"{count} items on the wire; MAVLink numbers at most {MAX_WIRE_ITEMS}",
                )

    def parse(self, text: str) -> Any:
        def reject_constant(name: str) -> NoReturn:
            self.fail(None, f"invalid JSON: {name} is not a JSON number")

        def unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
            obj = dict(pairs)
            if len(obj) != len(pairs):
                seen: set[str] = set()
                for key, _ in pairs:
                    if key in seen:
                        self.fail(
                            None, f"invalid JSON: key {_short(key)} appears twice in an object"
                        )
                    seen.add(key)
            return obj

        try:
            return json.loads(text, parse_constant=reject_constant, object_pairs_hook=unique_keys)
        except json.JSONDecodeError as err:
            self.fail(None, f"invalid JSON: {err.msg} (line {err.lineno}, column {err.colno})")
        except RecursionError:
            self.fail(None, "invalid JSON: nested too deeply")
        except ValueError as err:  # e.g. an integer literal longer than Python converts
            self.fail(None, f"invalid JSON: {_first_line(str(err))}")

    def home(self, value: Any) -> GeoPoint | None:
        key = "mission.plannedHomePosition"
        lat, lon, alt = self.coordinate(value, key, 3, nullable=True)
        if lat is None or lon is None or (lat, lon) == (0.0, 0.0):
            return None  # QGC writes zeros (or nulls) when it has no home
        return self.model(key, GeoPoint, lat, lon, 0.0 if alt is None else alt)

    def items(self, values: list[Any], autopilot: Autopilot) -> tuple[MissionItem, ...]:
        items: list[MissionItem] = []
        jump_ids: list[int | None] = []
        for index, value in enumerate(values):
            path = f"mission.items[{index}]"
            if not isinstance(value, dict):
                self.fail(path, f"must be a JSON object, not {_json_type(value)}")
            item_type = self.require(value, "type", path)
            if item_type == "ComplexItem":
                for inner, inner_path in self.transect_items(value, path):
                    items.append(self.simple_item(inner, inner_path))
                    jump_id = inner.get("doJumpId")
                    jump_ids.append(
                        None
                        if jump_id is None
                        else self.integer(jump_id, _join(inner_path, "doJumpId"))
                    )
                continue
            if item_type != "SimpleItem":
                self.fail(_join(path, "type"), f"unknown item type {_short(item_type)}")
            items.append(self.simple_item(value, path))
            jump_id = value.get("doJumpId")
            jump_ids.append(
                None if jump_id is None else self.integer(jump_id, _join(path, "doJumpId"))
            )
        return self.resolve_jumps(items, jump_ids, autopilot)

    def transect_items(self, value: dict[str, Any], path: str) -> list[tuple[dict[str, Any], str]]:
        """A Survey or CorridorScan ComplexItem's mission items, as QGroundControl saved them
        in ``TransectStyleComplexItem.Items`` (what QGC uploads while the pattern is not
        edited): the items the vehicle flies, each with its key path. Other complex items
        (StructureScan), and a transect item saved without its items, are refused."""
        kind = value.get("complexItemType", "unknown")
        kind = kind if isinstance(kind, str) and len(kind) <= 40 else _short(kind)
        if kind not in TRANSECT_ITEM_TYPES:
            self.fail(
                path,
                f"ComplexItem ({kind}) is not supported: uavplan reads SimpleItems and the "
                "items of Survey and CorridorScan complex items",
            )
        transect = value.get("TransectStyleComplexItem")
        where = _join(path, "TransectStyleComplexItem")
        if not isinstance(transect, dict):
            self.fail(where, f"a {kind} item needs its TransectStyleComplexItem object")
        inner = transect.get("Items")
        if not isinstance(inner, list) or not inner:
            self.fail(
                _join(where, "Items"),
                f"the {kind} item holds no mission items (QGroundControl saves them with the "
                "pattern: open the plan in QGroundControl and save it again)",
            )
        out = []
        for j, item in enumerate(inner):
            item_path = f"{where}.Items[{j}]"
            if not isinstance(item, dict):
                self.fail(item_path, f"must be a JSON object, not {_json_type(item)}")
            if self.require(item, "type", item_path) != "SimpleItem":
                self.fail(_join(item_path, "type"), "a transect's items must be SimpleItems")
            out.append((item, item_path))
        return out

    def simple_item(self, value: dict[str, Any], path: str) -> MissionItem:
        command = self.integer(self.require(value, "command", path), _join(path, "command"))
        if not 0 <= command <= _MAX_COMMAND:
            self.fail(_join(path, "command"), f"{command} is not a MAV_CMD value (0..65535)")
        frame = self.integer(self.require(value, "frame", path), _join(path, "frame"))
        if not 0 <= frame <= _MAX_FRAME:
            self.fail(_join(path, "frame"), f"{frame} is not a MAV_FRAME value (0..255)")
        params = self.array(value, "params", path)
        if len(params) != 7:
            self.fail(_join(path, "params"), f"must hold exactly 7 values, found {len(params)}")
        numbers = [
            self.number(p, f"{path}.params[{i}]", nullable=True) for i, p in enumerate(params)
        ]
        autocontinue = self.boolean(value, "autoContinue", path)
        present = [k for k in _ALTITUDE_KEYS if k in value]
        if present and len(present) != len(_ALTITUDE_KEYS):
            missing = next(k for k in _ALTITUDE_KEYS if k not in value)
            self.fail(_join(path, missing), f"missing required key (it goes with {present[0]})")
        for name in present:
            self.number(value[name], _join(path, name), nullable=True)
        x, y, z = (0.0 if v is None else v for v in numbers[4:])  # null position: 0, as MAVSDK
        return self.model(
            path,
            MissionItem,
            command=command,
            frame=frame,
            param1=numbers[0],
            param2=numbers[1],
            param3=numbers[2],
            param4=numbers[3],
            x=x,
            y=y,
            z=z,
            autocontinue=autocontinue,
        )

    def resolve_jumps(
        self, items: list[MissionItem], jump_ids: list[int | None], autopilot: Autopilot
    ) -> tuple[MissionItem, ...]:
        slots = _home_slots(autopilot)
        index_of_id: dict[int, int] = {}
        for index, jump_id in enumerate(jump_ids):
            if jump_id is not None:
                index_of_id.setdefault(jump_id, index)
        resolved = list(items)
        for index, item in enumerate(items):
            if item.command != MavCmd.DO_JUMP:
                continue
            key = f"mission.items[{index}].params[0]"
            if item.param1 is None or not item.param1.is_integer():
                self.fail(key, f"DO_JUMP needs a target doJumpId, found {item.param1!r}")
            target = index_of_id.get(int(item.param1))
            if target is None:
                self.fail(key, f"could not find doJumpId: {int(item.param1)}")
            resolved[index] = replace(item, param1=float(target + slots))
        return tuple(resolved)

    def fence(self, obj: dict[str, Any]) -> GeoFence:
        version = obj.get("version")
        if version is None or (_is_number(version) and version == 1):
            return GeoFence()  # QGC silently ignores a version-1 (or unversioned) fence
        self.version(obj, "geoFence", FENCE_VERSION)
        polygons = []
        for i, poly in enumerate(self.array(obj, "polygons", "geoFence")):
            path = f"geoFence.polygons[{i}]"
            if not isinstance(poly, dict):
                self.fail(path, f"must be a JSON object, not {_json_type(poly)}")
            self.version(poly, path, FENCE_SHAPE_VERSION)
            inclusion = self.boolean(poly, "inclusion", path)
            vertices = [
                self.coordinate(v, f"{path}.polygon[{j}]", 2, nullable=False)
                for j, v in enumerate(self.array(poly, "polygon", path))
            ]
            polygons.append(
                self.model(path, FencePolygon, tuple(tuple(v) for v in vertices), inclusion)
            )
        circles = []
        for i, circ in enumerate(self.array(obj, "circles", "geoFence")):
            path = f"geoFence.circles[{i}]"
            if not isinstance(circ, dict):
                self.fail(path, f"must be a JSON object, not {_json_type(circ)}")
            self.version(circ, path, FENCE_SHAPE_VERSION)
            inclusion = self.boolean(circ, "inclusion", path)
            shape = self.object(circ, "circle", path)
            center = self.coordinate(
                self.require(shape, "center", f"{path}.circle"),
                f"{path}.circle.center",
                2,
                nullable=False,
            )
            radius = self.number(
                self.require(shape, "radius", f"{path}.circle"), f"{path}.circle.radius"
            )
            circles.append(self.model(path, FenceCircle, tuple(center), radius, inclusion))
        breach = None
        if obj.get("breachReturn") is not None:
            lat, lon, alt = self.coordinate(
                obj["breachReturn"], "geoFence.breachReturn", 3, nullable=False
            )
            breach = self.model("geoFence.breachReturn", GeoPoint, lat, lon, alt)
        return GeoFence(tuple(polygons), tuple(circles), breach)

    def rally(self, obj: dict[str, Any]) -> tuple[RallyPoint, ...]:
        version = obj.get("version")
        if version is None or (_is_number(version) and version == 1):
            return ()  # QGC silently ignores version-1 (or unversioned) rally points
        self.version(obj, "rallyPoints", RALLY_VERSION)
        points = []
        for i, value in enumerate(self.array(obj, "points", "rallyPoints")):
            key = f"rallyPoints.points[{i}]"
            lat, lon, alt = self.coordinate(value, key, 3, nullable=False)
            points.append(self.model(key, RallyPoint, lat, lon, alt))
        return tuple(points)

    def model(self, key: str, cls: Any, *args: Any, **kwargs: Any) -> Any:
        """Build a model value; its validation errors become file errors at ``key``."""
        try:
            return cls(*args, **kwargs)
        except ValueError as err:
            self.fail(key, str(err))


def _join(path: str, name: str) -> str:
    return f"{path}.{name}" if path else name


def _is_number(value: Any) -> bool:
    """A finite JSON number (booleans are not numbers, whatever Python says)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer literal beyond float range
        return False


def _short(value: Any, limit: int = 40) -> str:
    """A JSON value for a one-line message: strings quoted, anything long cut short."""
    if isinstance(value, str):
        return repr(value) if len(value) <= limit else repr(value[:limit]) + "…"
    if isinstance(value, int | float) and not isinstance(value, bool):
        return _number_text(value)
    return _json_type(value)


def _first_line(text: str) -> str:
    return text.splitlines()[0] if text else text


def _json_type(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, int | float):
        return f"the number {_number_text(value)}"
    if isinstance(value, str):
        return f"the string {_short(value)}"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def _number_text(value: int | float, limit: int = 40) -> str:
    """repr of a number, cut short (a long integer has hundreds of digits)."""
    text = repr(value) if isinstance(value, float) or abs(value) < 10**limit else None
    return text if text is not None else f"{str(value)[:12]}… ({len(str(abs(value)))} digits)"
