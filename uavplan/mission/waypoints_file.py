"""Mission Planner / ``QGC WPL 110`` text files (``.waypoints``, ``.txt``), reference §6.

Line 1 is the header ``QGC WPL 110``; each following line is one item with 12 columns:
seq, current, frame, command, param1..param4, x/lat (deg), y/lon (deg), z/alt (m),
autocontinue. Line 0 (seq 0) is home: frame 0, AMSL altitude, current = 1.

Writer: tabs, ``\\n`` line endings, no comments, no blank line, 8 decimals for degrees and
params (1e-8° ≈ 1 mm), 6 for altitudes, always a '.' decimal point (Python's formatting
ignores the locale). An unset param (``None``) is written ``NaN``, as Mission Planner
writes it. The format holds no geofence, rally points, speeds or vehicle type.

Reader: accepts CRLF, tabs or spaces, ``#`` comments and blank lines; strict about the
header, the column count, numbers and consecutive seqs. The file carries no autopilot: it is
ArduPilot's native layout (home = seq 0), and the reader's ``autopilot`` decides what the
DO_JUMP targets mean in the resulting :class:`MissionPlan` (for PX4 they drop by one,
because PX4 has no home slot). Line 0 always becomes ``plan.home``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import NoReturn

from uavplan.errors import MissionFileError
from uavplan.geo import GeoPoint
from uavplan.mission.items import (
    Autopilot,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
)

HEADER = "QGC WPL 110"
N_COLUMNS = 12
DEGREE_DECIMALS = 8
PARAM_DECIMALS = 8
ALTITUDE_DECIMALS = 6

_COLUMN_NAMES = (
    "seq",
    "current",
    "frame",
    "command",
    "param1",
    "param2",
    "param3",
    "param4",
    "x/lat",
    "y/lon",
    "z/alt",
    "autocontinue",
)
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_INTEGER = re.compile(r"[+-]?\d+", re.ASCII)
#: the longest integer column read (a uint16 has 5 digits; leading zeros are allowed)
_MAX_INTEGER_CHARS = 32
#: line breaks: \n, \r\n and a lone \r (not the other characters str.splitlines() breaks on,
#: so that the line numbers in messages are the ones an editor shows)
_LINE_BREAK = re.compile(r"\r\n|\r|\n")
#: MISSION_COUNT's count is a uint16: the most items the file can hold with its home line
MAX_WIRE_ITEMS = 0xFFFF
_NAN = "NaN"


def _home_slots(autopilot: Autopilot) -> int:
    """Wire seqs taken before the first item: ArduPilot's home is seq 0 (reference §4.1)."""
    return 1 if autopilot == Autopilot.ARDUPILOT else 0


# =============================================================================================
# Writer


def waypoints_to_text(plan: MissionPlan, *, ignore_fence_and_rally: bool = False) -> str:
    """The ``QGC WPL 110`` file text for ``plan``.

    The format has no geofence or rally points: a plan that holds some raises
    :class:`MissionFileError` unless ``ignore_fence_and_rally`` is set (then they are
    dropped). Also raises it for a DO_JUMP whose target is not an item of the plan.
    """
    if not ignore_fence_and_rally and (not plan.fence.is_empty or plan.rally):
        raise MissionFileError(
            "the .waypoints format cannot hold a geofence or rally points; save the "
            "mission as .plan to keep them"
        )
    home = plan.home or GeoPoint(0.0, 0.0, 0.0)
    lines = [
        HEADER,
        "\t".join(
            (
                "0",
                "1",
                str(int(MavFrame.GLOBAL)),
                str(int(MavCmd.NAV_WAYPOINT)),
                "0",
                "0",
                "0",
                "0",
                _fixed(home.lat_deg, DEGREE_DECIMALS),
                _fixed(home.lon_deg, DEGREE_DECIMALS),
                _fixed(home.alt_m, ALTITUDE_DECIMALS),
                "1",
            )
        ),
    ]
    slots = _home_slots(plan.autopilot)
    n_items = len(plan.items)
    for index, item in enumerate(plan.items):
        params = list(item.params)
        if item.command == MavCmd.DO_JUMP:
            target = _jump_index(item.param1, slots, n_items)
            if target is None:
                raise MissionFileError(
                    f"DO_JUMP target {item.param1!r} is not an item of the mission "
                    f"(seq {slots}..{slots + n_items - 1} on {plan.autopilot.label})",
                    key=f"item {index}",
                )
            params[0] = float(target + 1)  # the file's seq of the target
        lines.append(
            "\t".join(
                (
                    str(index + 1),
                    "0",
                    str(item.frame),
                    str(item.command),
                    *(_param(p) for p in params),
                    _fixed(item.x, DEGREE_DECIMALS),
                    _fixed(item.y, DEGREE_DECIMALS),
                    _fixed(item.z, ALTITUDE_DECIMALS),
                    "1" if item.autocontinue else "0",
                )
            )
        )
    return "\n".join(lines) + "\n"


def _fixed(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    if text.startswith("-") and float(text) == 0.0:
        text = text[1:]  # no "-0.00000000"
    return text


def _param(value: float | None) -> str:
    return _NAN if value is None else _fixed(value, PARAM_DECIMALS)


def _jump_index(param1: float | None, slots: int, n_items: int) -> int | None:
    """Index in ``plan.items`` of a DO_JUMP's target wire seq, or None if there is none."""
    if param1 is None or not float(param1).is_integer():
        return None
    index = int(param1) - slots
    return index if 0 <= index < n_items else None


# =============================================================================================
# Reader


def waypoints_from_text(
    text: str, *, file: str | None = None, autopilot: Autopilot = Autopilot.ARDUPILOT
) -> MissionPlan:
    """Parse ``QGC WPL 110`` text into a plan for ``autopilot``. ``file`` labels errors."""

    def fail(key: str, reason: str) -> NoReturn:
        raise MissionFileError(reason, file=file, key=key)

    lines = _LINE_BREAK.split(text.removeprefix("\ufeff"))
    if lines and lines[-1] == "":
        lines.pop()
    if not lines or not lines[0].strip():
        fail("line 1", f"empty header: expected {HEADER!r}")
    header = lines[0].strip()
    if header != HEADER:
        shown = repr(header[:40]) + ("…" if len(header) > 40 else "")
        fail("line 1", f"bad header {shown}: expected {HEADER!r}")

    rows: list[tuple[int, list[str]]] = []
    for lineno, line in enumerate(lines[1:], start=2):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        columns = stripped.split()
        if len(columns) != N_COLUMNS:
            fail(f"line {lineno}", f"expected {N_COLUMNS} columns, found {len(columns)}")
        rows.append((lineno, columns))
    if len(rows) > MAX_WIRE_ITEMS:
        fail(
            f"line {rows[MAX_WIRE_ITEMS][0]}",
            f"{len(rows)} items with home; MAVLink numbers at most {MAX_WIRE_ITEMS}",
        )

    home: GeoPoint | None = None
    items: list[MissionItem] = []
    jump_lines: list[int] = []
    for seq, (lineno, columns) in enumerate(rows):
        row = _parse_row(columns, lineno, fail)
        if row.seq != seq:
            fail(f"line {lineno}", f"seq {row.seq} out of order: expected {seq}")
        if seq == 0:
            if row.lat_deg is None or row.lon_deg is None:
                fail(f"line {lineno}", "the home line needs a position")
            try:
                # the home line goes on the wire as ArduPilot's seq 0: it must fit there too
                MissionItem(
                    command=MavCmd.NAV_WAYPOINT,
                    frame=MavFrame.GLOBAL,
                    x=row.lat_deg,
                    y=row.lon_deg,
                    z=row.alt_m,
                )
                if (row.lat_deg, row.lon_deg) != (0.0, 0.0):
                    home = GeoPoint(row.lat_deg, row.lon_deg, row.alt_m)
            except ValueError as err:
                fail(f"line {lineno}", f"home: {err}")
            continue
        try:
            item = MissionItem(
                command=row.command,
                frame=row.frame,
                param1=row.params[0],
                param2=row.params[1],
                param3=row.params[2],
                param4=row.params[3],
                x=0.0 if row.lat_deg is None else row.lat_deg,
                y=0.0 if row.lon_deg is None else row.lon_deg,
                z=row.alt_m,
                autocontinue=row.autocontinue,
            )
        except ValueError as err:
            fail(f"line {lineno}", str(err))
        items.append(item)
        jump_lines.append(lineno)

    slots = _home_slots(autopilot)
    for index, item in enumerate(items):
        if item.command != MavCmd.DO_JUMP:
            continue
        target = item.param1
        if target is None or not target.is_integer() or not 1 <= target <= len(items):
            fail(
                f"line {jump_lines[index]}",
                f"DO_JUMP target {target!r} is not the seq of a mission item (1..{len(items)})",
            )
        items[index] = replace(item, param1=target - 1 + slots)
    return MissionPlan(items=tuple(items), autopilot=autopilot, home=home)


@dataclass(frozen=True)
class _Row:
    """One parsed line; ``None`` is NaN in the file (unset)."""

    seq: int
    frame: int
    command: int
    params: tuple[float | None, float | None, float | None, float | None]
    lat_deg: float | None
    lon_deg: float | None
    alt_m: float
    autocontinue: bool


_INTEGER_LIMITS = {0: 0xFFFF, 1: 0xFF, 2: 0xFF, 3: 0xFFFF, 11: 0xFF}  # column → max (uint)
_ALTITUDE_COLUMN = 10


def _parse_row(columns: list[str], lineno: int, fail: Callable[[str, str], NoReturn]) -> _Row:
    values: list[float | None] = []
    for i, text in enumerate(columns):
        key = f"line {lineno}, column {i + 1} ({_COLUMN_NAMES[i]})"
        if i in _INTEGER_LIMITS:
            if not _INTEGER.fullmatch(text):
                fail(key, f"{_shown(text)} is not a whole number")
            if len(text) > _MAX_INTEGER_CHARS:
                fail(key, f"{_shown(text)} is out of range (0..{_INTEGER_LIMITS[i]})")
            value = int(text)
            if not 0 <= value <= _INTEGER_LIMITS[i]:
                fail(key, f"{value} is out of range (0..{_INTEGER_LIMITS[i]})")
            values.append(value)
        elif text.lower() == "nan":
            if i == _ALTITUDE_COLUMN:
                fail(key, "the altitude must be a number, not NaN")
            values.append(None)
        else:
            if not _NUMBER.fullmatch(text):
                fail(key, f"{_shown(text)} is not a number")
            number = float(text)
            if not math.isfinite(number):
                fail(key, f"{_shown(text)} is out of range")
            values.append(number)
    seq, _current, frame, command = (int(v or 0) for v in values[:4])
    p1, p2, p3, p4, lat, lon, alt = values[4:11]
    return _Row(
        seq=seq,
        frame=frame,
        command=command,
        params=(p1, p2, p3, p4),
        lat_deg=lat,
        lon_deg=lon,
        alt_m=float(alt or 0.0),
        autocontinue=bool(values[11]),
    )


def _shown(text: str, limit: int = 40) -> str:
    """A column's text for a one-line message, cut short."""
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "…"
