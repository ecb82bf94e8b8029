"""Fuzzing scenario and map files through ``uavplan validate`` and ``uavplan plan`` (issue 12).

Hypothesis generates and mutates scenario and map YAML — values of every type, NaN / inf /
huge and tiny numbers, unicode and control characters, deep nesting, duplicate keys, anchors
and alias bombs, byte-order marks, UTF-16 / UTF-32 / Latin-1 bytes, truncation and bit flips —
and runs each file through the CLI in-process (click's ``CliRunner``). The invariant: exit 0,
or exit 2 with one message naming the file at fault; never exit 1, a traceback, an "internal
error", a hang (pytest-timeout ends the run) or a partial output file.

Example counts (the default run: 2,120 in all, about a minute on a quiet core):

* ``test_validate_mutated_scenarios``: 900 (value mutations at any key path)
* ``test_validate_mutated_bytes``: 800 (text and byte mutations of a valid file)
* ``test_validate_mutated_maps``: 400 (a scenario naming a mutated map)
* ``test_plan_mutated_scenarios``: 20 (``plan --iterations 3 --population 4``)

Set ``UAVPLAN_FUZZ_EXAMPLES=N`` to multiply every count by N/1000 (for example
``UAVPLAN_FUZZ_EXAMPLES=20000`` for a nightly run twenty times as long). Hypothesis keeps no
example database here, so every run draws afresh from its seed (``--hypothesis-seed``).
"""

from __future__ import annotations

import copy
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml  # type: ignore[import-untyped]
from click.testing import CliRunner
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from uavplan.cli import main

SCALE = int(os.environ.get("UAVPLAN_FUZZ_EXAMPLES", "1000")) / 1000.0


def examples(n: int) -> int:
    return max(1, int(n * SCALE))


def fuzz_settings(n: int) -> settings:
    return settings(
        max_examples=examples(n),
        deadline=None,  # no wall-clock assertions; pytest-timeout catches a hang
        database=None,
        suppress_health_check=list(HealthCheck),
        derandomize=False,
    )


BASE: dict[str, Any] = {
    "name": "fuzz",
    "origin": {"lat": 47.0, "lon": 8.0, "alt": 400.0},
    "bounds": {"x": [0, 300], "y": [-140, 140], "z": [0, 120]},
    "start": [0, 0, 30],
    "goal": [300, 20, 40],
    "safety_margin": 5,
    "obstacles": [
        {"type": "box", "center": [150, 10], "size": [40, 60], "height": 100, "yaw": 10},
        {"type": "cylinder", "center": [80, -90], "radius": 15, "height": 60},
        {"type": "prism", "polygon": [[200, 60], [240, 70], [230, 110]], "height": 50},
    ],
    "vehicle": {"cruise_speed": 8, "takeoff_altitude": 30},
    "planner": {
        "algorithm": "spsa",
        "population": 8,
        "iterations": 5,
        "seed": 1,
        "grid": {"dx": 20, "dy": 20, "dz": 10},
        "spsa": {"v_max": 5, "oscillation_window": 5},
        "de": {"cr": 0.5},
        "post": {"sample_step_m": 5},
        "energy": {"k0": 1},
    },
    "mission": {"autopilot": "px4", "spacing": 40, "end": "land"},
}

MAP: dict[str, Any] = {
    "name": "fuzz-map",
    "origin": {"lat": 47.0, "lon": 8.0, "alt": 400.0},
    "bounds": {"x": [0, 300], "y": [-140, 140], "z": [0, 120]},
    "obstacles": [
        {"type": "box", "center": [150, 10], "size": [40, 60], "height": 100},
        {"type": "cylinder", "center": [80, -90], "radius": 15, "height": 60},
    ],
}


def nested(depth: int) -> Any:
    value: Any = 1
    for _ in range(depth):
        value = [value]
    return value


NASTY_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**6), max_value=10**6),
    st.sampled_from([0, -1, 3, 4, 2**31, 2**40, 2**63, 10**400, -(10**400)]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e308, -1e308, 1e-9, 5e-324, -0.0, 1e9]),
    st.text(max_size=12),
    st.sampled_from(["", "\x00", "é", "\U0001f600", "nan", ".inf", "0x10", "~", "box", "land"]),
)
NASTY = st.one_of(
    NASTY_SCALARS,
    st.lists(NASTY_SCALARS, max_size=4),
    st.dictionaries(st.text(max_size=6), NASTY_SCALARS, max_size=3),
    st.integers(min_value=1, max_value=150).map(nested),
)


def key_paths(doc: Any, prefix: tuple[Any, ...] = ()) -> Iterator[tuple[Any, ...]]:
    """Every key path into ``doc`` (mapping keys and list indices)."""
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from key_paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from key_paths(v, (*prefix, i))


def apply(doc: Any, path: tuple[Any, ...], action: str, value: Any, new_key: str) -> Any:
    """``doc`` with the value at ``path`` replaced, deleted, or given an extra key."""
    if not path:
        return value if action == "replace" else doc
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    last = path[-1]
    if action == "delete":
        del parent[last]
    elif action == "add" and isinstance(parent[last], dict):
        parent[last][new_key] = value
    else:
        parent[last] = value
    return doc


@st.composite
def mutated_docs(draw: st.DrawFn, base: dict[str, Any]) -> Any:
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(min_value=1, max_value=3))):
        paths = list(key_paths(doc))
        path = draw(st.sampled_from(paths))
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        value = draw(NASTY)
        new_key = draw(st.sampled_from(["x", "extra", "dx", "cr", "f", "spsa", "map", "<<"]))
        try:
            doc = apply(doc, path, action, value, new_key)
        except (KeyError, IndexError, TypeError):
            pass
    return doc


def dump(doc: Any) -> str:
    return yaml.safe_dump(doc, allow_unicode=True, sort_keys=False, width=10**6)


def bomb(depth: int) -> str:
    lines = ['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, depth):
        lines.append(f"a{i}: &a{i} [" + ",".join([f"*a{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


@st.composite
def mutated_bytes(draw: st.DrawFn, base: dict[str, Any]) -> bytes:
    text = dump(base)
    kind = draw(
        st.sampled_from(
            [
                "duplicate",
                "bomb",
                "anchor",
                "truncate",
                "bitflip",
                "encoding",
                "insert",
                "indent",
                "deep",
            ]
        )
    )
    if kind == "duplicate":
        key = draw(st.sampled_from(list(base)))
        text += f"{key}: {json.dumps(base[key])}\n"
    elif kind == "bomb":
        depth = draw(st.integers(min_value=2, max_value=12))
        where = draw(st.sampled_from(["start", "name", "obstacles", "planner"]))
        text = (
            bomb(depth) + text.replace(f"{where}:", "unused_was:", 1) + f"{where}: *a{depth - 1}\n"
        )
    elif kind == "anchor":
        text = text.replace("start:", "start: &s", 1).replace("goal: [", "goal: *s\nold_goal: [", 1)
        if draw(st.booleans()):
            text += "vehicle: &v [1, *v]\n"
    elif kind == "truncate":
        text = text[: draw(st.integers(min_value=0, max_value=len(text)))]
    elif kind == "deep":
        n = draw(st.integers(min_value=30, max_value=3000))
        text = text.replace("[0, 0, 30]", "[" * n + "]" * n, 1)
    elif kind == "indent":
        lines = text.splitlines()
        i = draw(st.integers(min_value=0, max_value=len(lines) - 1))
        lines[i] = draw(st.sampled_from(["\t", "  ", " - ", "? ", "! "])) + lines[i]
        text = "\n".join(lines) + "\n"
    data = text.encode("utf-8")
    if kind == "bitflip":
        buf = bytearray(data)
        for _ in range(draw(st.integers(min_value=1, max_value=8))):
            i = draw(st.integers(min_value=0, max_value=len(buf) - 1))
            buf[i] ^= 1 << draw(st.integers(min_value=0, max_value=7))
        data = bytes(buf)
    elif kind == "encoding":
        enc = draw(st.sampled_from(["utf-16", "utf-16-le", "utf-32", "latin-1", "bom", "cp1252"]))
        text = text.replace("fuzz", "füzz\u00e9")
        data = b"\xef\xbb\xbf" + text.encode() if enc == "bom" else text.encode(enc)
    elif kind == "insert":
        junk = draw(st.binary(min_size=1, max_size=8))
        i = draw(st.integers(min_value=0, max_value=len(data)))
        data = data[:i] + junk + data[i:]
    return data


@pytest.fixture(scope="module")
def workdir() -> Iterator[Path]:
    with tempfile.TemporaryDirectory(prefix="uavplan-fuzz-") as d:
        yield Path(d)


def check_outcome(result: Any, files: list[Path], allowed: tuple[int, ...] = (0, 2)) -> None:
    output = result.output
    event(f"exit {result.exit_code}")
    assert result.exit_code in allowed, f"exit {result.exit_code}: {output}"
    assert "Traceback" not in output, output
    assert "internal error" not in output, output
    if result.exception is not None:
        assert isinstance(result.exception, SystemExit), repr(result.exception)
    if result.exit_code == 2:
        assert any(str(f) in output for f in files), output
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def validate(path: Path) -> Any:
    return CliRunner().invoke(main, ["validate", str(path)])


@fuzz_settings(900)
@given(doc=mutated_docs(BASE))
@pytest.mark.slow
def test_validate_mutated_scenarios(workdir: Path, doc: Any) -> None:
    path = workdir / "scenario.yaml"
    path.write_text(dump(doc), encoding="utf-8")
    check_outcome(validate(path), [path])


@fuzz_settings(800)
@given(data=mutated_bytes(BASE))
@pytest.mark.slow
def test_validate_mutated_bytes(workdir: Path, data: bytes) -> None:
    path = workdir / "bytes.yaml"
    path.write_bytes(data)
    check_outcome(validate(path), [path])


@fuzz_settings(400)
@given(doc=st.one_of(mutated_docs(MAP), mutated_bytes(MAP)))
@pytest.mark.slow
def test_validate_mutated_maps(workdir: Path, doc: Any) -> None:
    map_path = workdir / "maps" / "m.yaml"
    map_path.parent.mkdir(exist_ok=True)
    if isinstance(doc, bytes):
        map_path.write_bytes(doc)
    else:
        map_path.write_text(dump(doc), encoding="utf-8")
    scenario = {k: v for k, v in BASE.items() if k not in ("origin", "bounds", "obstacles")}
    scenario["map"] = "maps/m.yaml"
    path = workdir / "with-map.yaml"
    path.write_text(dump(scenario), encoding="utf-8")
    check_outcome(validate(path), [path, map_path.resolve()])


@fuzz_settings(20)
@given(doc=mutated_docs(BASE))
def test_plan_mutated_scenarios(workdir: Path, doc: Any) -> None:
    path = workdir / "plan.yaml"
    path.write_text(dump(doc), encoding="utf-8")
    out = workdir / "out.plan"
    out.unlink(missing_ok=True)
    args = ["plan", str(path), "-o", str(out), "--iterations", "3", "--population", "4", "-q"]
    result = CliRunner().invoke(main, args)
    check_outcome(result, [path], allowed=(0, 2, 3))
    if result.exit_code == 0:
        json.loads(out.read_text(encoding="utf-8"))  # a whole .plan file
    else:
        assert not out.exists(), "a failed plan left an output file"
    assert not [p for p in workdir.iterdir() if p.name.startswith(".out.plan")]
    # validate agrees with plan on what a valid scenario is
    if result.exit_code == 0:
        assert validate(path).exit_code == 0
