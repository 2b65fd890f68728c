"""The C heap settings of the serving process (service/heap.py): a large block comes from the
heap, not a fresh mmap, and freed memory stays for the next large request instead of being
trimmed (so its pages are not faulted in afresh)."""

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
MB = 1024 * 1024

# In a fresh process (mallopt is process-wide): allocate a 9 MB block and note the bytes held
# in mmap'd blocks (hblkhd); then grow the heap by ~12 MB of 96 kB blocks, free everything,
# and note the releasable space left at the top of the heap (keepcost).
PROBE = textwrap.dedent("""
    import ctypes, ctypes.util, sys
    from service import heap
    class MallInfo2(ctypes.Structure):
        _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks",
                    "hblkhd", "usmblks", "fsmblks", "uordblks", "fordblks", "keepcost")]
    libc = ctypes.CDLL(ctypes.util.find_library("c"))
    libc.mallinfo2.restype = MallInfo2
    tuned = heap.retain_freed_memory(int(sys.argv[1]))
    body = bytes(9 * 1024 * 1024)
    mapped = libc.mallinfo2().hblkhd
    del body
    blocks = [bytes(96 * 1024) for _ in range(128)]
    del blocks
    print(tuned, mapped, libc.mallinfo2().keepcost)
""")


def _probe(retain_mb: int) -> tuple[bool, int, int]:
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(retain_mb)], capture_output=True, text=True, check=True
    ).stdout.split()
    return out[0] == "True", int(out[1]), int(out[2])


@pytest.mark.skipif(not GLIBC_MALLINFO2, reason="needs glibc ≥ 2.33 (mallopt, mallinfo2)")
def test_large_blocks_come_from_the_heap_and_freed_memory_stays() -> None:
    tuned, mapped, kept = _probe(64)
    assert tuned
    assert mapped < MB  # the 9 MB block is not an mmap of its own
    assert kept >= 12 * MB  # the freed blocks stay at the top of the heap

    default, mapped_by_default, _ = _probe(0)
    assert not default  # 0 leaves the C library alone:
    assert mapped_by_default >= 9 * MB  # glibc maps a 9 MB block afresh


def test_zero_leaves_the_c_library_alone() -> None:
    assert heap.retain_freed_memory(0) is False


def test_setting_is_bounded() -> None:
    assert Settings().heap_retain_mb == 64
    with pytest.raises(ValueError):
        Settings(heap_retain_mb=-1)
