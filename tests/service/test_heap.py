"""The C heap padding of the serving process (service/heap.py): after large buffers are freed,
glibc keeps the padded amount at the top of the heap instead of trimming it (so the next large
body does not fault its pages in afresh)."""

from __future__ import annotations

import ctypes
import ctypes.util
import subprocess
import sys
import textwrap

import pytest

from service import heap
from service.settings import Settings

GLIBC_MALLINFO2 = hasattr(ctypes.CDLL(ctypes.util.find_library("c")), "mallinfo2")

# In a fresh process (mallopt is process-wide): grow the heap by ~12 MB of 96 kB blocks (below
# the mmap threshold, so they come from the heap), free them, and print the releasable space
# left at the top of the heap (mallinfo2().keepcost).
PROBE = textwrap.dedent("""
    import ctypes, ctypes.util, sys
    from service import heap
    class MallInfo2(ctypes.Structure):
        _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks",
                    "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]
    libc = ctypes.CDLL(ctypes.util.find_library("c"))
    libc.mallinfo2.restype = MallInfo2
    padded = heap.pad_heap_top(int(sys.argv[1]))
    blocks = [bytes(96 * 1024) for _ in range(128)]
    del blocks
    print(padded, libc.mallinfo2().keepcost)
""")


def _keepcost(megabytes: int) -> tuple[bool, int]:
    out = subprocess.run([sys.executable, "-c", PROBE, str(megabytes)], capture_output=True,
                         text=True, check=True).stdout.split()
    return out[0] == "True", int(out[1])


@pytest.mark.skipif(not GLIBC_MALLINFO2, reason="needs glibc ≥ 2.33 (mallopt, mallinfo2)")
def test_padding_keeps_freed_memory_at_the_top_of_the_heap() -> None:
    padded, kept = _keepcost(16)
    assert padded
    assert kept >= 4 * 1024 * 1024  # megabytes of the freed blocks stay (6 MB seen)
    default, kept_by_default = _keepcost(0)
    assert not default  # 0 leaves the C library alone
    assert kept_by_default < 1024 * 1024  # glibc trims the heap back down (129 kB seen)


def test_zero_leaves_the_c_library_alone() -> None:
    assert heap.pad_heap_top(0) is False


def test_setting_is_bounded() -> None:
    assert Settings().heap_top_pad_mb == 16
    with pytest.raises(ValueError):
        Settings(heap_top_pad_mb=-1)
