"""The values every obstacle reader shares: the file entry, its errors, the features a reader
produces and the counts it keeps, and the parsing of heights.

The readers (:mod:`~uavplan.sources.osm`, :mod:`~uavplan.sources.vector`) import this module
only; :mod:`~uavplan.sources.common` imports the readers where a file of their format is read,
so the package has no import cycle.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from uavplan.errors import InputError
from uavplan.limits import MAX_ALTITUDE_M
from uavplan.obstacles import Obstacle

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry

#: height of a feature with no usable height information (metres)
DEFAULT_HEIGHT_M = 10.0
#: height of one storey when only ``building:levels`` is known (metres)
LEVEL_HEIGHT_M = 3.0
OSM_SUFFIXES = (".osm", ".osm.pbf", ".pbf", ".osm.bz2", ".osm.gz", ".o5m", ".opl")


class SourceError(InputError):
    """A data file or its entry is unusable. ``key`` is the entry key at fault
    (``file``, ``layer``, ``height_attribute``, ...), ``index`` the entry's position."""

    def __init__(
        self,
        reason: str,
        *,
        file: str | None = None,
        key: str | None = None,
        index: int | None = None,
    ) -> None:
        self.index = index
        super().__init__(reason, file=file, key=key)

    def key_path(self, list_key: str = "obstacle_files") -> str:
        """``obstacle_files[1].layer`` for the entry at fault."""
        head = f"{list_key}[{self.index}]" if self.index is not None else list_key
        return f"{head}.{self.key}" if self.key else head


@dataclass(frozen=True)
class ObstacleFileSpec:
    """One ``obstacle_files`` entry. ``path`` is resolved (absolute or relative to the cwd)."""

    path: Path
    layer: str | None = None
    height_attribute: str | None = None
    default_height_m: float = DEFAULT_HEIGHT_M
    min_height_m: float | None = None  # a base for every feature of the file (metres)

    def __post_init__(self) -> None:
        default = self.default_height_m
        if not (math.isfinite(default) and 0 < default <= MAX_ALTITUDE_M):
            raise SourceError(
                f"must be a number > 0 and <= {MAX_ALTITUDE_M:g}, got {self.default_height_m!r}",
                key="default_height",
            )
        if self.min_height_m is not None and not (
            math.isfinite(self.min_height_m) and 0 <= self.min_height_m <= MAX_ALTITUDE_M
        ):
            raise SourceError(
                f"must be a number >= 0 and <= {MAX_ALTITUDE_M:g}, got {self.min_height_m!r}",
                key="min_height",
            )

    @property
    def is_osm(self) -> bool:
        name = self.path.name.lower()
        return name.endswith(OSM_SUFFIXES)

    @classmethod
    def from_mapping(cls, raw: Any, base_dir: Path) -> ObstacleFileSpec:
        """Check one entry as written in a scenario or map (keys as the user spells them)."""
        if isinstance(raw, str):
            raw = {"file": raw}
        if not isinstance(raw, Mapping):
            raise SourceError(f"must be a mapping with a 'file' key, got {type(raw).__name__}")
        allowed = {"file", "layer", "height_attribute", "default_height", "min_height"}
        for k in raw:
            if k not in allowed:
                raise SourceError(f"unknown key (allowed: {', '.join(sorted(allowed))})", key=k)
        if "file" not in raw:
            raise SourceError("missing required key", key="file")
        file = raw["file"]
        if not isinstance(file, str) or not file:
            raise SourceError("must be a file name", key="file")
        layer = raw.get("layer")
        if layer is not None and not isinstance(layer, str | int):
            raise SourceError("must be a layer name", key="layer")
        attr = raw.get("height_attribute")
        if attr is not None and not isinstance(attr, str):
            raise SourceError("must be an attribute name", key="height_attribute")
        default = _number(raw.get("default_height", DEFAULT_HEIGHT_M), "default_height")
        min_h = raw.get("min_height")
        min_height = None if min_h is None else _number(min_h, "min_height")
        path = Path(file).expanduser()
        if not path.is_absolute():
            path = (base_dir / path).resolve()
        return cls(path, None if layer is None else str(layer), attr, default, min_height)


def _number(value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SourceError(f"must be a number, got {value!r}", key=key)
    return float(value)


@dataclass
class Feature:
    """A footprint in longitude/latitude degrees (shapely), its height and provenance."""

    geometry: BaseGeometry
    height_m: float
    height_source: str  # "height", "levels", "attribute", "default"
    kind: str  # "building", "tower", ...
    base_m: float = 0.0
    radius_m: float | None = None  # point features only


@dataclass
class ImportResult:
    """Obstacles read from one file, with what was kept, skipped and why.

    ``kept`` counts source features by kind, ``skipped`` by reason, ``notes`` counts things
    the reader did to kept features (a default height, a lifted base modelled to the ground,
    a courtyard split, a simplified outline).
    """

    path: Path
    obstacles: tuple[Obstacle, ...] = ()
    kept: Counter[str] = field(default_factory=Counter)
    skipped: Counter[str] = field(default_factory=Counter)
    notes: Counter[str] = field(default_factory=Counter)
    seconds: float = 0.0

    def summary_lines(self) -> list[str]:
        """Human-readable report lines (the ``import`` command prints these)."""
        lines = [
            f"{self.path.name}: kept {sum(self.kept.values())} features as "
            f"{len(self.obstacles)} obstacles, skipped {sum(self.skipped.values())}"
        ]
        for kind, n in sorted(self.kept.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  kept     {n:6d}  {kind}")
        for reason, n in sorted(self.skipped.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  skipped  {n:6d}  {reason}")
        for note, n in sorted(self.notes.items(), key=lambda kv: (-kv[1], kv[0])):
            lines.append(f"  note     {n:6d}  {note}")
        return lines


# ---------------------------------------------------------------------------------------------
# Heights

_HEIGHT_RE = re.compile(
    r"^\s*(?P<num>[+]?\d+(?:[.,]\d+)?)\s*(?P<unit>m|meters?|metres?|ft|feet|foot|')?\s*$",
    re.IGNORECASE,
)
_FEET_INCHES_RE = re.compile(r"^\s*(?P<ft>\d+)\s*'\s*(?P<inch>\d+(?:\.\d+)?)\s*(?:\"|'')\s*$")
FOOT_M = 0.3048


def parse_height_m(value: Any) -> float | None:
    """A height in metres from an OSM ``height`` tag or an attribute value, or ``None``.

    Accepts numbers, ``"12"``, ``"12.5 m"``, ``"12,5"``, ``"40'"``, ``"40 ft"`` and
    ``"12'6\\""`` (feet and inches); of OSM multiple values (``"12;15"``) the tallest.
    Anything else, zero or negative → ``None``.
    """
    if value is None or isinstance(value, bool):
        return None
    if isinstance(value, int | float):
        out = float(value)
    elif ";" in str(value):  # OSM multiple values: the tallest one (conservative)
        heights = [h for h in (parse_height_m(v) for v in str(value).split(";")) if h is not None]
        return max(heights) if heights else None
    else:
        text = str(value)
        m = _FEET_INCHES_RE.match(text)
        if m:
            out = (int(m["ft"]) + float(m["inch"]) / 12.0) * FOOT_M
        else:
            m = _HEIGHT_RE.match(text)
            if not m:
                return None
            out = float(m["num"].replace(",", "."))
            unit = (m["unit"] or "m").lower()
            if unit in ("ft", "feet", "foot", "'"):
                out *= FOOT_M
    if not math.isfinite(out) or out <= 0:
        return None
    return out


def parse_levels(value: Any) -> float | None:
    """``building:levels`` → a positive number of storeys, or ``None``."""
    if value is None:
        return None
    try:
        out = float(str(value).strip().replace(",", "."))
    except ValueError:
        return None
    return out if math.isfinite(out) and out > 0 else None
