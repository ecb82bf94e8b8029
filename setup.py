"""Build of the compiled kernels (uavplan._ckernels, plain C99); everything else is in
pyproject.toml. Strict IEEE double arithmetic: no fused multiply-add contraction and no
fast-math, so results do not depend on the compiler's or the CPU's choices. POSIX threads
for the SPSA step's helper threads (-pthread: glibc before 2.34 keeps them in libpthread)."""

import os
from glob import glob

from setuptools import Extension, setup

THREADS = [] if os.name == "nt" else ["-pthread"]

setup(
    ext_modules=[
        Extension(
            "uavplan._ckernels",
            sources=sorted(glob("uavplan/_csrc/*.c")),
            depends=["uavplan/_csrc/kernels.h"],
            extra_compile_args=["-std=c99", "-O2", "-ffp-contract=off", "-fno-fast-math", *THREADS],
            extra_link_args=THREADS,
        )
    ]
)
