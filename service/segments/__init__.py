"""Shared-memory segments of co-located clients (docs/deployment.md, "Co-located clients").

Over the Unix socket, a large binary request travels as a file of the private segment
directory beside the socket (`<socket>.segments`, mode 0700, files 0600: readable only by the
service's user): the client writes the safetensors body into `r-<32 hex>` and names it in the
request; the service maps it, computes, and writes a binary answer into `r-<32 hex>.answer`:
a file of the client's own (its answer room) when the client linked one there, else an answer
file of the service's. `directory.py` is the directory (its checks and the sweeper),
`segment.py` one request's segments and who removes them when, `answer_pool.py` the answer
files a process reuses, `client_mappings.py` the clients' files it keeps mapped. No HTTP in
here.
"""

from service.segments.directory import SegmentDirectory, segment_directory_of
from service.segments.segment import RequestSegment, SegmentError

__all__ = ["RequestSegment", "SegmentDirectory", "SegmentError", "segment_directory_of"]
