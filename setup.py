"""Build of the compiled kernels (uavplan._ckernels: one module from the C99 files of
uavplan/_csrc/); everything else is in pyproject.toml.

The kernels need strict IEEE double arithmetic, the same on every compiler: no contraction of
a multiply and an add into a fused multiply-add, no fast-math, so results do not depend on
the compiler's or the CPU's choices. Each compiler gets its own flags for that
(:func:`compiler_flags`):

- GCC and Clang (``unix``, ``mingw32``, ``cygwin``): ``-ffp-contract=off -fno-fast-math``, and
  POSIX threads for the SPSA step's helper threads (``-pthread``: glibc before 2.34 keeps them
  in libpthread).
- MSVC (``msvc``): ``/fp:precise`` (value-safe: no reassociation, no algebra invalid for
  NaN, infinities or signed zeros) and never ``/fp:fast`` or ``/fp:contract``, the options
  that allow contractions (https://learn.microsoft.com/cpp/build/reference/fp-specify-floating-point-behavior).
  Contraction is off by default under ``/fp:precise`` from Visual Studio 2022 17.0 on; before
  it, it was on (https://learn.microsoft.com/cpp/preprocessor/fp-contract), so kernels.h also
  says ``#pragma fp_contract(off)`` to MSVC.

The helper threads use POSIX threads and GCC's / Clang's atomics; a Windows build (MSVC or
MinGW) runs the step on one thread. It says so when it is built (a warning here and a
``#pragma message`` of kernels.h) and when it runs (``uavplan._ckernels.HAVE_THREADS`` is 0,
reported by the planner's notes, ``uavplan bench`` and tools/bench_core.py).

The flag selection is a plain function, tested without a compiler
(tests/architecture/test_build_flags.py); ``setup()`` runs only when this file is run as the
build script.
"""

from __future__ import annotations

import sys
from glob import glob
from typing import NamedTuple


class Flags(NamedTuple):
    """What one compiler type gets: compile and link arguments, and whether the build has the
    SPSA step's helper threads."""

    compile: list[str]
    link: list[str]
    threads: bool


#: compiler types (setuptools' ``compiler.compiler_type``) that take GCC's options
GCC_LIKE = ("unix", "mingw32", "cygwin")


def compiler_flags(compiler_type: str, platform: str = sys.platform) -> Flags:
    """The kernels' flags for a setuptools compiler type on ``platform`` (``sys.platform``).
    ValueError for a compiler type whose floating-point options are not known here: building
    without them would silently lose the arithmetic guarantees."""
    if compiler_type == "msvc":
        return Flags(["/O2", "/fp:precise"], [], threads=False)
    if compiler_type in GCC_LIKE:
        # as kernels.h decides: threads unless _WIN32 (MinGW), i.e. on every POSIX system
        threads = platform != "win32"
        pthread = ["-pthread"] if threads else []
        flags = ["-std=c99", "-O2", "-ffp-contract=off", "-fno-fast-math", *pthread]
        return Flags(flags, pthread, threads)
    raise ValueError(
        f"uavplan: no floating-point flags known for the compiler type {compiler_type!r} "
        f"(known: msvc, {', '.join(GCC_LIKE)})"
    )


def main() -> None:
    from setuptools import Extension, setup
    from setuptools.command.build_ext import build_ext

    class BuildExt(build_ext):
        """build_ext that gives the kernels the flags of the compiler actually used."""

        def build_extensions(self) -> None:
            flags = compiler_flags(self.compiler.compiler_type)
            if not flags.threads:
                self.warn(
                    "uavplan: this build of the kernels has no helper threads "
                    f"({self.compiler.compiler_type} on {sys.platform}): the SPSA step runs "
                    "on one thread (uavplan._ckernels.HAVE_THREADS = 0)"
                )
            for ext in self.extensions:
                ext.extra_compile_args = list(flags.compile)
                ext.extra_link_args = list(flags.link)
            super().build_extensions()

    setup(
        ext_modules=[
            Extension(
                "uavplan._ckernels",
                sources=sorted(glob("uavplan/_csrc/*.c")),
                depends=["uavplan/_csrc/kernels.h"],
            )
        ],
        cmdclass={"build_ext": BuildExt},
    )


if __name__ == "__main__":
    main()
