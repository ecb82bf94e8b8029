"""The compiled kernels' build flags, chosen per compiler (setup.py's ``compiler_flags``):
each compiler gets its own spelling of the floating-point contract (no contraction into
fused multiply-adds, no fast-math), and a build without the SPSA step's helper threads says
so. No compiler runs here: the selection is a plain function of the compiler type."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _setup_module():  # type: ignore[no-untyped-def]
    """setup.py as a module (its ``setup()`` runs only as the build script)."""
    spec = importlib.util.spec_from_file_location("uavplan_build_script", ROOT / "setup.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


build = _setup_module()


@pytest.mark.parametrize("compiler", ["unix", "mingw32", "cygwin"])
@pytest.mark.parametrize("platform", ["linux", "darwin", "win32", "cygwin"])
def test_gcc_and_clang_keep_ieee_arithmetic(compiler: str, platform: str) -> None:
    flags = build.compiler_flags(compiler, platform)
    assert {"-ffp-contract=off", "-fno-fast-math", "-std=c99"} <= set(flags.compile)
    assert not any(f.startswith("/") for f in flags.compile + flags.link)
    assert not any("fast-math" in f and f != "-fno-fast-math" for f in flags.compile)
    # POSIX threads everywhere but a Windows build (MinGW: kernels.h sees _WIN32)
    assert flags.threads == (platform != "win32")
    assert ("-pthread" in flags.compile) == flags.threads == ("-pthread" in flags.link)


@pytest.mark.parametrize("platform", ["win32", "linux"])
def test_msvc_gets_its_own_flags_for_the_same_contract(platform: str) -> None:
    flags = build.compiler_flags("msvc", platform)
    assert "/fp:precise" in flags.compile
    # the options that allow contraction or unsafe algebra are never given
    assert not {"/fp:fast", "/fp:contract"} & set(flags.compile)
    assert not any(f.startswith("-") for f in flags.compile + flags.link)  # no GCC flags
    assert flags.threads is False  # and the build says so (HAVE_THREADS = 0, a warning)


def test_an_unknown_compiler_is_refused_not_built_without_the_contract() -> None:
    with pytest.raises(ValueError, match="bcpp"):
        build.compiler_flags("bcpp", "win32")


def test_msvc_before_2022_is_told_not_to_contract_in_the_source() -> None:
    """MSVC contracted under /fp:precise before Visual Studio 2022 17.0: the header turns
    contraction off for MSVC itself (not for clang-cl, which takes the flags)."""
    header = (ROOT / "uavplan" / "_csrc" / "kernels.h").read_text()
    guarded = header.split("#if defined(_MSC_VER) && !defined(__clang__)", 1)[1]
    assert guarded.split("#endif", 1)[0].strip() == "#pragma fp_contract(off)"


def test_the_build_uses_every_kernel_file() -> None:
    text = (ROOT / "setup.py").read_text()
    assert 'glob("uavplan/_csrc/*.c")' in text and '"uavplan/_csrc/kernels.h"' in text
    sources = sorted((ROOT / "uavplan" / "_csrc").glob("*.c"))
    assert len(sources) >= 8
    for path in [*sources, ROOT / "uavplan" / "_csrc" / "kernels.h"]:
        assert len(path.read_text().splitlines()) <= 1200, path.name  # a file per layer
