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

import codecs
import os
import stat
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from uavplan.errors import MissionFileError
from uavplan.fileio import OutputFileError, atomic_write_text
from uavplan.mission.items import Autopilot, MissionPlan
from uavplan.mission.qgc_plan import plan_from_json, plan_to_json

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
    from uavplan.mission.waypoints_file import waypoints_from_text  # only for this format

    # The format has no autopilot field; it is ArduPilot's native layout (home = seq 0).
    return waypoints_from_text(text, file=file, autopilot=autopilot or Autopilot.ARDUPILOT)


def _dump_waypoints(plan: MissionPlan) -> str:
    from uavplan.mission.waypoints_file import waypoints_to_text

    return waypoints_to_text(plan)


def _geojson(plan: MissionPlan, extras: ExportExtras | None = None) -> str:
    from uavplan.mission.export import geojson_dumps  # numpy/pyproj only when exporting

    return geojson_dumps(plan, extras)


def _kml(plan: MissionPlan, extras: ExportExtras | None = None) -> str:
    from uavplan.mission.export import kml_dumps

    return kml_dumps(plan, extras)


PLAN_FORMAT = MissionFormat("QGroundControl plan", plan_to_json, plan_from_json)
WAYPOINTS_FORMAT = MissionFormat("QGC WPL 110 waypoints", _dump_waypoints, _load_waypoints)
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


def format_for(path: str | os.PathLike[str], *, reading: bool = False) -> MissionFormat:
    """The format a file name asks for; :class:`MissionFileError` for an unknown extension
    (``reading``: or one that can only be written; the message lists what can)."""
    suffix = Path(path).suffix.lower()
    fmt = FORMATS.get(suffix)
    if fmt is None or (reading and fmt.loads is None):
        known = ", ".join(sorted(readable_extensions() if reading else FORMATS))
        found = f"extension {suffix!r}" if suffix else "no extension"
        if fmt is not None:
            reason = (
                f"{fmt.name} is a map export: it can be written but not read as a mission; "
                f"read one of {known}"
            )
        else:
            kind = "mission file type to read" if reading else "mission file type"
            reason = f"unknown {kind} ({found}); use one of {known}"
        raise MissionFileError(reason, file=str(path))
    return fmt


def readable_extensions() -> tuple[str, ...]:
    """The extensions of the formats :func:`load_mission` reads."""
    return tuple(ext for ext, fmt in FORMATS.items() if fmt.loads is not None)


def mission_text(
    plan: MissionPlan,
    path: str | os.PathLike[str],
    *,
    extras: ExportExtras | Callable[[], ExportExtras] | None = None,
) -> str:
    """``plan`` as the text of a file named ``path`` (its format from the extension; see
    :func:`save_mission`). A problem is a :class:`MissionFileError` naming ``path``."""
    fmt = format_for(path)
    try:
        if extras is not None and fmt.dumps_extras is not None:
            return fmt.dumps_extras(plan, extras() if callable(extras) else extras)
        return fmt.dumps(plan)
    except MissionFileError as err:
        raise MissionFileError(err.reason, file=str(path), key=err.key) from err


def save_mission(
    plan: MissionPlan,
    path: str | os.PathLike[str],
    *,
    extras: ExportExtras | Callable[[], ExportExtras] | None = None,
) -> None:
    """Write ``plan`` to ``path`` in the format of its extension, atomically.

    ``extras`` (obstacles, planned path) are drawn by the export formats and ignored by the
    mission formats; a callable is called only when the format draws them. Any failure is a
    :class:`MissionFileError` naming ``path``; nothing is written then. (A command writes its
    outputs as a set: :mod:`uavplan.app.outputs`, with :func:`mission_text`.)
    """
    text = mission_text(plan, path, extras=extras)
    try:
        atomic_write_text(path, text)
    except OutputFileError as err:
        raise MissionFileError(err.reason, file=str(path)) from None


#: the largest mission file read; a 65,535-item .plan (the most MAVLink can number) is ~30 MB
MAX_FILE_BYTES = 64 * 1024 * 1024

#: byte-order marks → the codec that reads the text after them (UTF-32 before UTF-16: its
#: little-endian mark starts with UTF-16's)
_BOMS = (
    (codecs.BOM_UTF8, "utf-8"),
    (codecs.BOM_UTF32_LE, "utf-32-le"),
    (codecs.BOM_UTF32_BE, "utf-32-be"),
    (codecs.BOM_UTF16_LE, "utf-16-le"),
    (codecs.BOM_UTF16_BE, "utf-16-be"),
)


def load_mission(path: str | os.PathLike[str], autopilot: Autopilot | None = None) -> MissionPlan:
    """Read a mission file. ``autopilot`` overrides what the file says (``.plan``) or
    assumes (``.waypoints``: ArduPilot); it decides how DO_JUMP targets are numbered.

    Every problem is one :class:`MissionFileError` naming the file: it cannot be opened, is
    not a regular file, is larger than :data:`MAX_FILE_BYTES`, is not text (UTF-8, or UTF-16
    / UTF-32 with a byte-order mark), or its content is invalid (the reader names the key or
    line). A plan that loads can be sent: every value fits its MAVLink field.
    """
    shown = os.fspath(path)
    if isinstance(shown, bytes):  # pragma: no cover - the CLI passes str
        shown = shown.decode(errors="replace")
    fmt = format_for(shown, reading=True)
    assert fmt.loads is not None
    text = decode_text(read_bytes(shown), file=shown)
    return fmt.loads(text, file=shown, autopilot=autopilot)


def read_bytes(path: str, *, limit: int | None = None) -> bytes:
    """The bytes of the regular file ``path`` (at most ``limit``, default
    :data:`MAX_FILE_BYTES`); :class:`MissionFileError` otherwise."""
    if limit is None:
        limit = MAX_FILE_BYTES
    if "\x00" in path:
        raise MissionFileError("the file name contains a NUL byte", file=repr(path))
    try:
        # O_NONBLOCK: opening a FIFO must not wait for a writer; it is refused below
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as err:
        raise MissionFileError(f"cannot read: {err.strerror or err}", file=path) from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise MissionFileError("cannot read: not a regular file", file=path)
        if info.st_size > limit:
            raise MissionFileError(
                f"the file is {info.st_size / 2**20:.0f} MiB; mission files up to "
                f"{limit // 2**20} MiB are read",
                file=path,
            )
        chunks = []
        size = 0
        while size <= limit:
            chunk = os.read(fd, min(1 << 20, limit + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        data = b"".join(chunks)
    except OSError as err:
        raise MissionFileError(f"cannot read: {err.strerror or err}", file=path) from None
    finally:
        os.close(fd)
    if len(data) > limit:  # the file grew while it was read
        raise MissionFileError(f"mission files up to {limit // 2**20} MiB are read", file=path)
    return data


def decode_text(data: bytes, *, file: str) -> str:
    """Text of a mission file: UTF-8 (a BOM is dropped), or UTF-16 / UTF-32 with a BOM."""
    codec = "utf-8"
    for bom, name in _BOMS:
        if data.startswith(bom):
            codec, data = name, data[len(bom) :]
            break
    try:
        text = data.decode(codec)
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1 if codec == "utf-8" else None
        where = f"line {line}, " if line is not None else ""
        raise MissionFileError(
            f"not {codec.upper().removesuffix('-LE').removesuffix('-BE')} text: "
            f"{err.reason} ({where}byte {err.start + 1})",
            file=file,
        ) from None
    if "\x00" in text:
        hint = " (UTF-16 without a byte-order mark? save it as UTF-8)" if codec == "utf-8" else ""
        raise MissionFileError(f"not a text file: it holds NUL characters{hint}", file=file)
    return text
