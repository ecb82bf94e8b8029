"""Click parameter types derived from the planner table :data:`uavplan.config.PLANNERS`.

They validate at parse time against the table as it is *then*, so a planner registered at run
time (``uavplan.config.register``) is accepted by ``--algorithm`` without touching the CLI.
"""

from __future__ import annotations

from typing import Any

import click
from click.shell_completion import CompletionItem

from uavplan.config import PLANNERS


class AlgorithmType(click.ParamType):
    """One registered planner name (case-insensitive), e.g. ``--algorithm pso``."""

    name = "algorithm"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> str:
        if isinstance(value, str) and value.strip().lower() in PLANNERS:
            return value.strip().lower()
        self.fail(f"unknown algorithm {value!r} (available: {', '.join(PLANNERS)})", param, ctx)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "[" + "|".join(PLANNERS) + "]"

    def shell_complete(
        self, ctx: click.Context, param: click.Parameter, incomplete: str
    ) -> list[CompletionItem]:
        return [CompletionItem(n) for n in PLANNERS if n.startswith(incomplete.lower())]


class AlgorithmListType(click.ParamType):
    """A comma-separated list of bench variant labels (``spsa,de(cr=0.1),spsa-no-escape``),
    parsed into :class:`uavplan.bench.Variant` values; each label's parameters go through the
    one configuration validator."""

    name = "algorithms"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, list):
            return value
        from uavplan import bench

        try:
            variants = [bench.Variant.parse(label) for label in bench.split_labels(str(value))]
        except ValueError as err:
            self.fail(str(err), param, ctx)
        if not variants:
            self.fail("no algorithms given", param, ctx)
        return variants

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "LABEL[,LABEL...]"


#: ``--algorithm`` of ``plan`` and ``render`` (the lead wires it in)
ALGORITHM = AlgorithmType()
#: ``--algorithms`` of ``bench``
ALGORITHMS = AlgorithmListType()


class WindType(click.ParamType):
    """``E,N``: wind blowing toward east and north, m/s (``--wind 3,-1.5``)."""

    name = "wind"

    def convert(
        self, value: Any, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[float, float]:
        if isinstance(value, tuple):
            return value
        import math

        try:
            east, north = (float(v) for v in str(value).split(","))
        except ValueError:
            self.fail(f"expected E,N in m/s, got {value!r}", param, ctx)
        if not (math.isfinite(east) and math.isfinite(north)):
            self.fail(f"the wind must be finite, got {value!r}", param, ctx)
        return (east, north)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "E,N"


class ParamAssignmentType(click.ParamType):
    """``NAME=VALUE``: an autopilot parameter and its value (``--param WPNAV_SPEED=500``);
    the name and the range are checked against the flavour's table by the use case."""

    name = "param"

    def convert(
        self, value: Any, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[str, float]:
        if isinstance(value, tuple):
            return value
        name, sep, text = str(value).partition("=")
        try:
            if not sep or not name.strip():
                raise ValueError
            return (name.strip(), float(text))
        except ValueError:
            self.fail(f"expected NAME=VALUE, got {value!r}", param, ctx)

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "NAME=VALUE"


class ItemLimitsType(click.ParamType):
    """``M`` or ``M,F,R``: the most mission items, fence items and rally points a vehicle
    stores (``--max-items 2000`` or ``--max-items 2000,64,32``)."""

    name = "items"

    def convert(
        self, value: Any, param: click.Parameter | None, ctx: click.Context | None
    ) -> tuple[int, ...]:
        if isinstance(value, tuple):
            return value
        try:
            numbers = tuple(int(v) for v in str(value).split(","))
        except ValueError:
            self.fail(f"expected M or M,F,R (whole numbers), got {value!r}", param, ctx)
        if len(numbers) not in (1, 3) or not all(0 <= n <= 65534 for n in numbers):
            self.fail(f"expected M or M,F,R, each 0..65534, got {value!r}", param, ctx)
        if numbers[0] < 1:
            self.fail("a vehicle stores at least one mission item", param, ctx)
        return numbers

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "M[,F,R]"


#: ``--wind`` of ``simulate``
WIND = WindType()
#: ``--param`` of ``simulate`` and ``mock-vehicle``
PARAM = ParamAssignmentType()
#: ``--max-items`` of ``upload``
ITEM_LIMITS = ItemLimitsType()
