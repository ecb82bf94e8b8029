"""Particle swarm optimisation (Kennedy & Eberhart 1995) with a linearly decreasing inertia
weight (Shi & Eberhart 1998, 1999), on the paper's path encoding.

Every particle proposes all its nodes as one :class:`Proposal`
(v ← w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x), clamped to ±Vmax, x ← x + v) under the
reachability rule every planner follows: an unreachable node is re-proposed with fresh
r1, r2 up to T_max times, then the old node is kept (paper section 6). Positions are not
selected greedily (PSO has no selection); memory lives in the personal and global bests.
The velocity carried forward is the displacement the particle actually made; where a node
could not move (every proposal unreachable) it keeps its inertia w·v rather than dropping to
zero, so a blocked particle is not stopped dead.
"""

from __future__ import annotations

import numpy as np

from uavplan.config import PsoParams, SearchParams
from uavplan.planners.base import PathProblem, Population, SwarmPlanner
from uavplan.planners.proposal import Draw, Proposal


def axis_ranges_units(problem: PathProblem) -> np.ndarray:
    """(2,) extent of the flight volume across the path, in grid units: (y, z)."""
    tab = problem.table[0]  # (D + 1, ny, nz) node clearance over the bounds' grid
    return np.array([tab.shape[1] - 1, tab.shape[2] - 1], dtype=float)


class ParticleSwarmPlanner(SwarmPlanner):
    name = "pso"

    def __init__(self, search: SearchParams, params: PsoParams | None = None) -> None:
        super().__init__(search)
        self.params = params or PsoParams()

    def setup(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        i = pop.best_index
        st = pop.state
        st["velocity"] = np.zeros_like(pop.x)
        st["pbest"] = pop.x.copy()
        st["pbest_f"] = pop.f.copy()
        st["gbest"] = pop.x[i].copy()
        st["gbest_f"] = float(pop.f[i])
        frac = self.params.v_max_fraction
        st["v_max"] = (
            np.full(2, np.inf)
            if frac is None
            else np.maximum(1.0, frac * axis_ranges_units(problem))
        )
        pop.count("failed_updates", 0)

    def inertia(self, pop: Population) -> float:
        """w, linear from ``w_start`` at the first iteration to ``w_end`` at the last."""
        prm = self.params
        frac = pop.iteration / max(1, pop.iterations - 1)
        return prm.w_start + (prm.w_end - prm.w_start) * frac

    def rule(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> Proposal:
        """Every particle: x + clip(w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x), ±Vmax)."""
        prm, st = self.params, pop.state
        x = pop.x
        prop = Proposal.for_population(x)
        prop.active[:] = True
        prop.offset = self.inertia(pop) * st["velocity"]
        prop.spread = prm.c1 * (st["pbest"] - x)
        prop.draw[:] = Draw.UNIFORM
        prop.spread2 = prm.c2 * (st["gbest"] - x)
        prop.draw2[:] = Draw.UNIFORM
        prop.clamp = st["v_max"]
        return prop

    def step(self, problem: PathProblem, pop: Population, rng: np.random.Generator) -> None:
        st, x = pop.state, pop.x
        w = self.inertia(pop)
        cand, ok, _ = problem.propose(x, self.rule(problem, pop, rng), self.search.t_max, rng)
        # the velocity carried on is the move made; where a node could not move (its
        # proposals were unreachable, or the whole update failed) the particle keeps its
        # inertia w·v instead of stopping dead (zeroing it dropped 76–95 % of the updates)
        moved = cand != x
        st["velocity"] = np.where(moved, cand - x, w * st["velocity"])
        pop.x = cand
        pop.f = problem.fitness_of_changed(cand, x, pop.f)
        better = pop.f < st["pbest_f"]
        st["pbest"][better] = cand[better]
        st["pbest_f"][better] = pop.f[better]
        i = int(np.argmin(st["pbest_f"]))
        if st["pbest_f"][i] < st["gbest_f"]:
            st["gbest"] = st["pbest"][i].copy()
            st["gbest_f"] = float(st["pbest_f"][i])
        pop.count("failed_updates", int((~ok).sum()))

    def best(self, pop: Population) -> tuple[np.ndarray, float]:
        return pop.state["gbest"], pop.state["gbest_f"]
