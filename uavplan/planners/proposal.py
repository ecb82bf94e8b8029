"""The one typed entry through which every planner's update rule reaches the shared kernel.

A planner computes its update rule in its own module, vectorised over the population with
numpy, and describes the result as a :class:`Proposal`. The kernel
(:func:`uavplan.planners._kernels.rebuild`) then walks every active individual node by node
from start to goal and applies the reachability rule (PAPER-NOTES "Path model"): an
unreachable node is proposed again, up to ``t_max`` attempts, then (optionally) the adaptive
variable-speed escape of eq. 12, else the old node is kept.

For individual ``g``, node ``j``, axis ``a`` (0: y across the path, 1: z up; grid units)
attempt ``t`` proposes::

    explicit[t, g, j, a]                                  if t < n_explicit[g]
    first[g, j, a]                                        if t = 0 and first is given for g
    anchor + clip(offset + spread·X + spread2·Y, ±clamp[a])  otherwise

with ``X``, ``Y`` fresh draws of the individual's kinds ``draw[g]``, ``draw2[g]`` for every
attempt and axis (:class:`Draw`). Rules whose retries are of this form (SSA, SPSA, PSO, CSO)
state them so; rules whose retries are not (GWO's redrawn A and C, DE's redrawn donors) give
their ``t_max`` attempts explicitly. The draws come from per-individual streams seeded by the
run's ``numpy.random.Generator``, so runs are reproducible.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from uavplan.planners import _kernels as K

Array = NDArray[np.float64]


class Draw(enum.IntEnum):
    """The random term of a proposal."""

    NONE = K.DRAW_NONE  # deterministic: every attempt proposes the same value
    UNIFORM = K.DRAW_UNIFORM  # U[0, 1)
    SYMMETRIC = K.DRAW_SYMMETRIC  # U[−1, 1)
    NORMAL = K.DRAW_NORMAL  # N(0, 1)


@dataclass
class Proposal:
    """New-node proposals for a population of ``G`` individuals with ``n`` inner nodes.

    Every array is ``(G, n, 2)`` (node, axis: y, z in grid units) unless stated; create one
    with :meth:`for_population` and fill the rows of the individuals a rule moves.

    ``active`` (G,): individuals to update (others keep their path untouched).
    ``anchor``, ``offset``, ``spread``, ``spread2``: the terms of the formula above.
    ``draw``, ``draw2`` (G,): the kinds of X and Y (:class:`Draw`).
    ``clamp`` (2,): bound on ``|offset + spread·X + spread2·Y|`` per axis (inf: none).
    ``first`` with ``use_first`` (G,): an explicit value for attempt 0.
    ``explicit`` (A, G, n, 2) with ``n_explicit`` (G,): explicit values for attempts < A.
    ``escape`` (G,): after ``t_max`` failed attempts, try eq. 12's variable-speed escape.
    """

    active: NDArray[np.bool_]
    anchor: Array
    offset: Array
    spread: Array
    draw: NDArray[np.int64]
    spread2: Array
    draw2: NDArray[np.int64]
    clamp: Array
    first: Array
    use_first: NDArray[np.bool_]
    explicit: Array
    n_explicit: NDArray[np.int64]
    escape: NDArray[np.bool_]

    @classmethod
    def for_population(cls, base: Array, n_explicit: int = 0) -> Proposal:
        """An all-inactive proposal shaped like ``base`` (G, n, 2), room for ``n_explicit``
        explicit attempts. Anchors start at the current positions."""
        g = base.shape[0]
        zeros = np.zeros_like(base)
        return cls(
            active=np.zeros(g, dtype=np.bool_),
            anchor=base.copy(),
            offset=zeros,
            spread=np.zeros_like(base),
            draw=np.zeros(g, dtype=np.int64),
            spread2=np.zeros_like(base),
            draw2=np.zeros(g, dtype=np.int64),
            clamp=np.full(2, math.inf),
            first=np.zeros_like(base),
            use_first=np.zeros(g, dtype=np.bool_),
            explicit=np.zeros((n_explicit, *base.shape)),
            n_explicit=np.zeros(g, dtype=np.int64),
            escape=np.zeros(g, dtype=np.bool_),
        )
