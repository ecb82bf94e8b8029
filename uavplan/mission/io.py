"""Save and load mission files, choosing the format from the file name's extension.

Supported: ``.plan`` (QGroundControl JSON) and ``.waypoints`` / ``.txt`` (``QGC WPL 110``),
read and written; ``.geojson`` and ``.kml`` (map exports, :mod:`uavplan.mission.export`),
written only. Another format is one more :class:`MissionFormat` in :data:`FORMATS` (a format
that can only be written passes ``loads=None``). Saving is atomic: the old file stays whole
until the new one is complete.

Export formats draw more than a mission holds when they are given it: ``save_mission(plan,
path, extras=ExportExtras(...))`` adds obstacle footprints and the planned path; without
extras they draw the mission alone (what ``uavplan convert`` has). Formats that cannot use
extras ignore them.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.errors import MissionFileError
from uavplan.fileio import atomic_write_text
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.mission.qgc_plan import plan_from_json, plan_to_json
from uavplan.mission.waypoints_file import waypoints_from_text, waypoints_to_text

if TYPE_CHECKING:
    from uavplan.mission.export import ExportExtras

#: ``loads(text, file=..., autopilot=...)``; ``autopilot`` is None when the caller gave none
Loader = Callable[..., MissionPlan]


@dataclass(frozen=True)
class MissionFormat:
    """One mission file format: its name, how to write it and (optionally) how to read it.

    ``dumps_extras(plan, extras)``: set by export formats that can draw more than the mission
    (obstacles, the planned path); ``dumps(plan)`` is then the mission-only case.
    """

    name: str
    dumps: Callable[[MissionPlan], str]
    loads: Loader | None = None
    dumps_extras: Callable[[MissionPlan, ExportExtras], str] | None = None


def _load_waypoints(text: str, *, file: str, autopilot: Autopilot | None) -> MissionPlan:
    # The format has no autopilot field; it is ArduPilot's native layout (home = seq 0).
    return waypoints_from_text(text, file=file, autopilot=autopilot or Autopilot.ARDUPILOT)


def _geojson(plan: MissionPlan, extras: ExportExtras | None = None) -> str:
    from uavplan.mission.export import geojson_dumps  # numpy/pyproj only when exporting

    return geojson_dumps(plan, extras)


def _kml(plan: MissionPlan, extras: ExportExtras | None = None) -> str:
    from uavplan.mission.export import kml_dumps

    return kml_dumps(plan, extras)


PLAN_FORMAT = MissionFormat("QGroundControl plan", plan_to_json, plan_from_json)
WAYPOINTS_FORMAT = MissionFormat("QGC WPL 110 waypoints", waypoints_to_text, _load_waypoints)
GEOJSON_FORMAT = MissionFormat("GeoJSON", _geojson, None, _geojson)
KML_FORMAT = MissionFormat("KML", _kml, None, _kml)

#: extension (lower case, with the dot) → format
FORMATS: dict[str, MissionFormat] = {
    ".plan": PLAN_FORMAT,
    ".waypoints": WAYPOINTS_FORMAT,
    ".txt": WAYPOINTS_FORMAT,
    ".geojson": GEOJSON_FORMAT,
    ".kml": KML_FORMAT,
}


def format_for(path: str | os.PathLike[str]) -> MissionFormat:
    """The format a file name asks for; :class:`MissionFileError` for an unknown extension."""
    suffix = Path(path).suffix.lower()
    fmt = FORMATS.get(suffix)
    if fmt is None:
        known = ", ".join(sorted(FORMATS))
        found = f"extension {suffix!r}" if suffix else "no extension"
        raise MissionFileError(
            f"unknown mission file type ({found}); use one of {known}", file=str(path)
        )
    return fmt


def save_mission(
    plan: MissionPlan,
    path: str | os.PathLike[str],
    *,
    extras: ExportExtras | None = None,
) -> None:
    """Write ``plan`` to ``path`` in the format of its extension, atomically.

    ``extras`` (obstacles, planned path) are drawn by the export formats and ignored by the
    mission formats.
    """
    fmt = format_for(path)
    try:
        if extras is not None and fmt.dumps_extras is not None:
            text = fmt.dumps_extras(plan, extras)
        else:
            text = fmt.dumps(plan)
    except MissionFileError as err:
        raise MissionFileError(err.reason, file=str(path), key=err.key) from err
    try:
        atomic_write_text(path, text)
    except OSError as err:
        raise MissionFileError(f"cannot write: {err.strerror or err}", file=str(path)) from err


def load_mission(path: str | os.PathLike[str], autopilot: Autopilot | None = None) -> MissionPlan:
    """Read a mission file. ``autopilot`` overrides what the file says (``.plan``) or
    assumes (``.waypoints``: ArduPilot); it decides how DO_JUMP targets are numbered."""
    fmt = format_for(path)
    if fmt.loads is None:
        raise MissionFileError(f"{fmt.name} files can be written but not read", file=str(path))
    try:
        with open(path, encoding="utf-8-sig") as handle:
            text = handle.read()
    except UnicodeDecodeError as err:
        raise MissionFileError(f"not UTF-8 text ({err.reason})", file=str(path)) from err
    except OSError as err:
        raise MissionFileError(f"cannot read: {err.strerror or err}", file=str(path)) from err
    return fmt.loads(text, file=str(path), autopilot=autopilot)
