"""Packages whose public names load their module on first use (PEP 562), so that importing
the package costs nothing: ``__getattr__, __dir__ = lazy_exports(__name__, EXPORTS,
globals())``, ``EXPORTS`` mapping each public name to the submodule that defines it."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, str], namespace: Mapping[str, Any]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module-level ``__getattr__`` and ``__dir__`` of ``package``: a name of
    ``exports`` imports ``package.<its module>`` and returns the name from it; any other
    name is an AttributeError, as for a module without them."""

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(f"{package}.{module}"), name)

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
