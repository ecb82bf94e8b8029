"""The fast paths of scenario loading give exactly what the full loader gives (issue 13).

``scenario._load_fast`` reads long one-line flow lists with the JSON parser and
``scenario._obstacle_fast`` validates plain obstacles without the per-key checker; both
must either decline (None) or agree with the full path value for value and type, on
generated documents (valid and hostile) and on every bundled file.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uavplan import geometry2d
from uavplan.errors import ScenarioError
from uavplan.obstacles import BoxObstacle, CylinderObstacle, PrismObstacle
from uavplan.scenario import checker, clearance, fields
from uavplan.scenario import yamlfile as Y

ROOT = Path(__file__).resolve().parents[2]


def same(a: Any, b: Any) -> bool:
    """Equal values of equal types all the way down (1 != 1.0 != True here)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        return list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    if isinstance(a, float):
        return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)
    return bool(a == b)


def full(text: str) -> Any:
    try:
        return Y.load_full(text, "x.yaml", "scenario")
    except ScenarioError as err:
        return ("error", str(err))


def read(text: str, tmp_path: Path) -> Any:
    path = tmp_path / "x.yaml"
    path.write_text(text, encoding="utf-8")
    try:
        return Y.read_yaml(path, "scenario")
    except ScenarioError as err:
        return ("error", str(err).replace(str(path), "x.yaml"))


# Scalars the fast path takes, and YAML 1.1 look-alikes it must leave to the full loader.
GOOD_NUMBERS = st.one_of(
    st.integers(-(10**6), 10**6).map(str),
    st.integers(-(10**9), 10**9).map(lambda v: f"{v / 1000:.3f}"),
    st.sampled_from(["0", "-0", "-0.0", "0.5", "0.0", "10.25"]),
)
TRICKY_NUMBERS = st.sampled_from(
    ["10.", ".5", "+1", "1e3", "1.0e+3", "012", "0x1f", "0b101", "1_000", "1:30", "1:30.5",
     "2001-12-14", ".inf", "-.inf", ".nan", "00", "1.5e-3", "007.5", "1__0", "-", "1 2"]
)  # fmt: skip
GOOD_WORDS = st.one_of(
    st.sampled_from(["box", "cylinder", "prism", "type", "center", "x", "y", "n", "nan", "_a"]),
    st.from_regex(r"[a-z_][a-z0-9_]{0,6}", fullmatch=True).filter(
        lambda w: w not in ("yes", "no", "on", "off", "true", "false", "null")
    ),
)
TRICKY_WORDS = st.sampled_from(
    ["yes", "no", "on", "off", "true", "false", "null", "Null", "True", "NO", "inf", "yess",
     "nullx", "onion", "E", "Box", "'box'", '"box"', "~", "=", "<<", "a b", "a-b", "a:b", "&x",
     "*x", "!!str x", "a #b", "[]", "{}"]
)  # fmt: skip
SPACE = st.sampled_from(["", " ", "  "])


def numbers(hostile: bool) -> Any:
    return st.one_of(GOOD_NUMBERS, TRICKY_NUMBERS) if hostile else GOOD_NUMBERS


def words(hostile: bool) -> Any:
    return st.one_of(GOOD_WORDS, TRICKY_WORDS) if hostile else GOOD_WORDS


@st.composite
def flow_seq(draw: Any, hostile: bool, depth: int) -> str:
    n = draw(st.integers(0 if hostile else 1, 4))
    if depth > 1 and draw(st.booleans()):
        parts = [draw(flow_seq(hostile, depth - 1)) for _ in range(max(n, 1))]
    else:
        parts = [draw(numbers(hostile)) for _ in range(n)]
    sp, sp2 = draw(SPACE), draw(SPACE)
    return "[" + sp + f"{sp2},{sp}".join(parts) + draw(SPACE) + "]"


@st.composite
def flow_map(draw: Any, hostile: bool) -> str:
    keys = draw(st.lists(words(hostile), min_size=1, max_size=5, unique=not hostile))
    pairs = []
    for key in keys:
        value = draw(st.one_of(numbers(hostile), words(hostile), flow_seq(hostile, 2)))
        colon = draw(st.sampled_from([": ", ":  ", ":"])) if hostile else ": "
        pairs.append(f"{key}{colon}{value}")
    sp = draw(SPACE)
    return "{" + sp + f",{sp}".join(pairs) + draw(SPACE) + "}"


@st.composite
def item_line(draw: Any, indent: str, hostile: bool) -> str:
    body = draw(st.one_of(flow_map(hostile), flow_seq(hostile, 2)))
    tails = ["", "", " # note", "  #: a, b", " "] + (["#x", "\t", " # \u2028 x"] if hostile else [])
    dash = draw(st.sampled_from(["- ", "-  ", "-"] if hostile else ["- ", "-  "]))
    return f"{indent}{dash}{body}{draw(st.sampled_from(tails))}"


@st.composite
def document(draw: Any) -> str:
    hostile = draw(st.integers(0, 2)) == 0
    lines: list[str] = []
    if draw(st.booleans()):
        lines.append(draw(st.sampled_from(["---", "%YAML 1.1\n---", "# a comment", ""])))
    for _ in range(draw(st.integers(1, 3))):
        key = draw(st.sampled_from(["obstacles", "via", "name", "on", "b_1", "obstacles"]))
        kind = draw(st.integers(0, 3))
        if kind == 0:
            lines.append(f"{key}: {draw(st.one_of(GOOD_NUMBERS, GOOD_WORDS, flow_map(False)))}")
            continue
        lines.append(key + ":" + draw(st.sampled_from(["", " ", " # list", "  "])))
        indent = draw(st.sampled_from(["", "  ", "    ", " "]))
        for _ in range(draw(st.integers(0, 12))):
            if hostile and draw(st.integers(0, 30)) == 0:
                lines.append(draw(st.sampled_from(["", "  # c", "#c", "   ", "\t", "  x: 1"])))
            elif draw(st.integers(0, 15)) == 0:
                lines.append(draw(st.sampled_from(["", "  # c", "#c", "   "])))
            ind = indent + " " if hostile and draw(st.integers(0, 40)) == 0 else indent
            lines.append(draw(item_line(ind, hostile)))
        if kind == 3:  # something after the list, maybe not at column 0
            after = ["  - [1, 2]", "- type: box", "  foo: 1", "...", "---", "x:   # c", "# end"]
            lines.append(draw(st.sampled_from(after)))
    if hostile and draw(st.integers(0, 5)) == 0:
        lines.append(draw(st.sampled_from(["&a x: 1", "y: *a", "z: [1,", "- 1", "obstacles: 1"])))
    return "\n".join(lines) + draw(st.sampled_from(["\n", "", "\n\n"]))


@settings(max_examples=120, deadline=None, suppress_health_check=list(HealthCheck))
@given(document())
@pytest.mark.slow
def test_fast_lists_equal_the_full_loader(text: str) -> None:
    Y.FAST_MIN_ITEMS, saved = 1, Y.FAST_MIN_ITEMS  # exercise it on short lists too
    try:
        fast = Y.load_fast(text, "x.yaml")
    finally:
        Y.FAST_MIN_ITEMS = saved
    reference = full(text)
    if fast is not None:
        assert same(fast, reference), (text, fast, reference)


def test_generated_lists_take_the_fast_path() -> None:
    """The generator above is not vacuous: a plain obstacle list does take the fast path."""
    items = "\n".join(
        f"  - {{type: box, center: [{k}, {k}.5], size: [1, 2], height: 3}}" for k in range(20)
    )
    text = f"name: a\nobstacles:\n{items}\nvia:\n- [1, 2, 3]\n"
    fast = Y.load_fast(text, "x.yaml")
    assert fast is not None and same(fast, full(text))
    assert fast["obstacles"][3] == {"type": "box", "center": [3, 3.5], "size": [1, 2], "height": 3}


def test_a_short_document_does_not_compile_the_fast_patterns() -> None:
    """Fewer "- " than a fast list needs: declined before the patterns are compiled; the
    shortest qualifying list still takes the fast path."""
    items = [f"- [{k}, 1]" for k in range(Y.FAST_MIN_ITEMS)]
    Y.fast_patterns.cache_clear()
    short = "via:\n" + "\n".join(items[:-1]) + "\n"
    assert Y.load_fast(short, "x.yaml") is None
    assert Y.fast_patterns.cache_info().currsize == 0
    text = "via:\n" + "\n".join(items) + "\n"
    fast = Y.load_fast(text, "x.yaml")
    assert fast is not None and same(fast, full(text))


@pytest.mark.parametrize(
    "bad",
    [
        "  - {type: box, type: box, height: 3}",  # duplicate key: the full loader's message
        "  - {type: box, center: [1, 2], height: 1e3}",  # YAML 1.1: 1e3 is a string
        "  - {type: box, on: 1}",  # on is True in YAML 1.1
        "  - {type: box, center: [1, 012]}",  # octal
        "- {type: box}",  # another indent
        "  - {type: box, center: [1, 2]",  # broken
    ],
)
def test_doubtful_lists_give_the_full_loaders_answer(bad: str, tmp_path: Path) -> None:
    items = [f"  - {{type: cylinder, center: [{k}, 0], radius: 1, height: 2}}" for k in range(30)]
    items.insert(17, bad)
    text = "name: a\nobstacles:\n" + "\n".join(items) + "\nstart: [0, 0, 1]\n"
    assert same(read(text, tmp_path), full(text))


def test_bundled_files_agree() -> None:
    files = sorted((ROOT / "missions").glob("*.yaml")) + sorted((ROOT / "maps").glob("*.yaml"))
    assert files
    taken = 0
    for path in files:
        text = path.read_text(encoding="utf-8")
        fast = Y.load_fast(text, str(path))
        if fast is not None:
            taken += 1
            assert same(fast, full(text)), path
    assert taken >= 1  # midtown-manhattan's obstacle list is long enough


# ---------------------------------------------------------------------------------------------
# Obstacles

NUM = st.one_of(
    st.integers(-3, 3),
    st.floats(-400.0, 400.0),
    st.sampled_from([0, 0.0, -0.0, 1e7, 2e6, 2_000_000, 20_000, 20_001.0, 360, -360.5, 10**400]),
    st.sampled_from([math.nan, math.inf, -math.inf]),
    st.booleans(),
    st.none(),
    st.just("5"),
)
PT = st.one_of(st.lists(NUM, min_size=1, max_size=3), st.tuples(NUM, NUM), NUM)
GOOD_PT = st.lists(st.floats(-300.0, 300.0), min_size=2, max_size=2)


@st.composite
def raw_obstacle(draw: Any) -> Any:
    kind = draw(st.sampled_from(["box", "cylinder", "prism", "Box", None, 3]))
    good = draw(st.booleans())
    raw: dict[Any, Any] = {"type": kind} if draw(st.integers(0, 9)) else {}
    height = draw(st.floats(0.5, 300.0)) if good else draw(NUM)
    if draw(st.integers(0, 9)):
        raw["height"] = height
    if kind == "box" or not good:
        raw["center"] = draw(GOOD_PT) if good else draw(PT)
        raw["size"] = draw(st.lists(st.floats(0.5, 50.0), min_size=2, max_size=2) if good else PT)
        if draw(st.booleans()):
            raw["yaw"] = draw(st.floats(-360.0, 360.0)) if good else draw(NUM)
    if kind == "cylinder" or not good:
        raw["center"] = draw(GOOD_PT) if good else draw(PT)
        raw["radius"] = draw(st.floats(0.1, 50.0)) if good else draw(NUM)
    if kind == "prism" or not good:
        ring = draw(st.lists(GOOD_PT if good else PT, min_size=0, max_size=8))
        if ring and draw(st.booleans()):
            ring.append(ring[0])
        raw["polygon"] = ring
    if draw(st.integers(0, 12)) == 0:
        raw[draw(st.sampled_from(["extra", 1, "radius", "yaw"]))] = 1.0
    if draw(st.integers(0, 20)) == 0:
        return draw(st.sampled_from([[], "box", None, 3]))
    return raw


@settings(max_examples=800, deadline=None)
@given(raw_obstacle())
@pytest.mark.slow
def test_fast_obstacles_equal_the_checker(raw: Any) -> None:
    fast = fields.obstacle_fast(raw)
    chk = checker.Checker("x.yaml")
    try:
        reference = fields.obstacle(chk, raw, "obstacles[0]")
    except ScenarioError:
        assert fast is None
        return
    if fast is not None:
        assert fast == reference
        assert [type(v) for v in vars(fast).values()] == [type(v) for v in vars(reference).values()]


def test_plain_obstacles_take_the_fast_path() -> None:
    box = {"type": "box", "center": [1, 2.5], "size": [3, 4], "height": 5, "yaw": 10}
    cyl = {"type": "cylinder", "center": [0, 0], "radius": 2, "height": 9.5}
    prism = {"type": "prism", "polygon": [[0, 0], [0, 4], [4, 4], [4, 0], [0, 0]], "height": 3}
    chk = checker.Checker("x.yaml")
    for raw in (box, cyl, prism):
        fast = fields.obstacle_fast(raw)
        assert fast is not None and fast == fields.obstacle(chk, raw, "obstacles[0]")


def _reference_self_intersects(poly: list[tuple[float, float]]) -> bool:
    """The all-pairs proper-crossing test written out plainly."""
    n = len(poly)

    def cross(o: Any, a: Any, b: Any) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            c, d = poly[j], poly[(j + 1) % n]
            if cross(c, d, a) * cross(c, d, b) < 0 and cross(a, b, c) * cross(a, b, d) < 0:
                return True
    return False


@pytest.mark.slow
@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(st.integers(-5, 5), st.integers(-5, 5)), min_size=3, max_size=16))
def test_polygon_checks_match_the_plain_definitions(pts: list[tuple[int, int]]) -> None:
    poly = [(float(x), float(y)) for x, y in pts]
    n = len(poly)
    area = 0.5 * sum(
        poly[i][0] * poly[(i + 1) % n][1] - poly[(i + 1) % n][0] * poly[i][1] for i in range(n)
    )
    assert geometry2d.signed_area(poly) == area
    assert geometry2d.self_intersects(poly, touching=False) == _reference_self_intersects(poly)
    ring = np.asarray(poly)  # the array path gives the same answer as the plain loop
    assert geometry2d.self_intersects(ring, touching=False) == _reference_self_intersects(poly)


def test_the_plain_python_cull_never_hides_a_close_obstacle() -> None:
    """Small scenarios are checked without numpy (`validate` starts faster) when every
    obstacle's bounding box is far enough; the cull must never call a point clear that an
    obstacle is closer to than the reach, and otherwise the exact distance decides."""
    obstacles: list[Any] = []
    rng = np.random.default_rng(5)
    for k in range(40):
        x, y, h = rng.uniform(-300, 300), rng.uniform(-300, 300), rng.uniform(5, 100)
        if k % 3 == 0:
            obstacles.append(CylinderObstacle((x, y), rng.uniform(1, 40), h))
        elif k % 3 == 1:
            size = (rng.uniform(1, 60), rng.uniform(1, 60))
            obstacles.append(BoxObstacle((x, y), size, h, rng.uniform(-180, 180)))
        else:
            ring = ((x, y), (x + 30, y), (x + 30, y + 10), (x + 10, y + 10), (x + 10, y + 40))
            obstacles.append(PrismObstacle((*ring, (x, y + 40)), h))
    fp = clearance.Footprints(obstacles)
    culled = 0
    for _ in range(300):
        p = (rng.uniform(-350, 350), rng.uniform(-350, 350), rng.uniform(1, 150))
        exact = np.hypot(fp.horizontal(p[:2]), np.maximum(p[2] - fp.heights, 0.0))
        reach = float(rng.uniform(1, 60))
        dist, index = clearance.point_clearance(obstacles, p, within_m=reach)
        if index < 0:
            culled += 1
            assert float(exact.min()) >= reach
        else:
            assert dist == pytest.approx(float(exact.min()), abs=1e-12)
        column, c_index = clearance.column_clearance(obstacles, p[:2], within_m=reach)
        if c_index < 0:
            assert float(fp.horizontal(p[:2]).min()) >= reach
        else:
            assert column == pytest.approx(float(fp.horizontal(p[:2]).min()), abs=1e-12)
    assert culled > 0  # the cull does decide some points


def test_footprint_distances_match_the_world() -> None:
    """The one footprint-distance routine agrees with an independent one (geometry2d's
    per-polygon distance, and circles by hand)."""
    rng = np.random.default_rng(7)
    obstacles: list[Any] = [
        BoxObstacle((10.0, 20.0), (30.0, 12.0), 40.0, 33.0),
        CylinderObstacle((-50.0, 5.0), 9.0, 10.0),
        PrismObstacle(((0.0, -80.0), (40.0, -80.0), (40.0, -60.0), (20.0, -70.0)), 15.0),
    ]
    fp = clearance.Footprints(obstacles)
    for _ in range(200):
        xy = rng.uniform(-120, 120, 2)
        got = fp.horizontal(xy)
        box = geometry2d.points_polygon_distance(xy, obstacles[0].footprint())[0]
        cyl = max(float(np.hypot(*(xy - (-50.0, 5.0)))) - 9.0, 0.0)
        prism = geometry2d.points_polygon_distance(xy, obstacles[2].polygon_m)[0]
        assert np.allclose(got, [box, cyl, prism], rtol=0, atol=1e-9)
