"""Kernel readiness. The kernels are C (:mod:`uavplan._ckernels`), compiled by pip when the
package is installed, so there is nothing to compile or load at run time: the first plan
after installing is as fast as any later one. ``warm_up`` keeps the extension's import out
of timed sections (benchmarks); ``kernels_cached`` tells whether the extension is built."""

from __future__ import annotations

import functools


def kernels_cached() -> bool:
    """True when the compiled kernels are ready to use (always, once the package imports:
    the extension is built at install time)."""
    import importlib.util

    return importlib.util.find_spec("uavplan._ckernels") is not None


@functools.cache
def warm_up() -> None:
    """Load the compiled kernels once per process, so that no timed section pays for the
    extension's import (about a millisecond)."""
    import uavplan._ckernels  # noqa: F401
