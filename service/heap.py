"""The C heap of the serving process: keep freed memory for the next large request instead of
handing it back to the kernel and faulting it in again.

Large requests allocate megabytes several times over: the body arrives in 256 kB reads that the
HTTP parser copies, is joined, and the answer is computed into and encoded from new arrays.
With glibc's defaults each allocation over 128 kB is a fresh `mmap` and the heap is trimmed
after each request, so every page of every buffer is faulted in (and zeroed) anew. Measured:
receiving a 9.2 MB body took 11.6 ms in uvicorn against 2 ms for a bare asyncio protocol;
10,000 Talos states end to end 65 → 58 ms, 2,000 Talos mass matrices 82 → 65 ms (README
"Performance"). The cost is resident memory: each process keeps up to `retain_mb` MB of freed
heap (plus what fragmentation holds), which the next large request reuses.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

# glibc <malloc.h>
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3
MMAP_THRESHOLD_MAX_MB = 32  # glibc refuses more on 64-bit (DEFAULT_MMAP_THRESHOLD_MAX)
TOP_PAD_MB = 16

log = logging.getLogger(__name__)


def retain_freed_memory(retain_mb: int) -> bool:
    """Let this process keep up to `retain_mb` MB of freed C heap for reuse (glibc `mallopt`):
    blocks up to min(retain_mb, 32) MB come from the heap rather than `mmap`, the heap is
    trimmed only past `retain_mb` MB free at its top, and grows 16 MB at a time.
    0 keeps the C library's defaults. False where there is no `mallopt` (musl, macOS) or it
    refuses a value; the service works the same there, large requests only take longer."""
    if retain_mb <= 0:
        return False
    try:
        mallopt = ctypes.CDLL(ctypes.util.find_library("c")).mallopt
    except (OSError, AttributeError, TypeError):
        log.info("no mallopt in this C library: the heap keeps its default settings")
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    mb = 1024 * 1024
    return all(
        [
            mallopt(_M_MMAP_THRESHOLD, min(retain_mb, MMAP_THRESHOLD_MAX_MB) * mb),
            mallopt(_M_TRIM_THRESHOLD, retain_mb * mb),
            mallopt(_M_TOP_PAD, min(retain_mb, TOP_PAD_MB) * mb),
        ]
    )
