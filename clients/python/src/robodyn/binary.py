"""The server's binary encoding of dynamics requests and answers: a safetensors file
(docs/binary-format.md).

    N (uint64, little-endian) | header (UTF-8 JSON, N bytes, space-padded to a multiple of 8)
    | data: the tensors' float64 values, little-endian, row-major, back to back

The header is `{"__metadata__": {field: JSON text}, name: {"dtype": "F64", "shape": [...],
"data_offsets": [begin, end]}}`, offsets relative to the start of the data. Large batches
travel this way: no text formatting or parsing of numbers on either side, float64 values
arrive bit for bit, and `safetensors.numpy.load` / `safetensors.torch.load` read the bodies.
The client reads and writes the format itself: the `safetensors` package is not needed.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np

MEDIA_TYPE = "application/vnd.robodyn.safetensors"
METADATA = "__metadata__"
_LENGTH = struct.Struct("<Q")

CHUNK_BYTES = 256 * 1024  # the data section is sent in views of at most this size


def _json(value: Any) -> str:
    return json.dumps(value, separators=(",", ":"), allow_nan=False)


def encode_parts(
    arrays: Mapping[str, np.ndarray], fields: Mapping[str, Any] | None = None
) -> list[bytes | memoryview]:
    """A request body as a list of parts: the length and header, then views of the arrays' own
    memory (no copy), at most `CHUNK_BYTES` each. Sent part by part, a 9.2 MB body is not
    first joined into one new buffer (about 6 ms)."""
    header: dict[str, Any] = {}
    if fields:
        header[METADATA] = {name: _json(value) for name, value in fields.items()}
    views: list[memoryview] = []
    offset = 0
    for name, value in arrays.items():
        array = np.asarray(value, dtype="<f8")
        if not array.flags.c_contiguous:  # (not np.ascontiguousarray: it makes 0-d 1-d)
            array = array.copy(order="C")
        header[name] = {
            "dtype": "F64",
            "shape": list(array.shape),
            "data_offsets": [offset, offset + array.nbytes],
        }
        view = array.data.cast("B")
        views += [view[i : i + CHUNK_BYTES] for i in range(0, len(view), CHUNK_BYTES)]
        offset += array.nbytes
    text = _json(header).encode()
    text += b" " * (-len(text) % 8)
    return [_LENGTH.pack(len(text)) + text, *views]


def encode(arrays: Mapping[str, np.ndarray], fields: Mapping[str, Any] | None = None) -> bytes:
    """A request body in one piece: `arrays` (float64, any shape) as tensors, `fields` as JSON
    texts in the metadata."""
    return b"".join(encode_parts(arrays, fields))


def decode(content: bytes | bytearray | memoryview) -> dict[str, Any]:
    """An answer as one mapping: its fields (from the metadata), and its tensors as writable
    float64 arrays (views of `content` when it is a bytearray or a writable memoryview, else
    of one copy). Raises ValueError when the content is not a safetensors file of F64
    tensors."""
    if len(content) < _LENGTH.size:
        raise ValueError("binary answer shorter than its 8-byte header length")
    (size,) = _LENGTH.unpack_from(content)
    if _LENGTH.size + size > len(content):
        raise ValueError("not a safetensors answer: the header runs past the body")
    header = json.loads(bytes(content[_LENGTH.size : _LENGTH.size + size]))
    if not isinstance(header, dict):
        raise ValueError("not a safetensors answer: the header is not an object")
    start = _LENGTH.size + size
    data: Any = memoryview(content)[start:]
    owned = isinstance(content, bytearray) or (
        isinstance(content, memoryview) and not content.readonly
    )
    if not owned or start % 8:
        data = bytearray(data)  # one copy: the answer's arrays are writable (and aligned)
    out: dict[str, Any] = {
        name: json.loads(text) for name, text in dict(header.pop(METADATA, None) or {}).items()
    }
    for name, d in header.items():
        if d["dtype"] != "F64":
            raise ValueError(f"tensor {name} is {d['dtype']}, not F64")
        shape = [int(n) for n in d["shape"]]
        count = math.prod(shape)
        begin, end = (int(n) for n in d["data_offsets"])
        if (
            min(shape, default=0) < 0
            or end - begin != 8 * count
            or not 0 <= begin <= end <= len(data)
        ):
            raise ValueError(f"tensor {name} does not fit the answer")
        out[name] = np.frombuffer(data, dtype="<f8", count=count, offset=begin).reshape(shape)
    return out
