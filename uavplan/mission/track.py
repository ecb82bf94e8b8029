"""A flown track, sample by sample, and its files: ``.csv`` (a table) and ``.geojson`` (a line).

A :class:`Track` is what a flight left behind, simulated (``uavplan simulate``) or flown
(``uavplan fly``): for each sample the time since the mission started, the position (WGS84
degrees), the altitude above mean sea level and above home, the ground speed, the current
mission item (its sequence number as on the wire, -1 when unknown) and, when the vehicle
said it, its flight mode. Geometry (where the track is in a scenario, how close it comes to
what) is not here: :func:`uavplan.flightcheck.flight_of_track` places it in a site.

Files are written atomically (:mod:`uavplan.fileio`): a reader sees the old file or the
whole new one.

- **CSV**: one header row ``time_s,lat_deg,lon_deg,alt_amsl_m,relative_alt_m,speed_m_s,
  current_seq,mode``, one row per sample.
- **GeoJSON** (RFC 7946): a FeatureCollection holding one LineString feature whose
  coordinates are ``[lon, lat, alt_amsl_m]``; its properties hold the per-sample columns as
  arrays of the same length (``time_s``, ``relative_alt_m``, ``speed_m_s``, ``current_seq``,
  ``mode``) and what the track is (``source``, ``autopilot``). GIS tools draw the line and
  keep the columns.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from uavplan.errors import InputError
from uavplan.fileio import atomic_write_text

__all__ = ["TRACK_FORMATS", "Track", "TrackFileError", "check_track_path", "observed_stretches"]

#: the file types a track is written as (by extension)
TRACK_FORMATS = (".csv", ".geojson")
CSV_COLUMNS = (
    "time_s",
    "lat_deg",
    "lon_deg",
    "alt_amsl_m",
    "relative_alt_m",
    "speed_m_s",
    "current_seq",
    "mode",
)
#: the longest track file read back (a flight of hours at 10 samples a second fits)
MAX_TRACK_BYTES = 256 * 1024 * 1024


class TrackFileError(InputError):
    """A track file cannot be read or written (exit 2)."""


def check_track_path(path: str | os.PathLike[str]) -> str:
    """The format (``.csv`` / ``.geojson``) ``path`` asks for; :class:`TrackFileError`
    for any other extension."""
    suffix = Path(path).suffix.lower()
    if suffix not in TRACK_FORMATS:
        found = f"extension {suffix!r}" if suffix else "no extension"
        raise TrackFileError(
            f"a track is written as .csv or .geojson ({found})", file=os.fspath(path)
        )
    return suffix


def _column(values: ArrayLike, dtype: type, name: str) -> NDArray[Any]:
    arr: NDArray[Any] = np.asarray(values, dtype=dtype).reshape(-1)
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise ValueError(f"track column {name} holds a value that is not a finite number")
    return arr


@dataclass(frozen=True, eq=False)
class Track:
    """A flown track: ``n`` samples, each column an array of length ``n``.

    ``time_s``: seconds since the mission started; ``lat_deg`` / ``lon_deg``: WGS84;
    ``alt_amsl_m``: altitude above mean sea level; ``relative_alt_m``: above home;
    ``speed_m_s``: ground speed; ``current_seq``: the current mission item as numbered on
    the wire (-1: unknown); ``mode``: the flight mode's name per sample (empty: unknown).
    ``source`` says where it comes from (``"simulate px4"``, ``"fly udpout:..."``).
    """

    time_s: NDArray[np.float64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    alt_amsl_m: NDArray[np.float64]
    relative_alt_m: NDArray[np.float64]
    speed_m_s: NDArray[np.float64]
    current_seq: NDArray[np.int64]
    mode: tuple[str, ...] = ()
    source: str = ""
    autopilot: str = ""
    extra: dict[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        floats = ("time_s", "lat_deg", "lon_deg", "alt_amsl_m", "relative_alt_m", "speed_m_s")
        for name in floats:
            object.__setattr__(self, name, _column(getattr(self, name), np.float64, name))
        object.__setattr__(self, "current_seq", _column(self.current_seq, np.int64, "seq"))
        n = len(self.time_s)
        for name in (*floats, "current_seq"):
            if len(getattr(self, name)) != n:
                raise ValueError(
                    f"track column {name} has {len(getattr(self, name))} rows, not {n}"
                )
        mode = tuple(str(m) for m in self.mode) if self.mode else ("",) * n
        if len(mode) != n:
            raise ValueError(f"track column mode has {len(mode)} rows, not {n}")
        object.__setattr__(self, "mode", mode)
        if n and (np.any(np.abs(self.lat_deg) > 90.0) or np.any(np.abs(self.lon_deg) > 180.0)):
            raise ValueError("track latitudes must be within ±90° and longitudes within ±180°")
        if n > 1 and np.any(np.diff(self.time_s) < 0.0):
            raise ValueError("track times must not go backwards")

    def __len__(self) -> int:
        return len(self.time_s)

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0]) if len(self) else 0.0

    def until(self, index: int) -> Track:
        """The first ``index`` samples."""
        return self.between(0, index)

    def since(self, index: int) -> Track:
        """The samples from ``index`` on."""
        return self.between(index, len(self))

    def between(self, start: int, stop: int) -> Track:
        """Samples ``start`` to ``stop - 1`` (their times as they are)."""
        part = slice(start, stop)
        return Track(
            self.time_s[part],
            self.lat_deg[part],
            self.lon_deg[part],
            self.alt_amsl_m[part],
            self.relative_alt_m[part],
            self.speed_m_s[part],
            self.current_seq[part],
            self.mode[part],
            self.source,
            self.autopilot,
            dict(self.extra),
        )

    def gaps(self, max_step_s: float) -> list[tuple[float, float]]:
        """Where the track has no sample for longer than ``max_step_s``: (from, to) in its
        own seconds, the last sample before and the first one after each."""
        return [
            (float(self.time_s[stop - 1]), float(self.time_s[stop]))
            for _start, stop in observed_stretches(self.time_s, max_step_s)[:-1]
        ]

    # -- files ----------------------------------------------------------------------------
    def dumps(self, suffix: str) -> str:
        """The file text for ``suffix`` (``.csv`` or ``.geojson``)."""
        if suffix == ".csv":
            return self._csv()
        if suffix == ".geojson":
            return self._geojson()
        raise ValueError(f"no track format {suffix!r}")

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the track to ``path`` (format from the extension), atomically."""
        atomic_write_text(path, self.dumps(check_track_path(path)))

    def _csv(self) -> str:
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(CSV_COLUMNS)
        for i in range(len(self)):
            writer.writerow(
                (
                    f"{self.time_s[i]:.3f}",
                    f"{self.lat_deg[i]:.8f}",
                    f"{self.lon_deg[i]:.8f}",
                    f"{self.alt_amsl_m[i]:.3f}",
                    f"{self.relative_alt_m[i]:.3f}",
                    f"{self.speed_m_s[i]:.3f}",
                    int(self.current_seq[i]),
                    self.mode[i],
                )
            )
        return out.getvalue()

    def _geojson(self) -> str:
        coords = [
            [round(float(lon), 8), round(float(lat), 8), round(float(alt), 3)]
            for lat, lon, alt in zip(self.lat_deg, self.lon_deg, self.alt_amsl_m, strict=True)
        ]
        properties: dict[str, object] = {
            "name": "flown track",
            "source": self.source,
            "autopilot": self.autopilot,
            **self.extra,
            "time_s": [round(float(t), 3) for t in self.time_s],
            "relative_alt_m": [round(float(z), 3) for z in self.relative_alt_m],
            "speed_m_s": [round(float(v), 3) for v in self.speed_m_s],
            "current_seq": [int(s) for s in self.current_seq],
            "mode": list(self.mode),
        }
        doc = {
            "type": "FeatureCollection",
            "features": [
                {
                    "type": "Feature",
                    "geometry": {"type": "LineString", "coordinates": coords},
                    "properties": properties,
                }
            ],
        }
        return json.dumps(doc, separators=(",", ":")) + "\n"

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Track:
        """Read a track file written by :meth:`save` (or any file of the same shape);
        :class:`TrackFileError` names the file and what is wrong."""
        shown = os.fspath(path)
        suffix = check_track_path(shown)
        try:
            size = os.stat(shown).st_size
            if size > MAX_TRACK_BYTES:
                raise TrackFileError(
                    f"the file is {size} bytes, more than {MAX_TRACK_BYTES}", file=shown
                )
            text = Path(shown).read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as err:
            reason = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
            raise TrackFileError(f"cannot read the track: {reason}", file=shown) from None
        try:
            return cls._from_csv(text) if suffix == ".csv" else cls._from_geojson(text)
        except (ValueError, KeyError, TypeError, IndexError) as err:
            raise TrackFileError(f"not a flown track: {err}", file=shown) from None

    @classmethod
    def _from_csv(cls, text: str) -> Track:
        rows = list(csv.reader(io.StringIO(text)))
        if not rows:
            raise ValueError("the file is empty")
        header = [h.strip() for h in rows[0]]
        missing = [c for c in CSV_COLUMNS[:7] if c not in header]
        if missing:
            raise ValueError(f"missing column(s) {', '.join(missing)}")
        index = {name: header.index(name) for name in header}
        body = [r for r in rows[1:] if r]

        def col(name: str) -> list[str]:
            return [r[index[name]] for r in body]

        def floats(name: str) -> NDArray[np.float64]:
            return np.array([float(v) for v in col(name)], dtype=np.float64)

        return cls(
            time_s=floats("time_s"),
            lat_deg=floats("lat_deg"),
            lon_deg=floats("lon_deg"),
            alt_amsl_m=floats("alt_amsl_m"),
            relative_alt_m=floats("relative_alt_m"),
            speed_m_s=floats("speed_m_s"),
            current_seq=np.array([int(v) for v in col("current_seq")], dtype=np.int64),
            mode=tuple(col("mode")) if "mode" in index else (),
        )

    @classmethod
    def _from_geojson(cls, text: str) -> Track:
        doc = json.loads(text)
        features = doc["features"] if doc.get("type") == "FeatureCollection" else [doc]
        lines = [f for f in features if f["geometry"]["type"] == "LineString"]
        if not lines:
            raise ValueError("no LineString feature")
        feature = lines[0]
        coords = feature["geometry"]["coordinates"]
        props = feature.get("properties") or {}
        n = len(coords)

        def numbers(name: str, default: float) -> NDArray[np.float64]:
            values = props.get(name)
            listed = [default] * n if values is None else [float(v) for v in values]
            return np.array(listed, dtype=np.float64)

        def axis(k: int) -> NDArray[np.float64]:
            return np.array([float(c[k]) for c in coords], dtype=np.float64)

        known = {"time_s", "relative_alt_m", "speed_m_s", "current_seq", "mode", "source"}
        known |= {"autopilot", "name"}
        return cls(
            time_s=numbers("time_s", math.nan) if "time_s" in props else np.arange(n, dtype=float),
            lat_deg=axis(1),
            lon_deg=axis(0),
            alt_amsl_m=axis(2),
            relative_alt_m=numbers("relative_alt_m", math.nan),
            speed_m_s=numbers("speed_m_s", 0.0),
            current_seq=np.array([int(v) for v in props.get("current_seq", [-1] * n)]),
            mode=tuple(str(m) for m in props.get("mode", [])),
            source=str(props.get("source", "")),
            autopilot=str(props.get("autopilot", "")),
            extra={k: v for k, v in props.items() if k not in known},
        )


def observed_stretches(time_s: ArrayLike, max_step_s: float) -> list[tuple[int, int]]:
    """The stretches of sample times ``time_s`` (ascending) with no step longer than
    ``max_step_s``: index ranges ``(start, stop)``, ``stop`` exclusive, in order, covering
    every sample (a lone sample between two gaps is a stretch of one). Between two stretches
    nothing was observed: a line drawn across that step would be a guess."""
    t = np.asarray(time_s, dtype=np.float64).reshape(-1)
    if not len(t):
        return []
    cuts = np.flatnonzero(np.diff(t) > max_step_s) + 1
    bounds = [0, *(int(c) for c in cuts), len(t)]
    return list(itertools.pairwise(bounds))
