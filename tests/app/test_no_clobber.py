"""Outputs never overwrite inputs, and a symbolic link is written through (issue 37, item 7).

Every command that writes refuses (exit 2, before any planning, and leaving every file as it
was) an output path that names one of its inputs: the scenario, the map it names, its DEM,
the input ``.plan``, ``--scenario``'s files, directly or through a symbolic link. An output
that is a symbolic link to a new place is written there, the link kept. ``--report`` must end
in ``.json``.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from uavplan.app.outputs import OutputSet
from uavplan.cli import main
from uavplan.fileio import OutputFileError, atomic_write_text

ROOT = Path(__file__).resolve().parents[2]


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(main, list(args))
    return result.exit_code, result.output


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    """paper-env1 and its map, copied: (tmp/missions/paper-env1.yaml, tmp/maps/...)."""
    (tmp_path / "missions").mkdir()
    (tmp_path / "maps").mkdir()
    shutil.copy(ROOT / "maps" / "paper-env1.yaml", tmp_path / "maps" / "paper-env1.yaml")
    path = tmp_path / "missions" / "paper-env1.yaml"
    shutil.copy(ROOT / "missions" / "paper-env1.yaml", path)
    return path


def snapshot(folder: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


QUICK = ["--iterations", "5", "-q"]


@pytest.mark.parametrize("target", ["scenario", "map"])
def test_report_onto_the_scenario_or_its_map_is_refused_and_nothing_changes(
    tmp_path: Path, scenario: Path, target: str
) -> None:
    victim = scenario if target == "scenario" else tmp_path / "maps" / "paper-env1.yaml"
    # the .json rule would catch a .yaml report first: reach the input check through a link
    link = tmp_path / "r.json"
    link.symlink_to(victim)
    before = snapshot(tmp_path)
    code, out = run("plan", str(scenario), "-o", str(tmp_path / "v.plan"), "--report", str(link))
    assert code == 2, out
    role = "the scenario" if target == "scenario" else "the map of"
    assert role in out and "which this command reads" in out, out
    assert snapshot(tmp_path) == before
    assert not (tmp_path / "v.plan").exists()


def test_report_named_like_the_scenario_is_refused_for_its_name(
    tmp_path: Path, scenario: Path
) -> None:
    """The issue's typo: ``plan s.yaml -o v.plan --report s.yaml``."""
    before = snapshot(tmp_path)
    code, out = run(
        "plan", str(scenario), "-o", str(tmp_path / "v.plan"), "--report", str(scenario)
    )
    assert code == 2, out
    assert "--report writes a JSON report; name the file *.json" in out
    assert snapshot(tmp_path) == before


def test_output_onto_the_scenario_itself_is_refused(tmp_path: Path, scenario: Path) -> None:
    """``-o`` through a link (a name that passes the extension check) onto the scenario."""
    link = tmp_path / "v.plan"
    link.symlink_to(scenario)
    before = snapshot(tmp_path)
    code, out = run("plan", str(scenario), "-o", str(link), *QUICK)
    assert code == 2, out
    assert "is the scenario" in out
    assert snapshot(tmp_path) == before


def test_report_onto_the_input_plan_is_refused(tmp_path: Path) -> None:
    """Rerouting a .plan: a report (through a link) or a second output onto it."""
    source = tmp_path / "in.plan"
    shutil.copy(ROOT / "missions" / "qgc-inspection.plan", source)
    link = tmp_path / "r.json"
    link.symlink_to(source)
    before = source.read_bytes()
    code, out = run("plan", str(source), "-o", str(tmp_path / "out.plan"), "--report", str(link))
    assert code == 2, out
    assert "the mission to reroute" in out
    code, out = run("plan", str(source), "-o", str(source))
    assert code == 2, out
    assert source.read_bytes() == before


def test_report_must_end_in_json(tmp_path: Path, scenario: Path) -> None:
    code, out = run(
        "plan", str(scenario), "-o", str(tmp_path / "v.plan"), "--report", str(tmp_path / "r.txt")
    )
    assert code == 2 and "*.json" in out, out


@pytest.mark.slow
def test_output_through_a_symlink_writes_its_target_and_keeps_the_link(
    tmp_path: Path, scenario: Path
) -> None:
    (tmp_path / "real").mkdir()
    target = tmp_path / "real" / "v.plan"
    target.write_text("old")
    link = tmp_path / "v.plan"
    link.symlink_to(target)
    code, out = run("plan", str(scenario), "-o", str(link), *QUICK)
    assert code == 0, out
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert '"fileType": "Plan"' in target.read_text()
    # a dangling link: its target is created
    (tmp_path / "gone.json").symlink_to(tmp_path / "real" / "r.json")
    code, out = run(
        "plan", str(scenario), "-o", str(target), "--report", str(tmp_path / "gone.json"), *QUICK
    )
    assert code == 0, out
    assert (tmp_path / "gone.json").is_symlink()
    assert (tmp_path / "real" / "r.json").read_text().startswith("{")


def test_atomic_write_through_a_link_keeps_the_link(tmp_path: Path) -> None:
    target = tmp_path / "t.csv"
    target.write_text("old")
    link = tmp_path / "l.csv"
    link.symlink_to(target)
    atomic_write_text(link, "new")
    assert link.is_symlink() and target.read_text() == "new"


def test_same_file_sees_through_links_and_hard_links(tmp_path: Path) -> None:
    from uavplan.fileio import same_file

    a = tmp_path / "a.yaml"
    a.write_text("x")
    (tmp_path / "s").symlink_to(a)
    os.link(a, tmp_path / "h")
    assert same_file(a, tmp_path / "s")
    assert same_file(a, tmp_path / "h")
    assert same_file(a, tmp_path / "." / "a.yaml")
    assert not same_file(a, tmp_path / "b.yaml")


def test_inputs_named_after_the_check_are_checked_at_once(tmp_path: Path) -> None:
    from uavplan.fileio import InputFile

    source = tmp_path / "map.yaml"
    source.write_text("x")
    outputs = OutputSet()
    outputs.file(tmp_path / "map.yaml")
    outputs.check()
    with pytest.raises(OutputFileError, match=r"the map of s\.yaml"):
        outputs.reads(InputFile(str(source), "the map of s.yaml"))
    # a folder's file named late is checked against the inputs too
    outputs = OutputSet()
    outputs.reads(tmp_path / "out" / "s.yaml")
    folder = outputs.folder(tmp_path / "out")
    outputs.check()
    with pytest.raises(OutputFileError):
        folder.file("s.yaml")


def test_two_outputs_through_a_link_are_one_file(tmp_path: Path) -> None:
    (tmp_path / "a.png").symlink_to(tmp_path / "b.png")
    outputs = OutputSet()
    outputs.file(tmp_path / "a.png")
    outputs.file(tmp_path / "b.png")
    with pytest.raises(Exception, match="are the same file"):
        outputs.check()


@pytest.mark.slow
def test_other_commands_refuse_their_inputs(tmp_path: Path, scenario: Path) -> None:
    plan = tmp_path / "m.plan"
    code, out = run("plan", str(scenario), "-o", str(plan), *QUICK)
    assert code == 0, out
    before = snapshot(tmp_path)
    mapped = tmp_path / "maps" / "paper-env1.yaml"
    link = tmp_path / "to-map.geojson"
    link.symlink_to(mapped)
    csv = tmp_path / "to-map.csv"
    csv.symlink_to(mapped)
    png = tmp_path / "to-map.png"
    png.symlink_to(mapped)
    for args in (
        ["convert", str(plan), str(plan)],
        ["convert", str(plan), str(link), "--scenario", str(scenario)],
        ["simulate", str(plan), "--scenario", str(scenario), "--track", str(csv), "-q"],
        ["render", str(scenario), "--mission", str(plan), "-o", str(png)],
        ["render", str(scenario), "--no-plan", "-o", str(png)],
    ):
        code, out = run(*args)
        assert code == 2, (args, out)
        assert "which this command reads" in out, (args, out)
    assert snapshot(tmp_path) == before
