"""The energy fitness of the paper (eq. 1–2) and the physical one, compiled (C:
:mod:`uavplan._ckernels`).

``E = k0·Σ|segment| + k1·Σ μ0·(1 + cos θ) + k2·Σ|Δz|`` over a polyline, with θ the angle at a
vertex between its two segments (straight: θ = 180°, term 0). The search evaluates it on the
natural cubic spline through a path's column nodes, sampled ``n_sub`` times per column
(section 2.2: "the fitness is performed by cubic spline interpolation"). With uniform columns
the spline is a linear map of the node values, solved here by one tridiagonal sweep per
individual and axis, so a whole population costs O(G·D).

The physical fitness (``planner: {energy: physical}``, :class:`PhysicalFitness`) evaluates the
same spline samples with the power model of :mod:`uavplan.airframe`: each step a leg flown at
the commanded ground speed through the wind, its energy in watt-hours. The kernel reads the
vehicle's figures and a table of the wind (in the path frame) and the air density by height
(:meth:`PhysicalFitness.table`); :meth:`PhysicalFitness.polyline_wh` is the same sum in
numpy through :func:`uavplan.airframe.flight_energy` (the reference the tests compare with).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

import uavplan.airframe.constants as VC
from uavplan._geom import _c, kernel_fields
from uavplan.airframe import Legs, VehicleProfile, Wind, air_density_kg_m3, flight_energy
from uavplan.airframe.power import disc_area_m2, scale_and_drag
from uavplan.config import EnergyWeights

#: spline samples per column interval used by the search fitness
N_SUB = 3

#: no physical fitness (the paper's): an empty table
NO_PHYSICS = np.zeros(0)
#: the physical fitness's table of wind and density holds at most this many heights
PHYS_TABLE_ROWS = 2049


def _f64(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


@dataclass(frozen=True, slots=True, eq=False)
class EnergyArgs:
    """The fitness's fixed arguments for one path problem, by name, as the kernels read them
    (:attr:`PathProblem.energy_args <uavplan.planners.base.PathProblem.energy_args>` builds
    them; :func:`energy_of` and the fused SPSA step read them). See
    :func:`population_energy` for their meaning."""

    start_yz: np.ndarray
    goal_yz: np.ndarray
    cols: np.ndarray
    dx: float
    dy: float
    dz: float
    n_sub: int
    k0: float
    k1: float
    mu0: float
    k2: float
    smooth: int
    straight: bool
    #: the physical fitness's table (:meth:`PhysicalFitness.table`); empty: the paper's
    phys: np.ndarray = field(default_factory=lambda: NO_PHYSICS)

    def __post_init__(self) -> None:
        kernel_fields(self, "energy")


@dataclass(frozen=True, eq=False)
class PhysicalFitness:
    """What the physical fitness flies a path with: the vehicle, the wind (None: calm), the
    commanded horizontal ground speed and the vertical rates of a mission leg, and the
    altitude (AMSL) of the path frame's z = 0 for the air density."""

    profile: VehicleProfile
    wind: Wind | None
    speed_m_s: float
    climb_rate_m_s: float
    descent_rate_m_s: float
    datum_amsl_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("speed_m_s", "climb_rate_m_s", "descent_rate_m_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")

    def wind_pf(self, heading_rad: float, heights_m: np.ndarray) -> np.ndarray:
        """The wind's velocity (n, 2) at ``heights_m`` in a path frame whose +x points
        ``heading_rad`` counter-clockwise from east."""
        if self.wind is None:
            return np.zeros((len(heights_m), 2))
        w = self.wind.velocity_at(np.asarray(heights_m, dtype=float)).reshape(-1, 2)
        c, s = math.cos(heading_rad), math.sin(heading_rad)
        return np.column_stack([c * w[:, 0] + s * w[:, 1], -s * w[:, 0] + c * w[:, 1]])

    def table(self, heading_rad: float, z_lo_m: float, z_hi_m: float) -> np.ndarray:
        """The kernel's ``phys`` array: the vehicle's figures, the leg speeds, and the wind
        (in the path frame of ``heading_rad``) and the air density at heights from
        ``z_lo_m`` to ``z_hi_m`` (at most :data:`PHYS_TABLE_ROWS`, 1 m apart or coarser)."""
        p = self.profile
        scale, drag = scale_and_drag(p)
        k1, k2, k3, k4 = VC.VORTEX_RING_FIT
        z_lo, z_hi = float(min(z_lo_m, z_hi_m)), float(max(z_lo_m, z_hi_m))
        rows = int(min(PHYS_TABLE_ROWS, max(2, math.ceil(z_hi - z_lo) + 1)))
        heights = np.linspace(z_lo, z_hi if z_hi > z_lo else z_lo + 1.0, rows)
        step = float(heights[1] - heights[0])
        head = [
            p.mass_kg * VC.GRAVITY_M_S2, disc_area_m2(p), p.figure_of_merit,
            p.induced_power_factor, p.motor_esc_efficiency, p.thrust_coefficient, drag,
            p.avionics_power_w, scale, p.max_airspeed_m_s, self.speed_m_s,
            self.climb_rate_m_s, self.descent_rate_m_s, k1, k2, k3, k4,
            float(heights[0]), step, float(rows),
        ]  # fmt: skip
        rho = air_density_kg_m3(self.datum_amsl_m + np.clip(heights, 0.0, None))
        body = np.column_stack([self.wind_pf(heading_rad, np.maximum(heights, 0.0)), rho])
        return np.ascontiguousarray(np.concatenate([np.array(head), body.reshape(-1)]))

    def polyline_wh(self, points: np.ndarray, heading_rad: float = 0.0) -> float:
        """Watt-hours of the polyline ``points`` (n, 3) flown leg by leg (path frame of
        ``heading_rad``: z above the datum, the wind's height), through
        :func:`uavplan.airframe.flight_energy`: the physical fitness in numpy."""
        p = np.asarray(points, dtype=float)
        keep = np.ones(len(p), dtype=bool)
        keep[1:] = np.linalg.norm(np.diff(p, axis=0), axis=1) > 1e-12
        p = p[keep]
        if len(p) < 2:
            return 0.0
        c, s = math.cos(heading_rad), math.sin(heading_rad)
        enu = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])
        legs = Legs.from_path(
            enu,
            speed_m_s=self.speed_m_s,
            climb_rate_m_s=self.climb_rate_m_s,
            descent_rate_m_s=self.descent_rate_m_s,
            heights_agl_m=np.maximum(p[:, 2], 0.0),
        )
        altitudes = self.datum_amsl_m + np.maximum((p[:-1, 2] + p[1:, 2]) / 2.0, 0.0)
        return flight_energy(self.profile, legs, self.wind, altitude_amsl_m=altitudes).energy_wh


def polyline_energy(
    points: np.ndarray, k0: float, k1: float, mu0: float, k2: float
) -> tuple[float, float, float]:
    """(E_path, E_turning, E_climb) of the polyline ``points`` (n, 3), weights applied."""
    return _c.polyline_energy(_f64(points), float(k0), float(k1), float(mu0), float(k2))


def _thomas_factors(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Forward-sweep factors of tridiag(1, 4, 1) of size n (natural spline, uniform knots)."""
    cp = np.empty(n)
    den = np.empty(n)
    prev = 0.0
    for i in range(n):
        d = 4.0 - prev
        den[i] = d
        prev = 1.0 / d
        cp[i] = prev
    return cp, den


def spline_points(
    ys: np.ndarray,
    zs: np.ndarray,
    dx: float,
    n_sub: int,
    cp: np.ndarray,
    den: np.ndarray,
    out: np.ndarray,
) -> None:
    """Sample the natural cubic splines y(x), z(x) through knots at x = j·dx.

    ``ys``, ``zs``: knot values (D + 1,) in metres. ``out``: (D·n_sub + 1, 3) filled.
    """
    _c.spline_points(_f64(ys), _f64(zs), float(dx), int(n_sub), _f64(cp), _f64(den), out)


def population_energy(
    nodes: np.ndarray,
    start_yz: np.ndarray,
    goal_yz: np.ndarray,
    dx: float,
    dy: float,
    dz: float,
    n_sub: int,
    k0: float,
    k1: float,
    mu0: float,
    k2: float,
    smooth: int,
    cols: np.ndarray,
    straight: bool,
) -> np.ndarray:
    """Energy (G,) of every individual: nodes (G, D − 1, 2) in grid units (y, z).

    ``start_yz`` / ``goal_yz`` are the fixed end points in metres. ``smooth`` > 0 evaluates
    the spline through a centred moving average of the knots (half-width ``smooth``) instead
    of the knots themselves: the grid rounding of the encoding then no longer shows up as
    staircase wiggles in the fitness (ours; 0 is the paper's fitness). The spline samples
    are summed as they are produced (same result as :func:`spline_points` followed by
    :func:`polyline_energy`, without storing them).

    ``cols`` (D + 1, 4): the columns' origins and unit normals (see the path frame). With a
    ``straight`` guide the columns are x = j·dx and the splines are y(x), z(x), as in the
    paper; along a curved guide every knot is placed in the plane (origin + y·normal) and
    x, y and z are splines of the column index.
    """
    energy = EnergyArgs(
        start_yz, goal_yz, cols, float(dx), float(dy), float(dz), int(n_sub), float(k0),
        float(k1), float(mu0), float(k2), int(smooth), bool(straight),
    )  # fmt: skip
    return energy_of(nodes, energy)


def energy_of(nodes: np.ndarray, energy: EnergyArgs) -> np.ndarray:
    """:func:`population_energy` with its fixed arguments packed once (an
    :class:`EnergyArgs`, as ``PathProblem.energy_args`` builds it and the fused SPSA step
    reads it too)."""
    return _per_individual(_c.population_energy, nodes, energy)


def energy_bounds(nodes: np.ndarray, energy: EnergyArgs) -> np.ndarray:
    """A lower bound (G,) of :func:`energy_of` that costs a fraction of it: k0 times the
    length of the knots' polyline plus k2 times its climb (the spline's samples include the
    knots, so its polyline is no shorter and climbs no less, and the turn term is >= 0).
    -1 where the weights allow no bound (a negative weight). The fused SPSA step uses it in
    greedy selection: a candidate whose bound already reaches its parent's fitness is
    rejected without its energy being computed (the decision is the same)."""
    return _per_individual(_c.energy_bounds, nodes, energy)


def _per_individual(
    kernel: Callable[..., None], nodes: np.ndarray, energy: EnergyArgs
) -> np.ndarray:
    """``kernel(nodes, energy, out)`` for nodes (G, n, 2): one value per individual."""
    nodes = _f64(nodes)
    out = np.empty(nodes.shape[0])
    kernel(nodes, energy, out)
    return out


def energy_terms(points: np.ndarray, weights: EnergyWeights) -> tuple[float, float, float]:
    """(path, turning, climb) energy of a polyline (n, 3) in metres."""
    e = polyline_energy(points, weights.k0, weights.k1, weights.mu0, weights.k2)
    return float(e[0]), float(e[1]), float(e[2])


def column_spline(knots_yz_m: np.ndarray, dx_m: float, n_sub: int = N_SUB) -> np.ndarray:
    """Dense samples ((D·n_sub + 1), 3) in the path frame of the natural cubic spline through
    knots (D + 1, 2) = (y, z) in metres at x = j·dx."""
    k = np.ascontiguousarray(knots_yz_m, dtype=float)
    cp, den = _thomas_factors(max(k.shape[0] - 2, 1))
    out = np.empty(((k.shape[0] - 1) * n_sub + 1, 3))
    spline_points(
        np.ascontiguousarray(k[:, 0]), np.ascontiguousarray(k[:, 1]), dx_m, n_sub, cp, den, out
    )
    return out
