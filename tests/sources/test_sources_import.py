"""``uavplan import`` on the bundled OpenStreetMap extract, its errors, and the bundled DEM."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

pytest.importorskip("osmium")
pytest.importorskip("shapely")

from uavplan.cli import main
from uavplan.errors import EXIT_INPUT
from uavplan.geo import EnuFrame, GeoPoint
from uavplan.obstacles import CylinderObstacle, PrismObstacle
from uavplan.scenario import load_map

ROOT = Path(__file__).resolve().parents[2]
EXTRACT = ROOT / "maps" / "helsinki-centre.osm.pbf"
DEM = ROOT / "maps" / "jacksboro-fault-dem.tif"


def counts(output: str, word: str) -> dict[str, int]:
    return {
        m.group(2): int(m.group(1))
        for m in re.finditer(rf"^  {word} +(\d+)  (.+)$", output, flags=re.MULTILINE)
    }


def test_import_bundled_extract_reports_kept_and_skipped_by_reason(tmp_path: Path) -> None:
    out = tmp_path / "helsinki.yaml"
    result = CliRunner().invoke(
        main,
        [
            "import",
            str(EXTRACT),
            "-o",
            str(out),
            "--origin",
            "60.171586,24.94429,10",
            "--bounds",
            "-450,450,-600,600",
            "--ceiling",
            "60",
            "--default-height",
            "20",
        ],
    )
    assert result.exit_code == 0, result.output
    kept = counts(result.output, "kept")
    skipped = counts(result.output, "skipped")
    # the extract's buildings: closed ways and multipolygon relations, with their parts
    assert kept["building (way)"] > 300
    assert kept["building (multipolygon relation)"] > 40
    assert kept["building:part (way)"] > 50
    assert kept["tower (node)"] == 1 and kept["flagpole (node)"] > 10
    # relations cut by the extract's edge cannot be assembled: skipped, with the reason
    assert skipped["multipolygon relation did not assemble (members missing or broken)"] >= 1
    assert skipped["outside the bounds"] >= 1
    assert "© OpenStreetMap" in out.read_text(encoding="utf-8").replace("(c)", "©")
    origin, bounds, obstacles = load_map(out)  # the written map is a valid, editable map
    assert origin == GeoPoint(60.171586, 24.94429, 10.0)
    assert bounds is not None and bounds.z_m == (0.0, 60.0)
    header = re.search(r"as (\d+) obstacles", result.output)
    assert header is not None and len(obstacles) == int(header.group(1))
    assert all(isinstance(o, PrismObstacle | CylinderObstacle) for o in obstacles)
    assert all(o.height_m > 0 for o in obstacles)


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["missing.osm.pbf", "-o", "x.yaml"], "file not found"),
        ([str(EXTRACT), "-o", "x.txt"], "name the output *.yaml"),
        ([str(EXTRACT), "-o", "x.yaml", "--bounds", "1,2,3"], "--bounds: expected 4 numbers"),
        ([str(EXTRACT), "-o", "x.yaml", "--bounds", "5,1,0,9"], "XMIN < XMAX"),
        ([str(EXTRACT), "-o", "x.yaml", "--origin", "95,10"], "--origin: latitude"),
        ([str(EXTRACT), "-o", "x.yaml", "--layer", "roofs"], "--layer: OpenStreetMap files"),
        ([str(EXTRACT), "-o", "x.yaml", "--default-height", "0"], "--default-height: must be"),
    ],
)
def test_import_errors_are_one_line_exit_2(tmp_path: Path, args: list[str], words: str) -> None:
    args = [str(tmp_path / a) if a.startswith(("x.", "missing")) else a for a in args]
    result = CliRunner().invoke(main, ["import", *args])
    assert result.exit_code == EXIT_INPUT, result.output
    assert words in result.output
    assert "Traceback" not in result.output and not (tmp_path / "x.yaml").exists()


def test_import_help_has_an_example() -> None:
    result = CliRunner().invoke(main, ["import", "--help"])
    assert result.exit_code == 0
    assert "uavplan import town.osm.pbf -o maps/town.yaml" in result.output


def test_bundled_dem_reads_back_its_posts() -> None:
    pytest.importorskip("rasterio")
    from matplotlib import cbook

    from uavplan.sources.dem import Terrain

    npz = cbook.get_sample_data("jacksboro_fault_dem.npz")
    z = np.asarray(npz["elevation"], dtype=float)
    west, north = float(npz["xmin"]), float(npz["ymin"])
    step = float(npz["dx"])
    frame = EnuFrame.at(GeoPoint(36.6, -84.25, 0.0))
    terrain = Terrain.from_file(DEM, frame)
    rows = np.array([100, 150, 200, 163])
    cols = np.array([150, 200, 250, 193])
    lat = north - (rows + 0.5) * step
    lon = west + (cols + 0.5) * step
    xy = frame.to_enu_xy(lat, lon)
    assert np.allclose(terrain.height_m(xy), z[rows, cols], atol=0.01)
    assert 80.0 < terrain.post_spacing_m < 95.0  # 3 arc-seconds at 36.6° N
