"""The one configuration language (:mod:`uavplan.config`): field bounds, the validator every
input path uses, the planner table and what derives from it, and the resolved configuration.
A toy planner registered here (one class, one entry) runs through ``plan`` and ``bench``."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np
import pytest
from click.testing import CliRunner

from uavplan import config
from uavplan.cli import main
from uavplan.cli.options import ALGORITHM, ALGORITHMS
from uavplan.config import (
    PLANNERS,
    ConfigError,
    CsoParams,
    DeParams,
    GridSpec,
    PlannerConfig,
    PlannerEntry,
    PsoParams,
    SearchParams,
    SpsaParams,
    build,
    override,
    register,
    resolved_planner,
    short_repr,
    unregister,
)
from uavplan.errors import EXIT_INPUT, InputError
from uavplan.scenario import load_scenario, resolved_config

SCENARIO = """\
name: cfg
origin: {lat: 47.0, lon: 8.0, alt: 400}
bounds: {x: [0, 300], y: [-140, 140], z: [0, 120]}
start: [0, 0, 30]
goal: [300, 20, 40]
obstacles:
  - {type: box, center: [150, 10], size: [40, 60], height: 100}
"""


def write(tmp_path: Path, text: str, name: str = "s.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# --- the validator ------------------------------------------------------------------------------


def test_build_takes_user_keys_and_field_names() -> None:
    assert build(GridSpec, {"dx": 10, "dy_m": 5}) == GridSpec(10.0, 5.0, 10.0)
    assert isinstance(build(GridSpec, {"dx": 10}).dx_m, float)
    assert build(SearchParams, {"iterations": 1e3}).iterations == 1000  # 1e3 written for 1000
    with pytest.raises(ConfigError) as err:
        build(GridSpec, {"dx": 10, "dx_m": 5}, "planner.grid")
    assert err.value.key == "planner.grid.dx_m"


@pytest.mark.parametrize(
    ("cls", "raw", "key", "reason"),
    [
        (SearchParams, {"population": 2**40}, "population", "must be an integer >= 4 and <="),
        (SearchParams, {"population": 3}, "population", "got 3"),
        (SearchParams, {"population": True}, "population", "must be an integer, got a boolean"),
        (SearchParams, {"population": 30.5}, "population", "must be an integer"),
        (SearchParams, {"t_max": 10**9}, "t_max", "<= 1000"),
        (SearchParams, {"seed": -1}, "seed", ">= 0"),
        (SearchParams, {"seed": 10**400}, "seed", "an integer of about 401 digits"),
        (SearchParams, {"fitness_smoothing": -1}, "fitness_smoothing", ">= 0"),
        (SpsaParams, {"oscillation_window": 10**9}, "oscillation_window", "<= 1000"),
        (SpsaParams, {"producer_rule": "other"}, "producer_rule", "one of deviation, literal"),
        (SpsaParams, {"producer_ratio": 0.5}, "scrounger_ratio", "must be 1"),
        (SpsaParams, {"v_min": 6}, "v_max", "v_min <= v_max"),
        (config.PostParams, {"sample_step_m": 1e-9}, "sample_step_m", ">= 0.1"),
        (config.EnergyWeights, {"k0": 1e308}, "k0", "<= 1e+06"),
        (config.EnergyWeights, {"k0": float("nan")}, "k0", "finite"),
        (config.EnergyWeights, {"k0": "high"}, "k0", "must be a number, got a string ('high')"),
        (DeParams, {"cr": 2}, "cr", "<= 1"),
        (DeParams, {"f": 0}, "f", "> 0"),
        (PsoParams, {"v_max_fraction": 0}, "v_max_fraction", "> 0"),
        (CsoParams, {"rooster_ratio": 0.5, "hen_ratio": 0.6}, "hen_ratio", "must be < 1"),
        (GridSpec, {"dw": 3}, "dw", "unknown key (allowed: dx, dy, dz)"),
        (GridSpec, {1: 3}, "", "keys must be strings"),
        (GridSpec, [1, 2], "", "must be a mapping, got a list"),
    ],
)
def test_every_bad_value_is_one_error_with_its_key(
    cls: type, raw: object, key: str, reason: str
) -> None:
    with pytest.raises(ConfigError) as err:
        build(cls, raw, "sec")
    assert err.value.key == (f"sec.{key}" if key else "sec")
    assert reason in err.value.reason
    assert isinstance(err.value, InputError) and isinstance(err.value, ValueError)
    assert err.value.exit_code == EXIT_INPUT


def test_optional_fields_take_null_and_override_keeps_other_values() -> None:
    assert build(PsoParams, {"v_max_fraction": None}).v_max_fraction is None
    base = SearchParams(population=12, seed=9)
    assert override(base, {"iterations": 5}) == SearchParams(population=12, iterations=5, seed=9)
    with pytest.raises(ConfigError, match="population"):
        override(base, {"population": 2})


def test_post_init_checks_cross_field_rules_with_the_same_error_type() -> None:
    with pytest.raises(ConfigError) as err:
        SpsaParams(producer_ratio=0.5)
    assert err.value.key == "scrounger_ratio"
    with pytest.raises(ConfigError) as err:
        CsoParams(fl_min=0.9, fl_max=0.5)
    assert err.value.key == "fl_max"


def test_every_parameter_field_documents_its_bounds() -> None:
    for cls in (config.EnergyWeights, GridSpec, SearchParams, SpsaParams, config.PostParams):
        for f in dataclasses.fields(cls):
            assert f.metadata.get("kind") in ("int", "float", "bool", "str"), (cls, f.name)
            if f.metadata["kind"] in ("int", "float"):
                assert f.metadata["lo"] is not None and f.metadata["hi"] is not None, f.name
    for entry in PLANNERS.values():
        if entry.params is not None:
            for f in dataclasses.fields(entry.params):
                assert "kind" in f.metadata, (entry.name, f.name)


def test_short_repr_is_bounded_for_huge_and_deep_values() -> None:
    bomb: list = ["lol"] * 9
    for _ in range(8):
        bomb = [bomb] * 9  # 9^9 leaves, shared
    assert len(short_repr(bomb)) <= 60
    assert len(short_repr("x" * 10**6)) <= 60
    assert short_repr(-(10**500)) == "-an integer of about 501 digits"
    deep: list = []
    for _ in range(5000):
        deep = [deep]
    assert len(short_repr(deep)) <= 60


def test_margin_pad_lives_in_config() -> None:
    assert config.MARGIN_PAD_M == 0.02


def test_importing_config_is_light() -> None:
    code = (
        "import sys, uavplan.config; "
        "print(','.join(m for m in ('numpy', 'numba', 'yaml', 'click') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


# --- scenario sections --------------------------------------------------------------------------


def test_one_section_per_planner_and_params_for(tmp_path: Path) -> None:
    text = SCENARIO + "planner: {algorithm: de, de: {f: 0.4, cr: 0.5}, pso: {c1: 1.5}}\n"
    cfg = load_scenario(write(tmp_path, text)).planner
    assert cfg.params_for() == DeParams(0.4, 0.5)
    assert cfg.params_for("pso") == PsoParams(c1=1.5)
    assert cfg.params_for("gwo") == config.GwoParams()
    assert cfg.params_for("ssa") is None
    assert cfg.spsa == SpsaParams()


def test_old_options_key_is_the_section_of_algorithm(tmp_path: Path) -> None:
    text = SCENARIO + "planner: {algorithm: de, options: {cr: 0.5}}\n"
    cfg = load_scenario(write(tmp_path, text)).planner
    assert cfg.params_for("de") == DeParams(cr=0.5)
    assert cfg.options == {"cr": 0.5}
    both = SCENARIO + "planner: {algorithm: de, options: {cr: 0.5}, de: {f: 1}}\n"
    with pytest.raises(InputError) as err:
        load_scenario(write(tmp_path, both))
    assert err.value.key == "planner.options" and "not both" in err.value.reason


@pytest.mark.parametrize(
    ("planner", "key", "reason"),
    [
        ("{de: {cr: 2}}", "planner.de.cr", "<= 1"),
        ("{ssa: {x: 1}}", "planner.ssa", "takes no parameters"),
        ("{pso: 3}", "planner.pso", "must be a mapping"),
        ("{algorithm: [de]}", "planner.algorithm", "must be a string"),
        ("{algorithm: toy}", "planner.algorithm", "unknown algorithm 'toy'"),
        ("{grid: {dx: 0.01}}", "planner.grid.dx", ">= 0.1"),
        ("{spsa: {oscillation_window: 1000000000}}", "planner.spsa.oscillation_window", "<="),
    ],
)
def test_section_errors_name_file_and_key(
    tmp_path: Path, planner: str, key: str, reason: str
) -> None:
    path = write(tmp_path, SCENARIO + f"planner: {planner}\n")
    with pytest.raises(InputError) as err:
        load_scenario(path)
    assert (err.value.file, err.value.key) == (str(path), key)
    assert reason in err.value.reason


def test_another_algorithm_uses_its_own_section_or_defaults(tmp_path: Path) -> None:
    """Issue 8: ``algorithm: de`` + ``options: {cr: 0.5}`` run with ``--algorithm pso`` was an
    internal error; now pso runs with its own section or its defaults."""
    scn = load_scenario(
        write(tmp_path, SCENARIO + "planner: {algorithm: de, options: {cr: 0.5}}\n")
    )
    pso = scn.with_planner(algorithm="pso")
    assert pso.planner.params_for() == PsoParams()
    assert pso.planner.params_for("de") == DeParams(cr=0.5)
    from uavplan.planners.registry import make_planner

    planner = make_planner("pso", pso.planner)
    assert planner.params == PsoParams()
    with pytest.raises(ConfigError, match="unknown algorithm"):
        scn.with_planner(algorithm="nope")


def test_cli_plan_with_another_algorithm_than_the_sections(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        SCENARIO + "planner: {algorithm: de, options: {cr: 0.5}, population: 4, iterations: 2}\n",
    )
    out = tmp_path / "m.plan"
    result = CliRunner().invoke(main, ["plan", str(path), "-o", str(out), "--algorithm", "pso"])
    assert result.exit_code in (0, 3), result.output
    assert "internal error" not in result.output


# --- resolved configuration ---------------------------------------------------------------------


@pytest.mark.parametrize("algorithm", ["spsa", "ssa", "pso", "de", "cso", "gwo"])
def test_resolved_config_echoes_everything_a_run_needs(tmp_path: Path, algorithm: str) -> None:
    text = SCENARIO + "planner: {algorithm: de, de: {cr: 0.3}, fitness_smoothing: null}\n"
    scn = load_scenario(write(tmp_path, text))
    doc = resolved_config(scn, algorithm)
    json.dumps(doc)  # JSON-able
    p = doc["planner"]
    assert p["algorithm"] == algorithm
    assert p["search"]["fitness_smoothing"] == (2 if algorithm == "spsa" else 0)
    assert set(p["search"]) == {f.name for f in dataclasses.fields(SearchParams)}
    assert p["grid"] == {"dx": 20.0, "dy": 20.0, "dz": 10.0}  # the grid the run used
    assert p["grid_fitted"] is True  # the scenario sets none: fitted (here the default)
    assert p["margin_pad_m"] == config.MARGIN_PAD_M
    assert set(p["post"]) >= {"simplify", "sample_step_m", "select"}
    assert p["postprocess"] is (algorithm == "spsa")
    if algorithm == "de":
        assert p["params"] == {"f": DeParams().f, "cr": 0.3}
    elif algorithm == "ssa":
        assert p["params"] == dataclasses.asdict(SpsaParams.ssa())  # the fixed SSA settings
    else:
        assert p["params"] == dataclasses.asdict(PLANNERS[algorithm].params())
    assert doc["safety_margin_m"] == 10.0
    assert doc["mission"] == {"autopilot": "ardupilot", "spacing_m": 60.0, "end": "rtl"}
    assert doc["start"] == [0.0, 0.0, 30.0]
    # the planner part alone: without a scenario no flight volume to fit a grid to
    alone = {**p, "grid": None}
    del alone["grid_fitted"]
    assert resolved_config(scn.planner, algorithm) == {"planner": alone}


def test_resolved_config_rebuilds_the_same_planner_config(tmp_path: Path) -> None:
    text = SCENARIO + "planner: {algorithm: cso, cso: {g: 7}, grid: {dx: 15}, seed: 4}\n"
    cfg = load_scenario(write(tmp_path, text)).planner
    p = resolved_planner(cfg)
    again = PlannerConfig(
        p["algorithm"],
        build(SearchParams, p["search"]),
        build(GridSpec, p["grid"]),
        build(config.EnergyWeights, p["energy"]),
        build(config.PostParams, p["post"]),
        {p["algorithm"]: build(CsoParams, p["params"])},
    )
    assert again.params_for() == cfg.params_for()
    assert (again.grid, again.energy, again.post) == (cfg.grid, cfg.energy, cfg.post)
    assert again.search == dataclasses.replace(cfg.search, fitness_smoothing=0)


# --- the planner table and what derives from it ------------------------------------------------


def test_table_lists_the_paper_algorithms() -> None:
    assert list(PLANNERS)[:6] == ["spsa", "ssa", "pso", "gwo", "de", "cso"]
    assert config.paper_algorithms() == ("spsa", "ssa", "pso", "gwo", "de", "cso")
    assert PLANNERS["spsa"].postprocess and PLANNERS["spsa"].fitness_smoothing == 2
    # SPSA's numpy formulation is SPSA: the same search, the same post-processing
    assert not any(e.postprocess for n, e in PLANNERS.items() if n not in ("spsa", "spsa_numpy"))
    numpy_spsa = PLANNERS["spsa_numpy"]
    assert numpy_spsa.postprocess and numpy_spsa.fitness_smoothing == 2 and not numpy_spsa.paper


@pytest.mark.parametrize("name", ["grid", "options", "Bad", "with-dash", ""])
def test_register_refuses_reserved_or_bad_names(name: str) -> None:
    with pytest.raises(ValueError):
        register(PlannerEntry(name, "m:C", None, "x"))


def test_register_refuses_a_target_without_a_class() -> None:
    with pytest.raises(ValueError, match="module:Class"):
        register(PlannerEntry("nocls", "uavplan.planners.sparrow", None, "x"))


def test_cli_algorithm_type_follows_the_table() -> None:
    assert ALGORITHM.convert("PSO", None, None) == "pso"
    with pytest.raises(click.BadParameter, match="unknown algorithm 'toy'"):
        ALGORITHM.convert("toy", None, None)
    variants = ALGORITHMS.convert("spsa,de(cr=0.1)", None, None)
    assert [v.label for v in variants] == ["spsa", "de(cr=0.1)"]
    with pytest.raises(click.BadParameter, match="cr: must be a number >= 0 and <= 1"):
        ALGORITHMS.convert("de(cr=2)", None, None)


# A toy planner: one params class, one planner class, one table entry.


@dataclass(frozen=True)
class ToyParams:
    """Random restarts: each iteration draws a fresh initial population and keeps, per
    individual, the better of old and new."""

    keep_best: bool = config.flag(True)
    draws: int = config.param(1, kind="int", lo=1, hi=10)


def _toy_class() -> type:
    from uavplan.planners.base import SwarmPlanner

    class ToyPlanner(SwarmPlanner):
        name = "toy"

        def __init__(self, search: SearchParams, params: ToyParams | None = None) -> None:
            super().__init__(search)
            self.params = params or ToyParams()

        def step(self, problem, pop, rng) -> None:  # type: ignore[no-untyped-def]
            for _ in range(self.params.draws):
                x, ok, _ = problem.initial_population(pop.x.shape[0], self.search, rng)
                f = np.where(ok, problem.fitness(x), np.inf)
                better = f < pop.f
                pop.x[better] = x[better]
                pop.f[better] = f[better]

    return ToyPlanner


@pytest.fixture
def toy() -> Iterator[PlannerEntry]:
    entry = register(PlannerEntry("toy", _toy_class(), ToyParams, "random restarts"))
    try:
        yield entry
    finally:
        unregister("toy")


def test_toy_planner_through_scenario_and_plan(toy: PlannerEntry, tmp_path: Path) -> None:
    text = SCENARIO + "planner: {algorithm: toy, toy: {draws: 2}, population: 6, iterations: 3}\n"
    path = write(tmp_path, text)
    scn = load_scenario(path)
    assert scn.planner.params_for() == ToyParams(draws=2)
    assert ALGORITHM.convert("toy", None, None) == "toy"
    bad = write(tmp_path, SCENARIO + "planner: {algorithm: toy, toy: {draws: 0}}\n", "b.yaml")
    with pytest.raises(InputError, match=r"planner\.toy\.draws"):
        load_scenario(bad)
    out = tmp_path / "toy.plan"
    report = tmp_path / "toy.json"
    result = CliRunner().invoke(
        main, ["plan", str(path), "-o", str(out), "--report", str(report), "-q"]
    )
    assert result.exit_code == 0, result.output
    assert out.is_file()
    assert json.loads(report.read_text())["algorithm"] == "toy"


def test_toy_planner_through_bench(toy: PlannerEntry, tmp_path: Path) -> None:
    path = write(tmp_path, SCENARIO + "planner: {population: 6, iterations: 2}\n")
    out = tmp_path / "bench"
    args = ["bench", str(path), "--algorithms", "toy(draws=2),ssa", "--runs", "1"]
    result = CliRunner().invoke(main, [*args, "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    assert "toy(draws=2)" in result.output
    doc = json.loads((out / "bench.json").read_text())
    assert doc["config"]["algorithms"]["toy(draws=2)"]["params"] == {"keep_best": True, "draws": 2}
    bad = CliRunner().invoke(main, ["bench", str(path), "--algorithms", "toy(draws=11)"])
    assert bad.exit_code == EXIT_INPUT and "draws: must be an integer" in bad.output


def test_bench_default_is_every_registered_paper_algorithm(toy: PlannerEntry) -> None:
    from uavplan import bench

    assert bench.default_algorithms() == ("spsa", "ssa", "pso", "gwo", "de", "cso")
    register(dataclasses.replace(toy, paper=True))
    assert bench.default_algorithms()[-1] == "toy"


def test_with_search_validates_overrides_and_size(tmp_path: Path) -> None:
    from uavplan.scenario import with_search

    scn = load_scenario(write(tmp_path, SCENARIO))
    assert with_search(scn, {"iterations": 5, "population": None}).planner.search.iterations == 5
    with pytest.raises(ConfigError) as err:
        with_search(scn, {"iterations": 10**9}, "--iterations")
    assert err.value.key == "--iterations" and "<= 1000000" in err.value.reason
    huge = {"iterations": 1_000_000, "population": 10_000}
    with pytest.raises(InputError, match="too large to plan"):
        with_search(scn, huge)


def test_config_imports_nothing_of_uavplan_but_errors() -> None:
    import ast

    tree = ast.parse(Path(config.__file__).read_text(encoding="utf-8"))
    imported = {
        node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom) and node.module
    } | {a.name for node in ast.walk(tree) if isinstance(node, ast.Import) for a in node.names}
    assert {m for m in imported if m.startswith("uavplan")} == {"uavplan.errors"}
    assert not imported & {"numpy", "yaml", "click"}
