"""Every planner default in one documented place (STYLE habit 7).

Values marked "Table 1" are the paper's (``paper/spsa-paper.md``, Table 1). The energy
weights are ours: the paper gives no numbers, and Table 2's SPSA values (≈ 2000 on a ≈ 2 km
route) fit ``k0 = 1`` per metre; ``k1·μ0 = 1`` and ``k2 = 1`` make a 1 m climb and a 90° kink
each cost like a metre of flight. All of them can be set in a scenario's ``planner:`` section.

This module holds plain dataclasses only (no numba, no numpy work) so that the scenario layer
can validate planner options without importing the optimisers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

#: Every algorithm the ``--algorithm`` option accepts.
ALGORITHMS: tuple[str, ...] = ("spsa", "ssa", "pso", "gwo", "de", "cso")


@dataclass(frozen=True)
class EnergyWeights:
    """Weights of the energy fitness (eq. 1–2): E = k0·L + k1·Σ μ0(1 + cos θ) + k2·Σ|Δz|."""

    k0: float = 1.0  # per metre flown
    k1: float = 1.0  # turning scale
    mu0: float = 1.0  # turning-angle coefficient
    k2: float = 1.0  # per metre climbed or descended

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{f.name} must be a finite number >= 0")


@dataclass(frozen=True)
class GridSpec:
    """Path grid (section 2.1, 6): one node per ``dx`` column, nodes rounded to ``dy``/``dz``."""

    dx_m: float = 20.0
    dy_m: float = 20.0
    dz_m: float = 10.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ValueError(f"{f.name} must be a number > 0")


@dataclass(frozen=True)
class SearchParams:
    """Options shared by every planner: population, iterations, seed and the initialisation.

    ``init_half_window`` is Δh of eq. 9–10 in grid units (paper: ten units in y and z);
    ``t_max`` is the reselection limit T_max (Table 1) used by every algorithm, so all of
    them follow the same reachability rule.
    """

    population: int = 30  # G, Table 1
    iterations: int = 1000  # M, Table 1
    seed: int = 1
    t_max: int = 10  # T_max, Table 1
    init_half_window: float = 10.0  # Δh, section 6
    #: the fitness spline runs through a moving average of the nodes (half-width in columns)
    #: so the grid rounding's staircase does not dominate it; 0 = the paper's fitness; None =
    #: each algorithm's own default (SPSA 2, ours; every baseline 0, the paper's protocol)
    fitness_smoothing: int | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.population, int) and self.population >= 4):
            raise ValueError("population must be an integer >= 4")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ValueError("iterations must be an integer >= 1")
        if not (isinstance(self.seed, int) and self.seed >= 0):
            raise ValueError("seed must be an integer >= 0")
        if not (isinstance(self.t_max, int) and self.t_max >= 1):
            raise ValueError("t_max must be an integer >= 1")
        if not (self.init_half_window > 0):
            raise ValueError("init_half_window must be > 0")
        smoothing = self.fitness_smoothing
        if smoothing is not None and not (
            isinstance(smoothing, int) and not isinstance(smoothing, bool) and smoothing >= 0
        ):
            raise ValueError("fitness_smoothing must be an integer >= 0")


@dataclass(frozen=True)
class SpsaParams:
    """SPSA's own parameters (Table 1) and switches for each of its five contributions.

    ``producer_rule``: how eq. 11's garbled "+ exp(−i/(α·M))" is read.
      * ``"deviation"`` (default): SSA's multiplicative eq. 3 applied to the deviation δ from
        the start-end line: δ' = δ·exp(−i/(α·M)) − rand·δ. It contracts toward the line.
      * ``"literal"``: P' = P + exp(−i/(α·M)) + rand·(P_ST − P), a scalar added to every
        coordinate, as printed.
    The switches (all on by default) exist for the ablation study in ``uavplan bench``;
    contribution 5 (node simplification, spline smoothing) is switched in :class:`PostParams`.
    """

    producer_ratio: float = 0.7  # PD
    scrounger_ratio: float = 0.3  # JD
    danger_ratio: float = 0.2  # SD
    warning_value: float = 0.6  # ST
    v_min: int = 1
    v_max: int = 5
    oscillation_window: int = 5  # N_p (max); min is 3 (section 4.4)
    producer_rule: str = "deviation"
    scrounger_index: str = "scrounger"  # i in eq. 4: "scrounger" (paper text) | "population"
    start_end_producer: bool = True  # contribution 2 (off: SSA's eq. 3 producer)
    escape: bool = True  # contribution 3 (adaptive variable-speed escape)
    oscillation: bool = True  # contribution 4
    restarts: int = 4  # ours: split the iterations into this many independent searches (paper: 1)

    def __post_init__(self) -> None:
        for name in ("producer_ratio", "scrounger_ratio", "danger_ratio", "warning_value"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0.0 <= value <= 1.0):
                raise ValueError(f"{name} must be within [0, 1]")
        if abs(self.producer_ratio + self.scrounger_ratio - 1.0) > 1e-9:
            raise ValueError("producer_ratio + scrounger_ratio must be 1")
        if not (isinstance(self.v_min, int) and isinstance(self.v_max, int)):
            raise ValueError("v_min and v_max must be integers")
        if not 1 <= self.v_min <= self.v_max:
            raise ValueError("need 1 <= v_min <= v_max")
        if not (isinstance(self.oscillation_window, int) and self.oscillation_window >= 3):
            raise ValueError("oscillation_window must be an integer >= 3")
        if not (isinstance(self.restarts, int) and self.restarts >= 1):
            raise ValueError("restarts must be an integer >= 1")
        if self.producer_rule not in ("deviation", "literal"):
            raise ValueError("producer_rule must be 'deviation' or 'literal'")
        if self.scrounger_index not in ("scrounger", "population"):
            raise ValueError("scrounger_index must be 'scrounger' or 'population'")

    @classmethod
    def ssa(cls) -> SpsaParams:
        """The original sparrow search (Xue & Shen 2020, reference code): 20 % producers with
        eq. 3, ST = 0.8, scroungers ranked in the whole population, and none of SPSA's
        contributions."""
        return cls(
            producer_ratio=0.2,
            scrounger_ratio=0.8,
            danger_ratio=0.2,
            warning_value=0.8,
            scrounger_index="population",
            start_end_producer=False,
            escape=False,
            oscillation=False,
        )


@dataclass(frozen=True)
class PostParams:
    """Post-processing of the best path into a flyable route (section 4.5 and SPEC §4).

    ``simplify`` and ``smooth`` are SPSA's contribution 5. ``refine`` (a pattern search on
    the simplified polyline) and ``tighten`` (string pulling) are ours, not the paper's: they
    move vertices off the grid while every leg keeps the margin. The paper's protocol post-processes
    SPSA's path only; baselines report their raw best path unless asked otherwise.
    """

    simplify: bool = True
    refine: bool = True
    tighten: bool = True
    smooth: bool = True
    sample_step_m: float = 5.0  # resolution of the final smoothed curve
    #: which paths are post-processed: "best" (the paper: the best individual) or
    #: "population" (ours: every distinct final individual is simplified and the lowest
    #: simplified energy wins; the search fitness is measured on the jagged grid path, so
    #: its best is not always the best route once simplified)
    select: str = "population"

    def __post_init__(self) -> None:
        if self.select not in ("best", "population"):
            raise ValueError("select must be 'best' or 'population'")
        if not self.sample_step_m > 0:
            raise ValueError("sample_step_m must be > 0")


def field_names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


# ---------------------------------------------------------------------------------------------
# Baselines (paper section 6). Each uses the shared SearchParams (G, M, T_max, initialisation)
# and its authors' standard settings below; none is tuned for these maps.


@dataclass(frozen=True)
class PsoParams:
    """Particle swarm (Kennedy & Eberhart 1995) with the inertia weight of Shi & Eberhart.

    v ← w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x), x ← x + v, r1, r2 ~ U(0, 1) per node and
    axis. ``w`` falls linearly from ``w_start`` to ``w_end`` over the run (Shi & Eberhart
    1999, "Empirical study of particle swarm optimization": 0.9 → 0.4); c1 = c2 = 2
    (Kennedy & Eberhart 1995). Each velocity component is clamped to ``v_max_fraction`` of
    its axis's range (Vmax; Eberhart & Shi 2001 recommend 10–20 % of the dynamic range; 10 %
    did better than 20 % on the bundled paper-like maps, so it is the default, in PSO's
    favour); ``None`` disables the clamp. The velocity carried to the next iteration is the
    displacement actually made, after rounding to the grid and the reachability rule.
    """

    w_start: float = 0.9
    w_end: float = 0.4
    c1: float = 2.0
    c2: float = 2.0
    v_max_fraction: float | None = 0.1

    def __post_init__(self) -> None:
        for name in ("w_start", "w_end", "c1", "c2"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0")
        v = self.v_max_fraction
        if v is not None and not (isinstance(v, int | float) and 0 < v <= 1):
            raise ValueError("v_max_fraction must be within (0, 1] or None")


@dataclass(frozen=True)
class GwoParams:
    """Grey wolf optimiser (Mirjalili, Mirjalili & Lewis 2014).

    Each wolf moves to the mean of X_k − A·|C·X_k − X| over the three leaders k = α, β, δ
    (the best three positions found so far), A = 2a·r1 − a, C = 2·r2 per node and axis; ``a``
    falls linearly from ``a_start`` to ``a_end`` (2 → 0 in the paper).
    """

    a_start: float = 2.0
    a_end: float = 0.0

    def __post_init__(self) -> None:
        for name in ("a_start", "a_end"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0")


@dataclass(frozen=True)
class DeParams:
    """Differential evolution, DE/rand/1/bin (Storn & Price 1997).

    Mutant v = x_r1 + F·(x_r2 − x_r3), r1, r2, r3 distinct and different from the target;
    binomial crossover with rate CR and one forced coordinate j_rand; greedy selection.
    F = 0.5, CR = 0.9 are Storn & Price's recommended starting values.
    """

    f: float = 0.5  # differential weight F
    cr: float = 0.9  # crossover rate CR

    def __post_init__(self) -> None:
        if not (isinstance(self.f, int | float) and 0 < self.f <= 2):
            raise ValueError("f must be within (0, 2]")
        if not (isinstance(self.cr, int | float) and 0 <= self.cr <= 1):
            raise ValueError("cr must be within [0, 1]")


@dataclass(frozen=True)
class CsoParams:
    """Chicken swarm optimisation (Meng, Liu, Gao & Zhang 2014; *chicken*, not cat, swarm).

    Every ``g`` iterations the swarm is ranked: the best ``rooster_ratio`` are roosters, the
    next ``hen_ratio`` hens, the rest chicks; ``mother_ratio`` of the hens are mothers. Each hen
    follows a rooster (its group), each chick a mother. Proportions are those of the paper's
    experiments (RN = 0.2·N, HN = 0.6·N, MN = 0.1·N, i.e. a sixth of the hens are mothers);
    the authors' released MATLAB code uses rPercent 0.15, hPercent 0.7, mPercent 0.5, which did
    worse on the bundled paper-like maps. ``g`` = 10 and FL ∈ [0.4, 1] are the paper's too.
    """

    rooster_ratio: float = 0.2
    hen_ratio: float = 0.6
    mother_ratio: float = 1 / 6
    g: int = 10  # G: hierarchy update period (iterations)
    fl_min: float = 0.4
    fl_max: float = 1.0

    def __post_init__(self) -> None:
        for name in ("rooster_ratio", "hen_ratio", "mother_ratio"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and 0 < value < 1):
                raise ValueError(f"{name} must be within (0, 1)")
        if self.rooster_ratio + self.hen_ratio >= 1:
            raise ValueError("rooster_ratio + hen_ratio must be < 1 (the rest are chicks)")
        if not (isinstance(self.g, int) and self.g >= 1):
            raise ValueError("g must be an integer >= 1")
        if not (0 <= self.fl_min <= self.fl_max <= 2):
            raise ValueError("need 0 <= fl_min <= fl_max <= 2")
