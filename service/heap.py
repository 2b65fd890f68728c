"""The C heap of the serving process: keep some free memory at its top instead of handing it back
to the kernel after every large request.

Large request bodies arrive in 256 kB reads, each copied once more by the HTTP parser. With
glibc's default settings, freeing those buffers trims the heap and the next ones grow it again,
so every page of every body is faulted in afresh: receiving a 9.2 MB body took 11.6 ms in
uvicorn against 2 ms for a bare asyncio protocol. Padding the top of the heap (glibc's
`M_TOP_PAD`) by 16 MB brings it to 2.7 ms (measured with a trivial ASGI app; README
"Performance"), for at most that much more resident memory per process.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

_M_TOP_PAD = -2  # glibc <malloc.h>
log = logging.getLogger(__name__)


def pad_heap_top(megabytes: int) -> bool:
    """Ask glibc to keep `megabytes` MB free at the top of the heap (mallopt M_TOP_PAD);
    0 keeps the C library's default. False where the C library has no `mallopt` (musl, macOS)
    or refuses the value; the service works the same, only large bodies arrive more slowly."""
    if megabytes <= 0:
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c"))
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        log.info("no mallopt in this C library: the heap keeps its default settings")
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(_M_TOP_PAD, megabytes * 1024 * 1024))
