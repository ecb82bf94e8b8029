"""The page of ``uavplan view`` opened in a real browser (headless Chromium,
tests/helpers/browser.py): no console error, nothing fetched, the 3-D view drawn (its pixels are not
blank), the waypoints and red legs it draws are the mission check's, the slider moves the vehicle,
the hover texts say what the issue asks. Each check is shown to fail on a page broken on purpose (a
trace missing, a script error, a blank view).

Skipped with the reason where the browser cannot run, unless ``UAVPLAN_REQUIRE_BROWSER=1``
(CI sets it: there the browser must run)."""

from __future__ import annotations

import importlib.util
import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from helpers.browser import Browser, Loaded, required, unavailable

from uavplan.cli import main

ROOT = Path(__file__).resolve().parents[2]
ENV1 = ROOT / "missions" / "paper-env1.yaml"
RIDGE = ROOT / "missions" / "jacksboro-ridge.yaml"
#: a browser per module and seconds per page: the slow tier
pytestmark = pytest.mark.slow


def _why_not() -> str | None:
    if importlib.util.find_spec("plotly") is None:
        return "the view extra (plotly) is not installed"
    return unavailable()


@pytest.fixture(scope="module")
def chromium() -> Iterator[Browser]:
    why = _why_not()
    if why is not None:
        if required():
            pytest.fail(f"UAVPLAN_REQUIRE_BROWSER is set but the browser cannot run: {why}")
        pytest.skip(why)
    b = Browser()
    try:
        yield b
    finally:
        b.close()


def run(*args: str | Path) -> object:
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory, chromium: Browser) -> dict[str, Path]:
    """The pages the tests open: paper-env1's mission, the same with a track bent under the
    margin on one leg, the ridge's scenario alone."""
    from test_view import _shifted_track

    tmp = tmp_path_factory.mktemp("pages")
    plan = tmp / "env1.plan"
    assert run("plan", ENV1, "-o", plan, "-q").exit_code == 0  # type: ignore[attr-defined]
    out = {"env1": tmp / "env1.html", "bent": tmp / "bent.html", "ridge": tmp / "ridge.html"}
    assert run("view", plan, "--scenario", ENV1, "-o", out["env1"]).exit_code == 0  # type: ignore[attr-defined]
    track, leg = _shifted_track(plan, tmp)
    result = run("view", plan, "--scenario", ENV1, "--track", track, "-o", out["bent"])
    assert result.exit_code == 3  # type: ignore[attr-defined]
    assert run("view", RIDGE, "-o", out["ridge"]).exit_code == 0  # type: ignore[attr-defined]
    out["bent-leg"] = Path(str(leg))
    out["plan"] = plan
    return out


# ---------------------------------------------------------------------------------------------
# the checks (each one fails on a broken page: the tests of the test below)


def assert_drawn_cleanly(loaded: Loaded) -> None:
    """No console error, the page says it is drawn, nothing fetched from the network."""
    assert loaded.errors == [], loaded.errors
    assert loaded.view("V.error") is None
    assert loaded.view("V.ready") is True
    fetched = [u for u in loaded.requests if not u.startswith(("file:", "data:", "blob:"))]
    assert fetched == []


def assert_3d_not_blank(loaded: Loaded) -> None:
    """The middle of the 3-D view (away from its legend) holds a drawn scene: many colours."""
    import io

    import numpy as np
    from matplotlib import image

    box = loaded.page.locator("#scene3d").bounding_box()
    assert box is not None
    clip = {
        "x": box["x"] + box["width"] * 0.3,
        "y": box["y"] + box["height"] * 0.25,
        "width": box["width"] * 0.4,
        "height": box["height"] * 0.5,
    }
    png = loaded.page.screenshot(clip=clip)
    pixels = (image.imread(io.BytesIO(png), format="png")[..., :3] * 255).astype(np.uint8)
    colours = {tuple(p) for p in pixels.reshape(-1, 3)[::3].tolist()}
    assert len(colours) > 40, f"the 3-D view is blank ({len(colours)} colours)"


def shown(loaded: Loaded) -> tuple[int, list[int], list[int]]:
    """(waypoints drawn, red legs drawn in 3-D, red legs in the profile and table)."""
    waypoints = loaded.view(
        "V.roles.waypoints === undefined ? -1 : "
        "document.getElementById('scene3d').data[V.roles.waypoints].x.length"
    )
    red3d = loaded.view(
        "V.roles['red-legs'] === undefined ? [] : [...new Set("
        "document.getElementById('scene3d').data[V.roles['red-legs']].customdata)].sort((a,b)=>a-b)"
    )
    table = loaded.view(
        "[...document.querySelectorAll('#legs tr.red')].map(r => Number(r.dataset.leg))"
    )
    profile = loaded.view(
        "V.profileRoles['profile-red-legs'] === undefined ? [] : [...new Set("
        "document.getElementById('profile').data[V.profileRoles['profile-red-legs']]"
        ".customdata)].sort((a,b)=>a-b)"
    )
    assert profile == table, (profile, table)
    return waypoints, red3d, table


def expected(plan_path: Path, track: Path | None = None) -> tuple[int, list[int]]:
    """The mission check's own answer: the items it flies to, and the legs under the margin
    (the planned line's segments by the one check, the flown track's by the same check)."""
    from test_view import _document

    doc = _document(ENV1, plan_path, track)["mission"]
    return len(doc["legs"]), doc["red_legs"]


def assert_shows_the_check(loaded: Loaded, waypoints: int, red: list[int]) -> None:
    got_waypoints, red3d, table = shown(loaded)
    assert got_waypoints == waypoints
    assert red3d == red
    assert table == red


def move_slider(loaded: Loaded, to: int) -> None:
    loaded.page.evaluate(
        "n => { const s = document.getElementById('replay'); s.value = String(n);"
        " s.dispatchEvent(new Event('input', {bubbles: true})); }",
        to,
    )
    loaded.page.wait_for_function(f"window.uavplanView.frame === {to}")
    loaded.page.wait_for_timeout(300)  # the next animation frame restyles


def vehicle_at(loaded: Loaded) -> list[float]:
    return loaded.view(
        "(() => { const d = document.getElementById('scene3d').data[V.roles.vehicle];"
        " return [d.x[0], d.y[0], d.z[0]]; })()"
    )


def assert_slider_moves_the_vehicle(loaded: Loaded) -> None:
    start = vehicle_at(loaded)
    text = loaded.page.locator("#readout").inner_text()
    last = int(loaded.page.locator("#replay").get_attribute("max") or 0)
    assert last > 10
    move_slider(loaded, last // 2)
    middle = vehicle_at(loaded)
    assert middle != start
    after = loaded.page.locator("#readout").inner_text()
    assert after != text and "m/s" in after and "battery" in after and "item" in after


# ---------------------------------------------------------------------------------------------
# the tests


def test_the_mission_page(chromium: Browser, pages: dict[str, Path]) -> None:
    loaded = chromium.open(pages["env1"])
    try:
        assert_drawn_cleanly(loaded)
        assert_3d_not_blank(loaded)
        waypoints, red = expected(pages["plan"])
        assert (waypoints, red) == (74, [])
        assert_shows_the_check(loaded, waypoints, red)
        assert_slider_moves_the_vehicle(loaded)
        roles = loaded.view("V.roles")
        for role in ("obstacles", "planned", "waypoints", "flown", "planned-return", "bounds"):
            assert role in roles, role
    finally:
        loaded.page.close()


def test_hover_texts(chromium: Browser, pages: dict[str, Path]) -> None:
    """Every waypoint: its number, lat/lon, altitude AMSL and above the ground, clearance;
    every obstacle: its name from the map file, its height and top."""
    loaded = chromium.open(pages["env1"])
    try:
        wp = loaded.view("document.getElementById('scene3d').data[V.roles.waypoints].hovertext")
        assert len(wp) == 74
        assert re.match(r"#5 waypoint \(item 5, seq 6\)<br>-?\d+\.\d{7}, -?\d+\.\d{7}<br>", wp[4])
        assert "m AMSL" in wp[4] and "above the ground" in wp[4] and "clearance" in wp[4]
        obstacle = loaded.view(
            "document.getElementById('scene3d').data[V.roles.obstacles].hovertext[0]"
        )
        assert obstacle.startswith("obstacle #0 of map ../maps/paper-env1.yaml")
        assert "above the ground, top" in obstacle
        assert re.search(r"<br>box at -?\d+\.\d{7}, -?\d+\.\d{7}<br>", obstacle), obstacle
    finally:
        loaded.page.close()


def test_a_track_under_the_margin_on_one_leg_is_that_leg_red(
    chromium: Browser, pages: dict[str, Path]
) -> None:
    leg = int(str(pages["bent-leg"]))
    loaded = chromium.open(pages["bent"])
    try:
        assert_drawn_cleanly(loaded)
        waypoints, red = expected(pages["plan"], pages["bent"].with_name("bent.csv"))
        assert red == [leg]
        assert_shows_the_check(loaded, waypoints, [leg])
        assert loaded.page.locator("#verdict li.problem").count() >= 2
    finally:
        loaded.page.close()


def test_a_scenario_over_terrain(chromium: Browser, pages: dict[str, Path]) -> None:
    loaded = chromium.open(pages["ridge"])
    try:
        assert_drawn_cleanly(loaded)
        assert_3d_not_blank(loaded)
        roles = loaded.view("V.roles")
        assert "terrain" in roles and "route-points" in roles and "vehicle" not in roles
    finally:
        loaded.page.close()


# ---------------------------------------------------------------------------------------------
# tests of the test: the checks above fail on a broken page


def _broken(source: Path, tmp: Path, name: str, old: str, new: str) -> Path:
    html = source.read_text(encoding="utf-8")
    assert old in html
    out = tmp / name
    out.write_text(html.replace(old, new, 1), encoding="utf-8")
    return out


def test_the_checks_catch_a_missing_trace(
    chromium: Browser, pages: dict[str, Path], tmp_path: Path
) -> None:
    broken = _broken(pages["env1"], tmp_path, "no-waypoints.html", 'add("waypoints", {', "({")
    loaded = chromium.open(broken)
    try:
        assert_drawn_cleanly(loaded)  # it draws, without its waypoints
        with pytest.raises(AssertionError):
            assert_shows_the_check(loaded, 74, [])
    finally:
        loaded.page.close()


def test_the_checks_catch_a_script_error(
    chromium: Browser, pages: dict[str, Path], tmp_path: Path
) -> None:
    broken = _broken(
        pages["env1"], tmp_path, "error.html", "function drawProfile(mission, margin) {",
        "function drawProfile(mission, margin) { undefinedFunction();",
    )  # fmt: skip
    loaded = chromium.open(broken)
    try:
        with pytest.raises(AssertionError):
            assert_drawn_cleanly(loaded)
        assert any("undefinedFunction" in e for e in loaded.errors)
    finally:
        loaded.page.close()


def test_the_checks_catch_a_blank_view_and_a_dead_slider(
    chromium: Browser, pages: dict[str, Path], tmp_path: Path
) -> None:
    blank = _broken(
        pages["env1"], tmp_path, "blank.html", "</style>",
        "#scene3d .gl-container { visibility: hidden; }\n</style>",
    )  # fmt: skip
    loaded = chromium.open(blank)
    try:
        assert_drawn_cleanly(loaded)
        with pytest.raises(AssertionError, match="blank"):
            assert_3d_not_blank(loaded)
    finally:
        loaded.page.close()
    dead = _broken(
        pages["env1"], tmp_path, "dead.html", "var jobs = [Plotly.restyle(div3d",
        "var jobs = [Promise.resolve(div3d",
    )  # fmt: skip
    loaded = chromium.open(dead)
    try:
        with pytest.raises(AssertionError):
            assert_slider_moves_the_vehicle(loaded)
    finally:
        loaded.page.close()
