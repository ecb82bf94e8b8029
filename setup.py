"""Build of the compiled kernels (uavplan._ckernels, plain C99); everything else is in
pyproject.toml. Strict IEEE double arithmetic: no fused multiply-add contraction and no
fast-math, so results do not depend on the compiler's or the CPU's choices."""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "uavplan._ckernels",
            sources=["uavplan/_ckernels.c"],
            extra_compile_args=["-std=c99", "-O2", "-ffp-contract=off", "-fno-fast-math"],
        )
    ]
)
