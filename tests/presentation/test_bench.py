"""``uavplan bench`` and :mod:`uavplan.bench`: jobs, the three backends (serial, local
processes, Dask) giving the same records, the Table-2 aggregation and the files written."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from uavplan import bench
from uavplan.cli import main
from uavplan.errors import EXIT_INPUT
from uavplan.scenario import load_scenario

TINY = """\
name: tiny
origin: {lat: 47.0, lon: 8.0, alt: 400}
bounds: {x: [0, 300], y: [-140, 140], z: [0, 120]}
start: [0, 0, 30]
goal: [300, 20, 40]
obstacles:
  - {type: box, center: [150, 10], size: [40, 60], height: 100}
planner: {population: 8, iterations: 4}
"""


@pytest.fixture
def tiny_path(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(TINY)
    return path


def _record(alg: str, energy: float, seed: int = 1, ok: bool = True) -> bench.RunRecord:
    return bench.RunRecord(
        index=seed,
        scenario="s",
        algorithm=alg,
        seed=seed,
        status="ok",
        route_energy=energy,
        search_fitness=energy + 10,
        collision_free=ok,
        min_clearance_m=10.0,
        length_m=energy,
        runtime_s=float(seed),
        iterations=3,
        deadlocks=0,
        evaluations=100 * seed,
        reach_checks=1000 * seed,
        termination="iterations",
        convergence=np.array([energy + 2, energy + 1, energy]),
    )


def _key(records: list[bench.RunRecord]) -> list[tuple]:
    return [(r.scenario, r.algorithm, r.seed, r.route_energy, r.search_fitness) for r in records]


# --- variants and jobs ------------------------------------------------------------------------


def test_variant_labels() -> None:
    v = bench.Variant.parse("spsa-no-escape")
    assert (v.algorithm, dict(v.spsa_changes), dict(v.post_changes)) == (
        "spsa",
        {"escape": False},
        {},
    )
    assert bench.Variant.parse("CSO") == bench.Variant("cso", "cso")
    assert dict(bench.Variant.parse("spsa-no-simplify").post_changes)["simplify"] is False
    with pytest.raises(ValueError, match="unknown algorithm 'cat'"):
        bench.Variant.parse("cat")
    labels = [v.label for v in bench.ablation_variants()]
    assert labels[0] == "spsa" and len(labels) == 1 + len(bench.ABLATIONS)


def test_parameter_variants() -> None:
    v = bench.Variant.parse("de(cr=0.1; f=0.7)")
    assert (v.label, v.algorithm, dict(v.options)) == (
        "de(cr=0.1; f=0.7)",
        "de",
        {"cr": 0.1, "f": 0.7},
    )
    v = bench.Variant.parse("spsa-no-escape(oscillation_window=4, smooth=false)")
    assert dict(v.spsa_changes) == {"escape": False, "oscillation_window": 4}
    assert dict(v.post_changes) == {"smooth": False}
    assert bench.Variant.parse("pso(v_max_fraction=null)").options == (("v_max_fraction", None),)
    for bad, message in [
        ("de(F=1)", "F: unknown key"),
        ("spsa(nope=1)", "nope: unknown key"),
        ("gwo(a_start=-1)", "a_start: must be a number >= 0"),
        ("ssa(x=1)", "takes no parameters"),
        ("de(cr)", "not KEY=VALUE"),
    ]:
        with pytest.raises(ValueError, match=message):
            bench.Variant.parse(bad)
    v = bench.Variant.parse("ssa(fitness_smoothing=0)")
    assert (v.algorithm, v.search_changes) == ("ssa", (("fitness_smoothing", 0),))
    with pytest.raises(ValueError, match="seeds come from"):
        bench.Variant.parse("pso(seed=3)")
    with pytest.raises(ValueError, match="t_max: must be an integer >= 1"):
        bench.Variant.parse("pso(t_max=0)")
    assert bench.split_labels("spsa, de(cr=0.1,f=0.6),pso") == ["spsa", "de(cr=0.1,f=0.6)", "pso"]


def test_make_jobs_covers_every_scenario_variant_and_seed(tiny_path: Path) -> None:
    scn = load_scenario(tiny_path)
    jobs = bench.make_jobs([scn, scn], ["spsa", "pso"], runs=3, seed0=7, iterations=2)
    assert len(jobs) == 2 * 3 * 2
    assert [j.index for j in jobs] == list(range(12))
    assert {j.seed for j in jobs} == {7, 8, 9}
    assert {j.scenario.name for j in jobs} == {"tiny", "tiny#2"}
    assert all(j.scenario.planner.search.iterations == 2 for j in jobs)
    assert len({j.scenario_key for j in jobs}) == 1  # same geometry, one world per worker
    jobs = bench.make_jobs([scn], ["ssa"], runs=1, search={"fitness_smoothing": 0})
    assert jobs[0].scenario.planner.search.fitness_smoothing == 0
    with pytest.raises(ValueError, match="listed twice"):
        bench.make_jobs([scn], ["pso", "pso"])


def test_job_scenario_applies_variant_and_seed(tiny_path: Path) -> None:
    scn = load_scenario(tiny_path)
    (job,) = bench.make_jobs([scn], ["spsa-no-smooth"], runs=1, seed0=4)
    run = bench.job_scenario(job)
    assert run.planner.algorithm == "spsa"
    assert run.planner.search.seed == 4
    assert run.planner.post.smooth is False
    (job,) = bench.make_jobs([scn], ["de(cr=0.1)"], runs=1)
    run = bench.job_scenario(job)
    assert (run.planner.algorithm, dict(run.planner.options)) == ("de", {"cr": 0.1})


@pytest.mark.parametrize("label", ["spsa", "pso", "spsa(fitness_smoothing=0; restarts=1)"])
def test_a_bench_run_is_what_plan_route_returns(tiny_path: Path, label: str) -> None:
    """bench reuses the world and problem across runs; the result must not depend on it."""
    from uavplan.planning import plan_route

    (job,) = bench.make_jobs([load_scenario(tiny_path)], [label], runs=1, seed0=2)
    rec = bench.run_job(job)
    direct = plan_route(bench.job_scenario(job))
    assert rec.route_energy == direct.energy
    assert rec.search_fitness == direct.planner.best_fitness
    np.testing.assert_array_equal(rec.convergence, direct.planner.convergence)


# --- backends -----------------------------------------------------------------------------------


def test_serial_runs_are_reproducible_and_in_job_order(tiny_path: Path) -> None:
    jobs = bench.make_jobs([load_scenario(tiny_path)], ["spsa", "ssa", "pso"], runs=2)
    seen = []
    a = bench.run_jobs(jobs, progress=lambda done, total, rec: seen.append((done, total)))
    b = bench.run_jobs(jobs)
    assert seen == [(i, 6) for i in range(1, 7)]
    assert [r.index for r in a] == list(range(6))
    assert _key(a) == _key(b)
    for r in a:
        assert r.status == "ok" and math.isfinite(r.route_energy)
        assert r.convergence.shape == (4,)


@pytest.mark.timeout(90)
@pytest.mark.slow
def test_process_pool_matches_serial(tiny_path: Path) -> None:
    jobs = bench.make_jobs([load_scenario(tiny_path)], ["spsa", "gwo"], runs=2)
    assert _key(bench.run_jobs(jobs, workers=2)) == _key(bench.run_jobs(jobs))


@pytest.mark.timeout(90)
@pytest.mark.slow
def test_dask_local_cluster_matches_serial(tiny_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    jobs = bench.make_jobs([load_scenario(tiny_path)], ["de", "cso"], runs=2)
    with (
        distributed.LocalCluster(
            processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        by_address = bench.run_jobs(jobs, dask=cluster.scheduler_address)
        by_client = bench.run_jobs(jobs, dask=client)
    serial = bench.run_jobs(jobs)
    assert _key(by_address) == _key(serial) == _key(by_client)


# --- aggregation and outputs ----------------------------------------------------------------


def test_summary_is_table_two_statistics() -> None:
    recs = [_record("spsa", e, i) for i, e in enumerate([100.0, 102.0, 104.0], 1)]
    recs += [_record("pso", e, i, ok=i != 2) for i, e in enumerate([200.0, 300.0], 1)]
    spsa, pso = bench.summarise(recs)
    assert (spsa.route_mean, spsa.route_worst, spsa.route_best, spsa.route_std) == (
        102.0,
        104.0,
        100.0,
        2.0,
    )
    assert (spsa.search_mean, spsa.search_std) == (112.0, 2.0)
    assert spsa.median_runtime_s == 2.0 and spsa.success_rate == 1.0
    assert (spsa.mean_evaluations, spsa.mean_reach_checks) == (200.0, 2000.0)
    assert (pso.route_mean, pso.collision_free, pso.runs) == (250.0, 1, 2)
    table = bench.format_table([spsa, pso], "s")
    assert "| s | spsa | pso |" in table
    assert "| search fitness mean (raw, Table 2) | 112.00 | 260.00 |" in table
    assert "| route energy mean (post-processed) | 102.00 | 250.00 |" in table
    assert "| collision-free | 3/3 | 1/2 |" in table
    assert "| evaluations / run | 200 | 150 |" in table
    assert "| wall time / run (s) | 2.00 | 1.50 |" in table
    assert "| SPSA mean ÷ mean (raw) | 1.000 | 0.431 |" in table
    assert "| SPSA mean ÷ mean (post-processed) | 1.000 | 0.408 |" in table
    assert "stopped by the budget" not in table
    curve = bench.mean_convergence(recs)["s"]["spsa"]
    np.testing.assert_allclose(curve, [104.0, 103.0, 102.0])


def test_write_outputs(tmp_path: Path) -> None:
    recs = [_record("spsa", 100.0, 1), _record("spsa", 101.0, 2), _record("de", 400.0, 1)]
    written = bench.write_outputs(tmp_path / "out", recs, config={"runs": 2})
    names = {p.name for p in written}
    assert names == {
        "runs.csv",
        "summary.csv",
        "bench.json",
        "summary.md",
        "convergence-s.png",
    }
    with open(tmp_path / "out" / "runs.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3 and rows[2]["algorithm"] == "de" and "convergence" not in rows[0]
    doc = json.loads((tmp_path / "out" / "bench.json").read_text())
    assert doc["config"] == {"runs": 2}
    assert doc["summary"][0]["route_mean"] == 100.5
    assert doc["summary"][0]["search_mean"] == 110.5
    assert {"search_fitness", "route_energy", "evaluations", "reach_checks"} <= set(rows[0])
    assert len(doc["mean_convergence"]["s"]["de"]) == 3
    assert (tmp_path / "out" / "convergence-s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# --- CLI ------------------------------------------------------------------------------------------


def test_cli_bench_with_ablation(tiny_path: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    result = CliRunner().invoke(
        main,
        [
            "bench",
            str(tiny_path),
            "--algorithms",
            "spsa,pso",
            "--ablation",
            "--runs",
            "1",
            "--iterations",
            "2",
            "--seed0",
            "3",
            "--fitness-smoothing",
            "0",
            "--out",
            str(out),
            "-q",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "| tiny | spsa | pso | spsa-no-start-end |" in result.output
    doc = json.loads((out / "bench.json").read_text())
    assert sum(row["runs"] for row in doc["summary"]) == 2 + len(bench.ABLATIONS)
    assert len((out / "runs.csv").read_text().splitlines()) == 1 + 2 + len(bench.ABLATIONS)
    assert doc["config"]["seeds"] == [3]
    assert doc["config"]["scenarios"]["tiny"]["search"]["fitness_smoothing"] == 0
    assert doc["config"]["algorithms"]["spsa-no-escape"]["params"]["escape"] is False
    assert doc["config"]["algorithms"]["pso"]["params"]["c1"] == 2.0


@pytest.mark.parametrize(
    "args, message",
    [
        (["--algorithms", "spsa,cat"], "unknown algorithm 'cat'"),
        (["--workers", "2", "--dask", "tcp://127.0.0.1:1"], "exclusive"),
        (["--runs", "0"], "--runs"),
    ],
)
def test_cli_bench_rejects_bad_options(tiny_path: Path, args: list[str], message: str) -> None:
    result = CliRunner().invoke(main, ["bench", str(tiny_path), *args])
    assert result.exit_code == EXIT_INPUT
    assert message in result.output


def test_cli_bench_bad_scenario_is_input_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\n")
    result = CliRunner().invoke(main, ["bench", str(bad)])
    assert result.exit_code == EXIT_INPUT
    assert "bad.yaml" in result.output


# --- the same budget for every algorithm ---------------------------------------------------


def test_budget_stops_every_algorithm_at_the_same_evaluation_count(tiny_path: Path) -> None:
    budget = 200
    jobs = bench.make_jobs(
        [load_scenario(tiny_path)], bench.default_algorithms(), runs=1, budget=budget
    )
    records = bench.run_jobs(jobs)
    g = 8  # the tiny scenario's population
    cap = bench.ITERATION_CAP_FACTOR * math.ceil(budget / g)
    for r in records:
        assert r.reach_checks > 0
        if r.algorithm == "de" and r.termination == "iterations":
            # DE (F = 0.1) collapses onto copies of its best paths and then scores only the
            # few trials that differ from their parent: it may reach the iteration cap first
            assert r.iterations == cap and r.evaluations < budget
            continue
        assert r.termination == "budget", (r.algorithm, r.termination)
        # the check runs after each iteration: at most one iteration's evaluations over
        # (SPSA scores each individual a few times per iteration)
        assert budget <= r.evaluations < budget + 6 * g, (r.algorithm, r.evaluations)
    # the iterations differ: the budget, not M, is what the algorithms share
    assert len({r.iterations for r in records}) > 1
    doc = bench.resolved_config(jobs)
    assert doc["budget"] == {"evaluations": budget}


def test_without_budget_evaluations_are_counted(tiny_path: Path) -> None:
    jobs = bench.make_jobs([load_scenario(tiny_path)], ["pso", "de"], runs=1)
    for r in bench.run_jobs(jobs):
        assert r.termination == "iterations" and r.iterations == 4
        assert 8 <= r.evaluations <= 8 * 5  # the initial population + at most G per iteration


def test_cli_budget(tiny_path: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    args = ["bench", str(tiny_path), "--algorithms", "spsa,de", "--runs", "1"]
    result = CliRunner().invoke(main, [*args, "--budget", "evaluations=120", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "| stopped by the budget | 1/1 | 1/1 |" in result.output
    with open(out / "runs.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert all(int(r["evaluations"]) >= 120 and r["termination"] == "budget" for r in rows)


@pytest.mark.parametrize(
    "value, message",
    [
        ("evaluations=0", "evaluations must be in 1..1000000000"),
        ("evaluations=many", "evaluations must be a whole number"),
        ("iterations=10", "expected evaluations=N"),
        ("30000", "expected evaluations=N"),
    ],
)
def test_cli_bad_budget_is_an_input_error(tiny_path: Path, value: str, message: str) -> None:
    result = CliRunner().invoke(main, ["bench", str(tiny_path), "--budget", value])
    assert result.exit_code == EXIT_INPUT, result.output
    assert message in result.output and "--budget" in result.output
    assert "Traceback" not in result.output


# --- reference rows -------------------------------------------------------------------------


def test_astar_reference_row(tiny_path: Path) -> None:
    jobs = bench.make_jobs([load_scenario(tiny_path)], ["spsa", "astar-los"], runs=2)
    assert [j.variant.label for j in jobs] == ["spsa", "astar-los", "spsa"]  # A*: one run
    records = bench.run_jobs(jobs)
    ref = next(r for r in records if r.algorithm == "astar-los")
    assert ref.status == "ok" and ref.collision_free
    assert ref.min_clearance_m >= 10.0 - 1e-6  # the tiny scenario's default margin
    # the raw A* polyline zig-zags on the grid; the shared chain shortens it
    assert ref.route_energy < ref.search_fitness
    straight = math.dist((0, 0, 30), (300, 20, 40))
    assert straight < ref.length_m < 1.5 * straight


def test_reference_labels() -> None:
    assert bench.Variant.parse("ompl-rrtstar(time_s=0.5)").time_s == 0.5
    assert bench.Variant.parse("ompl-bitstar").time_s is None
    assert bench.Variant.parse("astar-los").reference
    for bad, msg in [
        ("ompl-rrtstar(time_s=0)", "time_s must be"),
        ("ompl-rrtstar(range=3)", "unknown parameter 'range'"),
        ("astar-los(time_s=1)", "unknown parameter 'time_s'"),
    ]:
        with pytest.raises(ValueError, match=msg):
            bench.Variant.parse(bad)


def test_ompl_rows_get_spsa_wall_time(tiny_path: Path) -> None:
    pytest.importorskip("ompl")
    labels = ["spsa", "ompl-rrtstar", "ompl-informed-rrtstar", "ompl-bitstar"]
    jobs = bench.make_jobs([load_scenario(tiny_path)], labels, runs=1)
    records = {r.algorithm: r for r in bench.run_jobs(jobs)}
    spsa_s = records["spsa"].runtime_s
    for label in labels[1:]:
        r = records[label]
        assert r.stats["time_limit_s"] == pytest.approx(spsa_s)
        assert r.stats["motions_checked"] > 0
        # SPSA's time on this tiny case is a fraction of a second: on a loaded machine a
        # planner may find nothing in it, which the record must say (not crash)
        if r.status == "ok":
            assert r.collision_free and r.min_clearance_m >= 10.0 - 1e-6
            # the chain smooths the polyline: a little longer, far fewer corners
            assert abs(r.route_energy - r.search_fitness) < 0.1 * r.search_fitness
        else:
            assert "no exact solution" in r.message and not r.collision_free


def test_ompl_fixed_time_and_validity(tiny_path: Path) -> None:
    pytest.importorskip("ompl")
    from uavplan.bench.reference import reference_world, run_ompl
    from uavplan.planning import build_world

    scn = load_scenario(tiny_path)
    world = build_world(scn)
    out = run_ompl(scn, world, "ompl-rrtstar", 1.0, seed=1)
    assert out.found and out.collision_free
    # the path goes round the box (it blocks the straight line), not through it
    assert not world.segments_free(np.array([[0.0, 0, 30]]), np.array([[300.0, 20, 40]]))[0]
    assert out.length_m > math.dist((0, 0, 30), (300, 20, 40))
    assert reference_world(scn, world).margin_m > scn.safety_margin_m


def test_cli_ompl_rows_without_ompl(tiny_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from uavplan.bench import reference

    monkeypatch.setattr(reference, "ompl_available", lambda: False)
    monkeypatch.setattr(bench, "ompl_available", lambda: False)
    result = CliRunner().invoke(main, ["bench", str(tiny_path), "--algorithms", "ompl-rrtstar"])
    assert result.exit_code == EXIT_INPUT
    assert "pip install 'uavplan[ompl]'" in result.output
    ok = CliRunner().invoke(
        main, ["bench", str(tiny_path), "--algorithms", "spsa", "--references", "--runs", "1"]
    )
    assert ok.exit_code == 0, ok.output
    assert "astar-los" in ok.output and "ompl-rrtstar" not in ok.output
