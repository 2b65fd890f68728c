"""Mappings of the clients' files, kept by a server process from request to request: their
body files (read-only) and their answer rooms (read and write: the answers are written there).

A client reuses its body file (`c-<32 hex>`) for its next requests, each time linked under a
new request name. Mapping its 9.2 MB anew for each request (10,000 Talos states) costs about
0.9 ms with the pages populated, and unmapping it 0.4 ms (measured on the 2-core machine);
kept, a request whose file is already mapped pays neither. A mapping is found by the file's
identity (device and inode): the kept mapping holds the file open, so its inode number is not
given to another file while it is kept.

An answer room (`c-<32 hex>` too) is reused alike, and its answers would be written into new
pages each time (a page fault per 4 kB page) without a kept mapping. The mappings hold the
file's memory while the client's names are gone: at most `MAX_KEPT` are kept and `MAX_BYTES`
bytes mapped, and one whose file has no name left (the client closed it, or the sweeper removed
it) is let go at the next lookup or sweep. A request still reading a mapping that is let go
keeps it until its arrays are collected (mmap's `close` refuses while buffers are exported; the
mapping then ends with its last reference).
"""

from __future__ import annotations

import contextlib
import mmap
import os
import threading
from collections import OrderedDict

MAX_KEPT = 8
MAX_BYTES = 1 << 30
_POPULATE = getattr(mmap, "MAP_POPULATE", 0)  # pages mapped at once, not one fault each


class ClientMappings:
    """Mappings of clients' files by (device, inode), most recently used last: read-only, or
    `writable`."""

    def __init__(self, writable: bool = False) -> None:
        self._prot = mmap.PROT_READ | (mmap.PROT_WRITE if writable else 0)
        self._kept: OrderedDict[tuple[int, int], tuple[int, mmap.mmap]] = OrderedDict()
        self._lock = threading.Lock()

    def map(self, fd: int, info: os.stat_result, length: int) -> mmap.mmap:
        """A mapping of at least the first `length` bytes (> 0) of the file open as `fd`
        (described by `info`, checked by the caller to hold them; open for writing when the
        mappings are `writable`): a kept one, or a new
        one that is then kept. The caller keeps `fd` and closes it itself."""
        key = (info.st_dev, info.st_ino)
        with self._lock:
            kept = self._kept.pop(key, None)
            if kept is not None:
                if len(kept[1]) >= length:
                    self._kept[key] = kept
                    return kept[1]
                _let_go(*kept)
        own = os.dup(fd)
        try:
            mapping = mmap.mmap(own, length, flags=mmap.MAP_SHARED | _POPULATE, prot=self._prot)
        except BaseException:
            os.close(own)
            raise
        with self._lock:
            replaced = self._kept.pop(key, None)  # (another request mapped it meanwhile)
            self._kept[key] = (own, mapping)
            dropped = [replaced] if replaced is not None else []
            while len(self._kept) > MAX_KEPT or self._bytes() > MAX_BYTES:
                dropped.append(self._kept.popitem(last=False)[1])
            dropped += self._unnamed()
        for each in dropped:
            _let_go(*each)
        return mapping

    def sweep(self) -> int:
        """Let go of the mappings whose file has no name left; how many."""
        with self._lock:
            dropped = self._unnamed()
        for each in dropped:
            _let_go(*each)
        return len(dropped)

    def close(self) -> None:
        with self._lock:
            kept, self._kept = list(self._kept.values()), OrderedDict()
        for each in kept:
            _let_go(*each)

    def __len__(self) -> int:
        return len(self._kept)

    def _bytes(self) -> int:
        return sum(len(mapping) for _, mapping in self._kept.values())

    def _unnamed(self) -> list[tuple[int, mmap.mmap]]:
        """Remove (and return) the kept mappings whose file has no name left."""
        gone = [key for key, (fd, _) in self._kept.items() if _links(fd) == 0]
        return [self._kept.pop(key) for key in gone]


def _links(fd: int) -> int:
    try:
        return os.fstat(fd).st_nlink
    except OSError:
        return 0


def _let_go(fd: int, mapping: mmap.mmap) -> None:
    with contextlib.suppress(BufferError):  # (still read by a request: unmapped when collected)
        mapping.close()
    os.close(fd)
