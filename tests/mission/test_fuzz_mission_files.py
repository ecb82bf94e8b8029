"""Fuzz the mission-file readers through the CLI: ``validate``, ``convert`` and ``upload``.

hypothesis starts from valid ``.plan`` and ``.waypoints`` files written by uavplan and breaks
them: JSON values replaced by other types, NaN / inf / huge numbers (beyond float32, int32,
uint16, a double, Python's integer-string limit), unicode and lone surrogates, deep nesting,
duplicate keys, deleted keys and columns, reordered lines, then bytes: a BOM, UTF-16 / UTF-32
with or without a byte-order mark, non-UTF-8 bytes, NUL, truncation and bit flips. Each file
goes through, in-process with click's ``CliRunner``:

* ``uavplan validate FILE --scenario S`` (a small scenario the seed missions fly through);
* ``uavplan convert FILE OUT`` to one of ``.plan`` / ``.waypoints`` / ``.geojson`` / ``.kml``
  (hypothesis picks; over a run every format is hit many times);
* ``uavplan upload FILE --conn ...`` with the connection replaced by one that fails at once
  (exit 4, "stopped before connecting"): the file is read first, and the upload must refuse a
  bad file before it touches the link.

Invariant: exit 0 with a correct result, or exit 2 with one line naming the file; never exit
1, a traceback, a hang or a partial output file. In detail: ``validate`` may also exit 3 (the
file is valid and the flown path leaves the scenario's bounds or hits an obstacle), naming the
file; a ``convert`` that exits 0 wrote an output that reads back as the same mission (or, for
the map exports, is well-formed JSON / XML), and one that fails left nothing in the output
folder; an ``upload`` that reached the link holds a plan whose every item packs into a
MISSION_ITEM_INT and every list into a uint16 count. A numpy RuntimeWarning is a failure too
(it would leak onto a user's terminal).

Examples: ``UAVPLAN_FUZZ_EXAMPLES`` per fuzz test (default 500; four tests: 2,000 files and
6,000 command runs, about 45 s of CPU). Nightly: ``UAVPLAN_FUZZ_EXAMPLES=20000
UAVPLAN_FUZZ_RANDOM=1 pytest -q tests/mission/test_fuzz_mission_files.py`` (random seeds instead of
the fixed derandomized sequence CI uses; a failure prints its reproduction blob).
``UAVPLAN_FUZZ_REPORT=out.json`` writes the outcome counts (per suite, command and exit code)
for ``tools/reliability.py``.
"""

from __future__ import annotations

import json
import math
import os
import struct
import warnings
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner, Result
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import uavplan.app.check as app_check
import uavplan.app.link as app_link
from uavplan.cli import main
from uavplan.errors import LinkError, MissionFileError
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.mavlink.protocol import item_to_wire
from uavplan.mission.builder import build_mission
from uavplan.mission.io import load_mission
from uavplan.mission.items import (
    Autopilot,
    FenceCircle,
    FencePolygon,
    GeoFence,
    MavCmd,
    MavFrame,
    MissionItem,
    MissionPlan,
    MissionType,
    RallyPoint,
    items_equal,
)

EXAMPLES = int(os.environ.get("UAVPLAN_FUZZ_EXAMPLES", "500"))
RANDOM = os.environ.get("UAVPLAN_FUZZ_RANDOM", "") not in ("", "0")
REPORT = os.environ.get("UAVPLAN_FUZZ_REPORT")

FUZZ = settings(
    max_examples=EXAMPLES,
    derandomize=not RANDOM,
    database=None,
    deadline=timedelta(seconds=20),  # a hang, not a slow machine
    suppress_health_check=[
        HealthCheck.function_scoped_fixture,
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
    ],
)

ORIGIN = GeoPoint(47.397, 8.545, 488.0)
SCENARIO_YAML = """\
name: fuzz
origin: {lat: 47.397, lon: 8.545, alt: 488}
bounds: {x: [-200, 800], y: [-400, 400], z: [0, 150]}
start: [0, 0, 20]
goal: [500, 0, 30]
safety_margin: 5
obstacles:
  - {type: box, center: [250, 150], size: [60, 60], height: 50}
"""
STOPPED = "fuzz: stopped before connecting"
OUT_SUFFIXES = (".plan", ".waypoints", ".geojson", ".kml")

#: (suite, command, exit code) -> count, written to UAVPLAN_FUZZ_REPORT at the end
OUTCOMES: Counter[tuple[str, str, int]] = Counter()

# =============================================================================================
# Seed missions: what uavplan writes, plus the hand-made corners (DO_JUMP, a frame-2 item,
# fence and rally)


def _seed_plans() -> list[MissionPlan]:
    path = np.array([[0, 0, 20], [200, 0, 25], [300, -50, 30], [500, 0, 30]], dtype=float)
    px4 = build_mission(path, EnuFrame.at(ORIGIN), autopilot=Autopilot.PX4, cruise_speed_m_s=10.0)
    ardu = build_mission(path, EnuFrame.at(ORIGIN), autopilot=Autopilot.ARDUPILOT, end="land")
    fence = GeoFence(
        polygons=(
            FencePolygon(((47.39, 8.54), (47.40, 8.54), (47.40, 8.56), (47.39, 8.56)), True),
        ),
        circles=(FenceCircle((47.3975, 8.548), 30.0, False),),
        breach_return=GeoPoint(47.3972, 8.5452, 30.0),
    )
    jump = MissionItem(command=MavCmd.DO_JUMP, frame=MavFrame.MISSION, param1=2.0, param2=3.0)
    raw = MissionItem(command=31000, frame=MavFrame.MISSION, param1=1.0, x=5.0, y=-7.0, z=1.5)
    with_jump = MissionPlan(
        items=(*px4.items[:-1], jump, raw, px4.items[-1]),
        autopilot=Autopilot.PX4,
        home=px4.home,
        fence=fence,
        rally=(RallyPoint(47.3971, 8.5451, 25.0),),
        cruise_speed_m_s=px4.cruise_speed_m_s,
    )
    return [px4, ardu, with_jump]


SEED_PLANS = _seed_plans()


def _seed_texts(suffix: str) -> list[str]:
    from uavplan.mission.qgc_plan import plan_to_json
    from uavplan.mission.waypoints_file import waypoints_to_text

    if suffix == ".plan":
        return [plan_to_json(p) for p in SEED_PLANS]
    return [waypoints_to_text(p, ignore_fence_and_rally=True) for p in SEED_PLANS]


# =============================================================================================
# A JSON writer that can say what json.dumps refuses: duplicate keys and raw tokens


@dataclass(frozen=True)
class Raw:
    """Text put into the document as it is (a bad number, a cut-off token, deep nesting)."""

    text: str


@dataclass(frozen=True)
class Pairs:
    """A JSON object as key/value pairs, so a key can appear twice."""

    items: tuple[tuple[str, Any], ...]


def dump_json(value: Any) -> str:
    if isinstance(value, Raw):
        return value.text
    if isinstance(value, Pairs):
        return "{" + ", ".join(f"{json.dumps(k)}: {dump_json(v)}" for k, v in value.items) + "}"
    if isinstance(value, dict):
        return dump_json(Pairs(tuple(value.items())))
    if isinstance(value, list):
        return "[" + ", ".join(dump_json(v) for v in value) + "]"
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if math.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    return json.dumps(value)


HOSTILE_NUMBERS: list[Any] = [
    math.nan,
    math.inf,
    -math.inf,
    1e39,
    -1e39,
    3.4028235e38,  # rounds to float32 max: fits
    3.402823669209385e38,  # just beyond float32
    1e308,
    -1e308,
    3e9,
    -3e9,
    2**31,
    2**31 - 1,
    -(2**31) - 1,
    2**64,
    65535,
    65536,
    255,
    256,
    -1,
    0,
    -0.0,
    0.5,
    1e-320,
    Raw("1e400"),
    Raw("-1e400"),
    Raw("9" * 5000),
    Raw("0" * 3000 + "1"),
    Raw("1" + "0" * 400),
]
HOSTILE_TOKENS = [
    Raw("-"),
    Raw("01"),
    Raw("1."),
    Raw(".5"),
    Raw("tru"),
    Raw("nul"),
    Raw('"\\ud800"'),
    Raw('"\\u0000"'),
    Raw('"unterminated'),
    Raw("[" * 5000 + "]" * 5000),
    Raw('{"a":' * 3000 + "1" + "}" * 3000),
    Raw("[" * 50),
    Raw("NaN"),
    Raw("Infinity"),
    Raw("undefined"),
]

json_scalars = st.one_of(
    st.sampled_from(HOSTILE_NUMBERS),
    st.sampled_from(HOSTILE_TOKENS),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**80), max_value=2**80),
    st.text(max_size=30),
    st.text(alphabet=st.characters(codec="utf-8"), min_size=100, max_size=300),
    st.booleans(),
    st.none(),
)
json_values = st.recursive(
    json_scalars,
    lambda children: st.one_of(
        st.lists(children, max_size=8),
        st.dictionaries(st.text(max_size=12), children, max_size=5),
    ),
    max_leaves=20,
)


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """Every path (tuple of keys and indices) into a parsed JSON document."""
    yield prefix
    if isinstance(doc, dict):
        for key, value in doc.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(doc, list):
        for index, value in enumerate(doc):
            yield from _paths(value, (*prefix, index))


def _get(doc: Any, path: tuple[Any, ...]) -> Any:
    for part in path:
        doc = doc[part]
    return doc


def _set(doc: Any, path: tuple[Any, ...], value: Any) -> Any:
    if not path:
        return value
    _get(doc, path[:-1])[path[-1]] = value
    return doc


def mutate_json(data: st.DataObject, text: str) -> str:
    """One to four structural mutations of a .plan document, then its text."""
    doc: Any = json.loads(text)
    for _ in range(data.draw(st.integers(1, 4), label="n_mutations")):
        paths = list(_paths(doc))
        path = paths[data.draw(st.integers(0, len(paths) - 1), label="path")]
        op = data.draw(
            st.sampled_from(["value", "number", "delete", "duplicate", "nest", "wrap", "type"]),
            label="op",
        )
        target = _get(doc, path)
        if op == "value":
            doc = _set(doc, path, data.draw(json_values, label="value"))
        elif op == "number":
            doc = _set(doc, path, data.draw(st.sampled_from(HOSTILE_NUMBERS), label="number"))
        elif op == "delete" and path:
            parent = _get(doc, path[:-1])
            if isinstance(parent, dict | list):
                del parent[path[-1]]
        elif op == "duplicate" and isinstance(target, dict) and target:
            key = data.draw(st.sampled_from(sorted(target)), label="dup_key")
            again = data.draw(st.one_of(st.just(target[key]), json_values), label="dup_value")
            doc = _set(doc, path, Pairs((*target.items(), (key, again))))
            break  # a Pairs is no longer a dict: stop mutating inside it
        elif op == "nest":
            depth = data.draw(st.sampled_from([2, 50, 900, 5000]), label="depth")
            doc = _set(doc, path, Raw("[" * depth + dump_json(target) + "]" * depth))
            break
        elif op == "wrap":
            doc = _set(doc, path, [target])
        elif op == "type":
            doc = _set(doc, path, str(target) if not isinstance(target, str) else 1)
    return dump_json(doc)


WAYPOINT_TOKENS = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "1e39",
    "-1e39",
    "3.4028236e38",
    "3e9",
    "-3e9",
    "2147483648",
    "1e400",
    "9" * 5000,
    "0" * 40 + "1",
    "65535",
    "65536",
    "255",
    "256",
    "-1",
    "0x10",
    "1_0",
    "١٢",
    "½",
    "1e",
    ".",
    "+",
    "--1",
    "\x00",
    "\udcff",
    "🚁",
]


def mutate_lines(data: st.DataObject, text: str) -> str:
    """One to four line / column mutations of a .waypoints file."""
    lines = text.split("\n")
    for _ in range(data.draw(st.integers(1, 4), label="n_mutations")):
        index = data.draw(st.integers(0, max(len(lines) - 1, 0)), label="line")
        columns = lines[index].split("\t") if lines else [""]
        op = data.draw(
            st.sampled_from(
                [
                    "token",
                    "text",
                    "drop_col",
                    "add_col",
                    "dup_line",
                    "drop_line",
                    "swap",
                    "header",
                    "comment",
                    "endings",
                    "spaces",
                    "many",
                ]
            ),
            label="op",
        )
        if op in ("token", "text"):
            col = data.draw(st.integers(0, len(columns) - 1), label="column")
            columns[col] = (
                data.draw(st.sampled_from(WAYPOINT_TOKENS), label="token")
                if op == "token"
                else data.draw(st.text(max_size=20), label="text")
            )
            lines[index] = "\t".join(columns)
        elif op == "drop_col" and len(columns) > 1:
            del columns[data.draw(st.integers(0, len(columns) - 1), label="column")]
            lines[index] = "\t".join(columns)
        elif op == "add_col":
            columns.insert(data.draw(st.integers(0, len(columns)), label="column"), "0")
            lines[index] = "\t".join(columns)
        elif op == "dup_line" and lines:
            lines.insert(index, lines[index])
        elif op == "drop_line" and lines:
            del lines[index]
        elif op == "swap" and len(lines) > 1:
            other = data.draw(st.integers(0, len(lines) - 1), label="other")
            lines[index], lines[other] = lines[other], lines[index]
        elif op == "header":
            lines[0] = data.draw(
                st.sampled_from(["QGC WPL 120", "qgc wpl 110", "", " QGC WPL 110 ", "QGC"]),
                label="header",
            )
        elif op == "comment":
            lines.insert(index, data.draw(st.sampled_from(["# note", "", "  ", "#"]), label="c"))
        elif op == "endings":
            sep = data.draw(st.sampled_from(["\r\n", "\r", "\n\n", "\u2028", "\x0c"]), label="e")
            return sep.join(lines)
        elif op == "spaces":
            lines[index] = lines[index].replace(
                "\t", data.draw(st.sampled_from([" ", "  ", "\u00a0", "\u3000", ","]), label="sep")
            )
        elif op == "many" and len(lines) > 1:
            copies = data.draw(st.sampled_from([10, 300]), label="copies")
            last = lines[-2] if lines[-1] == "" else lines[-1]
            lines[-1:] = [last] * copies + [""]
    return "\n".join(lines)


def mutate_bytes(data: st.DataObject, text: str) -> bytes:
    """Encode the text, then maybe break the bytes."""
    codec = data.draw(
        st.sampled_from(
            [
                "utf-8",
                "utf-8",
                "utf-8",
                "utf-8-sig",
                "utf-16",
                "utf-16-le",
                "utf-16-be",
                "utf-32",
                "latin-1",
                "cp1252",
            ]
        ),
        label="codec",
    )
    raw = text.encode(codec, errors="surrogateescape" if codec == "utf-8" else "replace")
    for _ in range(data.draw(st.integers(0, 3), label="n_byte_ops")):
        op = data.draw(st.sampled_from(["flip", "cut", "insert", "bom"]), label="byte_op")
        if not raw:
            break
        pos = data.draw(st.integers(0, len(raw) - 1), label="pos")
        if op == "flip":
            bit = data.draw(st.integers(0, 7), label="bit")
            raw = raw[:pos] + bytes([raw[pos] ^ (1 << bit)]) + raw[pos + 1 :]
        elif op == "cut":
            raw = raw[:pos]
        elif op == "insert":
            junk = data.draw(
                st.one_of(
                    st.sampled_from([b"\x00", b"\xff", b"\xc3", b"\xed\xa0\x80", b"\xef\xbb\xbf"]),
                    st.binary(min_size=1, max_size=8),
                ),
                label="junk",
            )
            raw = raw[:pos] + junk + raw[pos:]
        else:
            raw = (
                data.draw(
                    st.sampled_from(
                        [b"\xef\xbb\xbf", b"\xff\xfe", b"\xfe\xff", b"\xff\xfe\x00\x00"]
                    ),
                    label="bom",
                )
                + raw
            )
    return raw


# =============================================================================================
# Running the commands and checking the invariant


@pytest.fixture(scope="module", autouse=True)
def _write_report() -> Iterator[None]:
    yield
    if REPORT:
        old = {}
        if Path(REPORT).exists():
            old = json.loads(Path(REPORT).read_text(encoding="utf-8"))
        for (suite, command, code), n in OUTCOMES.items():
            key = f"{suite}|{command}|{code}"
            old[key] = old.get(key, 0) + n
        Path(REPORT).write_text(json.dumps(old, indent=1, sort_keys=True) + "\n", encoding="utf-8")


@pytest.fixture()
def fuzz_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> dict[str, Path]:
    """A scenario, an output folder, no fsync (durability is not what is fuzzed) and an
    upload connection that fails before it opens anything."""
    scenario = tmp_path / "scenario.yaml"
    scenario.write_text(SCENARIO_YAML, encoding="utf-8")
    loaded = app_check.load_site(str(scenario))

    def cached_scenario(path: str) -> Any:
        # the scenario is the same file every time; only the mission file is fuzzed
        return loaded if path == str(scenario) else _original_load(path)

    _original_load = app_check.load_site
    monkeypatch.setattr(app_check, "load_site", cached_scenario)

    def no_connect(*_args: Any, **_kwargs: Any) -> Any:
        raise LinkError(STOPPED, step="connect")

    monkeypatch.setattr(app_link, "_connect", no_connect)
    monkeypatch.setattr(os, "fsync", lambda _fd: None)
    out = tmp_path / "out"
    out.mkdir()
    return {"scenario": scenario, "out": out, "dir": tmp_path}


def _invoke(args: list[str]) -> Result:
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        return CliRunner().invoke(main, args)


def _check_common(result: Result, file: Path, allowed: tuple[int, ...], what: str) -> None:
    text = result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), (
        f"{what}: exception {result.exception!r}"
    )
    assert result.exit_code in allowed, f"{what}: exit {result.exit_code}: {text[-500:]}"
    assert "Traceback" not in text and "internal error" not in text, f"{what}: {text[-500:]}"
    if result.exit_code not in (0,):
        message = result.stderr.strip()
        assert message.count("\n") == 0, f"{what}: more than one line: {message[:500]!r}"
        assert len(message) < 600, f"{what}: message of {len(message)} chars"
        assert str(file) in message or result.exit_code == 4, f"{what}: {message!r}"


def _reference(file: Path, autopilot: Autopilot | None = None) -> MissionPlan | None:
    """The plan as the library reads it, or None when the reader refuses the file."""
    try:
        return load_mission(file, autopilot)
    except MissionFileError:
        return None


def _same_mission(a: MissionPlan, b: MissionPlan, *, fence: bool) -> bool:
    if len(a.items) != len(b.items):
        return False
    if not all(items_equal(x, y) for x, y in zip(a.items, b.items, strict=True)):
        return False
    if (a.home is None) != (b.home is None):
        # a home at (0, 0) means "unknown" in a .waypoints file (Mission Planner's convention);
        # a home closer to it than the file's 8 decimals (e.g. lon 5e-324) reads back unknown
        return a.home is None or (abs(a.home.lat_deg) < 5e-9 and abs(a.home.lon_deg) < 5e-9)
    if a.home is not None and b.home is not None:
        if abs(a.home.lat_deg - b.home.lat_deg) > 1e-7 or abs(a.home.alt_m - b.home.alt_m) > 1e-5:
            return False
    return not fence or (a.fence == b.fence and a.rally == b.rally)


MISSION_ITEM_INT = struct.Struct("<ffffiifHHBBBBBB")


def _packs(plan: MissionPlan) -> None:
    """Every wire item of every plan type packs into a MISSION_ITEM_INT (or this raises)."""
    for mission_type in (MissionType.MISSION, MissionType.FENCE, MissionType.RALLY):
        items = plan.wire_items(mission_type)
        assert len(items) <= 0xFFFF, f"{len(items)} {mission_type.name} items"
        for seq, item in enumerate(items):
            w = item_to_wire(item, seq, mission_type, 1, 1)
            MISSION_ITEM_INT.pack(
                w.param1,
                w.param2,
                w.param3,
                w.param4,
                w.x,
                w.y,
                w.z,
                w.seq,
                w.command,
                w.target_system,
                w.target_component,
                w.frame,
                w.current,
                w.autocontinue,
                w.mission_type,
            )


def _refused_before_the_link(plan: MissionPlan) -> bool:
    """A mission the reader accepts that ``upload`` still refuses before connecting (exit
    2): an empty one (it would clear the vehicle's; ``--clear``), or one larger than the
    flavour's default storage (issue 37, item 6)."""
    from uavplan.mavlink.transfer import storage_limits, storage_problem

    if not plan.items:
        return True
    return storage_problem(plan, plan.autopilot, storage_limits(plan.autopilot)) is not None


def check_file(suite: str, file: Path, env: dict[str, Path], out_suffix: str) -> None:
    """Run validate, convert and upload on ``file`` and check the invariant for each."""
    reference = _reference(file)

    # --- upload: refuses a bad file before the link; a good one reaches it -----------------
    result = _invoke(["upload", str(file), "--conn", "udpout:127.0.0.1:9", "-q"])
    OUTCOMES[(suite, "upload", result.exit_code)] += 1
    _check_common(result, file, (2, 4), "upload")
    if result.exit_code == 4:
        assert STOPPED in result.stderr, result.stderr
        assert reference is not None
        _packs(reference)
    else:
        assert reference is None or _refused_before_the_link(reference), (
            "upload refused a file the reader accepts"
        )

    # --- validate against the scenario -------------------------------------------------------
    result = _invoke(["validate", str(file), "--scenario", str(env["scenario"])])
    OUTCOMES[(suite, "validate", result.exit_code)] += 1
    _check_common(result, file, (0, 2, 3), "validate")
    if result.exit_code == 0:
        assert f"{file}: ok" in result.output
    if result.exit_code in (0, 3):
        assert reference is not None

    # --- convert to one format ---------------------------------------------------------------
    out = env["out"] / f"converted{out_suffix}"
    result = _invoke(["convert", str(file), str(out), "-q"])
    OUTCOMES[(suite, f"convert{out_suffix}", result.exit_code)] += 1
    _check_common(result, file, (0, 2), f"convert to {out_suffix}")
    written = sorted(p.name for p in env["out"].iterdir())
    if result.exit_code != 0:
        assert written == [], f"convert failed and left {written}"
        assert reference is None or out_suffix in (".geojson", ".kml")
        return
    assert written == [out.name], written
    assert reference is not None
    if out_suffix in (".plan", ".waypoints"):
        again = load_mission(out, reference.autopilot)
        assert _same_mission(reference, again, fence=out_suffix == ".plan")
    elif out_suffix == ".geojson":
        doc = json.loads(out.read_text(encoding="utf-8"), parse_constant=_no_constant)
        assert doc["type"] == "FeatureCollection"
    else:
        ET.fromstring(out.read_bytes())
    out.unlink()


def _no_constant(name: str) -> None:
    raise AssertionError(f"{name} in the GeoJSON output")


def _run(suite: str, env: dict[str, Path], data: bytes, suffix: str, out_suffix: str) -> None:
    file = env["dir"] / f"fuzzed{suffix}"
    file.write_bytes(data)
    check_file(suite, file, env, out_suffix)


out_suffixes = st.sampled_from(OUT_SUFFIXES)


# =============================================================================================
# The suites


@pytest.mark.slow
def test_seed_files_are_valid(fuzz_env: dict[str, Path]) -> None:
    """The unmutated seeds pass every command (so the fuzz starts from valid files)."""
    for suffix in (".plan", ".waypoints"):
        for text in _seed_texts(suffix):
            for out_suffix in OUT_SUFFIXES:
                file = fuzz_env["dir"] / f"seed{suffix}"
                file.write_text(text, encoding="utf-8")
                check_file("seed", file, fuzz_env, out_suffix)
    assert OUTCOMES[("seed", "validate", 0)] == 4 * 6
    assert OUTCOMES[("seed", "upload", 4)] == 4 * 6


@FUZZ
@given(data=st.data(), out_suffix=out_suffixes)
@pytest.mark.timeout(900)
@pytest.mark.slow
def test_fuzz_plan_json(fuzz_env: dict[str, Path], data: st.DataObject, out_suffix: str) -> None:
    seed = data.draw(st.sampled_from(_seed_texts(".plan")), label="seed")
    text = mutate_json(data, seed)
    _run("plan-json", fuzz_env, text.encode("utf-8", errors="surrogatepass"), ".plan", out_suffix)


@FUZZ
@given(data=st.data(), out_suffix=out_suffixes)
@pytest.mark.timeout(900)
@pytest.mark.slow
def test_fuzz_waypoints_lines(
    fuzz_env: dict[str, Path], data: st.DataObject, out_suffix: str
) -> None:
    seed = data.draw(st.sampled_from(_seed_texts(".waypoints")), label="seed")
    text = mutate_lines(data, seed)
    raw = text.encode("utf-8", errors="surrogatepass")
    _run("waypoints-lines", fuzz_env, raw, ".waypoints", out_suffix)


@FUZZ
@given(data=st.data(), suffix=st.sampled_from([".plan", ".waypoints"]), out_suffix=out_suffixes)
@pytest.mark.timeout(900)
@pytest.mark.slow
def test_fuzz_bytes(
    fuzz_env: dict[str, Path], data: st.DataObject, suffix: str, out_suffix: str
) -> None:
    seed = data.draw(st.sampled_from(_seed_texts(suffix)), label="seed")
    if data.draw(st.booleans(), label="also_structure"):
        seed = mutate_json(data, seed) if suffix == ".plan" else mutate_lines(data, seed)
    raw = mutate_bytes(data, seed)
    _run(f"bytes{suffix}", fuzz_env, raw, suffix, out_suffix)


_number = st.one_of(
    st.sampled_from([v for v in HOSTILE_NUMBERS if not isinstance(v, Raw)]),
    st.floats(allow_nan=False, allow_infinity=False),
    st.floats(-90, 90),
    st.none(),
)
_items = st.lists(
    st.fixed_dictionaries(
        {
            "autoContinue": st.one_of(st.booleans(), _number),
            "command": st.one_of(st.sampled_from([16, 20, 21, 22, 177, 178]), _number),
            "frame": st.one_of(st.sampled_from([0, 2, 3, 5, 6, 10]), _number),
            "params": st.lists(_number, min_size=7, max_size=7),
            "type": st.just("SimpleItem"),
        }
    ),
    max_size=6,
)
_circles = st.lists(
    st.fixed_dictionaries(
        {
            "circle": st.fixed_dictionaries(
                {"center": st.just([47.397, 8.545]), "radius": _number}
            ),
            "inclusion": st.booleans(),
            "version": st.just(1),
        }
    ),
    max_size=2,
)
generated_plans = st.fixed_dictionaries(
    {
        "fileType": st.just("Plan"),
        "geoFence": st.fixed_dictionaries(
            {"circles": _circles, "polygons": st.just([]), "version": st.just(2)}
        ),
        "groundStation": st.just("QGroundControl"),
        "mission": st.fixed_dictionaries(
            {
                "cruiseSpeed": _number,
                "firmwareType": st.sampled_from([0, 3, 12]),
                "hoverSpeed": st.just(5),
                "items": _items,
                "plannedHomePosition": st.lists(_number, min_size=3, max_size=3),
                "vehicleType": st.one_of(st.just(2), _number),
                "version": st.just(2),
            }
        ),
        "rallyPoints": st.fixed_dictionaries(
            {
                "points": st.lists(st.lists(_number, min_size=3, max_size=3), max_size=2),
                "version": st.just(2),
            }
        ),
        "version": st.just(1),
    }
)


@FUZZ
@given(doc=generated_plans, out_suffix=out_suffixes)
@pytest.mark.timeout(900)
@pytest.mark.slow
def test_fuzz_plan_from_generated_values(
    fuzz_env: dict[str, Path], doc: dict[str, Any], out_suffix: str
) -> None:
    """Whole documents from generated values: every field of a SimpleItem drawn from hostile
    numbers and plain floats, home, fence circles and rally points with them too."""
    for index, item in enumerate(doc["mission"]["items"]):
        item["doJumpId"] = index + 1
    _run("plan-values", fuzz_env, dump_json(doc).encode("utf-8"), ".plan", out_suffix)


# =============================================================================================
# The specific cases of issue 12, each once and by name


def _plan_with(item: dict[str, Any]) -> str:
    from uavplan.mission.qgc_plan import plan_to_dict

    doc = plan_to_dict(SEED_PLANS[0])
    doc["mission"]["items"][1].update(item)
    return dump_json(doc)


ISSUE_CASES: dict[str, Callable[[], str]] = {
    "param1-1e39": lambda: _plan_with({"params": [1e39, 0, 0, 0, 47.397, 8.545, 20]}),
    "altitude-1e39": lambda: _plan_with(
        {"params": [0, 0, 0, 0, 47.397, 8.545, 1e39], "Altitude": 1e39}
    ),
    "frame2-x-3e9": lambda: _plan_with({"frame": 2, "params": [0, 0, 0, 0, 3e9, 0, 0]}),
    "param-inf-token": lambda: _plan_with({"params": [Raw("Infinity"), 0, 0, 0, 47.3, 8.5, 20]}),
    "radius-1e39": lambda: dump_json(
        {
            **json.loads(_plan_with({})),
            "geoFence": {
                "version": 2,
                "polygons": [],
                "circles": [
                    {
                        "circle": {"center": [47.397, 8.545], "radius": 1e39},
                        "inclusion": True,
                        "version": 1,
                    }
                ],
            },
        }
    ),
}


@pytest.mark.parametrize("case", sorted(ISSUE_CASES))
def test_values_the_wire_cannot_hold_exit_2_before_connecting(
    fuzz_env: dict[str, Path], case: str
) -> None:
    file = fuzz_env["dir"] / "bad.plan"
    file.write_text(ISSUE_CASES[case](), encoding="utf-8")
    result = _invoke(["upload", str(file), "--conn", "udpout:127.0.0.1:9", "-q"])
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith(f"error: {file}: "), result.stderr
    assert STOPPED not in result.stderr


def test_waypoints_values_the_wire_cannot_hold(fuzz_env: dict[str, Path]) -> None:
    seed = _seed_texts(".waypoints")[0].split("\n")
    cases = {
        "param1 1e39": (2, 4, "1e39"),
        "altitude 1e39": (2, 10, "1e39"),
        "home altitude 1e39": (1, 10, "1e39"),
    }
    for name, (line, column, token) in cases.items():
        lines = list(seed)
        columns = lines[line].split("\t")
        columns[column] = token
        lines[line] = "\t".join(columns)
        file = fuzz_env["dir"] / "bad.waypoints"
        file.write_text("\n".join(lines), encoding="utf-8")
        result = _invoke(["upload", str(file), "--conn", "udpout:127.0.0.1:9", "-q"])
        assert result.exit_code == 2, (name, result.output)
        assert f"{file}: line {line + 1}" in result.stderr, (name, result.stderr)
        assert "float32" in result.stderr, (name, result.stderr)


@pytest.mark.slow
def test_huge_inputs_are_refused_with_one_message(
    fuzz_env: dict[str, Path], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The sizes the fuzz draws too rarely to rely on: more items than MAVLink numbers, JSON
    nested 200,000 deep, a file beyond the size limit."""
    from uavplan.mission import io

    lines = _seed_texts(".waypoints")[0].rstrip("\n").split("\n")
    last = lines[-1].split("\t")
    many = [lines[0], lines[1]]
    for seq in range(1, 70_001):
        many.append("\t".join([str(seq), *last[1:]]))
    cases = {
        "many.waypoints": ("\n".join(many) + "\n", "line 65537: 70001 items with home"),
        "deep.plan": ("[" * 200_000 + "]" * 200_000, "nested too deeply"),
    }
    for name, (text, message) in cases.items():
        file = fuzz_env["dir"] / name
        file.write_text(text, encoding="utf-8")
        result = _invoke(["upload", str(file), "--conn", "udpout:127.0.0.1:9", "-q"])
        assert result.exit_code == 2, (name, result.output[-300:])
        assert result.stderr.startswith(f"error: {file}: ") and message in result.stderr, (
            result.stderr[:300]
        )
    monkeypatch.setattr(io, "MAX_FILE_BYTES", 1000)
    file = fuzz_env["dir"] / "big.plan"
    file.write_text(_seed_texts(".plan")[0], encoding="utf-8")
    result = _invoke(["convert", str(file), str(fuzz_env["out"] / "x.kml")])
    assert result.exit_code == 2 and "MiB are read" in result.stderr, result.output
    assert list(fuzz_env["out"].iterdir()) == []
