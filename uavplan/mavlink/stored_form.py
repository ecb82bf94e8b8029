"""What PX4 and ArduPilot Copter keep of a mission item, and the form each accepts.

A firmware does not store a MISSION_ITEM_INT as it arrives: it converts it to its own mission
command and, on a download, converts that back. What comes back is the item in the
firmware's form: some params dropped or reduced, frames renamed, altitudes quantised. A
read-back check that compares the download with what was sent must expect that form, or it
refuses every plan (issue 32: "read-back differs ... frame 2 became 0" on every bundled plan
against ArduPilot SITL). And some items are refused unless sent in the form the firmware
parses (PX4 takes NAV_RETURN_TO_LAUNCH, DO_CHANGE_SPEED, DO_LAND_START ... only in
MAV_FRAME_MISSION).

:func:`upload_form` is the item as uavplan sends it to a vehicle of a flavour;
:func:`stored_form` is what that vehicle then holds and sends back. Both follow the firmware
source, and were measured against the real firmware (ArduCopter V4.7.0-dev SITL at ArduPilot
90700977c553, PX4 v1.16.0 SIH; tests/sitl/test_sitl_storage.py uploads every bundled plan and
items of every kind below and compares the download with :func:`stored_form`):

**ArduPilot** (libraries/AP_Mission/AP_Mission.cpp: ``mavlink_int_to_mission_cmd`` stores,
``mission_cmd_to_mavlink_int`` sends back; Copter build):

- ``mission_cmd_to_mavlink_int`` starts from ``frame = 0`` and params 0, so a command without
  a location (``AP_Mission::stored_in_location`` false: NAV_RETURN_TO_LAUNCH, DO_CHANGE_SPEED,
  DO_JUMP, DO_MOUNT_CONTROL ...) comes back in frame 0 (MAV_FRAME_GLOBAL) whatever frame it
  was sent in; a located one in the frame its flags give (0, 3 or 10: MAV_FRAME_MISSION
  counts as absolute, frame 0);
- NAV_WAYPOINT keeps only its hold time, as a ``uint16_t`` (``cmd.p1 = packet.param1``: whole
  seconds, truncated): the acceptance radius (param 2), pass radius (3) and yaw (4) come
  back 0;
- NAV_LAND: param 1 (abort altitude) kept as a ``uint16_t``, param 4 comes back
  ``loiter_ccw ? -1 : 1`` (1 for any yaw sent, NaN included), params 2, 3 are 0;
- NAV_TAKEOFF: param 1 kept as a ``uint16_t``, the others 0; NAV_LOITER_UNLIM: params 1, 2,
  4 are 0;
  NAV_LOITER_TIME: param 1 as ``uint16_t``, param 3 its sign (1 or -1; 0 counts as 1),
  param 4 ``loiter_xtrack`` (1 if param 4 > 0, else 0), param 2 is 0;
- DO_CHANGE_SPEED: params 1-3 kept, param 4 is 0; DO_JUMP: params 1, 2 kept (whole numbers),
  3, 4 are 0; DO_LAND_START: a location, no params;
- a location's altitude is kept in centimetres, ``int32_t alt = packet.z * 100.0f``:
  float32 arithmetic, truncated toward zero;
- fence items (libraries/AC_Fence/AC_PolyFence_loader.cpp) come back with z 0 and the return
  point in frame 0; rally points (libraries/AP_Rally) as sent. Neither keeps autocontinue.

**PX4** (src/modules/mavlink/mavlink_mission.cpp: ``parse_mavlink_mission_item`` stores,
``format_mavlink_mission_item`` sends back):

- items with a position are accepted in the global frames only for the commands the parser
  lists (waypoints, loiters, land, take-off, ROI, VTOL, fence and rally items); every other
  command only in MAV_FRAME_MISSION, else MAV_MISSION_UNSUPPORTED: :func:`upload_form` sends
  those in frame 2 (their position, which PX4 does not use, left out);
- a global item comes back in the ``_INT`` spelling of its frame (3 → 6, 0 → 5): synonyms;
- yaw (param 4 of NAV_WAYPOINT, LOITER_UNLIM, LAND, TAKEOFF) is stored in radians wrapped to
  [0, 2π) and sent back in degrees: -90 comes back 270;
- NAV_WAYPOINT keeps hold time, acceptance radius and yaw, not param 3 (pass radius);
  NAV_LAND keeps param 2 (precision landing) and yaw, not param 1 (abort altitude, "TODO");
  NAV_TAKEOFF keeps the yaw only; NAV_LOITER_TIME keeps param 1, param 2 and 4 as 0/1
  (``force_heading``, ``loiter_exit_xtrack``: > 0), and param 3;
- a frame-2 item keeps its params (float32) and x, y as whole numbers (``round``);
- fence items come back in frame 5 (MAV_FRAME_GLOBAL_INT, the fence return point's
  relative altitude included: measured on v1.16.0), with the params their kind has (a
  polygon vertex its vertex count, a circle its radius), the others 0.

Anything not listed is expected back as sent.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from uavplan.mission.items import Autopilot, MavCmd, MavFrame, MissionItem, MissionType

__all__ = [
    "ARDUPILOT_LOCATION_COMMANDS",
    "PX4_GLOBAL_FRAME_COMMANDS",
    "PX4_MISSION_FRAME_COMMANDS",
    "stored_form",
    "upload_form",
]

#: ``AP_Mission::stored_in_location``: the commands ArduPilot stores with a location (NAV
#: WAYPOINT, LOITER_UNLIM, LOITER_TURNS, LOITER_TIME, LAND, TAKEOFF, CONTINUE_AND_CHANGE_ALT,
#: LOITER_TO_ALT, SPLINE_WAYPOINT, GUIDED_ENABLE, DO_SET_HOME, DO_LAND_START, DO_GO_AROUND,
#: DO_SET_ROI, VTOL_TAKEOFF, VTOL_LAND, PAYLOAD_PLACE), and DO_SET_ROI_LOCATION, which the
#: SITL build (ArduPilot 90700977c553) keeps with its location too (measured)
ARDUPILOT_LOCATION_COMMANDS = frozenset(
    {16, 17, 18, 19, 21, 22, 30, 31, 82, 92, 179, 189, 191, 195, 201, 84, 85, 94}
)
#: the commands PX4's ``parse_mavlink_mission_item`` accepts in a global frame: WAYPOINT,
#: LOITER_UNLIM, LOITER_TIME, LAND, TAKEOFF, LOITER_TO_ALT, NAV_ROI, DO_SET_ROI,
#: DO_SET_ROI_LOCATION, VTOL_TAKEOFF, VTOL_LAND, CONDITION_GATE, the fence and rally items,
#: COMPONENT_ARM_DISARM, DO_AUTOTUNE_ENABLE
PX4_GLOBAL_FRAME_COMMANDS = frozenset(
    {16, 17, 19, 21, 22, 31, 80, 201, 195, 84, 85, 4501, 5000, 5001, 5002, 5003, 5004, 5100}
    | {400, 212}
)
#: the commands PX4's ``parse_mavlink_mission_item`` accepts in MAV_FRAME_MISSION: DO_JUMP,
#: NAV_ROI, DO_SET_ROI, DO_WINCH, DO_GRIPPER, DO_CHANGE_SPEED, DO_SET_HOME, DO_LAND_START,
#: DO_TRIGGER_CONTROL, DO_DIGICAM_CONTROL, DO_MOUNT_CONFIGURE, DO_MOUNT_CONTROL, the gimbal
#: manager and camera commands, DO_SET_CAM_TRIGG_DIST, OBLIQUE_SURVEY,
#: DO_SET_CAM_TRIGG_INTERVAL, DO_VTOL_TRANSITION, NAV_DELAY, NAV_RETURN_TO_LAUNCH,
#: DO_SET_ROI_WPNEXT_OFFSET, DO_SET_ROI_NONE, CONDITION_DELAY, CONDITION_DISTANCE,
#: DO_SET_ACTUATOR, DO_AUTOTUNE_ENABLE, COMPONENT_ARM_DISARM
PX4_MISSION_FRAME_COMMANDS = frozenset(
    {177, 80, 201, 42600, 211, 178, 179, 189, 2003, 203, 204, 205, 1000, 1001, 532}
    | {2000, 2001, 2500, 2501, 200, 206, 260, 214, 530, 534, 3000, 93, 20, 197, 198}
    | {112, 114, 187, 212, 400}
)
_POLYGON = frozenset({5001, 5002})
_PX4_YAW_PARAM4 = frozenset({16, 17, 21, 22, 84, 85})
_UINT16_MAX = 65535.0


def upload_form(item: MissionItem, autopilot: Autopilot) -> MissionItem:
    """``item`` in the form ``autopilot`` accepts (see the module docstring): for PX4 a
    command its parser takes only in MAV_FRAME_MISSION is sent in frame 2 without the
    position it does not use; everything else as it is."""
    if autopilot != Autopilot.PX4 or not item.is_global:
        return item
    if int(item.command) in PX4_GLOBAL_FRAME_COMMANDS:
        return item
    if int(item.command) not in PX4_MISSION_FRAME_COMMANDS:
        return item  # PX4 takes it in neither form: sent as it is, it refuses it
    return replace(item, frame=int(MavFrame.MISSION), x=0.0, y=0.0, z=0.0)


def stored_form(item: MissionItem, autopilot: Autopilot, mission_type: MissionType) -> MissionItem:
    """What a vehicle of flavour ``autopilot`` holds, and sends back on a download, for
    ``item`` uploaded as ``mission_type`` (see the module docstring)."""
    if autopilot == Autopilot.ARDUPILOT:
        return _ardupilot(item, mission_type)
    if autopilot == Autopilot.PX4:
        return _px4(item, mission_type)
    return item


def _f32(value: float) -> float:
    return float(np.float32(value))


def _p(value: float | None) -> float:
    """An unset (NaN) param as the firmware reads it: NaN."""
    return math.nan if value is None else float(value)


def _uint16(value: float | None) -> float:
    """``uint16_t p1 = packet.param1``: truncated to a whole number (NaN and negatives: 0,
    beyond the range: its top)."""
    v = _p(value)
    if not math.isfinite(v) or v <= 0.0:
        return 0.0
    return float(min(math.trunc(_f32(v)), _UINT16_MAX))


def _ardupilot_cm(z: float) -> float:
    """``int32_t alt = packet.z * 100.0f`` (float32, truncated toward zero), in metres."""
    cm = np.float32(z) * np.float32(100.0)
    return math.trunc(float(cm)) / 100.0


def _ardupilot(item: MissionItem, mission_type: MissionType) -> MissionItem:
    cmd = int(item.command)
    if mission_type == MissionType.FENCE:
        frame = int(MavFrame.GLOBAL) if cmd == MavCmd.NAV_FENCE_RETURN_POINT else item.frame
        return replace(item, frame=frame, z=0.0)
    if mission_type == MissionType.RALLY:
        return item
    zero = 0.0
    p1, p2, p3, p4 = item.param1, item.param2, item.param3, item.param4
    if cmd not in ARDUPILOT_LOCATION_COMMANDS:
        frame = int(MavFrame.GLOBAL)
        if cmd == MavCmd.DO_CHANGE_SPEED:
            p4 = zero
        elif cmd == MavCmd.DO_JUMP:
            p1 = float(math.trunc(_p(p1))) if math.isfinite(_p(p1)) else zero
            p2 = float(math.trunc(_p(p2))) if math.isfinite(_p(p2)) else zero
            p3 = p4 = zero
        elif cmd == MavCmd.NAV_RETURN_TO_LAUNCH:
            p1 = p2 = p3 = p4 = zero
        return replace(item, frame=frame, param1=p1, param2=p2, param3=p3, param4=p4)
    frame = int(item.frame)
    if frame in (int(MavFrame.MISSION), int(MavFrame.GLOBAL_INT)):
        frame = int(MavFrame.GLOBAL)
    elif frame == int(MavFrame.GLOBAL_RELATIVE_ALT_INT):
        frame = int(MavFrame.GLOBAL_RELATIVE_ALT)
    elif frame == int(MavFrame.GLOBAL_TERRAIN_ALT_INT):
        frame = int(MavFrame.GLOBAL_TERRAIN_ALT)
    if cmd == MavCmd.NAV_WAYPOINT:
        p1, p2, p3, p4 = _uint16(p1), zero, zero, zero
    elif cmd == MavCmd.NAV_LAND:
        ccw = math.isfinite(_p(p4)) and _p(p4) < 0.0
        p1, p2, p3, p4 = _uint16(p1), zero, zero, (-1.0 if ccw else 1.0)
    elif cmd == MavCmd.NAV_TAKEOFF:
        p1, p2, p3, p4 = _uint16(p1), zero, zero, zero
    elif cmd == MavCmd.NAV_LOITER_UNLIM:
        p1 = p2 = p4 = zero
    elif cmd == 19:  # NAV_LOITER_TIME
        negative = math.isfinite(_p(p3)) and _p(p3) < 0.0
        xtrack = math.isfinite(_p(p4)) and _p(p4) > 0.0
        p1, p2, p3, p4 = _uint16(p1), zero, (-1.0 if negative else 1.0), (1.0 if xtrack else 0.0)
    elif cmd in (MavCmd.DO_LAND_START, 201):
        p1 = p2 = p3 = p4 = zero
    return replace(
        item, frame=frame, param1=p1, param2=p2, param3=p3, param4=p4, z=_ardupilot_cm(item.z)
    )


def _wrap_deg(value: float | None) -> float | None:
    """``math::degrees(wrap_2pi(math::radians(p4)))`` in float32: [0, 360); NaN stays."""
    v = _p(value)
    if not math.isfinite(v):
        return value
    rad = float(np.float32(math.radians(v)))
    two_pi = 2.0 * math.pi
    rad = rad - two_pi * math.floor(rad / two_pi)
    return _f32(math.degrees(_f32(rad)))


def _flag(value: float | None) -> float:
    v = _p(value)
    return 1.0 if math.isfinite(v) and v > 0.0 else 0.0


def _px4(item: MissionItem, mission_type: MissionType) -> MissionItem:
    cmd = int(item.command)
    zero = 0.0
    p1, p2, p3, p4 = item.param1, item.param2, item.param3, item.param4
    if not item.is_global:
        if int(item.frame) == int(MavFrame.MISSION):
            return replace(item, x=float(round(item.x)), y=float(round(item.y)))
        return item
    if mission_type == MissionType.FENCE or cmd == MavCmd.NAV_RALLY_POINT:
        frame = item.frame
        if mission_type == MissionType.FENCE:
            frame = int(MavFrame.GLOBAL)  # every fence item comes back in frame 5 (measured)
        if cmd in _POLYGON:
            count = _p(p1)
            p1 = float(int(count + 0.5)) if math.isfinite(count) else zero
        elif cmd not in (MavCmd.NAV_FENCE_CIRCLE_INCLUSION, MavCmd.NAV_FENCE_CIRCLE_EXCLUSION):
            p1 = zero
        return replace(item, frame=frame, param1=p1, param2=zero, param3=zero, param4=zero)
    if cmd == MavCmd.NAV_WAYPOINT:
        p3 = zero
    elif cmd == MavCmd.NAV_LOITER_UNLIM:
        p1 = p2 = zero
    elif cmd == 19:  # NAV_LOITER_TIME
        p2, p4 = _flag(p2), _flag(p4)
    elif cmd == MavCmd.NAV_LAND:
        p1 = p3 = zero
    elif cmd == MavCmd.NAV_TAKEOFF:
        p1 = p2 = p3 = zero
    elif cmd == 31:  # NAV_LOITER_TO_ALT
        p1, p3, p4 = _flag(p1), zero, _flag(p4)
    if cmd in _PX4_YAW_PARAM4:
        p4 = _wrap_deg(p4)
    return replace(item, param1=p1, param2=p2, param3=p3, param4=p4)
