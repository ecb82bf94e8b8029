"""Fuzz the zone files of ``airspace:``: 100 OpenAir and 100 ED-269 / ED-318 files broken the
way real files break (lines lost, doubled or swapped, numbers made huge, negative, NaN or
text, keys deleted, values of the wrong type, the text cut short, bytes flipped), each read by
``uavplan validate`` through a scenario that names it. Invariant: exit 0, or exit 2 with one
line naming the scenario and the zone file; never exit 1, a traceback or a hang.

The mutations are drawn from a seeded generator (the same 200 files on every run);
``UAVPLAN_FUZZ_AIRSPACE=2000`` runs more of them.
"""

from __future__ import annotations

import copy
import json
import os
import random
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from uavplan.cli import main

ROOT = Path(__file__).resolve().parents[2]
COUNT = int(os.environ.get("UAVPLAN_FUZZ_AIRSPACE", "200")) // 2

pytestmark = pytest.mark.timeout(max(600, 6 * COUNT))

OPENAIR_SEED = (
    (ROOT / "missions" / "zurich-zones.txt").read_text()
    + """
AC Q
AN LINE
AL 2000ft
AH FL50
DP 47:24:00N 008:30:00E
DP 47:24:10N 008:30:10E

AC R
AN AGL ARC
AL 100 m AGL
AH 3000 STD
V X=47:23:50N 008:33:10E
V D=-
DA 0.3, 270, 90
DB 47:23:40N 008:33:10E, 47:24:00N 008:33:10E
DP 47:23:30N 008:33:00E
"""
)
ED269_SEED = json.loads((ROOT / "missions" / "zurich-zones.json").read_text())
ED318_SEED = {
    "type": "FeatureCollection",
    "features": [
        {
            "type": "Feature",
            "properties": {
                "identifier": "F1",
                "name": [{"text": "Prison (test)"}],
                "type": "PROHIBITED",
                "limitedApplicability": [
                    {
                        "startDateTime": "2026-12-01T08:00:00Z",
                        "endDateTime": "2026-12-01T18:00:00Z",
                        "schedule": [{"day": ["TUE"], "startTime": "08:00", "endTime": "12:00"}],
                    }
                ],
            },
            "geometry": {
                "type": "Point",
                "coordinates": [8.548, 47.401],
                "extent": {"subType": "Circle", "radius": 150},
                "layer": {
                    "upper": 120,
                    "upperReference": "AGL",
                    "lower": 0,
                    "lowerReference": "AGL",
                    "uom": "m",
                },
            },
        }
    ],
}

SCENARIO = """name: fz
origin: {lat: 47.397742, lon: 8.545594, alt: 430}
bounds: {x: [-2500, 2500], y: [-200, 2000], z: [0, 120]}
start: [-2200, 100, 40]
goal: [2200, 100, 40]
airspace: {files: [%s], at: 2026-12-01T09:00:00Z}
"""

WILD = [
    "",
    "-1",
    "0",
    "1e308",
    "nan",
    "inf",
    "999999999",
    "-0.0",
    "x",
    "FL",
    "UNL",
    "GND",
    "47:99:99N",
    "181:00:00E",
    "2026-13-45T99:00Z",
    ",",
    "=",
    "V X=",
    "+",
    "AGL",
    "\x7f",
]


def mutate_text(text: str, rng: random.Random) -> str:
    lines = text.splitlines()
    for _ in range(rng.randint(1, 4)):
        if not lines:
            break
        i = rng.randrange(len(lines))
        op = rng.randrange(7)
        if op == 0:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[rng.randrange(len(lines))])
        elif op == 2:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == 3:  # a token replaced
            words = lines[i].split(" ")
            words[rng.randrange(len(words))] = rng.choice(WILD)
            lines[i] = " ".join(words)
        elif op == 4:  # a digit changed
            chars = list(lines[i])
            digits = [k for k, c in enumerate(chars) if c.isdigit()]
            if digits:
                chars[rng.choice(digits)] = rng.choice("0123456789")
            lines[i] = "".join(chars)
        elif op == 5:
            lines = lines[: rng.randrange(len(lines) + 1)]  # cut short
        else:
            lines[i] = lines[i][: rng.randrange(len(lines[i]) + 1)]
    return "\n".join(lines) + "\n"


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out.extend(_paths(v, (*prefix, k)))
    elif isinstance(node, list):
        for k, v in enumerate(node):
            out.extend(_paths(v, (*prefix, k)))
    return out


WILD_JSON: list[Any] = [
    None,
    True,
    -1,
    0,
    1e300,
    -1e300,
    "x",
    "",
    [],
    {},
    [[[]]],
    [1, 2],
    "2026-02-30T00:00:00Z",
    "AGL",
    "WGS84",
    "Polygon",
    "Circle",
    10**30,
]


def mutate_json(doc: Any, rng: random.Random) -> str:
    doc = copy.deepcopy(doc)
    for _ in range(rng.randint(1, 3)):
        paths = [p for p in _paths(doc) if p]
        if not paths:
            break
        path = rng.choice(paths)
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        op = rng.randrange(3)
        if op == 0 and isinstance(parent, dict):
            del parent[path[-1]]
        elif op == 1 and isinstance(parent, list) and parent:
            parent.insert(path[-1], copy.deepcopy(parent[path[-1]]))
        else:
            parent[path[-1]] = copy.deepcopy(rng.choice(WILD_JSON))
    text = json.dumps(doc)
    if rng.random() < 0.15:  # the text itself broken
        cut = rng.randrange(len(text))
        text = text[:cut] + rng.choice(["", "}", "]", ",", '"', "NaN"]) + text[cut + 1 :]
    return text


def _check(tmp_path: Path, name: str, text: str) -> int:
    zone = tmp_path / name
    zone.write_text(text, encoding="utf-8", errors="surrogatepass")
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SCENARIO % name)
    result = CliRunner().invoke(main, ["validate", str(scenario)], catch_exceptions=False)
    assert result.exit_code in (0, 2), (result.exit_code, result.output, text)
    if result.exit_code == 2:
        message = result.stderr.strip()
        assert message.startswith(f"error: {scenario}: "), message
        assert name in message, message  # the zone file is named
        assert "Traceback" not in result.output
    return result.exit_code


def test_fuzzed_openair_files(tmp_path: Path) -> None:
    rng = random.Random(34)
    codes = [_check(tmp_path, "zones.txt", mutate_text(OPENAIR_SEED, rng)) for _ in range(COUNT)]
    assert 0 in codes and 2 in codes  # the mutations reach both outcomes


def test_fuzzed_ed269_and_ed318_files(tmp_path: Path) -> None:
    rng = random.Random(269)
    codes = []
    for k in range(COUNT):
        seed = ED269_SEED if k % 2 == 0 else ED318_SEED
        codes.append(_check(tmp_path, "zones.json", mutate_json(seed, rng)))
    assert 0 in codes and 2 in codes


def test_fuzz_seed_files_are_valid(tmp_path: Path) -> None:
    assert _check(tmp_path, "zones.txt", OPENAIR_SEED) == 0
    assert _check(tmp_path, "zones.json", json.dumps(ED269_SEED)) == 0
    assert _check(tmp_path, "zones.json", json.dumps(ED318_SEED)) == 0
