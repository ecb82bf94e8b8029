"""Typed accessors that turn a problem in a file into one :class:`ScenarioError` naming the
file, the key path (``obstacles[2].radius``) and the reason."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from uavplan.config import ConfigError, key_text, short_repr, type_name
from uavplan.errors import ScenarioError
from uavplan.scenario.limits import MAX_ALTITUDE_M, MAX_HORIZONTAL_M


def join(key: str, sub: str) -> str:
    """``key.sub`` (or ``sub`` at the top level)."""
    return f"{key}.{sub}" if key else sub


class Checker:
    """Small typed accessors that raise ScenarioError with file and key path."""

    def __init__(self, file: str) -> None:
        self.file = file

    def fail(self, key: str, reason: str) -> ScenarioError:
        return ScenarioError(reason, file=self.file, key=key or "(top level)")

    def config(self, err: ConfigError) -> ScenarioError:
        return self.fail(err.key or "", err.reason)

    def mapping(
        self, value: Any, key: str, allowed: set[str], required: Sequence[str] = ()
    ) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.fail(key, f"must be a mapping, got {type_name(value)}")
        for k in value:
            if not isinstance(k, str):
                raise self.fail(key, f"keys must be strings, got {short_repr(k)}")
            if k not in allowed:
                hint = f" (allowed: {', '.join(sorted(allowed))})"
                raise self.fail(join(key, key_text(k)), f"unknown key{hint}")
        for k in sorted(required):
            if k not in value:
                raise self.fail(join(key, k), "missing required key")
        return value

    def number(
        self,
        value: Any,
        key: str,
        *,
        minimum: float | None = None,
        strict: bool = False,
        maximum: float | None = None,
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"must be a number, got {type_name(value)}")
        if isinstance(value, int) and abs(value) > 1e300:
            raise self.fail(key, f"is out of range, got {short_repr(value)}")
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(key, "must be a finite number")
        if minimum is not None:
            if strict and value <= minimum:
                raise self.fail(key, f"must be > {minimum:g}, got {value:g}")
            if not strict and value < minimum:
                raise self.fail(key, f"must be >= {minimum:g}, got {value:g}")
        if maximum is not None and value > maximum:
            raise self.fail(key, f"must be <= {maximum:g}, got {value:g}")
        return value

    def coordinate(self, value: Any, key: str) -> float:
        v = self.number(value, key)
        if abs(v) > MAX_HORIZONTAL_M:
            raise self.fail(key, f"must be within ±{MAX_HORIZONTAL_M:g} m, got {v:g}")
        return v

    def string(self, value: Any, key: str, choices: Sequence[str] | None = None) -> str:
        if not isinstance(value, str):
            raise self.fail(key, f"must be a string, got {type_name(value)}")
        if choices is not None and value not in choices:
            raise self.fail(key, f"must be one of {', '.join(choices)}, got {short_repr(value)}")
        return value

    def vector(self, value: Any, key: str, n: int) -> tuple[float, ...]:
        if not isinstance(value, list | tuple) or len(value) != n:
            raise self.fail(key, f"must be a list of {n} numbers, got {short_repr(value)}")
        return tuple(self.number(v, f"{key}[{i}]") for i, v in enumerate(value))

    def point(self, value: Any, key: str, n: int) -> tuple[float, ...]:
        """A vector of ``n`` coordinates: x, y within ±MAX_HORIZONTAL_M, z within
        [-MAX_ALTITUDE_M, MAX_ALTITUDE_M]."""
        vec = self.vector(value, key, n)
        for i, v in enumerate(vec):
            limit = MAX_HORIZONTAL_M if i < 2 else MAX_ALTITUDE_M
            if abs(v) > limit:
                raise self.fail(f"{key}[{i}]", f"must be within ±{limit:g} m, got {v:g}")
        return vec
