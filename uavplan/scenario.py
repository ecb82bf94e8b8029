"""Scenario and map files (SPEC §2): the only YAML reader of the project.

:meth:`Scenario.from_file` loads a scenario, merges the map it names, checks every key and
returns frozen, validated values. Any problem raises :class:`~uavplan.errors.ScenarioError`
naming the file, the key path (``obstacles[2].radius``) and the reason.

Hostile or broken files end in that one error too: the file is read as bytes and must be UTF-8
(a UTF-8 byte-order mark is accepted, UTF-16/32 are refused by name), duplicate keys are
refused, the document may hold at most :data:`MAX_YAML_NODES` values once aliases are
expanded and nest at most :data:`MAX_YAML_DEPTH` deep, every number has documented bounds,
and a scenario whose path grid or search is larger than the documented limits
(:func:`problem_size`) is refused before planning. The planner's own values are checked by
:func:`uavplan.config.build`, the project's one configuration validator.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import itertools
import json
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, NamedTuple

import yaml  # type: ignore[import-untyped]

from uavplan.config import (
    PLANNER_KEYS,
    PLANNERS,
    Autopilot,
    ConfigError,
    EnergyWeights,
    GridSpec,
    PlannerConfig,
    PostParams,
    SearchParams,
    build,
    build_params,
    key_text,
    override,
    planner_entry,
    resolved_planner,
    short_repr,
    type_name,
)
from uavplan.errors import ScenarioError
from uavplan.geo import GeoPoint
from uavplan.limits import (
    MAX_ALTITUDE_M,
    MAX_HORIZONTAL_M,
    MAX_OBSTACLES,
    MAX_POLYGON_VERTICES,
    MAX_SIZE_M,
)
from uavplan.obstacles import (
    Bounds,
    BoxObstacle,
    CylinderObstacle,
    Ground,
    Obstacle,
    PrismObstacle,
)

__all__ = [
    "MissionConfig",
    "PlannerConfig",
    "Scenario",
    "VehicleConfig",
    "check_limits",
    "load_map",
    "load_scenario",
    "problem_size",
    "resolved_config",
    "with_search",
]

# ---------------------------------------------------------------------------------------------
# Documented limits (docs/scenario-format.md, "Limits")

#: largest scenario or map file read, bytes
MAX_FILE_BYTES = 32 * 1024 * 1024
#: most values (scalars, lists, mappings) in one document once aliases are expanded
MAX_YAML_NODES = 5_000_000
#: deepest nesting of lists and mappings
MAX_YAML_DEPTH = 64
# (the limits on coordinates, heights, obstacle counts and polygon sizes live in
# uavplan.limits: source files and .plan fences obey them too)
#: via points in one scenario
MAX_VIA_POINTS = 1_000
#: safety margin at most this, metres
MAX_SAFETY_MARGIN_M = 10_000.0
#: a name at most this many characters; a map path at most PATH_MAX / NAME_MAX
MAX_NAME_CHARS = 200
MAX_PATH_CHARS = 4096
MAX_PATH_PART_CHARS = 255
#: the path grid over the flight volume (columns × lateral × vertical cells, the grid a global
#: search over the bounds uses: ~70 bytes a cell) at most this many cells
MAX_GRID_CELLS = 50_000_000
#: population × iterations × path columns (node updates of one search) at most this many
MAX_SEARCH_WORK = 2_000_000_000
#: samples of the smoothed route (twice the start-goal distance / post.sample_step_m)
MAX_ROUTE_SAMPLES = 10_000_000


@dataclass(frozen=True)
class VehicleConfig:
    cruise_speed_m_s: float | None = None
    takeoff_altitude_m: float | None = None  # None: the start point's height


@dataclass(frozen=True)
class MissionConfig:
    autopilot: Autopilot = Autopilot.ARDUPILOT
    spacing_m: float = 60.0
    end: str = "rtl"  # rtl | land | none
    #: waypoint altitudes: relative (above home, MAV_FRAME_GLOBAL_RELATIVE_ALT), amsl
    #: (MAV_FRAME_GLOBAL) or terrain (above the ground beneath, MAV_FRAME_GLOBAL_TERRAIN_ALT)
    altitude: str = "relative"


@dataclass(frozen=True)
class Scenario:
    name: str
    origin: GeoPoint
    bounds: Bounds
    start_m: tuple[float, float, float]
    goal_m: tuple[float, float, float]
    obstacles: tuple[Obstacle, ...]
    safety_margin_m: float = 10.0
    vehicle: VehicleConfig = field(default_factory=VehicleConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    source: str | None = None
    #: points the route passes through, in order, between start and goal (ENU m)
    via_m: tuple[tuple[float, float, float], ...] = ()
    #: the DEM GeoTIFF named by ``terrain`` (resolved path), or None over flat ground
    terrain_file: str | None = None
    #: with terrain: the ground under the world. Every z of this scenario (start, goal, via,
    #: obstacle tops, bounds) is then metres above ``ground.datum_amsl_m`` (= ``origin.alt``),
    #: converted at load time from the file's heights above the ground beneath each point.
    ground: Ground | None = None

    @classmethod
    def from_file(cls, path: str | Path) -> Scenario:
        return load_scenario(path)

    def with_planner(self, **changes: Any) -> Scenario:
        """A copy whose planner config has ``changes`` (CLI overrides): any
        :class:`PlannerConfig` field, plus ``spsa=SpsaParams(...)`` (SPSA's section) and
        ``options={...}`` (the section of the resulting algorithm, validated)."""
        cfg = self.planner
        spsa = changes.pop("spsa", None)
        options = changes.pop("options", None)
        if "algorithm" in changes:
            planner_entry(changes["algorithm"], "--algorithm")
        cfg = replace(cfg, **changes)
        if spsa is not None:
            cfg = cfg.with_params("spsa", spsa)
        if options is not None:
            params = build_params(cfg.algorithm, dict(options), cfg.algorithm)
            cfg = cfg.with_params(cfg.algorithm, params) if params is not None else cfg
        return replace(self, planner=cfg)


def with_search(scenario: Scenario, changes: Mapping[str, Any], key: str = "") -> Scenario:
    """``scenario`` with command-line overrides of its search values (``{"iterations": 5}``),
    validated by :func:`uavplan.config.override` (ConfigError naming ``key``, e.g.
    ``--iterations``) and re-checked against the size limits (:func:`check_limits`)."""
    changes = {k: v for k, v in changes.items() if v is not None}
    if not changes:
        return scenario
    try:
        search = override(scenario.planner.search, changes)
    except ConfigError as err:
        raise ConfigError(err.reason, key=key or err.key) from None
    out = scenario.with_planner(search=search)
    check_limits(out)
    return out


def resolved_config(scenario: Scenario | PlannerConfig, algorithm: str | None = None) -> dict:
    """The whole resolved configuration of a run of ``algorithm`` (default: the configured
    one), JSON-able: every search value (with the effective fitness smoothing), the
    algorithm's own parameters, grid, energy, post-processing, margin and margin pad, and for a
    scenario its geometry summary and mission settings — enough to reproduce the run."""
    if isinstance(scenario, PlannerConfig):
        return {"planner": resolved_planner(scenario, algorithm)}
    scn = scenario
    return {
        "scenario": scn.name,
        "source": scn.source,
        "origin": {"lat": scn.origin.lat_deg, "lon": scn.origin.lon_deg, "alt": scn.origin.alt_m},
        "bounds": {"x": list(scn.bounds.x_m), "y": list(scn.bounds.y_m), "z": list(scn.bounds.z_m)},
        "start": list(scn.start_m),
        "goal": list(scn.goal_m),
        "obstacles": len(scn.obstacles),
        "safety_margin_m": scn.safety_margin_m,
        "planner": resolved_planner(scn.planner, algorithm),
        "vehicle": {
            "cruise_speed_m_s": scn.vehicle.cruise_speed_m_s,
            "takeoff_altitude_m": scn.vehicle.takeoff_altitude_m,
        },
        "mission": {
            "autopilot": scn.mission.autopilot.name.lower(),
            "spacing_m": scn.mission.spacing_m,
            "end": scn.mission.end,
        },
    }


# ---------------------------------------------------------------------------------------------
# Loading


_SCENARIO_KEYS = {
    "name",
    "origin",
    "bounds",
    "start",
    "goal",
    "via",
    "map",
    "obstacles",
    "safety_margin",
    "vehicle",
    "planner",
    "mission",
    "obstacle_files",
    "terrain",
}
_MAP_KEYS = {"name", "origin", "bounds", "obstacles", "obstacle_files", "terrain"}
ALTITUDE_MODES = ("relative", "amsl", "terrain")
#: the terrain is held as solids about this wide (m; fewer where that would exceed 40,000)
TERRAIN_CELL_M = 20.0


class _Checker:
    """Small typed accessors that raise ScenarioError with file and key path."""

    def __init__(self, file: str) -> None:
        self.file = file

    def fail(self, key: str, reason: str) -> ScenarioError:
        return ScenarioError(reason, file=self.file, key=key or "(top level)")

    def config(self, err: ConfigError) -> ScenarioError:
        return self.fail(err.key or "", err.reason)

    def mapping(
        self, value: Any, key: str, allowed: set[str], required: Sequence[str] = ()
    ) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.fail(key, f"must be a mapping, got {_type_name(value)}")
        for k in value:
            if not isinstance(k, str):
                raise self.fail(key, f"keys must be strings, got {short_repr(k)}")
            if k not in allowed:
                hint = f" (allowed: {', '.join(sorted(allowed))})"
                raise self.fail(_join(key, key_text(k)), f"unknown key{hint}")
        for k in sorted(required):
            if k not in value:
                raise self.fail(_join(key, k), "missing required key")
        return value

    def number(
        self,
        value: Any,
        key: str,
        *,
        minimum: float | None = None,
        strict: bool = False,
        maximum: float | None = None,
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {_type_name(value)}")
        if isinstance(value, int) and abs(value) > 1e300:
            raise self.fail(key, f"is out of range, got {short_repr(value)}")
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(key, "must be a finite number")
        if minimum is not None:
            if strict and value <= minimum:
                raise self.fail(key, f"must be > {minimum:g}, got {value:g}")
            if not strict and value < minimum:
                raise self.fail(key, f"must be >= {minimum:g}, got {value:g}")
        if maximum is not None and value > maximum:
            raise self.fail(key, f"must be <= {maximum:g}, got {value:g}")
        return value

    def coordinate(self, value: Any, key: str) -> float:
        v = self.number(value, key)
        if abs(v) > MAX_HORIZONTAL_M:
            raise self.fail(key, f"must be within ±{MAX_HORIZONTAL_M:g} m, got {v:g}")
        return v

    def string(self, value: Any, key: str, choices: Sequence[str] | None = None) -> str:
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string, got {_type_name(value)}")
        if choices is not None and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}, got {short_repr(value)}")
        return value

    def vector(self, value: Any, key: str, n: int) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != n:
            raise self.fail(key, f"must be a list of {n} numbers, got {_short(value)}")
        return tuple(self.number(v, f"{key}[{i}]") for i, v in enumerate(value))

    def point(self, value: Any, key: str, n: int) -> tuple[float, ...]:
        """A vector of ``n`` coordinates: x, y within ±MAX_HORIZONTAL_M, z within
        [-MAX_ALTITUDE_M, MAX_ALTITUDE_M]."""
        vec = self.vector(value, key, n)
        for i, v in enumerate(vec):
            limit = MAX_HORIZONTAL_M if i < 2 else MAX_ALTITUDE_M
            if abs(v) > limit:
                raise self.fail(f"{key}[{i}]", f"must be within ±{limit:g} m, got {v:g}")
        return vec


def _join(key: str, sub: str) -> str:
    return f"{key}.{sub}" if key else sub


def _type_name(value: Any) -> str:
    return type_name(value)


def _short(value: Any) -> str:
    return short_repr(value)


# ---------------------------------------------------------------------------------------------
# YAML


_BaseLoader: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_BaseLoader):  # type: ignore[misc,valid-type]
    """The safe loader (libyaml's when present) refusing duplicate keys."""

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=False)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:
                    continue  # unhashable: the base class says so
                if duplicate:
                    mark = key_node.start_mark
                    raise _DuplicateKey(key, mark.line + 1, mark.column + 1)
        return super().construct_mapping(node, deep=deep)


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _Loader.construct_mapping)


class _DuplicateKey(Exception):
    def __init__(self, key: Any, line: int, column: int) -> None:
        self.key, self.line, self.column = key, line, column


def _decode(data: bytes, file: str, what: str) -> str:
    """The file's text: UTF-8 (a leading byte-order mark is dropped); anything else is a
    clear error."""
    boms = (
        (b"\xff\xfe\x00\x00", "UTF-32"),
        (b"\x00\x00\xfe\xff", "UTF-32"),
        (b"\xff\xfe", "UTF-16"),
        (b"\xfe\xff", "UTF-16"),
    )
    for bom, name in boms:
        if data.startswith(bom):
            raise ScenarioError(f"the {what} file is {name} encoded; save it as UTF-8", file=file)
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data.count(b"\n", 0, err.start) + 1
        raise ScenarioError(
            f"the {what} file is not UTF-8 text (byte 0x{data[err.start]:02x} on line {line}); "
            "save it as UTF-8",
            file=file,
        ) from None


def _read_yaml(path: Path, what: str) -> Any:
    file = str(path)
    try:
        with open(path, "rb") as handle:
            data = handle.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise ScenarioError(f"{what} file not found", file=file) from None
    except IsADirectoryError:
        raise ScenarioError(f"the {what} file is a directory", file=file) from None
    except OSError as err:
        raise ScenarioError(f"cannot read {what} file: {err.strerror or err}", file=file) from None
    if len(data) > MAX_FILE_BYTES:
        raise ScenarioError(
            f"the {what} file is larger than {MAX_FILE_BYTES // (1024 * 1024)} MiB", file=file
        )
    text = _decode(data, file, what)
    fast = _load_fast(text, file)
    if fast is not None:
        return fast
    return _load_full(text, file, what)


def _load_full(text: str, file: str, what: str) -> Any:
    """The document through PyYAML's safe loader (libyaml's parser when present), refusing
    duplicate keys, with the size limits checked: the reference every fast path must match."""
    try:
        data_ = yaml.load(text, Loader=_Loader)
    except _DuplicateKey as err:
        raise ScenarioError(
            f"invalid YAML: line {err.line}, column {err.column}: duplicate key "
            f"{short_repr(err.key)}",
            file=file,
        ) from None
    except yaml.YAMLError as err:
        if _nesting_exceeds(text, MAX_YAML_DEPTH):  # the parser's own limit, in its words
            raise ScenarioError(
                f"invalid YAML: nested more than {MAX_YAML_DEPTH} levels deep", file=file
            ) from None
        mark = getattr(err, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ScenarioError(f"invalid YAML: {where}{problem}", file=file) from None
    except RecursionError:
        raise ScenarioError(
            f"invalid YAML: nested more than {MAX_YAML_DEPTH} levels deep", file=file
        ) from None
    except (ValueError, OverflowError) as err:  # e.g. an integer of more than 4300 digits
        raise ScenarioError(f"invalid YAML: {short_repr(str(err))}", file=file) from None
    if data_ is None:
        raise ScenarioError(f"the {what} file is empty", file=file)
    _check_size(data_, file)
    return data_


# The fast path. PyYAML builds Python objects in pure Python even over libyaml's parser
# (about 0.3 ms an obstacle: 20,000 obstacles took 7-17 s). Generated maps hold long lists
# of one-line flow items under a top-level key:
#
#     obstacles:
#       - {type: box, center: [420, 40], size: [160, 140], height: 180, yaw: 20}
#       - {type: cylinder, center: [850, -60.5], radius: 110, height: 220}  # a comment
#
# Such a list is read by the C JSON parser when every item is in a strict subset on which YAML
# 1.1 (safe loader) and JSON agree: lower-case words that resolve to strings (not yes/no/
# on/off/true/false/null), decimal numbers without exponent, leading zero or "+" (int without
# a dot, float with one), flow sequences of numbers or of such sequences, flow mappings of
# word keys. The list's lines are blanked and the rest of the document goes through the full
# loader, which must show the key at that line with an empty value, nothing else between it
# and the next top-level key. Any doubt (another shape, a duplicate key, an error anywhere,
# the size limits) means the whole file goes through the full loader, so the result and
# every error message are the full loader's (tests/test_fast_yaml.py checks equivalence).

_NUM = r"-?(?:0|[1-9][0-9]*)(?:\.[0-9]+)?"
_WORD = r"(?!(?:yes|no|true|false|on|off|null)(?![a-z0-9_]))[a-z_][a-z0-9_]*"
_SEQ1 = rf"\[ *{_NUM}(?: *, *{_NUM})* *\]"
_SEQ2 = rf"\[ *{_SEQ1}(?: *, *{_SEQ1})* *\]"
_PAIR = rf"{_WORD}: +(?:{_NUM}|{_WORD}|{_SEQ1}|{_SEQ2})"
_MAP = rf"\{{ *{_PAIR}(?: *, *{_PAIR})* *\}}"


class _FastPatterns(NamedTuple):
    item_line: re.Pattern[str]
    key_line: re.Pattern[str]
    skip_line: re.Pattern[str]
    #: splits a fast list at its words (kept at the odd places): joining with '"' quotes them
    json_word_split: re.Pattern[str]


@functools.cache
def _fast_patterns() -> _FastPatterns:
    """Compiled on first use: a few milliseconds that a small scenario never needs."""
    return _FastPatterns(
        re.compile(rf"( *)- +({_MAP}|{_SEQ1}|{_SEQ2})(?: +#[^\n]*)? *"),
        re.compile(rf"({_WORD}): *(?: #[^\n]*)?"),
        re.compile(r" *(?:#[^\n]*)?"),
        re.compile(r"([a-z_][a-z0-9_]*)"),
    )


#: lists shorter than this stay with the full loader (nothing to gain)
_FAST_MIN_ITEMS = 16


class _NotFast(Exception):
    pass


def _json_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out = dict(pairs)
    if len(out) != len(pairs):
        raise _NotFast  # a duplicate key: the full loader says where
    return out


def _fast_blocks(lines: list[str]) -> list[tuple[int, int, str, list[str]]]:
    """(key line, end line, key, flow items) of every top-level ``key:`` whose value is a
    block list of fast items (blank and comment lines allowed between them) ending at the
    end of the file or at a line starting in column 0 with something else."""
    pat = _fast_patterns()
    blocks = []
    n = len(lines)
    i = 0
    while i < n:
        line = lines[i]
        key = pat.key_line.fullmatch(line) if line[:1].islower() or line[:1] == "_" else None
        if key is None:
            i += 1
            continue
        j, indent, items = i + 1, None, []
        while j < n:
            item = pat.item_line.fullmatch(lines[j])
            if item is not None:
                if indent is None:
                    indent = item.group(1)
                elif item.group(1) != indent:
                    break
                items.append(item.group(2))
            elif pat.skip_line.fullmatch(lines[j]) is None:
                break
            j += 1
        ends = j == n or lines[j][:1] not in ("", " ", "\t", "-", "#")
        if len(items) >= _FAST_MIN_ITEMS and ends:
            blocks.append((i, j, key.group(1), items))
        i = max(j, i + 1)
    return blocks


def _load_fast(text: str, file: str) -> dict[str, Any] | None:
    """The document with its long flow-item lists read as JSON; None when the file does not
    qualify or anything is in doubt (the caller then uses the full loader)."""
    if len(text) > MAX_YAML_NODES or any(c in text for c in "\r\x85\u2028\u2029"):
        return None  # the node-count bound below needs the length; other line breaks
    if text.count("- ") < _FAST_MIN_ITEMS:
        return None  # every fast item line has one: too few to make a fast list
    lines = text.split("\n")
    blocks = _fast_blocks(lines)
    if not blocks:
        return None
    try:
        values = {}
        fast_nodes = 0
        for first, end, key, items in blocks:
            for k in range(first + 1, end):
                lines[k] = ""
            flow = ",".join(items)
            # nodes in the list: collections + (elements and pairs) + keys
            collections = flow.count("[") + flow.count("{")
            fast_nodes += collections + flow.count(",") + 1 + flow.count(":")
            js = "[" + '"'.join(_fast_patterns().json_word_split.split(flow)) + "]"
            values[first] = (key, json.loads(js, object_pairs_hook=_json_pairs))
        loader = _Loader("\n".join(lines))
        try:
            root = loader.get_single_node()
            if not isinstance(root, yaml.MappingNode):
                return None
            pairs = root.value
            lines_of_keys = [k.start_mark.line for k, _ in pairs]
            for first, end, key, _ in blocks:
                at = lines_of_keys.index(first) if first in lines_of_keys else -1
                if at < 0:
                    return None
                knode, vnode = pairs[at]
                if (
                    not isinstance(knode, yaml.ScalarNode)
                    or knode.value != key
                    or knode.start_mark.column != 0
                    or knode.style not in (None, "")
                    or not isinstance(vnode, yaml.ScalarNode)
                    or vnode.tag != "tag:yaml.org,2002:null"
                    or vnode.value != ""
                    or (at + 1 < len(pairs) and lines_of_keys[at + 1] < end)
                ):
                    return None
            doc = loader.construct_document(root)
        finally:
            loader.dispose()
        if not isinstance(doc, dict) or _check_size(doc, file) + fast_nodes > MAX_YAML_NODES:
            return None
        for key, value in values.values():
            if key not in doc or doc[key] is not None:
                return None
            doc[key] = value
        return doc
    except Exception:  # any doubt: the full loader decides and reports
        return None


def _nesting_exceeds(text: str, limit: int) -> bool:
    """Whether the document opens more than `limit` nested collections. Asked only once the
    parser has refused the text: libyaml has a nesting limit of its own (1,000 in PyYAML
    6.0.4's wheels), reported in its own words, which are not ours to repeat or to match.
    PyYAML's pure-Python parser has no such limit and streams its events, so it stops here as
    soon as the limit is passed."""
    depth = 0
    try:
        for event in yaml.parse(text, Loader=yaml.SafeLoader):
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > limit:
                    return True
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
    except yaml.YAMLError:
        pass
    return False


def _check_size(doc: Any, file: str) -> int:
    """Refuse documents nested deeper than MAX_YAML_DEPTH, with more than MAX_YAML_NODES
    values once aliases are expanded (a "billion laughs" file), or that contain themselves.
    Returns the number of values."""
    sizes: dict[int, int] = {}
    active: set[int] = set()

    def size(value: Any, depth: int) -> int:
        if not isinstance(value, list | dict):
            return 1
        ident = id(value)
        known = sizes.get(ident)
        if known is not None:
            return known
        if ident in active:
            raise ScenarioError("invalid YAML: an alias refers to its own anchor", file=file)
        if depth > MAX_YAML_DEPTH:
            raise ScenarioError(
                f"invalid YAML: nested more than {MAX_YAML_DEPTH} levels deep", file=file
            )
        active.add(ident)
        items = value if isinstance(value, list) else [*value.keys(), *value.values()]
        total = 1
        for item in items:
            total += size(item, depth + 1)
            if total > MAX_YAML_NODES:
                raise ScenarioError(
                    f"the file holds more than {MAX_YAML_NODES:,} values once its aliases are "
                    "expanded",
                    file=file,
                )
        active.discard(ident)
        sizes[ident] = total
        return total

    return size(doc, 0)


def _obstacle(chk: _Checker, raw: Any, key: str) -> Obstacle:
    if not isinstance(raw, Mapping):
        raise chk.fail(key, f"must be a mapping, got {_type_name(raw)}")
    kind = raw.get("type")
    if kind is None:
        raise chk.fail(_join(key, "type"), "missing required key (box, cylinder or prism)")
    kind = chk.string(kind, _join(key, "type"), ("box", "cylinder", "prism"))
    if kind == "box":
        chk.mapping(
            raw, key, {"type", "center", "size", "height", "yaw"}, ("center", "size", "height")
        )
        center = chk.point(raw["center"], _join(key, "center"), 2)
        size = chk.vector(raw["size"], _join(key, "size"), 2)
        for i, v in enumerate(size):
            if not 0 < v <= MAX_SIZE_M:
                raise chk.fail(f"{key}.size[{i}]", f"must be > 0 and <= {MAX_SIZE_M:g}, got {v:g}")
        height = _height(chk, raw["height"], _join(key, "height"))
        yaw = chk.number(raw.get("yaw", 0.0), _join(key, "yaw"), minimum=-360.0, maximum=360.0)
        return BoxObstacle((center[0], center[1]), (size[0], size[1]), height, yaw)
    if kind == "cylinder":
        chk.mapping(
            raw, key, {"type", "center", "radius", "height"}, ("center", "radius", "height")
        )
        center = chk.point(raw["center"], _join(key, "center"), 2)
        radius = chk.number(
            raw["radius"], _join(key, "radius"), minimum=0, strict=True, maximum=MAX_SIZE_M
        )
        height = _height(chk, raw["height"], _join(key, "height"))
        return CylinderObstacle((center[0], center[1]), radius, height)
    chk.mapping(raw, key, {"type", "polygon", "height"}, ("polygon", "height"))
    poly_raw = raw["polygon"]
    pkey = _join(key, "polygon")
    if not isinstance(poly_raw, list) or len(poly_raw) < 3:
        raise chk.fail(pkey, f"must be a list of at least 3 [x, y] points, got {_short(poly_raw)}")
    if len(poly_raw) > MAX_POLYGON_VERTICES + 1:
        raise chk.fail(pkey, f"has {len(poly_raw)} points (at most {MAX_POLYGON_VERTICES})")
    poly = [chk.point(p, f"{pkey}[{i}]", 2) for i, p in enumerate(poly_raw)]
    if len(poly) > 3 and poly[0] == poly[-1]:
        poly = poly[:-1]  # tolerate a closed ring
    if len(poly) > MAX_POLYGON_VERTICES:
        raise chk.fail(pkey, f"has {len(poly)} points (at most {MAX_POLYGON_VERTICES})")
    area = _signed_area(poly)
    if abs(area) < 1e-6:
        raise chk.fail(pkey, "polygon has zero area")
    if _self_intersects(poly):
        raise chk.fail(pkey, "polygon edges cross each other")
    if area < 0:
        poly = poly[::-1]
    height = _height(chk, raw["height"], _join(key, "height"))
    return PrismObstacle(tuple((p[0], p[1]) for p in poly), height)


def _height(chk: _Checker, raw: Any, key: str) -> float:
    return chk.number(raw, key, minimum=0, strict=True, maximum=MAX_ALTITUDE_M)


def _signed_area(poly: Sequence[Sequence[float]]) -> float:
    nxt = [*poly[1:], poly[0]]
    return 0.5 * sum(a[0] * b[1] - b[0] * a[1] for a, b in zip(poly, nxt, strict=True))


def _self_intersects(poly: Sequence[Sequence[float]]) -> bool:
    """Do two non-adjacent edges of the closed ring ``poly`` cross properly? All pairs at once
    (numpy; a 1,000-vertex ring is a million pairs, a few tens of milliseconds)."""
    import numpy as np

    n = len(poly)
    if n < 4:
        return False
    if n <= 16:
        return _self_intersects_small(poly)
    a = np.asarray(poly, dtype=np.float64)
    b = np.roll(a, -1, axis=0)

    def cross(o: Any, p: Any, q: Any) -> Any:
        return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (
            q[..., 0] - o[..., 0]
        )

    ai, bi = a[:, None, :], b[:, None, :]  # edge i
    cj, dj = a[None, :, :], b[None, :, :]  # edge j
    d1, d2 = cross(cj, dj, ai), cross(cj, dj, bi)
    d3, d4 = cross(ai, bi, cj), cross(ai, bi, dj)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    i, j = np.triu_indices(n, k=2)
    keep = ~((i == 0) & (j == n - 1))  # the first and last edges share a vertex
    return bool(crossing[i[keep], j[keep]].any())


def _self_intersects_small(poly: Sequence[Sequence[float]]) -> bool:
    """:func:`_self_intersects` for a few vertices (a plain loop is faster there)."""
    n = len(poly)
    for i in range(n):
        (ax, ay), (bx, by) = poly[i], poly[(i + 1) % n]
        for j in range(i + 2, n - 1 if i == 0 else n):
            (cx, cy), (dx, dy) = poly[j], poly[(j + 1) % n]
            # the same products as cross(o, p, q) = (p - o) × (q - o), in the same order
            d1 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
            d2 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
            if d1 * d2 < 0:
                d3 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
                d4 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
                if d3 * d4 < 0:
                    return True
    return False


def _origin(chk: _Checker, raw: Any) -> GeoPoint:
    chk.mapping(raw, "origin", {"lat", "lon", "alt"}, ("lat", "lon"))
    lat = chk.number(raw["lat"], "origin.lat")
    lon = chk.number(raw["lon"], "origin.lon")
    alt = chk.number(raw.get("alt", 0.0), "origin.alt")
    if not -90.0 <= lat <= 90.0:
        raise chk.fail("origin.lat", f"must be within [-90, 90] degrees, got {lat:g}")
    if abs(lat) > 89.9:
        raise chk.fail("origin.lat", "too close to a pole for a local ENU frame")
    if not -180.0 <= lon <= 180.0:
        raise chk.fail("origin.lon", f"must be within [-180, 180] degrees, got {lon:g}")
    if not -500.0 <= alt <= 10000.0:
        raise chk.fail("origin.alt", f"must be within [-500, 10000] m AMSL, got {alt:g}")
    return GeoPoint(lat, lon, alt)


def _bounds(chk: _Checker, raw: Any) -> Bounds:
    chk.mapping(raw, "bounds", {"x", "y", "z"}, ("x", "y", "z"))
    out = []
    for axis in ("x", "y", "z"):
        lo, hi = chk.vector(raw[axis], f"bounds.{axis}", 2)
        limit = MAX_ALTITUDE_M if axis == "z" else MAX_HORIZONTAL_M
        for v in (lo, hi):
            if abs(v) > limit:
                raise chk.fail(f"bounds.{axis}", f"must be within ±{limit:g} m, got {v:g}")
        if not lo < hi:
            raise chk.fail(f"bounds.{axis}", f"needs min < max, got [{lo:g}, {hi:g}]")
        out.append((lo, hi))
    if out[2][0] < 0:
        raise chk.fail("bounds.z", "must not go below the ground (z = 0)")
    return Bounds(*out)


#: ``planner:`` keys that fill :class:`SearchParams`
_SEARCH_KEYS = (
    "population",
    "iterations",
    "seed",
    "t_max",
    "init_half_window",
    "fitness_smoothing",
    "stall_iterations",
    "restart_stall_iterations",
)


def _planner(chk: _Checker, raw: Any) -> PlannerConfig:
    """The ``planner:`` section: shared search values at its top level, ``grid``, ``energy``,
    ``post``, and one section per planner named after it (``spsa:``, ``de:``, ...). The old
    ``options:`` key is the section of ``algorithm``."""
    allowed = set(PLANNER_KEYS) | set(PLANNERS)
    chk.mapping(raw, "planner", allowed)
    try:
        algorithm = "spsa"
        if "algorithm" in raw:
            value = raw["algorithm"]
            if not isinstance(value, str):
                raise ConfigError(f"must be a string, got {_type_name(value)}", key="algorithm")
            algorithm = planner_entry(value, "algorithm").name
        search = build(SearchParams, {k: raw[k] for k in _SEARCH_KEYS if k in raw}, "")
        grid = build(GridSpec, raw.get("grid", {}), "grid")
        energy = build(EnergyWeights, raw.get("energy", {}), "energy")
        post = build(PostParams, raw.get("post", {}), "post")
        sections: dict[str, Any] = {}
        for name in PLANNERS:
            if name in raw:
                params = build_params(name, raw[name], name)
                if params is not None and params != PLANNERS[name].params():  # type: ignore[misc]
                    sections[name] = params
        if "options" in raw:
            if algorithm in raw:
                raise ConfigError(
                    f"give the {algorithm} parameters in planner.{algorithm} or in "
                    "planner.options, not both",
                    key="options",
                )
            params = build_params(algorithm, raw["options"], "options")
            if params is not None and params != PLANNERS[algorithm].params():  # type: ignore[misc]
                sections[algorithm] = params
    except ConfigError as err:
        raise chk.config(err.under("planner")) from None
    return PlannerConfig(algorithm, search, grid, energy, post, sections)


def _vehicle(chk: _Checker, raw: Any) -> VehicleConfig:
    chk.mapping(raw, "vehicle", {"cruise_speed", "takeoff_altitude"})
    speed = raw.get("cruise_speed")
    if speed is not None:
        speed = chk.number(speed, "vehicle.cruise_speed", minimum=0, strict=True, maximum=100)
    takeoff = raw.get("takeoff_altitude")
    if takeoff is not None:
        takeoff = chk.number(
            takeoff, "vehicle.takeoff_altitude", minimum=0, strict=True, maximum=MAX_ALTITUDE_M
        )
    return VehicleConfig(speed, takeoff)


def _mission(chk: _Checker, raw: Any) -> MissionConfig:
    chk.mapping(raw, "mission", {"autopilot", "spacing", "end", "altitude"})
    autopilot = MissionConfig.autopilot
    if "autopilot" in raw:
        name = chk.string(raw["autopilot"], "mission.autopilot", ("px4", "ardupilot"))
        autopilot = Autopilot.from_name(name)
    spacing = MissionConfig.spacing_m
    if "spacing" in raw:
        spacing = chk.number(raw["spacing"], "mission.spacing", minimum=1.0, maximum=100_000.0)
    end = MissionConfig.end
    if "end" in raw:
        end = chk.string(raw["end"], "mission.end", ("rtl", "land", "none"))
    altitude = MissionConfig.altitude
    if "altitude" in raw:
        altitude = chk.string(raw["altitude"], "mission.altitude", ALTITUDE_MODES)
    return MissionConfig(autopilot, spacing, end, altitude)


@contextlib.contextmanager
def _no_gc() -> Iterator[None]:
    """Pause the cyclic garbage collector while a file's values are built: the hundreds of
    thousands of new lists and dicts of a large map trigger full collections that make
    loading grow faster than the file (20,000 obstacles: 0.9 s -> 0.6 s). They hold no
    cycles; the collector is restarted (if it was running) whatever happens."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def load_map(path: str | Path) -> tuple[GeoPoint | None, Bounds | None, tuple[Obstacle, ...]]:
    """Read a map file: (origin, bounds, obstacles); missing sections are ``None`` / empty."""
    return _load_map(path)[:3]


def _load_map(
    path: str | Path,
) -> tuple[GeoPoint | None, Bounds | None, tuple[Obstacle, ...], Any]:
    """:func:`load_map` plus the map's raw ``terrain`` value (None without one)."""
    with _no_gc():
        return _read_map(path)


def _read_map(
    path: str | Path,
) -> tuple[GeoPoint | None, Bounds | None, tuple[Obstacle, ...], Any]:
    path = Path(path)
    chk = _Checker(str(path))
    raw = _read_yaml(path, "map")
    chk.mapping(raw, "", _MAP_KEYS)
    if "name" in raw:
        _name(chk, raw["name"])
    origin = _origin(chk, raw["origin"]) if "origin" in raw else None
    bounds = _bounds(chk, raw["bounds"]) if "bounds" in raw else None
    obstacles = _obstacles(chk, raw.get("obstacles", []))
    if raw.get("obstacle_files"):
        if origin is None:
            raise chk.fail("obstacle_files", "needs origin in the same map file")
        obstacles += _obstacle_files(chk, raw["obstacle_files"], path, origin, bounds)
    return origin, bounds, obstacles, raw.get("terrain")


def _obstacle_files(
    chk: _Checker, raw: Any, path: Path, origin: GeoPoint, bounds: Bounds | None
) -> tuple[Obstacle, ...]:
    """Obstacles of the ``obstacle_files`` list (OSM, GIS files), paths relative to ``path``."""
    from uavplan.geo import EnuFrame
    from uavplan.sources import SourceError, obstacles_from_entries

    try:
        return obstacles_from_entries(raw, path.parent, EnuFrame.at(origin), bounds)
    except SourceError as err:
        raise chk.fail(err.key_path("obstacle_files"), err.reason) from None


def _terrain(chk: _Checker, raw: Any, path: Path, origin: GeoPoint, bounds: Bounds) -> Any:
    """The ``terrain`` DEM (a :class:`~uavplan.sources.dem.Terrain`), resolved next to
    ``path`` and checked to cover the bounds."""
    from uavplan.geo import EnuFrame
    from uavplan.sources.dem import Terrain, TerrainError

    dem = (path.parent / chk.string(raw, "terrain")).resolve()
    try:
        return Terrain.from_file(dem, EnuFrame.at(origin), area_xy_m=(bounds.x_m, bounds.y_m))
    except TerrainError as err:
        raise chk.fail("terrain", f"{dem.name}: {err.reason}") from None


def _on_terrain(chk: _Checker, scn: Scenario, terrain: Any) -> Scenario:
    """``scn`` (heights above the ground beneath each point) moved onto the DEM: every z
    becomes metres above a datum just below the lowest ground in the bounds (the origin's
    altitude from then on), obstacles stand on the ground at their centre and reach down into
    it, and the terrain's solids (:meth:`Terrain.quad_prisms`, raised to the bounds' floor
    where that is above the margin) join the world as a :class:`Ground`."""
    import numpy as np

    from uavplan.geo import EnuFrame
    from uavplan.sources.dem import TerrainError

    b = scn.bounds
    try:
        prisms, tops_amsl, lows_amsl = terrain.quad_prisms(b.x_m, b.y_m, cell_m=TERRAIN_CELL_M)
        posts = terrain.posts_amsl_m
        datum = math.floor(float(np.nanmin(posts))) - 1.0
        origin = GeoPoint(scn.origin.lat_deg, scn.origin.lon_deg, datum)
        terrain = replace(terrain, frame=EnuFrame.at(origin))

        def ground_z(xy: Any) -> Any:
            return terrain.height_m(xy) - datum

        points = np.array([p for _, p in _route_points(scn)], dtype=np.float64)
        under = ground_z(points[:, :2])
        centres = np.array([_centre(o) for o in scn.obstacles], dtype=np.float64).reshape(-1, 2)
        obstacle_ground = ground_z(centres) if len(centres) else np.empty(0)
    except TerrainError as err:
        raise chk.fail("terrain", err.reason) from None
    lift = max(0.0, b.z_m[0] - scn.safety_margin_m)  # the floor above the ground, if higher
    ground = Ground(
        datum_amsl_m=datum,
        prisms_xy=prisms,
        tops_m=tops_amsl - datum + lift,
        height_fn=ground_z,
        ceiling_agl_m=b.z_m[1],
        source=str(terrain.source),
        ceilings_m=lows_amsl - datum + b.z_m[1] + scn.safety_margin_m,
    )
    moved = points.copy()
    moved[:, 2] += under
    obstacles = tuple(
        replace(o, height_m=float(g + o.height_m))
        for o, g in zip(scn.obstacles, obstacle_ground, strict=True)
    )
    top = float(np.max(ground.tops_m)) - lift + b.z_m[1]
    out = replace(
        scn,
        origin=origin,
        bounds=Bounds(b.x_m, b.y_m, (0.0, top)),
        start_m=_xyz(moved[0]),
        via_m=tuple(_xyz(p) for p in moved[1:-1]),
        goal_m=_xyz(moved[-1]),
        obstacles=obstacles,
        ground=ground,
    )
    _check_above_terrain(chk, out, under)
    return out


def _xyz(p: Any) -> tuple[float, float, float]:
    return (float(p[0]), float(p[1]), float(p[2]))


def _centre(o: Obstacle) -> tuple[float, float]:
    if isinstance(o, PrismObstacle):
        xs, ys = zip(*o.polygon_m, strict=True)
        return (sum(xs) / len(xs), sum(ys) / len(ys))
    return o.center_m


def _check_above_terrain(chk: _Checker, scn: Scenario, under: Any) -> None:
    """Every route point keeps the margin from the terrain's solids (the DEM quads up to
    their highest post): a clear error naming the point otherwise."""
    assert scn.ground is not None
    g = scn.ground
    margin = scn.safety_margin_m
    lo = g.prisms_xy.min(axis=1)
    hi = g.prisms_xy.max(axis=1)
    for (key, point), z_ground in zip(_route_points(scn), under, strict=True):
        near = (
            (lo[:, 0] <= point[0] + margin)
            & (hi[:, 0] >= point[0] - margin)
            & (lo[:, 1] <= point[1] + margin)
            & (hi[:, 1] >= point[1] - margin)
        )
        solids = tuple(
            PrismObstacle(tuple((float(x), float(y)) for x, y in xy), float(h))
            for xy, h in zip(g.prisms_xy[near], g.tops_m[near], strict=True)
        )
        clearance, _ = _point_clearance(solids, point)
        agl = point[2] - float(z_ground)
        if clearance < margin - 1e-9:
            raise chk.fail(
                key,
                f"{agl:.1f} m above the ground there is {max(clearance, 0.0):.1f} m from the "
                f"terrain (needs {margin:g} m safety margin; the terrain is held as DEM cells up "
                "to their highest post): fly higher or move the point",
            )
        if g.ceilings_m is not None and solids:
            import numpy as np

            horizontal = _footprints(solids).horizontal(point[:2])
            below = np.maximum(np.asarray(g.ceilings_m)[near] - point[2], 0.0)
            if float(np.min(np.hypot(horizontal, below))) < margin - 1e-9:
                raise chk.fail(
                    key,
                    f"{agl:.1f} m above the ground there is too close to the ceiling "
                    f"(bounds.z max {g.ceiling_agl_m:g} m above the lowest ground nearby, less "
                    f"the {margin:g} m safety margin): fly lower or raise bounds.z",
                )


def _obstacles(chk: _Checker, raw: Any) -> tuple[Obstacle, ...]:
    if raw is None:
        return ()
    if not isinstance(raw, list):
        raise chk.fail("obstacles", f"must be a list, got {_type_name(raw)}")
    if len(raw) > MAX_OBSTACLES:
        raise chk.fail("obstacles", f"has {len(raw):,} obstacles (at most {MAX_OBSTACLES:,})")
    out = []
    for i, item in enumerate(raw):
        obstacle = _obstacle_fast(item)
        out.append(obstacle if obstacle is not None else _obstacle(chk, item, f"obstacles[{i}]"))
    return tuple(out)


_NUMBER_TYPES = (int, float)
_BOX_KEYS = frozenset(("type", "center", "size", "height", "yaw"))
_CYLINDER_KEYS = frozenset(("type", "center", "radius", "height"))
_PRISM_KEYS = frozenset(("type", "polygon", "height"))


def _xy_fast(value: Any) -> tuple[float, float] | None:
    """``value`` as an (x, y) point when it plainly is one (two ints or floats within
    ±MAX_HORIZONTAL_M), else None."""
    if type(value) is not list or len(value) != 2:
        return None
    x, y = value
    if (
        type(x) in _NUMBER_TYPES
        and type(y) in _NUMBER_TYPES
        and -MAX_HORIZONTAL_M <= x <= MAX_HORIZONTAL_M
        and -MAX_HORIZONTAL_M <= y <= MAX_HORIZONTAL_M
    ):
        return float(x), float(y)
    return None


def _obstacle_fast(raw: Any) -> Obstacle | None:
    """The obstacle :func:`_obstacle` builds from ``raw`` when ``raw`` plainly is a valid one
    (no key paths built, no per-number calls: 20,000 obstacles validate in a fraction of a
    second); None whenever anything is unusual, and :func:`_obstacle` then decides and says
    what is wrong. Both accept the same obstacles and build equal values
    (tests/test_fast_yaml.py)."""
    if type(raw) is not dict:
        return None
    kind: Any = raw.get("type")
    height: Any = raw.get("height")
    if type(height) not in _NUMBER_TYPES or not 0 < height <= MAX_ALTITUDE_M:
        return None
    if kind == "box" and type(kind) is str:
        if not raw.keys() <= _BOX_KEYS or len(raw) < 4:
            return None
        center = _xy_fast(raw.get("center"))
        size = raw.get("size")
        yaw = raw.get("yaw", 0.0)
        if center is None or type(size) is not list or len(size) != 2:
            return None
        sx, sy = size
        if (
            type(sx) in _NUMBER_TYPES
            and type(sy) in _NUMBER_TYPES
            and 0 < sx <= MAX_SIZE_M
            and 0 < sy <= MAX_SIZE_M
            and type(yaw) in _NUMBER_TYPES
            and -360.0 <= yaw <= 360.0
        ):
            return BoxObstacle(center, (float(sx), float(sy)), float(height), float(yaw))
        return None
    if kind == "cylinder" and type(kind) is str:
        if raw.keys() != _CYLINDER_KEYS:
            return None
        center = _xy_fast(raw["center"])
        radius = raw["radius"]
        if center is None or type(radius) not in _NUMBER_TYPES or not 0 < radius <= MAX_SIZE_M:
            return None
        return CylinderObstacle(center, float(radius), float(height))
    if kind == "prism" and type(kind) is str:
        if raw.keys() != _PRISM_KEYS:
            return None
        ring = raw["polygon"]
        if type(ring) is not list or not 3 <= len(ring) <= MAX_POLYGON_VERTICES + 1:
            return None
        poly = [_xy_fast(p) for p in ring]
        if None in poly:
            return None
        if len(poly) > 3 and poly[0] == poly[-1]:
            poly = poly[:-1]  # tolerate a closed ring
        if len(poly) > MAX_POLYGON_VERTICES:
            return None
        area = _signed_area(poly)  # type: ignore[arg-type]
        if abs(area) < 1e-6 or _self_intersects(poly):  # type: ignore[arg-type]
            return None
        if area < 0:
            poly = poly[::-1]
        return PrismObstacle(tuple(poly), float(height))  # type: ignore[arg-type]
    return None


def _name(chk: _Checker, raw: Any) -> str:
    name = chk.string(raw, "name")
    if not name.strip() or len(name) > MAX_NAME_CHARS:
        raise chk.fail("name", f"must be 1 to {MAX_NAME_CHARS} characters")
    if any(ord(c) < 32 or c == "\x7f" for c in name):
        raise chk.fail("name", "must not contain control characters")
    return name


def _map_path(chk: _Checker, raw: Any, scenario: Path) -> Path:
    ref = chk.string(raw, "map")
    if not ref or "\x00" in ref:
        raise chk.fail("map", "must be a file path (not empty, no NUL character)")
    if len(ref) > MAX_PATH_CHARS or any(len(p) > MAX_PATH_PART_CHARS for p in ref.split("/")):
        raise chk.fail(
            "map",
            f"path is too long (at most {MAX_PATH_CHARS} characters, "
            f"{MAX_PATH_PART_CHARS} per name)",
        )
    map_path = scenario.parent / ref
    try:
        if not map_path.is_file():
            raise chk.fail(
                "map", f"map file {short_repr(ref)} not found (looked at {map_path.resolve()})"
            )
        return map_path.resolve()
    except (OSError, ValueError) as err:
        reason = getattr(err, "strerror", None) or str(err)
        raise chk.fail("map", f"cannot open map file {short_repr(ref)}: {reason}") from None


def load_scenario(path: str | Path) -> Scenario:
    """Load and validate a scenario file (and the map it names)."""
    with _no_gc():
        return _load_scenario(path)


def _load_scenario(path: str | Path) -> Scenario:
    path = Path(path)
    chk = _Checker(str(path))
    raw = _read_yaml(path, "scenario")
    chk.mapping(raw, "", _SCENARIO_KEYS, ("start", "goal"))

    map_origin = map_bounds = None
    map_obstacles: tuple[Obstacle, ...] = ()
    map_terrain: Any = None
    map_path = path
    map_chk = chk
    if "map" in raw:
        map_path = _map_path(chk, raw["map"], path)
        map_origin, map_bounds, map_obstacles, map_terrain = _load_map(map_path)
        map_chk = _Checker(str(map_path))

    if "origin" in raw:
        origin = _origin(chk, raw["origin"])
    elif map_origin is not None:
        origin = map_origin
    else:
        raise chk.fail("origin", "missing required key (not set here nor in the map)")
    if "bounds" in raw:
        bounds = _bounds(chk, raw["bounds"])
    elif map_bounds is not None:
        bounds = map_bounds
    else:
        raise chk.fail("bounds", "missing required key (not set here nor in the map)")

    terrain = None
    terrain_file = None
    if "terrain" in raw:
        terrain = _terrain(chk, raw["terrain"], path, origin, bounds)
    elif map_terrain is not None:
        terrain = _terrain(map_chk, map_terrain, map_path, origin, bounds)
    if terrain is not None:
        terrain_file = str(terrain.source)
    obstacles = map_obstacles + _obstacles(chk, raw.get("obstacles", []))
    if raw.get("obstacle_files"):
        obstacles += _obstacle_files(chk, raw["obstacle_files"], path, origin, bounds)
    if len(obstacles) > MAX_OBSTACLES:
        raise chk.fail(
            "obstacles", f"map and scenario hold {len(obstacles):,} (at most {MAX_OBSTACLES:,})"
        )
    margin = 10.0
    if "safety_margin" in raw:
        margin = chk.number(
            raw["safety_margin"], "safety_margin", minimum=0, maximum=MAX_SAFETY_MARGIN_M
        )
    start = chk.point(raw["start"], "start", 3)
    goal = chk.point(raw["goal"], "goal", 3)
    via_raw = raw.get("via", [])
    if not isinstance(via_raw, list):
        raise chk.fail("via", f"must be a list of [x, y, z] points, got {type_name(via_raw)}")
    if len(via_raw) > MAX_VIA_POINTS:
        raise chk.fail("via", f"{len(via_raw):,} points (at most {MAX_VIA_POINTS:,})")
    via = tuple(chk.point(p, f"via[{i}]", 3) for i, p in enumerate(via_raw))
    name = _name(chk, raw["name"]) if "name" in raw else path.stem
    vehicle = _vehicle(chk, raw["vehicle"]) if "vehicle" in raw else VehicleConfig()
    planner = _planner(chk, raw["planner"]) if "planner" in raw else PlannerConfig()
    mission = _mission(chk, raw["mission"]) if "mission" in raw else MissionConfig()

    scenario = Scenario(
        name=name,
        origin=origin,
        bounds=bounds,
        start_m=(start[0], start[1], start[2]),
        goal_m=(goal[0], goal[1], goal[2]),
        via_m=tuple((p[0], p[1], p[2]) for p in via),
        obstacles=obstacles,
        safety_margin_m=margin,
        vehicle=vehicle,
        planner=planner,
        mission=mission,
        source=str(path),
        terrain_file=terrain_file,
    )
    n_inline = len(raw.get("obstacles") or [])
    _check_points(chk, scenario)
    _check_problem_size(chk, scenario)
    if terrain is not None:
        scenario = _on_terrain(chk, scenario, terrain)
    _check_geometry(chk, scenario, len(map_obstacles), raw.get("map"), n_inline)
    return scenario


# ---------------------------------------------------------------------------------------------
# Checks of the whole scenario


def _route_points(scn: Scenario) -> list[tuple[str, tuple[float, float, float]]]:
    """(key, point) of the start, every via point and the goal, in route order."""
    points = [("start", scn.start_m), *((f"via[{i}]", p) for i, p in enumerate(scn.via_m))]
    return [*points, ("goal", scn.goal_m)]


def _check_points(chk: _Checker, scn: Scenario) -> None:
    """Start, via points and goal inside the bounds and above the ground, each at least 1 m
    from the one before horizontally; the take-off altitude under the ceiling."""
    points = _route_points(scn)
    for key, point in points:
        if point[2] <= 0.0:
            if key == "start":
                hint = "the mission adds the take-off climb from the ground below it"
            elif key == "goal":
                hint = "to land there, use mission.end: land"
            else:
                hint = "a via point is a waypoint in the air"
            raise chk.fail(
                f"{key}[2]", f"must be above the ground (z > 0), got {point[2]:g}: {hint}"
            )
        if not scn.bounds.contains(point):
            raise chk.fail(key, f"{list(point)} is outside the bounds")
    for (_, a), (key, b) in itertools.pairwise(points):
        if math.hypot(b[0] - a[0], b[1] - a[1]) < 1.0:
            raise chk.fail(key, "must be at least 1 m away from the point before it horizontally")
    takeoff = scn.vehicle.takeoff_altitude_m
    ceiling = scn.bounds.z_m[1]
    if takeoff is not None and takeoff > ceiling + 1e-9:
        raise chk.fail(
            "vehicle.takeoff_altitude",
            f"{takeoff:g} m is above the ceiling of the flight volume (bounds.z max {ceiling:g})",
        )


def problem_size(scn: Scenario) -> dict[str, float]:
    """Estimates of what planning ``scn`` needs, each checked against its documented limit:
    ``grid_cells`` (path-frame columns × lateral × vertical cells over the flight volume),
    ``search_work`` (population × iterations × columns), ``route_samples`` (twice the
    start-goal distance / post.sample_step_m) and ``columns``."""
    cfg = scn.planner
    (x0, x1), (y0, y1), (z0, z1) = scn.bounds.x_m, scn.bounds.y_m, scn.bounds.z_m
    dx, dy = scn.goal_m[0] - scn.start_m[0], scn.goal_m[1] - scn.start_m[1]
    length = math.hypot(dx, dy)
    c, s = (dx / length, dy / length) if length > 0 else (1.0, 0.0)
    corners = [(x, y) for x in (x0, x1) for y in (y0, y1)]
    along = [c * x + s * y for x, y in corners]
    across = [-s * x + c * y for x, y in corners]
    columns = max(2, round(length / cfg.grid.dx_m))
    grid_cells = (
        (math.floor((max(along) - min(along)) / cfg.grid.dx_m) + 1)
        * (math.floor((max(across) - min(across)) / cfg.grid.dy_m) + 1)
        * (math.floor((z1 - z0) / cfg.grid.dz_m) + 1)
    )
    return {
        "columns": float(columns),
        "grid_cells": float(grid_cells),
        "search_work": float(cfg.search.population * cfg.search.iterations * columns),
        "route_samples": 2.0 * length / cfg.post.sample_step_m,
    }


_SIZE_LIMITS = {
    "grid_cells": (MAX_GRID_CELLS, "planner.grid", "path grid cells over the flight volume"),
    "search_work": (
        MAX_SEARCH_WORK,
        "planner.iterations",
        "node updates (population × iterations × path columns)",
    ),
    "route_samples": (MAX_ROUTE_SAMPLES, "planner.post.sample_step_m", "route samples"),
}


def check_limits(scn: Scenario) -> None:
    """Refuse ``scn`` (ScenarioError naming its file) when planning it would exceed a
    documented size limit (:func:`problem_size`); call it again after command-line overrides
    of the grid or the search effort, so ``validate`` and ``plan`` agree."""
    _check_problem_size(_Checker(scn.source or scn.name), scn)


def _check_problem_size(chk: _Checker, scn: Scenario) -> None:
    size = problem_size(scn)
    for what, (limit, key, text) in _SIZE_LIMITS.items():
        if size[what] > limit:
            raise chk.fail(
                key,
                f"the scenario is too large to plan: about {size[what]:.3g} {text}, "
                f"the limit is {limit:.3g} (coarsen the grid, shrink the bounds or lower the "
                "search effort)",
            )


def _check_geometry(
    chk: _Checker, scn: Scenario, n_map: int, map_ref: str | None, n_inline: int | None = None
) -> None:
    """Start and goal clear of every obstacle plus the margin, and the vertical take-off climb
    (and the landing descent with ``end: land``) clear too. Plain numpy, exact distances: no
    world, no compiled kernels."""

    def name(index: int) -> str:
        if index < n_map:
            return f"obstacle #{index} of map {map_ref}"
        if n_inline is not None and index >= n_map + n_inline:
            return f"obstacle #{index - n_map - n_inline} of obstacle_files"
        return f"obstacles[{index - n_map}]"

    margin = scn.safety_margin_m
    for key, point in _route_points(scn):
        clearance, index = _point_clearance(scn.obstacles, point)
        if index >= 0 and clearance < margin - 1e-9:
            inside = "inside" if clearance <= 0 else f"{clearance:.1f} m from"
            raise chk.fail(
                key, f"{list(point)} is {inside} {name(index)} (needs {margin:g} m safety margin)"
            )
    columns = [("start", scn.start_m, "take-off climb")]
    if scn.mission.end == "land":
        columns.append(("goal", scn.goal_m, "landing descent"))
    for key, point, what in columns:
        dist, index = _column_clearance(scn.obstacles, point[:2])
        if index >= 0 and dist < margin - 1e-9:
            raise chk.fail(
                key,
                f"the {what} above {list(point[:2])} passes {dist:.1f} m from "
                f"{name(index)} (needs {margin:g} m safety margin)",
            )


# ---------------------------------------------------------------------------------------------
# Exact clearances in plain numpy (validation must not need the planner's compiled kernels)


class _Footprints:
    """Every obstacle's footprint as flat numpy arrays, built once per obstacle tuple: the
    cylinders' centres and radii, the polygon edges (box corners computed vectorised) with
    the obstacle each belongs to, and the heights."""

    def __init__(self, obstacles: Sequence[Obstacle]) -> None:
        import numpy as np

        self.n = len(obstacles)
        self.heights = np.array([o.height_m for o in obstacles], dtype=np.float64)
        cyl = [i for i, o in enumerate(obstacles) if isinstance(o, CylinderObstacle)]
        self.cyl = np.array(cyl, dtype=np.int64)
        self.centres = np.array(
            [obstacles[i].center_m for i in cyl],  # type: ignore[union-attr]
            dtype=np.float64,
        ).reshape(-1, 2)
        self.radii = np.array([obstacles[i].radius_m for i in cyl], dtype=np.float64)  # type: ignore[union-attr]
        boxes = [i for i, o in enumerate(obstacles) if isinstance(o, BoxObstacle)]
        prisms = [i for i, o in enumerate(obstacles) if isinstance(o, PrismObstacle)]
        starts_list: list[Any] = []
        owners: list[Any] = []
        if boxes:
            bx = [obstacles[i] for i in boxes]
            c = np.array([o.center_m for o in bx], dtype=np.float64)  # type: ignore[union-attr]
            h = np.array([o.size_m for o in bx], dtype=np.float64) / 2.0  # type: ignore[union-attr]
            yaw = np.radians(np.array([o.yaw_deg for o in bx], dtype=np.float64))  # type: ignore[union-attr]
            cs, sn = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
            u = np.array([-1.0, 1.0, 1.0, -1.0]) * h[:, :1]
            v = np.array([-1.0, -1.0, 1.0, 1.0]) * h[:, 1:]
            corners = np.stack([c[:, :1] + cs * u - sn * v, c[:, 1:] + sn * u + cs * v], axis=-1)
            starts_list.append(corners.reshape(-1, 2))
            owners.append(np.repeat(np.array(boxes, dtype=np.int64), 4))
        counts = [4] * len(boxes)
        for i in prisms:
            ring = obstacles[i].polygon_m  # type: ignore[union-attr]
            starts_list.append(np.asarray(ring, dtype=np.float64))
            owners.append(np.full(len(ring), i, dtype=np.int64))
            counts.append(len(ring))
        if starts_list:
            a = np.concatenate(starts_list)
            k = np.array(counts, dtype=np.int64)
            first = np.repeat(np.cumsum(k) - k, k)
            local = np.arange(len(a)) - first
            self.a = a
            self.b = a[first + (local + 1) % np.repeat(k, k)]
            self.owner = np.concatenate(owners)
        else:
            self.a = self.b = np.empty((0, 2))
            self.owner = np.empty(0, dtype=np.int64)

    def horizontal(self, xy: Sequence[float]) -> Any:
        """Horizontal distance (metres, shape (n,)) from ``xy`` to every footprint; 0 inside."""
        import numpy as np

        out = np.full(self.n, np.inf)
        px, py = float(xy[0]), float(xy[1])
        if self.cyl.size:
            d = np.hypot(self.centres[:, 0] - px, self.centres[:, 1] - py) - self.radii
            out[self.cyl] = np.maximum(d, 0.0)
        if self.owner.size:
            a, ab = self.a, self.b - self.a
            ap = np.array([px, py]) - a
            den = np.einsum("ij,ij->i", ab, ab)
            t = np.clip(np.einsum("ij,ij->i", ap, ab) / np.where(den > 0, den, 1.0), 0.0, 1.0)
            dist = np.hypot(a[:, 0] + t * ab[:, 0] - px, a[:, 1] + t * ab[:, 1] - py)
            np.minimum.at(out, self.owner, dist)
            ay, by = a[:, 1], self.b[:, 1]
            straddles = (ay > py) != (by > py)
            with np.errstate(divide="ignore", invalid="ignore"):
                x_cross = a[:, 0] + ab[:, 0] * (py - ay) / np.where(straddles, by - ay, 1.0)
            hits = np.zeros(self.n, dtype=np.int64)
            np.add.at(hits, self.owner, (straddles & (px < x_cross)).astype(np.int64))
            out[hits % 2 == 1] = 0.0
        return out


_FOOTPRINTS: dict[int, tuple[Sequence[Obstacle], _Footprints]] = {}


def _footprints(obstacles: Sequence[Obstacle]) -> _Footprints:
    hit = _FOOTPRINTS.get(id(obstacles))
    if hit is not None and hit[0] is obstacles:
        return hit[1]
    fp = _Footprints(obstacles)
    _FOOTPRINTS.clear()  # one scenario at a time
    _FOOTPRINTS[id(obstacles)] = (obstacles, fp)
    return fp


def _horizontal_distances(obstacles: Sequence[Obstacle], xy: Sequence[float]) -> Any:
    """Horizontal distance (metres, shape (n,)) from ``xy`` to every obstacle's footprint;
    0 inside a footprint."""
    return _footprints(obstacles).horizontal(xy)


#: up to this many obstacles the clearances are computed in plain Python (no numpy import:
#: `uavplan validate` of a small scenario starts in a fraction of the time)
_SMALL_OBSTACLE_COUNT = 64


def _horizontal_small(obstacle: Obstacle, px: float, py: float) -> float:
    """:meth:`_Footprints.horizontal` for one obstacle in plain Python (the same formulas)."""
    if isinstance(obstacle, CylinderObstacle):
        cx, cy = obstacle.center_m
        return max(math.hypot(cx - px, cy - py) - obstacle.radius_m, 0.0)
    if isinstance(obstacle, BoxObstacle):
        (cx, cy), (sx, sy) = obstacle.center_m, obstacle.size_m
        hx, hy = sx / 2.0, sy / 2.0
        yaw = math.radians(obstacle.yaw_deg)
        cs, sn = math.cos(yaw), math.sin(yaw)
        ring = [
            (cx + cs * (ux * hx) - sn * (vy * hy), cy + sn * (ux * hx) + cs * (vy * hy))
            for ux, vy in ((-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0))
        ]
    else:
        ring = [(float(x), float(y)) for x, y in obstacle.polygon_m]  # type: ignore[union-attr]
    best, crossings = math.inf, 0
    for (ax, ay), (bx, by) in zip(ring, [*ring[1:], ring[0]], strict=True):
        abx, aby = bx - ax, by - ay
        den = abx * abx + aby * aby
        t = ((px - ax) * abx + (py - ay) * aby) / (den if den > 0 else 1.0)
        t = min(max(t, 0.0), 1.0)
        best = min(best, math.hypot(ax + t * abx - px, ay + t * aby - py))
        if (ay > py) != (by > py) and px < ax + abx * (py - ay) / (by - ay):
            crossings += 1
    return 0.0 if crossings % 2 == 1 else best


def _point_clearance(obstacles: Sequence[Obstacle], point: Sequence[float]) -> tuple[float, int]:
    """(distance, index) of the obstacle nearest to the 3-D ``point``; (inf, -1) without
    obstacles. Exact: obstacles are vertical solids from the ground to their height."""
    if not obstacles:
        return math.inf, -1
    if len(obstacles) <= _SMALL_OBSTACLE_COUNT:
        px, py, pz = float(point[0]), float(point[1]), float(point[2])
        dists = [
            math.hypot(_horizontal_small(o, px, py), max(pz - o.height_m, 0.0)) for o in obstacles
        ]
        index = dists.index(min(dists))
        return dists[index], index
    import numpy as np

    fp = _footprints(obstacles)
    horizontal = fp.horizontal(point[:2])
    vertical = np.maximum(float(point[2]) - fp.heights, 0.0)
    dist = np.hypot(horizontal, vertical)
    index = int(np.argmin(dist))
    return float(dist[index]), index


def _column_clearance(obstacles: Sequence[Obstacle], xy: Sequence[float]) -> tuple[float, int]:
    """(distance, index) of the obstacle nearest to the vertical segment from the ground up at
    ``xy``: obstacles stand on the ground, so it is the horizontal distance."""
    if not obstacles:
        return math.inf, -1
    if len(obstacles) <= _SMALL_OBSTACLE_COUNT:
        dists = [_horizontal_small(o, float(xy[0]), float(xy[1])) for o in obstacles]
        index = dists.index(min(dists))
        return dists[index], index
    import numpy as np

    horizontal = _horizontal_distances(obstacles, xy)
    index = int(np.argmin(horizontal))
    return float(horizontal[index]), index
