"""``uavplan view`` and the page's document, without a browser
(tests/presentation/test_view_browser.py opens the pages): the legs and waypoints the page shows are
the mission check's, a flown track under the margin on one leg marks exactly that leg, the page is
one file that fetches nothing, and every way a user can get it wrong is one message and exit 2."""

from __future__ import annotations

import importlib.util
import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from uavplan.cli import main

ROOT = Path(__file__).resolve().parents[2]
ENV1 = ROOT / "missions" / "paper-env1.yaml"
RIDGE = ROOT / "missions" / "jacksboro-ridge.yaml"

pytestmark = pytest.mark.skipif(
    importlib.util.find_spec("plotly") is None, reason="the view extra (plotly) is not installed"
)


def run(*args: str | Path) -> object:
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def env1_plan(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("env1") / "env1.plan"
    result = run("plan", ENV1, "-o", out, "-q")
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    return out


def document_of(html: str) -> dict:
    match = re.search(
        r'<script id="uavplan-data" type="application/json">(.*?)</script>', html, re.S
    )
    assert match is not None
    return json.loads(match.group(1))


# ---------------------------------------------------------------------------------------------
# legs


def test_legs_by_hand() -> None:
    """Take-off climb, two legs, a waypoint and a landing at one place (stacked): the
    landing's descent is the landing's leg."""
    from uavplan.view.build import leg_of_segments

    points = np.array(
        [[0, 0, 0], [0, 0, 30], [100, 0, 30], [100, 100, 30], [100, 100, 0]], dtype=float
    )
    targets = np.array([[0, 0], [100, 0], [100, 100], [100, 100]], dtype=float)
    seg, ends = leg_of_segments(points, targets, from_home=True)
    assert seg.tolist() == [0, 1, 2, 3]
    assert ends.tolist() == [1, 2, 3, 4]


def test_a_landing_descends_within_its_leg() -> None:
    from uavplan.view.build import leg_of_segments

    points = np.array([[0, 0, 0], [0, 0, 30], [50, 0, 30], [80, 0, 30], [80, 0, 0]], dtype=float)
    seg, ends = leg_of_segments(points, np.array([[0, 0], [50, 0], [80, 0]]), from_home=True)
    assert seg.tolist() == [0, 1, 2, 2]
    assert ends.tolist() == [1, 2, 4]


def _document(scenario_path: Path, plan_path: Path, track: Path | None = None) -> dict:
    from uavplan.app.view import mission_document_for
    from uavplan.mission.io import load_mission
    from uavplan.scenario import load_scenario

    scn = load_scenario(scenario_path)
    plan = load_mission(plan_path)
    return mission_document_for(
        scn, plan, source=str(plan_path), track=None if track is None else str(track)
    )


@pytest.mark.slow
def test_waypoints_and_red_legs_are_the_mission_checks(env1_plan: Path, tmp_path: Path) -> None:
    """A waypoint moved next to an obstacle: the page's red legs are the legs whose
    segments the one mission check finds under the margin (over flat ground each straight
    leg is one segment of its line), and its waypoints the items the check flies."""
    from uavplan.app.check import check_flight_in, mission_flight
    from uavplan.mission.io import load_mission, save_mission
    from uavplan.scenario import load_scenario

    scn = load_scenario(ENV1)
    plan = load_mission(env1_plan)
    # item 8 onto obstacle #3's wall: 4 m from it, at its height's middle
    items = list(plan.items)
    from uavplan.planning import enu_frame

    frame = enu_frame(scn.site)
    obstacle = scn.site.obstacles[3]
    cx, cy = obstacle.center_m if hasattr(obstacle, "center_m") else obstacle.polygon_m[0]
    radius = getattr(obstacle, "radius_m", 0.0)
    lat, lon, _ = frame.to_geodetic(np.array([[cx - radius - 4.0, cy, 0.0]]))
    items[8] = replace(items[8], x=float(lat[0]), y=float(lon[0]))
    bad = tmp_path / "bad.plan"
    save_mission(replace(plan, items=tuple(items)), bad)
    bad_plan = load_mission(bad)
    check = check_flight_in(scn, mission_flight(bad_plan, scn))
    under = np.flatnonzero(check.clearance_m < scn.safety_margin_m)
    assert under.size  # the test's own premise: the check finds the moved waypoint too close
    flight = mission_flight(bad_plan, scn)
    assert len(flight.points_enu) - 1 == len(document_of_plan(bad)["mission"]["legs"])
    doc = document_of_plan(bad)["mission"]
    assert doc["red_legs"] == [int(i) + 1 for i in under]
    positional = [i for i in bad_plan.items if i.is_global and i.command < 100]
    assert len(doc["waypoints"]["x"]) == len(positional) == len(doc["legs"])


def document_of_plan(path: Path) -> dict:
    return _document(ENV1, path)


def _shifted_track(plan_path: Path, tmp_path: Path) -> tuple[Path, int]:
    """The flight model's track of the plan, one leg of it bent toward the obstacle it
    passes nearest, by a bump that is zero at the leg's ends: (the track file, the leg,
    1-based). The leg is one whose nearest approach lies inside it."""
    import shapely
    import shapely.ops

    from uavplan.flightcheck import flight_of_track
    from uavplan.mission.fence import footprints_of
    from uavplan.mission.io import load_mission
    from uavplan.planning import enu_frame
    from uavplan.rehearsal import CheckSite
    from uavplan.scenario import load_scenario
    from uavplan.view.build import fly_mission, mission_waypoints

    scn = load_scenario(ENV1)
    plan = load_mission(plan_path)
    site = CheckSite.of_scenario(scn)
    flown = fly_mission(scn, plan, site)
    track = flown.track
    frame = enu_frame(scn.site)
    p = flight_of_track(track, frame, lands=False).points_enu
    seqs = [i + 1 for i, _ in mission_waypoints(plan)]  # ArduPilot: wire seq = index + 1
    polys = [shapely.Polygon(fp.outline_enu(72)) for fp in footprints_of(scn.site.obstacles)]
    margin = scn.safety_margin_m
    best = None
    for leg, seq in enumerate(seqs):
        run = np.flatnonzero(track.current_seq == seq)
        if run.size < 30 or leg == 0:
            continue
        pts = shapely.points(p[run, :2])
        d = np.min([shapely.distance(pts, poly) for poly in polys], axis=0)
        j = int(np.argmin(d))
        if 0.3 * run.size < j < 0.7 * run.size and d[j] < margin + 8:
            best = (leg, run, j, d)
            break
    assert best is not None, "no leg passes near an obstacle in its middle"
    leg, run, j, d = best
    which = int(np.argmin([shapely.distance(shapely.Point(p[run[j], :2]), q) for q in polys]))
    near = shapely.ops.nearest_points(polys[which], shapely.Point(p[run[j], :2]))[0]
    direction = np.array([near.x, near.y]) - p[run[j], :2]
    direction /= np.linalg.norm(direction)
    bend = d[j] - margin + 3.0  # 3 m under the margin at the worst sample
    t = np.arange(run.size, dtype=float)
    weight = np.where(t <= j, t / j, (run.size - 1 - t) / (run.size - 1 - j))
    xy = p[run, :2] + (bend * weight)[:, None] * direction
    lat, lon, _ = frame.to_geodetic(np.column_stack((xy, np.zeros(len(xy)))))
    lat_all, lon_all = track.lat_deg.copy(), track.lon_deg.copy()
    lat_all[run], lon_all[run] = lat, lon
    bent = replace(track, lat_deg=lat_all, lon_deg=lon_all)
    out = tmp_path / "bent.csv"
    bent.save(out)
    return out, leg + 1


@pytest.mark.slow
def test_a_track_under_the_margin_on_one_leg_marks_exactly_that_leg(
    env1_plan: Path, tmp_path: Path
) -> None:
    track, leg = _shifted_track(env1_plan, tmp_path)
    doc = _document(ENV1, env1_plan, track)
    mission = doc["mission"]
    assert all(
        entry["planned_m"] >= doc["scene"]["margin_m"] for entry in mission["legs"]
    )  # the planned line keeps the margin: only the flown track breaks it
    assert mission["red_legs"] == [leg]
    assert mission["flown"]["check"]["ok"] is False
    assert any("as flown" in p for p in doc["verdict"]["problems"])
    # and the command: the page written, exit 3
    out = tmp_path / "bent.html"
    result = run("view", env1_plan, "--scenario", ENV1, "--track", track, "-o", out)
    assert result.exit_code == 3, result.output  # type: ignore[attr-defined]
    assert out.is_file()
    assert f"1 leg(s) under the 10 m margin: leg {leg}" in result.output  # type: ignore[attr-defined]


# ---------------------------------------------------------------------------------------------
# the command


def test_view_writes_one_self_contained_page(env1_plan: Path, tmp_path: Path) -> None:
    out = tmp_path / "env1.html"
    result = run("view", env1_plan, "--scenario", ENV1, "-o", out)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    assert "74 waypoints, no leg under the margin" in result.output  # type: ignore[attr-defined]
    html = out.read_text(encoding="utf-8")
    own = html.split("<script>", 1)[0]  # everything before the inlined plotly.js
    assert "<link" not in own and "src=" not in own and "@import" not in own
    assert not re.search(r"<script[^>]+src=", html)
    doc = document_of(html)
    assert doc["mission"]["flown"]["label"].startswith("flight model: ArduPilot")
    assert doc["mission"]["flown"]["frames"]["battery"][0] == 100.0
    # the way home: paper-env1 ends with a planned return (no RTL altitude under the legal
    # ceiling brings it home), drawn as the last legs
    assert any(leg["planned_return"] for leg in doc["mission"]["legs"])


def test_view_of_a_scenario_alone_over_terrain(tmp_path: Path) -> None:
    out = tmp_path / "ridge.html"
    result = run("view", RIDGE, "-o", out)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    doc = document_of(out.read_text(encoding="utf-8"))
    assert doc["mission"] is None
    assert doc["scene"]["terrain"]["shape"] == [120, 120]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["{plan}", "-o", "{tmp}/p.html"], "give --scenario S"),
        (["{plan}", "--scenario", str(ENV1), "-o", "{tmp}/p.png"], "name the file *.html"),
        ([str(ENV1), "--scenario", str(ENV1), "-o", "{tmp}/p.html"], "--scenario goes with"),
        ([str(ENV1), "--track", "t.csv", "-o", "{tmp}/p.html"], "--track goes with"),
        (["{plan}", "--scenario", "{plan}", "-o", "{tmp}/p.html"], "not a scenario"),
        (["{plan}", "--scenario", str(ENV1), "-o", "{tmp}/none/p.html"], "p.html"),
    ],
)
def test_mistakes_are_one_message_and_exit_2(
    env1_plan: Path, tmp_path: Path, args: list[str], message: str
) -> None:
    filled = [a.format(plan=env1_plan, tmp=tmp_path) for a in args]
    result = run("view", *filled)
    assert result.exit_code == 2, result.output  # type: ignore[attr-defined]
    assert message in result.output  # type: ignore[attr-defined]
    assert "Traceback" not in result.output  # type: ignore[attr-defined]


def test_the_page_never_overwrites_an_input(env1_plan: Path, tmp_path: Path) -> None:
    copy = tmp_path / "in.html"
    copy.write_bytes(env1_plan.read_bytes())
    before = copy.read_bytes()
    result = run("view", copy, "--scenario", ENV1, "-o", copy)
    assert result.exit_code == 2
    assert "overwrite the input" in result.output  # type: ignore[attr-defined]
    assert copy.read_bytes() == before


def test_without_the_extra_the_message_says_how_to_install_it(
    env1_plan: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import uavplan.view.page as page

    real = importlib.util.find_spec

    def no_plotly(name: str, *a: object) -> object:
        return None if name == "plotly" else real(name, *a)  # type: ignore[arg-type]

    monkeypatch.setattr(page.importlib.util, "find_spec", no_plotly)
    out = tmp_path / "p.html"
    for args in (
        ["view", env1_plan, "--scenario", ENV1, "-o", out],
        ["plan", ENV1, "-o", tmp_path / "x.plan", "--view", out],
    ):
        result = run(*args)
        assert result.exit_code == 2, result.output  # type: ignore[attr-defined]
        assert "pip install 'uavplan[view]'" in result.output  # type: ignore[attr-defined]
    assert not out.exists() and not (tmp_path / "x.plan").exists()


@pytest.mark.slow
def test_plan_and_simulate_write_the_page(tmp_path: Path) -> None:
    mission, page = tmp_path / "env1.plan", tmp_path / "plan.html"
    result = run("plan", ENV1, "-o", mission, "--view", page, "-q")
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    doc = document_of(page.read_text(encoding="utf-8"))
    assert doc["source"] == str(mission)
    assert len(doc["mission"]["legs"]) == 74
    sim = tmp_path / "sim.html"
    result = run("simulate", mission, "--scenario", ENV1, "--view", sim)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    flown = document_of(sim.read_text(encoding="utf-8"))["mission"]["flown"]
    assert flown["label"] == "flight model: ArduPilot as simulated"


def test_plan_and_simulate_check_the_page_before_the_work(tmp_path: Path) -> None:
    result = run("plan", ENV1, "-o", tmp_path / "a.plan", "--view", tmp_path / "a.png")
    assert result.exit_code == 2 and "*.html" in result.output  # type: ignore[attr-defined]
    result = run("plan", ENV1, "-o", tmp_path / "a.plan", "--view", tmp_path / "no" / "a.html")
    assert result.exit_code == 2
    assert not (tmp_path / "a.plan").exists()
    (tmp_path / "b.plan").write_text("{}", encoding="utf-8")
    result = run("simulate", tmp_path / "b.plan", "--view", tmp_path / "b.html")
    assert result.exit_code == 2 and "--scenario" in result.output  # type: ignore[attr-defined]


def test_obstacle_mesh_is_one_mesh_of_every_obstacle() -> None:
    from uavplan.mission.fence import footprints_of
    from uavplan.scenario import load_scenario
    from uavplan.view.mesh import prism_mesh

    scn = load_scenario(ROOT / "missions" / "helsinki-centre.yaml")
    fps = footprints_of(scn.site.obstacles)
    mesh = prism_mesh(fps, 0.0, np.array([fp.height_m for fp in fps]))
    assert set(np.unique(mesh.owner).tolist()) == set(range(len(fps)))
    assert mesh.triangles.max() < len(mesh.vertices)
    # every wall stands from the base to its top, every top at its obstacle's height
    tops = mesh.vertices[:, 2] > 0
    heights = np.array([fp.height_m for fp in fps])
    assert np.allclose(mesh.vertices[tops, 2], heights[mesh.owner[tops]])


def test_without_the_constrained_triangulation_every_top_is_still_drawn(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """shapely 2.0 (no constrained Delaunay): the tops come from the plain triangulation,
    the triangles inside each footprint; every obstacle keeps a top at its height."""
    import shapely

    from uavplan.mission.fence import footprints_of
    from uavplan.scenario import load_scenario
    from uavplan.view.mesh import prism_mesh

    monkeypatch.delattr(shapely, "constrained_delaunay_triangles", raising=False)
    scn = load_scenario(ROOT / "missions" / "helsinki-centre.yaml")
    fps = footprints_of(scn.site.obstacles)
    mesh = prism_mesh(fps, 0.0, np.array([fp.height_m for fp in fps]))
    walls = 2 * int(np.count_nonzero(mesh.vertices[:, 2] == 0.0))  # two triangles an edge
    tops = mesh.triangles[walls:]
    assert set(np.unique(mesh.owner[tops[:, 0]]).tolist()) == set(range(len(fps)))


def test_a_rerouted_plan_has_no_view_of_its_own(env1_plan: Path, tmp_path: Path) -> None:
    result = run("plan", env1_plan, "-o", tmp_path / "r.plan", "--view", tmp_path / "r.html")
    assert result.exit_code == 2, result.output  # type: ignore[attr-defined]
    assert "uavplan view OUT.plan --scenario S" in result.output  # type: ignore[attr-defined]
    assert not (tmp_path / "r.plan").exists()
