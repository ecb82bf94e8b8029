"""The command line holds glibc's mmap threshold fixed (uavplan/__main__.py, issue 26): large
arrays freed after a larger one go back to the system even where smaller blocks outlive
them, instead of staying resident in the heap."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

CHILD = r"""
import sys
import numpy as np
import uavplan.__main__ as entry

if sys.argv[1] == "fixed":
    assert entry.fix_mmap_threshold()

import ctypes

class MallInfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks",
                "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]

libc = ctypes.CDLL(None)
libc.mallinfo2.restype = MallInfo2

def rss_kb():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS"):
            return int(line.split()[1])

def held_kb():
    # free bytes the allocator keeps in its heap: not handed back to the system, whatever
    # the kernel later does with the pages (RSS alone once read 4 KiB under memory reclaim)
    return libc.mallinfo2().fordblks // 1024

gone = np.ones(1 << 20)  # 8 MB, mapped and unmapped: glibc would raise its threshold to it
del gone
rss, held = rss_kb(), held_kb()
big, small = [], []
for _ in range(64):
    big.append(np.ones(1 << 16))  # 512 KB each, 32 MB in all
    small.append(np.ones(1 << 12))  # 32 KB each, outliving the big ones
del big
print(max(rss_kb() - rss, held_kb() - held))
"""


def _glibc() -> bool:
    try:
        return bool(os.confstr("CS_GNU_LIBC_VERSION"))
    except (ValueError, OSError, AttributeError):
        return False


def _kept_kib(mode: str) -> int:
    out = subprocess.run([sys.executable, "-c", CHILD, mode], capture_output=True, text=True,
                         check=True, timeout=60)  # fmt: skip
    return int(out.stdout.strip())


@pytest.mark.skipif(not sys.platform.startswith("linux") or not _glibc(), reason="glibc only")
def test_freed_large_arrays_go_back_to_the_system() -> None:
    kept = _kept_kib("fixed")
    assert kept < 8 * 1024, f"{kept} KiB of 32 MiB freed still resident"


@pytest.mark.skipif(not sys.platform.startswith("linux") or not _glibc(), reason="glibc only")
@pytest.mark.slow
def test_without_it_they_stay() -> None:
    """The measure can fail: glibc's own dynamic threshold keeps them resident, more than the
    bound above allows (how much more depends on numpy's allocations: 14 MiB of the 32 with
    numpy 1.26, over 16 with numpy 2). Kept is the larger of the RSS growth and the free
    bytes glibc's heap holds (mallinfo2); the most of three runs.

    Where the child's allocator keeps nothing even without the fix, the measure cannot be
    shown to fail there, and the test says so instead of failing: with numpy 1.26 (CI's
    lowest-versions pass), three runs in a row once kept nothing under the suite's load,
    where the same child run alone keeps 14 MiB, and a child of plain mallocs with the
    threshold set above the blocks keeps nothing there either. With today's numpy it keeps
    34 MiB."""
    kept = max(_kept_kib("dynamic") for _ in range(3))
    if kept <= 0:
        pytest.skip(
            f"this process's allocator returned the blocks even without the fix ({kept} KiB "
            "kept): the measure cannot be shown to fail here"
        )
    assert kept > 8 * 1024
