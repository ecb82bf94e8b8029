"""Planner configuration: every parameter, its default, its bounds, and the planner table.

This is the one configuration language of the project. Each parameter dataclass field carries
its documentation and its bounds in ``dataclasses.field(metadata=...)`` (see :func:`_num`);
:func:`build` is the one validator that every input path uses — a scenario's ``planner:``
section, a bench variant label such as ``de(cr=0.1)``, a command-line override. A bad value
raises :class:`ConfigError` carrying the key path (``planner.de.cr``); the scenario reader
turns it into a ``ScenarioError`` naming the file too.

Values marked "Table 1" are the paper's (``paper/spsa-paper.md``, Table 1). The energy
weights are ours: the paper gives no numbers, and Table 2's SPSA values (≈ 2000 on a ≈ 2 km
route) fit ``k0 = 1`` per metre; ``k1·μ0 = 1`` and ``k2 = 1`` make a 1 m climb and a 90° kink
each cost like a metre of flight.

:data:`PLANNERS` is the planner table: name → :class:`PlannerEntry` (import target, parameter
class, summary, default fitness smoothing, whether the paper's protocol post-processes it).
The CLI's ``--algorithm`` choices, the scenario's ``planner.algorithm`` and per-planner
sections, the bench defaults and :func:`uavplan.planners.registry.make_planner` all derive
from it; :func:`register` adds a planner at run time.

The bottom layer: this module imports nothing of uavplan but :mod:`uavplan.errors`, and no
numpy (``python -X importtime -c "import uavplan.config"`` stays in milliseconds).
"""

from __future__ import annotations

import dataclasses
import math
import reprlib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from enum import StrEnum
from typing import Any, Literal, TypeVar

from uavplan.errors import InputError

#: planning keeps this much beyond the safety margin (metres), so a route rounded to the grid
#: or sampled on its spline still keeps the full margin
MARGIN_PAD_M = 0.02

T = TypeVar("T")


class ConfigError(InputError, ValueError):
    """A configuration value is invalid. ``key`` is the dotted key path (``de.cr``), relative
    to where :func:`build` was called; ``reason`` says what is wrong (exit 2)."""

    def __init__(self, reason: str, *, key: str | None = None, file: str | None = None) -> None:
        super().__init__(reason, file=file, key=key)

    def under(self, prefix: str) -> ConfigError:
        """The same error with its key below ``prefix`` (``"planner.de"`` + ``"cr"``)."""
        return ConfigError(self.reason, key=join_key(prefix, self.key or ""), file=self.file)


def join_key(prefix: str, key: str) -> str:
    if not prefix:
        return key
    if not key:
        return prefix
    return f"{prefix}{key}" if key.startswith("[") else f"{prefix}.{key}"


_REPR = reprlib.Repr()
_REPR.maxlevel = 2
_REPR.maxlist = _REPR.maxtuple = _REPR.maxdict = _REPR.maxset = 4
_REPR.maxstring = _REPR.maxother = 40
_REPR.maxlong = 24


def short_repr(value: Any) -> str:
    """A bounded ``repr`` (at most ~60 characters, whatever the value's size or depth): error
    messages must not render a billion-laughs structure or a 4000-digit integer."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 80:
        digits = int(value.bit_length() * math.log10(2)) + 1
        return f"{'-' if value < 0 else ''}an integer of about {digits} digits"
    try:
        text = _REPR.repr(value)
    except (RecursionError, ValueError):  # pragma: no cover - defensive
        text = f"<{type(value).__name__}>"
    return text if len(text) <= 60 else text[:57] + "..."


def key_text(key: str) -> str:
    """A user's key as a key path shows it: as written when printable and short, else its
    bounded repr (a key with a line break or a control character must not break the
    one-line message)."""
    if key and key.isprintable() and len(key) <= 40 and "." not in key:
        return key
    return short_repr(key)


def type_name(value: Any) -> str:
    """How a YAML value reads to a user: ``an integer``, ``a list``, ``nothing (null)``."""
    if value is None:
        return "nothing (null)"
    return {
        bool: "a boolean",
        int: "an integer",
        float: "a number",
        str: "a string",
        list: "a list",
        dict: "a mapping",
    }.get(type(value), type(value).__name__)


# ---------------------------------------------------------------------------------------------
# Field metadata


def _num(
    default: Any,
    *,
    kind: str = "float",
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    hi_open: bool = False,
    optional: bool = False,
    key: str | None = None,
    doc: str = "",
) -> Any:
    """A numeric field: ``kind`` "int" or "float", bounds [lo, hi] (open where asked), and the
    key users write (``key``, default: the field name). ``optional``: ``None`` is allowed."""
    meta = {
        "kind": kind,
        "lo": lo,
        "hi": hi,
        "lo_open": lo_open,
        "hi_open": hi_open,
        "optional": optional,
        "key": key,
        "doc": doc,
    }
    return field(default=default, metadata=meta)


def _flag(default: bool, *, doc: str = "") -> Any:
    return field(default=default, metadata={"kind": "bool", "doc": doc})


def _choice(default: str, choices: tuple[str, ...] | type[StrEnum], *, doc: str = "") -> Any:
    """A field whose value is one of ``choices``: strings, or a ``str`` enum whose member the
    validated value becomes (its values are what a user writes)."""
    if isinstance(choices, type):
        meta = {"kind": "str", "choices": tuple(c.value for c in choices), "enum": choices}
        return field(default=choices(default), metadata={**meta, "doc": doc})
    return field(default=default, metadata={"kind": "str", "choices": choices, "doc": doc})


class ProducerRule(StrEnum):
    """SPSA's producer update (eq. 3): ``deviation`` (ours, the reading the paper's figures
    support) or ``literal`` (the equation as printed)."""

    DEVIATION = "deviation"
    LITERAL = "literal"


class ScroungerIndex(StrEnum):
    """The index ``i`` of eq. 4: over the scroungers (the paper's text) or the population."""

    SCROUNGER = "scrounger"
    POPULATION = "population"


class Selection(StrEnum):
    """Which final individual the post-processing keeps (:class:`PostParams`)."""

    #: the paper's: the best individual
    BEST = "best"
    #: ours: the lowest simplified (refined) energy among the distinct final individuals
    POPULATION = "population"


#: public names of the field helpers, for planners defined outside this module
param = _num
flag = _flag
choice = _choice


def user_key(f: dataclasses.Field[Any]) -> str:
    """The key a user writes for field ``f`` (``dx`` for ``dx_m``)."""
    return f.metadata.get("key") or f.name


def user_keys(cls: type) -> dict[str, str]:
    """User key → field name, for every field of parameter class ``cls``."""
    out: dict[str, str] = {}
    for f in fields(cls):
        out[user_key(f)] = f.name
        out.setdefault(f.name, f.name)
    return out


def field_names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in fields(cls))


def describe(f: dataclasses.Field[Any]) -> str:
    """The documented range of field ``f``, as error messages and docs show it."""
    m = f.metadata
    kind = m.get("kind")
    if kind == "bool":
        return "true or false"
    if kind == "str":
        return "one of " + ", ".join(m["choices"])
    what = "an integer" if kind == "int" else "a number"
    lo, hi = m.get("lo"), m.get("hi")

    def fmt(v: float) -> str:
        return str(int(v)) if kind == "int" else f"{v:g}"

    parts = []
    if lo is not None:
        parts.append(f"{'>' if m.get('lo_open') else '>='} {fmt(lo)}")
    if hi is not None:
        parts.append(f"{'<' if m.get('hi_open') else '<='} {fmt(hi)}")
    text = what + (" " + " and ".join(parts) if parts else "")
    return text + (" (or null)" if m.get("optional") else "")


def check_value(f: dataclasses.Field[Any], value: Any) -> Any:
    """``value`` for field ``f`` if it is of the right type and within bounds (ints stay
    ints, numbers become floats); ConfigError (without key) otherwise."""
    m = f.metadata
    kind = m.get("kind")
    if kind is None:  # pragma: no cover - every parameter field has metadata
        return value
    if value is None and m.get("optional"):
        return None
    if kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(f"must be true or false, got {type_name(value)}")
        return value
    if kind == "str":
        choices = m["choices"]
        if not isinstance(value, str) or value not in choices:
            raise ConfigError(f"must be one of {', '.join(choices)}, got {short_repr(value)}")
        enum = m.get("enum")
        return value if enum is None else enum(value)
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
                value = int(value)  # 1e3 written for 1000
            else:
                raise ConfigError(f"must be an integer, got {_got(value)}")
    else:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(f"must be a number, got {_got(value)}")
        if isinstance(value, int) and abs(value) > 1e300:
            raise ConfigError(f"must be {describe(f)}, got {short_repr(value)}")
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(f"must be a finite number, got {value}")
    lo, hi = m.get("lo"), m.get("hi")
    below = lo is not None and (value <= lo if m.get("lo_open") else value < lo)
    above = hi is not None and (value >= hi if m.get("hi_open") else value > hi)
    if below or above:
        shown = f"{value:g}" if isinstance(value, float) else short_repr(value)
        raise ConfigError(f"must be {describe(f)}, got {shown}")
    return value


def _got(value: Any) -> str:
    if isinstance(value, str | int | float) and not isinstance(value, bool):
        return f"{type_name(value)} ({short_repr(value)})"
    return type_name(value)


def build(cls: type[T], raw: Any, key: str = "", base: T | None = None) -> T:
    """THE validator: parameter class ``cls`` from the mapping ``raw`` of user keys.

    Keys may be a field's user key (``dx``) or its name (``dx_m``). Fields not in ``raw`` keep
    ``base``'s values (default: the class defaults). Type, bounds and choices come from each
    field's metadata; cross-field rules from ``__post_init__``. Every problem raises
    :class:`ConfigError` whose key is below ``key``.
    """
    if not isinstance(raw, Mapping):
        raise ConfigError(f"must be a mapping, got {type_name(raw)}", key=key or None)
    by_key = user_keys(cls)
    by_name = {f.name: f for f in fields(cls)}  # type: ignore[arg-type]
    changes: dict[str, Any] = {}
    for k, value in raw.items():
        if not isinstance(k, str):
            raise ConfigError(f"keys must be strings, got {short_repr(k)}", key=key or None)
        name = by_key.get(k)
        if name is None:
            known = sorted({user_key(f) for f in by_name.values()})
            raise ConfigError(
                f"unknown key (allowed: {', '.join(known)})", key=join_key(key, key_text(k))
            )
        if name in changes:
            raise ConfigError("given twice (by its name and its short key)", key=join_key(key, k))
        try:
            changes[name] = check_value(by_name[name], value)
        except ConfigError as err:
            raise err.under(join_key(key, k)) from None
    start = base if base is not None else cls()
    try:
        return dataclasses.replace(start, **changes)  # type: ignore[type-var]
    except ConfigError as err:
        # __post_init__ names a field; show the key the user wrote
        f = by_name.get(err.key or "")
        sub = user_key(f) if f is not None else (err.key or "")
        raise ConfigError(err.reason, key=join_key(key, sub) or None) from None


def override(obj: T, changes: Mapping[str, Any], key: str = "") -> T:
    """``obj`` with ``changes`` (user keys or field names), validated like :func:`build`."""
    return build(type(obj), changes, key, base=obj)


def as_dict(obj: Any) -> dict[str, Any]:
    """A parameter object as ``{user key: value}`` (JSON-able)."""
    return {user_key(f): getattr(obj, f.name) for f in fields(obj)}


def _cross(condition: bool, name: str, reason: str) -> None:
    if not condition:
        raise ConfigError(reason, key=name)


# ---------------------------------------------------------------------------------------------
# Parameter classes


@dataclass(frozen=True)
class EnergyWeights:
    """Weights of the energy fitness (eq. 1–2): E = k0·L + k1·Σ μ0(1 + cos θ) + k2·Σ|Δz|."""

    k0: float = _num(1.0, lo=0, hi=1e6, doc="per metre flown")
    k1: float = _num(1.0, lo=0, hi=1e6, doc="turning scale")
    mu0: float = _num(1.0, lo=0, hi=1e6, doc="turning-angle coefficient")
    k2: float = _num(1.0, lo=0, hi=1e6, doc="per metre climbed or descended")


#: the search fitness: ``paper`` (eq. 1-2 with :class:`EnergyWeights`, the default and the
#: paper's protocol) or ``physical`` (the power model's watt-hours, wind included:
#: docs/energy.md "The physical fitness")
FITNESS_MODES: tuple[str, ...] = ("paper", "physical")


@dataclass(frozen=True)
class GridSpec:
    """Path grid (section 2.1, 6): one node per ``dx`` column, nodes rounded to ``dy``/``dz``."""

    dx_m: float = _num(20.0, lo=0.1, hi=10_000, key="dx", doc="column spacing, metres")
    dy_m: float = _num(20.0, lo=0.1, hi=10_000, key="dy", doc="lateral lattice step, metres")
    dz_m: float = _num(10.0, lo=0.1, hi=10_000, key="dz", doc="vertical lattice step, metres")


#: the default early stop (:attr:`SearchParams.stall_iterations`): the first search ends once
#: the run's best fitness has not improved for this many iterations, each further restart of
#: SPSA after :data:`DEFAULT_RESTART_STALL_ITERATIONS`; chosen from measurements on the bundled
#: scenarios (docs/algorithm.md, "Termination")
DEFAULT_STALL_ITERATIONS = 100
DEFAULT_RESTART_STALL_ITERATIONS = 25


@dataclass(frozen=True)
class SearchParams:
    """Options shared by every planner: population, iterations, seed and the initialisation.

    ``init_half_window`` is Δh of eq. 9–10 in grid units (paper: ten units in y and z);
    ``t_max`` is the reselection limit T_max (Table 1) used by every algorithm, so all of
    them follow the same reachability rule. ``fitness_smoothing``: the fitness spline runs
    through a moving average of the nodes (half-width in columns) so the grid rounding's
    staircase does not dominate it; 0 = the paper's fitness; None = the planner's own default
    (:attr:`PlannerEntry.fitness_smoothing`: SPSA 2, ours; every baseline 0, the paper's).
    """

    population: int = _num(30, kind="int", lo=4, hi=10_000, doc="G, Table 1")
    iterations: int = _num(1000, kind="int", lo=1, hi=1_000_000, doc="M, Table 1")
    seed: int = _num(1, kind="int", lo=0, hi=2**63 - 1, doc="random seed")
    t_max: int = _num(10, kind="int", lo=1, hi=1000, doc="T_max, Table 1")
    init_half_window: float = _num(
        10.0, lo=0, lo_open=True, hi=10_000, doc="Δh of eq. 9–10, grid units"
    )
    fitness_smoothing: int | None = _num(
        None, kind="int", lo=0, hi=1000, optional=True, doc="moving-average half-width"
    )
    stall_iterations: int | None = _num(
        DEFAULT_STALL_ITERATIONS,
        kind="int",
        lo=1,
        hi=1_000_000,
        optional=True,
        doc="stop the first search once the run's best fitness has not improved for this "
        "many iterations; null: run all M (the paper's protocol)",
    )
    restart_stall_iterations: int | None = _num(
        DEFAULT_RESTART_STALL_ITERATIONS,
        kind="int",
        lo=1,
        hi=1_000_000,
        optional=True,
        doc="the same for every restart after the first (SPSA's restarts); null: stall_iterations",
    )


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

    producer_ratio: float = _num(0.7, lo=0, hi=1, doc="PD")
    scrounger_ratio: float = _num(0.3, lo=0, hi=1, doc="JD")
    danger_ratio: float = _num(0.2, lo=0, hi=1, doc="SD")
    warning_value: float = _num(0.6, lo=0, hi=1, doc="ST")
    v_min: int = _num(1, kind="int", lo=1, hi=1000, doc="slowest escape speed, grid units")
    v_max: int = _num(5, kind="int", lo=1, hi=1000, doc="fastest escape speed, grid units")
    oscillation_window: int = _num(
        5, kind="int", lo=3, hi=1000, doc="N_p (max); min is 3 (section 4.4)"
    )
    producer_rule: ProducerRule = _choice("deviation", ProducerRule)
    scrounger_index: ScroungerIndex = _choice(
        "scrounger", ScroungerIndex, doc="i in eq. 4 (paper text: scrounger)"
    )
    start_end_producer: bool = _flag(True, doc="contribution 2 (off: SSA's eq. 3 producer)")
    escape: bool = _flag(True, doc="contribution 3 (adaptive variable-speed escape)")
    oscillation: bool = _flag(True, doc="contribution 4")
    restarts: int = _num(
        4, kind="int", lo=1, hi=1000, doc="ours: independent searches the iterations split into"
    )

    def __post_init__(self) -> None:
        _cross(
            abs(self.producer_ratio + self.scrounger_ratio - 1.0) <= 1e-9,
            "scrounger_ratio",
            "producer_ratio + scrounger_ratio must be 1",
        )
        _cross(self.v_min <= self.v_max, "v_max", "need v_min <= v_max")

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
            scrounger_index=ScroungerIndex.POPULATION,
            start_end_producer=False,
            escape=False,
            oscillation=False,
        )


@dataclass(frozen=True)
class PostParams:
    """Post-processing of the best path into a flyable route (section 4.5 and SPEC §4).

    ``simplify`` and ``smooth`` are SPSA's contribution 5. ``refine`` (a pattern search on
    the simplified polyline) and ``tighten`` (string pulling) are ours, not the paper's: they
    move vertices off the grid while every leg keeps the margin. The paper's protocol
    post-processes only the planners whose entry says so (SPSA); baselines report their raw
    best path. ``select``: "best" (the paper: the best individual) or "population" (ours:
    every distinct final individual is simplified and the lowest simplified energy wins; with
    ``refine``, each is refined and the lowest refined energy wins).
    """

    simplify: bool = _flag(True)
    refine: bool = _flag(True)
    tighten: bool = _flag(True)
    smooth: bool = _flag(True)
    sample_step_m: float = _num(5.0, lo=0.1, hi=1000, doc="resolution of the smoothed curve")
    select: Selection = _choice("population", Selection)


# Baselines (paper section 6). Each uses the shared SearchParams (G, M, T_max, initialisation)
# and its authors' standard settings below; none is tuned for these maps.


@dataclass(frozen=True)
class PsoParams:
    """Particle swarm (Kennedy & Eberhart 1995) with the inertia weight of Shi & Eberhart.

    v ← w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x), x ← x + v, r1, r2 ~ U(0, 1) per node and
    axis. ``w`` falls linearly from ``w_start`` to ``w_end`` over the run (Shi & Eberhart
    1999: 0.9 → 0.4); c1 = c2 = 2 (Kennedy & Eberhart 1995). Each velocity component is
    clamped to ``v_max_fraction`` of its axis's range (Vmax; Eberhart & Shi 2001 recommend
    10–20 %; 10 % did better on the bundled paper-like maps, so it is the default, in PSO's
    favour); ``None`` disables the clamp. The velocity carried to the next iteration is the
    displacement actually made, after rounding to the grid and the reachability rule.
    """

    w_start: float = _num(0.9, lo=0, hi=100)
    w_end: float = _num(0.4, lo=0, hi=100)
    c1: float = _num(2.0, lo=0, hi=100)
    c2: float = _num(2.0, lo=0, hi=100)
    v_max_fraction: float | None = _num(0.1, lo=0, lo_open=True, hi=1, optional=True)


@dataclass(frozen=True)
class GwoParams:
    """Grey wolf optimiser (Mirjalili, Mirjalili & Lewis 2014).

    Each wolf moves to the mean of X_k − A·|C·X_k − X| over the three leaders k = α, β, δ
    (the best three positions found so far), A = 2a·r1 − a, C = 2·r2 per node and axis; ``a``
    falls linearly from ``a_start`` to ``a_end`` (2 → 0 in the paper).
    """

    a_start: float = _num(2.0, lo=0, hi=100)
    a_end: float = _num(0.0, lo=0, hi=100)


@dataclass(frozen=True)
class DeParams:
    """Differential evolution, DE/rand/1/bin (Storn & Price 1997).

    Mutant v = x_r1 + F·(x_r2 − x_r3), r1, r2, r3 distinct and different from the target;
    binomial crossover with rate CR and one forced coordinate j_rand; greedy selection.
    Storn & Price's recommended starting values are F = 0.5, CR = 0.9; on this encoding DE at
    F = 0.5 accepts no trial in 1000 generations (every mutant node is tens of grid units
    off and the path it makes is worse than its parent). The default F = 0.1, CR = 0.9 is the
    best cell of a measured F × CR grid on paper-env1 (docs/results.md, "DE: F × CR"): the
    only setting whose every run improved on its initial population.
    """

    f: float = _num(0.1, lo=0, lo_open=True, hi=2, doc="differential weight F")
    cr: float = _num(0.9, lo=0, hi=1, doc="crossover rate CR")


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

    rooster_ratio: float = _num(0.2, lo=0, hi=1, lo_open=True, hi_open=True)
    hen_ratio: float = _num(0.6, lo=0, hi=1, lo_open=True, hi_open=True)
    mother_ratio: float = _num(1 / 6, lo=0, hi=1, lo_open=True, hi_open=True)
    g: int = _num(10, kind="int", lo=1, hi=1_000_000, doc="hierarchy update period")
    fl_min: float = _num(0.4, lo=0, hi=2)
    fl_max: float = _num(1.0, lo=0, hi=2)

    def __post_init__(self) -> None:
        _cross(
            self.rooster_ratio + self.hen_ratio < 1,
            "hen_ratio",
            "rooster_ratio + hen_ratio must be < 1 (the rest are chicks)",
        )
        _cross(self.fl_min <= self.fl_max, "fl_max", "need fl_min <= fl_max")


# ---------------------------------------------------------------------------------------------
# The planner table


@dataclass(frozen=True)
class PlannerEntry:
    """One planner. ``target`` is ``"module:Class"`` (imported lazily) or the class itself;
    the class is built as ``Cls(search: SearchParams, params: ParamsClass | None)``.
    ``params`` is the dataclass of its scenario section ``planner.<name>`` (None: it takes
    none). ``fitness_smoothing`` is its default search-fitness smoothing; ``postprocess``:
    whether the paper's protocol post-processes its path; ``paper``: one of the algorithms
    the paper compares (the bench default set)."""

    name: str
    target: str | type
    params: type | None
    summary: str
    fitness_smoothing: int = 0
    postprocess: bool = False
    paper: bool = False
    #: the fixed parameters a planner without a section runs with, echoed in reports
    #: (SSA: :meth:`SpsaParams.ssa`)
    fixed_params: Any = None


#: keys of ``planner:`` that are not planner sections; no planner may take one as its name
PLANNER_KEYS: tuple[str, ...] = (
    "algorithm",
    "population",
    "iterations",
    "seed",
    "t_max",
    "init_half_window",
    "fitness_smoothing",
    "stall_iterations",
    "restart_stall_iterations",
    "grid",
    "energy",
    "post",
    "options",
)

#: name → entry, in the order tables list them
PLANNERS: dict[str, PlannerEntry] = {}


def register(entry: PlannerEntry) -> PlannerEntry:
    """Add ``entry`` to :data:`PLANNERS` (replacing one of the same name). ValueError when its
    name is not a lowercase identifier or is a reserved ``planner:`` key."""
    name = entry.name
    if not (name.isidentifier() and name == name.lower()) or name in PLANNER_KEYS:
        raise ValueError(f"cannot register a planner named {name!r}")
    if isinstance(entry.target, str) and ":" not in entry.target:
        raise ValueError(f"planner target {entry.target!r} is not 'module:Class'")
    PLANNERS[name] = entry
    return entry


def unregister(name: str) -> None:
    """Remove planner ``name`` (tests use this to clean up)."""
    PLANNERS.pop(name, None)


for _entry in (
    PlannerEntry(
        "spsa",
        "uavplan.planners.sparrow:SparrowPlanner",
        SpsaParams,
        "sparrow search with start-end producers, escape and oscillation (the paper's SPSA)",
        fitness_smoothing=2,
        postprocess=True,
        paper=True,
    ),
    PlannerEntry(
        "ssa",
        "uavplan.planners.sparrow:SsaPlanner",
        None,
        "the original sparrow search (Xue & Shen 2020)",
        paper=True,
        fixed_params=SpsaParams.ssa,
    ),
    PlannerEntry(
        "pso",
        "uavplan.planners.particle_swarm:ParticleSwarmPlanner",
        PsoParams,
        "particle swarm with linearly falling inertia (Shi & Eberhart)",
        paper=True,
    ),
    PlannerEntry(
        "gwo",
        "uavplan.planners.grey_wolf:GreyWolfPlanner",
        GwoParams,
        "grey wolf optimiser (Mirjalili et al. 2014)",
        paper=True,
    ),
    PlannerEntry(
        "de",
        "uavplan.planners.differential_evolution:DifferentialEvolutionPlanner",
        DeParams,
        "differential evolution DE/rand/1/bin (Storn & Price 1997)",
        paper=True,
    ),
    PlannerEntry(
        "cso",
        "uavplan.planners.chicken_swarm:ChickenSwarmPlanner",
        CsoParams,
        "chicken swarm optimisation (Meng et al. 2014)",
        paper=True,
    ),
    PlannerEntry(
        "spsa_numpy",
        "uavplan.planners.sparrow_numpy:NumpySparrowPlanner",
        SpsaParams,
        "SPSA's iteration in numpy: slow but readable, the compiled step's reference (same route)",
        fitness_smoothing=2,
        postprocess=True,
    ),
):
    register(_entry)


def planner_entry(name: str, key: str = "algorithm") -> PlannerEntry:
    """The entry of planner ``name``; ConfigError (at ``key``) listing the known ones."""
    entry = PLANNERS.get(name) if isinstance(name, str) else None
    if entry is None:
        raise ConfigError(
            f"unknown algorithm {short_repr(name)} (available: {', '.join(PLANNERS)})", key=key
        )
    return entry


def paper_algorithms() -> tuple[str, ...]:
    """Every registered planner of the paper's comparison, in table order."""
    return tuple(n for n, e in PLANNERS.items() if e.paper)


def default_params(name: str) -> Any:
    """Planner ``name``'s parameters with every default (None: it takes none)."""
    entry = planner_entry(name)
    return entry.params() if entry.params is not None else None


def build_params(name: str, raw: Any, key: str = "") -> Any:
    """Planner ``name``'s parameters from a mapping of its keys (``None``/empty: defaults)."""
    entry = planner_entry(name)
    if entry.params is None:
        if raw:
            keys = ", ".join(map(str, raw)) if isinstance(raw, Mapping) else short_repr(raw)
            raise ConfigError(f"algorithm {name!r} takes no parameters (got {keys})", key=key)
        return None
    return build(entry.params, {} if raw is None else raw, key)


# ---------------------------------------------------------------------------------------------
# The planner configuration of a run


@dataclass(frozen=True)
class PlannerConfig:
    """Everything a planner run is configured with: the algorithm, the shared search values,
    the grid, the energy weights, the post-processing and each planner's own section
    (``sections[name]``, validated parameter objects; a planner without one uses its
    defaults, see :meth:`params_for`). ``grid`` None: the grid is fitted to the flight
    volume (:attr:`uavplan.scenario.Scenario.grid`, docs/scenario-format.md "Limits")."""

    algorithm: str = "spsa"
    search: SearchParams = field(default_factory=SearchParams)
    grid: GridSpec | None = None
    energy: EnergyWeights = field(default_factory=EnergyWeights)
    post: PostParams = field(default_factory=PostParams)
    sections: Mapping[str, Any] = field(default_factory=dict)
    #: the search fitness, one of :data:`FITNESS_MODES` (``planner: {energy: physical}``)
    fitness: str = "paper"

    def __post_init__(self) -> None:
        if self.fitness not in FITNESS_MODES:
            raise ConfigError(f"must be one of {', '.join(FITNESS_MODES)}", key="energy")

    def params_for(self, name: str | None = None) -> Any:
        """Planner ``name``'s parameters (default: the configured algorithm's): its section
        if the scenario has one, else its defaults; None for a planner that takes none."""
        name = self.algorithm if name is None else name
        if name in self.sections:
            return self.sections[name]
        return default_params(name)

    @property
    def spsa(self) -> SpsaParams:
        """SPSA's parameters (its section or the defaults)."""
        params = self.params_for("spsa")
        return params if params is not None else SpsaParams()

    @property
    def options(self) -> dict[str, Any]:
        """The configured algorithm's parameters that differ from its defaults, as
        ``{field name: value}`` (the older ``options`` view; empty for defaults)."""
        params = self.params_for()
        if params is None:
            return {}
        defaults = type(params)()
        return {
            f.name: getattr(params, f.name)
            for f in fields(params)
            if getattr(params, f.name) != getattr(defaults, f.name)
        }

    def with_params(self, name: str, params: Any) -> PlannerConfig:
        """A copy whose section ``name`` is ``params`` (a parameter object)."""
        return dataclasses.replace(self, sections={**self.sections, name: params})

    def fitness_smoothing(self, name: str | None = None) -> int:
        """The effective search-fitness smoothing of planner ``name``."""
        name = self.algorithm if name is None else name
        s = self.search.fitness_smoothing
        return planner_entry(name).fitness_smoothing if s is None else s


def resolved_planner(cfg: PlannerConfig, algorithm: str | None = None) -> dict[str, Any]:
    """The whole resolved planner configuration of a run of ``algorithm`` (JSON-able)."""
    name = cfg.algorithm if algorithm is None else algorithm
    entry = planner_entry(name)
    search = as_dict(cfg.search)
    search["fitness_smoothing"] = cfg.fitness_smoothing(name)
    params = cfg.params_for(name)
    if params is None and entry.fixed_params is not None:
        params = entry.fixed_params()
    return {
        "algorithm": name,
        "search": search,
        "fitness_smoothing_default": entry.fitness_smoothing,
        "params": None if params is None else as_dict(params),
        "grid": None if cfg.grid is None else as_dict(cfg.grid),
        "energy": as_dict(cfg.energy),
        "fitness": cfg.fitness,
        "post": as_dict(cfg.post),
        "postprocess": entry.postprocess,
        "margin_pad_m": MARGIN_PAD_M,
    }


# ---------------------------------------------------------------------------------------------
# Mission flavour (a scenario's mission.autopilot; the mission layer re-exports it)

#: how a mission ends: return to launch, land at the goal, nothing (hover at the goal), or
#: fly a planned return home and land there
EndAction = Literal["rtl", "land", "none", "return"]
END_ACTIONS: tuple[str, ...] = ("rtl", "land", "none", "return")
#: mission.altitude: waypoint altitudes relative to home (MAV_FRAME_GLOBAL_RELATIVE_ALT), AMSL
#: (MAV_FRAME_GLOBAL) or above the ground beneath (MAV_FRAME_GLOBAL_TERRAIN_ALT)
ALTITUDE_MODES: tuple[str, ...] = ("relative", "amsl", "terrain")
