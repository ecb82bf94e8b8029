#!/usr/bin/env python3
"""Route energy against the reference with the post-processing's choices by energy switched
on one after another (issue 26; docs/algorithm.md, "Choosing by energy"): prints a table.

For every scenario, ``uavplan.planning.plan_route`` runs with seeds 1..runs and the
scenario's settings under four variants, each adding one rule to the one before:

* ``before``: the spline kept wherever it keeps the margin, the lowest simplified individual
  refined alone, pattern steps 16, 4 and 1 m;
* ``+smooth``: each leg's blend chosen by energy (``smooth_route(..., weights=...)``);
* ``+every``: every distinct final individual refined, the lowest refined kept
  (``refine_best``), steps 16, 4 and 1 m;
* ``now``: with the pattern steps halving from 64 m (the code as it is).

Each cell is E / (A* + line of sight, ``reference_energy``): mean and worst over the seeds.
The variants are made by swapping the rules' module-level switches in this process only.
``field-N`` is ``tools/bench_scale.py``'s field of N obstacles (its map seed 1).

    python tools/post_study.py                 # fields, helsinki-centre, paper-env1..3, midtown
    python tools/post_study.py field-5000 --runs 5
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # as `uavplan` itself does: before numpy

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_scale import field

import uavplan.planning as planning
from uavplan.path import post
from uavplan.scenario import Scenario, load_scenario

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["field-5000", "field-20000", "helsinki-centre", "paper-env1", "paper-env2",
           "paper-env3", "midtown-manhattan"]  # fmt: skip
OLD_STEPS = (16.0, 4.0, 1.0)
VARIANTS = ("before", "+smooth", "+every", "now")


@contextmanager
def variant(name: str) -> Iterator[None]:
    """The rules of ``name`` in force while the block runs."""
    saved_steps, saved_smooth, saved_best = (
        post.REFINE_STEPS_M, planning.smooth_route, planning.refine_best,
    )  # fmt: skip

    def margin_only(*args: Any, **kw: Any) -> post.SmoothRoute:
        return saved_smooth(*args, **{**kw, "weights": None})

    def first_only(cands: Any, world: Any, weights: Any, *_: Any) -> tuple[int, np.ndarray]:
        return saved_best(cands, world, weights, 0)  # the first candidate alone

    try:
        if name != "now":
            post.REFINE_STEPS_M = OLD_STEPS
        if name == "before":
            planning.smooth_route = margin_only  # type: ignore[assignment]
        if name in ("before", "+smooth"):
            planning.refine_best = first_only  # type: ignore[assignment]
        yield
    finally:
        post.REFINE_STEPS_M = saved_steps
        planning.smooth_route = saved_smooth  # type: ignore[assignment]
        planning.refine_best = saved_best  # type: ignore[assignment]


def load(name: str, folder: Path) -> Scenario:
    if name.startswith("field-"):
        path = folder / f"{name}.yaml"
        path.write_text(field(int(name.removeprefix("field-"))), encoding="utf-8")
        return load_scenario(path)
    path = Path(name) if name.endswith(".yaml") else ROOT / "missions" / f"{name}.yaml"
    return load_scenario(path)


def ratios(scenario: Scenario, ref: float, runs: int, world: Any) -> Callable[[str], list[float]]:
    def of(name: str) -> list[float]:
        out = []
        with variant(name):
            for seed in range(1, runs + 1):
                search = dataclasses.replace(scenario.planner.search, seed=seed)
                res = planning.plan_route(scenario.with_planner(search=search), world=world)
                out.append(res.energy / ref if res.ok else np.inf)
        return out

    return of


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", default=DEFAULT, help="names, field-N or files")
    ap.add_argument("--runs", type=int, default=3, help="seeds 1..runs (default 3)")
    args = ap.parse_args()
    print(f"{'scenario':<20} " + " ".join(f"{v:>16}" for v in VARIANTS))
    print("-" * (21 + 17 * len(VARIANTS)))
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.scenarios:
            scenario = load(name, Path(tmp))
            world = planning.build_world(scenario)
            ref = planning.reference_energy(scenario, world)
            if not ref == ref:  # NaN
                raise SystemExit(f"{name}: A* found no reference path")
            of = ratios(scenario, ref, args.runs, world)
            cells = []
            for v in VARIANTS:
                r = of(v)
                cells.append(f"{np.mean(r):.4f}, {np.max(r):.4f}")
            print(f"{name:<20} " + " ".join(f"{c:>16}" for c in cells), flush=True)
    print(f"E / (A* + line of sight): mean, worst over seeds 1..{args.runs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
