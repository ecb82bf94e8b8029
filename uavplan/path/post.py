"""From a planner's best node path to a flyable route (paper section 4.5, SPEC §4).

1. :func:`simplify` — node simplification: from the current node jump to the *farthest*
   later node reachable in a straight line (Figure 4).
2. :func:`refine` and :func:`tighten` — ours, not the paper's. ``refine`` is a pattern search
   on the simplified polyline in continuous space: legs are subdivided, and each vertex in
   turn moves to the best of its 26 neighbours at a step size that halves from 64 m to
   1 m, whenever that lowers the energy and both legs keep the margin. :func:`refine_best`
   runs it on several candidate polylines (the final population's) and keeps the one it
   brings lowest. ``tighten`` pulls each interior vertex toward the chord of its neighbours
   as far as both legs stay clear (string pulling); it can only lower every energy term.
3. :func:`smooth_route` — cubic spline through the vertices, parametrised by cumulative chord
   length; each leg between two vertices is a blend ``(1 − λ)·line + λ·spline`` and λ is
   halved on any leg whose dense samples come closer than the margin (λ = 0 is the straight,
   feasible leg), so the smoothed curve keeps the margin. Given the energy weights, each
   leg's λ is then the one (of 1, 1/2, …, 2⁻⁸, 0) that keeps the margin at the lowest energy,
   so the curve never costs more than the polyline it smooths.
4. :func:`resample_waypoints` — waypoints every ``spacing`` metres along the curve, vertices
   always kept; a straight leg that comes closer than the margin gets the curve's midpoint
   inserted until every leg is clear.

All coordinates are metres in one frame (the path frame or ENU); the world must be in the
same frame. Nothing here knows about optimisers, files or MAVLink.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from uavplan._geom import _c
from uavplan.config import EnergyWeights
from uavplan.path.energy import energy_terms
from uavplan.world import World

#: halvings of λ before a leg falls back to the straight line
MAX_BLEND_HALVINGS = 8
#: passes of the tightening sweep
TIGHTEN_PASSES = 30
TIGHTEN_BISECTIONS = 24


def simplify(points: np.ndarray, world: World) -> np.ndarray:
    """Indices of the simplified polyline: greedy farthest-reachable jumps (Figure 4).

    ``points`` (n, 3) is a feasible polyline; the result starts at 0 and ends at n − 1.
    (The next node is reachable by construction; when it is not, the chain steps to it
    anyway.)
    """
    return world.farthest_visible(np.asarray(points, dtype=float))


#: unit moves of the pattern search: the 26 neighbours of a grid cell
_MOVES = np.array([m for m in itertools.product((-1.0, 0.0, 1.0), repeat=3) if any(m)])
_MOVES /= np.linalg.norm(_MOVES, axis=1)[:, None]
#: step sizes of the pattern search, halving from a few grid cells (a vertex can move to the
#: other side of a building or a level down) to a metre
REFINE_STEPS_M: tuple[float, ...] = (64.0, 32.0, 16.0, 8.0, 4.0, 2.0, 1.0)
REFINE_PASSES = 3
REFINE_LEG_M = 40.0
#: :func:`refine_best`'s budget: subdivided vertices searched over all candidates (the first
#: candidate is always searched); about 4 candidate routes of 50 km, every one of a 2 km
#: route's population (67 × ~55). 10,000 cost the 13 km ridge crossing 0.23 s more core CPU
#: for the same route (tools/bench_scale.py)
REFINE_BUDGET_VERTICES = 5_000


def subdivide(vertices: np.ndarray, max_leg_m: float) -> np.ndarray:
    """Insert evenly spaced vertices so no leg is longer than ``max_leg_m``."""
    v = np.asarray(vertices, dtype=float)
    out = [v[:1]]
    for a, b in itertools.pairwise(v):
        n = max(1, math.ceil(np.linalg.norm(b - a) / max_leg_m))
        out.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.vstack(out)


def refine(vertices: np.ndarray, world: World, weights: EnergyWeights) -> np.ndarray:
    """Pattern search on a feasible polyline (see module doc); returns a feasible polyline
    whose energy is not higher, simplified and tightened.

    The legs are subdivided (at most ``REFINE_LEG_M``); then for each step size, up to
    ``REFINE_PASSES`` sweeps (until one moves nothing) in which every interior vertex in turn
    moves to the neighbour (one of the 26 unit moves) that lowers the energy of its window of
    two vertices either side the most, among those whose two legs keep the margin; equal
    gains go to the first move. Compiled (:func:`uavplan._ckernels.refine_vertices`)."""
    return tighten(_pattern_search(subdivide(vertices, REFINE_LEG_M), world, weights), world)


def _pattern_search(v: np.ndarray, world: World, weights: EnergyWeights) -> np.ndarray:
    """:func:`refine`'s pattern search on the subdivided polyline ``v``, simplified."""
    v = np.ascontiguousarray(v, dtype=float)
    w = weights
    _c.refine_vertices(
        v, _MOVES, np.array(REFINE_STEPS_M), REFINE_PASSES, world.kernel_args,
        world.margin_m, (w.k0, w.k1 * w.mu0, w.k2),
    )  # fmt: skip
    return v[simplify(v, world)]


def refine_best(
    candidates: Sequence[np.ndarray],
    world: World,
    weights: EnergyWeights,
    budget_vertices: int = REFINE_BUDGET_VERTICES,
) -> tuple[int, np.ndarray]:
    """:func:`refine` of the best of several feasible polylines: (its index, the result).

    The candidates are taken in the order given (best first by the caller's measure) while
    their subdivided vertices fit in ``budget_vertices`` (the first always); a candidate
    equal to an earlier one is skipped. Each gets :func:`refine`'s pattern search, and the
    one whose searched polyline has the lowest energy (eq. 1-2; ties: the earlier) is
    tightened and returned. The search can move a vertex by tens of metres but cannot turn
    one route class into another (over the clutter into through it); the final population
    often holds both, and which is lower is known only once each is refined."""
    best: tuple[float, int, np.ndarray] | None = None
    seen: set[bytes] = set()
    used = 0
    for i, cand in enumerate(candidates):
        v = np.ascontiguousarray(cand, dtype=float)
        key = v.tobytes()
        if key in seen:
            continue
        sub = subdivide(v, REFINE_LEG_M)
        if best is not None and used + sub.shape[0] > budget_vertices:
            break
        seen.add(key)
        used += sub.shape[0]
        searched = _pattern_search(sub, world, weights)
        e = float(sum(energy_terms(searched, weights)))
        if best is None or e < best[0]:
            best = (e, i, searched)
    if best is None:
        raise ValueError("refine_best: no candidate polyline")
    return best[1], tighten(best[2], world)


def tighten(vertices: np.ndarray, world: World, tol_m: float = 1e-3) -> np.ndarray:
    """Move interior vertices toward their neighbours' chord while both legs stay free.

    Each pass moves every interior vertex ``v`` along ``v → q`` (``q`` the closest point of
    the chord between its neighbours) by the largest fraction found by bisection for which
    both adjacent segments keep the margin. Vertices that become redundant (neighbours see
    each other) are dropped. Stops when no vertex moves more than ``tol_m``.
    """
    v = np.array(vertices, dtype=float)
    for _ in range(TIGHTEN_PASSES):
        moved = 0.0
        k = 1
        while k < v.shape[0] - 1:
            a, b = v[k - 1], v[k + 1]
            if world.segments_free(a[None], b[None])[0]:
                v = np.delete(v, k, axis=0)
                moved = max(moved, 1.0)
                continue
            ab = b - a
            t = float(np.clip(np.dot(v[k] - a, ab) / max(np.dot(ab, ab), 1e-12), 0.0, 1.0))
            q = a + t * ab
            step = q - v[k]
            if np.linalg.norm(step) > tol_m:
                fracs = _largest_free_fraction(v[k], step, a, b, world)
                if fracs > 0.0:
                    v[k] = v[k] + fracs * step
                    moved = max(moved, fracs * float(np.linalg.norm(step)))
            k += 1
        if moved <= tol_m:
            break
    return v


def _largest_free_fraction(
    p: np.ndarray, step: np.ndarray, a: np.ndarray, b: np.ndarray, world: World
) -> float:
    """Largest f in [0, 1] (to bisection precision) with a→p+f·step→b free (compiled:
    :meth:`World.largest_free_fraction`)."""
    return world.largest_free_fraction(p, step, a, b, TIGHTEN_BISECTIONS)


@dataclass(frozen=True)
class SmoothRoute:
    """A smoothed route: vertices it passes through, per-leg blend factors, dense samples.

    ``samples`` (k, 3) is the final curve; ``vertex_index`` gives the row of every vertex in
    ``samples``.
    """

    vertices: np.ndarray  # (m, 3)
    blend: np.ndarray  # (m − 1,) λ per leg
    samples: np.ndarray  # (k, 3)
    vertex_index: np.ndarray  # (m,)


class NaturalSpline:
    """Natural cubic spline through points ``v`` (m, 3) at parameters ``s`` (m,), strictly
    increasing. Small and dependency-free (importing scipy.interpolate costs half a second
    of every ``uavplan plan``)."""

    def __init__(self, s: np.ndarray, v: np.ndarray) -> None:
        self.s = np.asarray(s, dtype=float)
        self.v = np.asarray(v, dtype=float)
        m = self.s.size
        h = np.diff(self.s)
        a = np.zeros((m, m))
        rhs = np.zeros((m, self.v.shape[1]))
        a[0, 0] = a[-1, -1] = 1.0  # natural ends: zero second derivative
        for i in range(1, m - 1):
            a[i, i - 1] = h[i - 1]
            a[i, i] = 2.0 * (h[i - 1] + h[i])
            a[i, i + 1] = h[i]
            rhs[i] = 6.0 * (
                (self.v[i + 1] - self.v[i]) / h[i] - (self.v[i] - self.v[i - 1]) / h[i - 1]
            )
        self.m2 = np.linalg.solve(a, rhs)  # second derivatives at the knots

    def __call__(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        i = np.clip(np.searchsorted(self.s, t, side="right") - 1, 0, self.s.size - 2)
        h = (self.s[i + 1] - self.s[i])[:, None]
        u = ((t - self.s[i]) / h[:, 0])[:, None]
        w = 1.0 - u
        return (
            w * self.v[i]
            + u * self.v[i + 1]
            + (h * h / 6.0) * ((w**3 - w) * self.m2[i] + (u**3 - u) * self.m2[i + 1])
        )


def _leg_samples(
    v: np.ndarray, spline: NaturalSpline | None, s: np.ndarray, i: int, lam: float, step_m: float
) -> np.ndarray:
    """Dense samples of leg i (excluding its end vertex)."""
    a, b = v[i], v[i + 1]
    n = max(1, math.ceil(np.linalg.norm(b - a) / step_m))
    u = np.arange(n) / n
    line = a + u[:, None] * (b - a)
    if spline is None or lam == 0.0:
        return line
    curve = spline(s[i] + u * (s[i + 1] - s[i]))
    return (1.0 - lam) * line + lam * curve


def smooth_route(
    vertices: np.ndarray,
    world: World,
    *,
    smooth: bool = True,
    step_m: float = 5.0,
    weights: EnergyWeights | None = None,
) -> SmoothRoute:
    """Cubic-spline smoothing of a feasible polyline, blended back where it would cut into
    the margin (see module doc). With ``smooth=False`` the polyline itself is sampled.

    With ``weights`` (eq. 1-2), each leg's blend is then chosen by energy
    (:func:`_blend_by_energy`): a natural spline through unevenly spaced vertices swings
    wide of them (a climb over what the polyline flies level, a detour beside a short leg),
    and the straight leg, or a flatter blend, is then the cheaper route to fly."""
    v = np.asarray(vertices, dtype=float)
    m = v.shape[0]
    spline = None
    s = np.zeros(m)
    if smooth and m >= 3:
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(v, axis=0), axis=1))])
        spline = NaturalSpline(s, v)
    blend = np.ones(m - 1) if spline is not None else np.zeros(m - 1)
    legs: list[np.ndarray] = []
    for i in range(m - 1):
        while True:  # ends at the latest with λ = 0, the straight (feasible) leg
            pts = np.vstack([_leg_samples(v, spline, s, i, blend[i], step_m), v[i + 1]])
            if blend[i] == 0.0 or world.segments_free(pts[:-1], pts[1:]).all():
                break
            blend[i] = 0.0 if blend[i] <= 2.0**-MAX_BLEND_HALVINGS else blend[i] / 2.0
        legs.append(pts[:-1])
    if spline is not None and weights is not None:
        _blend_by_energy(v, spline, s, step_m, world, weights, blend, legs)
    samples = np.vstack([*legs, v[-1:]])
    counts = np.array([leg.shape[0] for leg in legs])
    vertex_index = np.concatenate([[0], np.cumsum(counts)])
    return SmoothRoute(v, blend, samples, vertex_index)


#: the blends a leg may take: 1, 1/2, ..., 2^-MAX_BLEND_HALVINGS, and the straight leg
BLENDS = (*(2.0**-k for k in range(MAX_BLEND_HALVINGS + 1)), 0.0)
#: sweeps of :func:`_blend_by_energy` over the legs (it stops after one that changes nothing)
BLEND_SWEEPS = 3


def _blend_by_energy(
    v: np.ndarray,
    spline: NaturalSpline,
    s: np.ndarray,
    step_m: float,
    world: World,
    weights: EnergyWeights,
    blend: np.ndarray,
    legs: list[np.ndarray],
) -> None:
    """Lower the smoothed curve's energy leg by leg, in place (``blend``, ``legs``: each
    leg's λ and samples, its end vertex excluded, as the margin rule left them).

    In each of up to :data:`BLEND_SWEEPS` sweeps every leg in turn takes, of the blends
    :data:`BLENDS`, the one of lowest energy whose samples keep the margin, the other legs
    as they stand; the energy compared is exactly what changes (the leg's segments and the
    turns at its samples and at both its vertices). Every change lowers the curve's energy.
    Last, a curve that still costs more than the polyline itself is replaced by it (λ = 0
    on every leg, always feasible)."""
    m = v.shape[0]

    def local(i: int, leg: np.ndarray) -> float:
        before = legs[i - 1][-1:] if i > 0 else v[:0]
        after = v[-1:] if i == m - 2 else np.vstack([legs[i + 1], v[i + 2 : i + 3]])[:2]
        return float(sum(energy_terms(np.vstack([before, leg, after]), weights)))

    for _ in range(BLEND_SWEEPS):
        changed = False
        for i in range(m - 1):
            now = local(i, legs[i])
            options = []
            for lam in BLENDS:
                if lam != blend[i]:
                    leg = _leg_samples(v, spline, s, i, lam, step_m)
                    options.append((local(i, leg), -lam, leg))
            options.sort(key=lambda o: (o[0], o[1]))  # ties: the smoother blend
            for e, neg_lam, leg in options:
                if e >= now - 1e-9:
                    break
                pts = np.vstack([leg, v[i + 1]])
                if neg_lam == 0.0 or world.segments_free(pts[:-1], pts[1:]).all():
                    blend[i], legs[i] = -neg_lam, leg
                    changed = True
                    break
        if not changed:
            break
    curve = float(sum(energy_terms(np.vstack([*legs, v[-1:]]), weights)))
    if curve > float(sum(energy_terms(v, weights))):
        blend[:] = 0.0
        legs[:] = [_leg_samples(v, None, s, i, 0.0, step_m) for i in range(m - 1)]


def resample_waypoints(route: SmoothRoute, world: World, spacing_m: float) -> np.ndarray:
    """Waypoints (w, 3) along ``route.samples`` about every ``spacing_m`` metres, keeping
    every vertex, refined until each straight leg keeps the margin.

    Legs made of consecutive dense samples are free (``smooth_route`` ensured it), so the
    refinement always terminates.
    """
    pts = route.samples
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    chosen: set[int] = set(int(i) for i in route.vertex_index)
    for a, b in zip(route.vertex_index[:-1], route.vertex_index[1:], strict=True):
        length = arc[b] - arc[a]
        n = max(1, round(length / spacing_m))
        targets = arc[a] + length * np.arange(1, n) / n
        chosen.update(int(i) for i in np.searchsorted(arc, targets))
    idx = np.array(sorted(chosen))
    for _ in range(64):
        free = world.segments_free(pts[idx[:-1]], pts[idx[1:]])
        if free.all():
            break
        bad = np.flatnonzero(~free)
        inserts = [(idx[i] + idx[i + 1]) // 2 for i in bad if idx[i + 1] - idx[i] > 1]
        if not inserts:  # cannot happen: consecutive samples are free
            break
        idx = np.array(sorted(set(idx.tolist()) | set(inserts)))
    return pts[idx]


def dedupe(points: np.ndarray, tol_m: float = 1e-6) -> np.ndarray:
    """Drop consecutive duplicate points."""
    p = np.asarray(points, dtype=float)
    if p.shape[0] < 2:
        return p
    keep = np.concatenate([[True], np.linalg.norm(np.diff(p, axis=0), axis=1) > tol_m])
    return p[keep]
