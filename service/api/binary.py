"""The binary encoding of dynamics requests and answers (media type `BINARY_MEDIA_TYPE`).

Large batches as JSON text cost more to format and parse than to compute. The binary form has
the same field names and shapes as the JSON form, with arrays as raw little-endian float64, and
is readable from any language with a standard library (a JSON parser and byte access):

    bytes 0–3    b"RDY1"                     magic and format version
    bytes 4–7    H, uint32 little-endian     length of the header
    bytes 8…8+H  header, UTF-8 JSON          {"fields": {...}, "arrays": {name: {"shape": [...],
                                              "offset": o}}}
    padding      0–7 zero bytes, so that the data section starts at a multiple of 8
    data         each array's float64 values, row-major, at data start + its offset (a
                 multiple of 8)

`fields` holds every non-array member (e.g. `"frame": "tool0"`) exactly as in JSON. The full
description with examples is docs/binary-format.md.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np
import orjson

from service.errors import InvalidInput

BINARY_MEDIA_TYPE = "application/vnd.robodyn.binary"
MAGIC = b"RDY1"
MAX_HEADER_BYTES = 1 << 20
MAX_ARRAY_ELEMENTS = 1 << 24
"""The most numbers an array of a body may declare: the product of its dimensions, zeros
counted as ones (so `[0, 2**63]` is refused too), and so also each single dimension. 2**24
float64 are 128 MiB, more than any request body the server accepts."""
_PREFIX = struct.Struct("<4sI")


def _bad(detail: str) -> InvalidInput:
    return InvalidInput(f"binary body: {detail} (format: docs/binary-format.md)")


def decode(body: bytes | bytearray) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Split a binary body into its JSON `fields` and its arrays (views of the body, no copy)."""
    if len(body) < _PREFIX.size:
        raise _bad("shorter than its 8-byte prefix")
    magic, header_size = _PREFIX.unpack_from(body)
    if magic != MAGIC:
        raise _bad("it does not start with b'RDY1'")
    if header_size > min(MAX_HEADER_BYTES, len(body) - _PREFIX.size):
        raise _bad(f"the header length {header_size} runs past the body")
    try:
        header = orjson.loads(body[_PREFIX.size:_PREFIX.size + header_size])
    except orjson.JSONDecodeError:
        raise _bad("the header is not valid JSON") from None
    if not isinstance(header, dict) or set(header) - {"fields", "arrays"}:
        raise _bad('the header must be an object with "fields" and "arrays"')
    fields, descriptors = header.get("fields", {}), header.get("arrays", {})
    if not isinstance(fields, dict) or not isinstance(descriptors, dict):
        raise _bad('"fields" and "arrays" must be objects')
    start = _aligned(_PREFIX.size + header_size)
    data = memoryview(body)[start:] if start <= len(body) else memoryview(b"")
    arrays = {name: _array(name, d, data) for name, d in descriptors.items()}
    overlap = set(arrays) & set(fields)
    if overlap:
        raise _bad(f"{sorted(overlap)[0]} is both a field and an array")
    return fields, arrays


def _array(name: str, descriptor: Any, data: memoryview) -> np.ndarray:
    if not isinstance(descriptor, dict) or set(descriptor) != {"shape", "offset"}:
        raise _bad(f'array {name} needs exactly "shape" and "offset"')
    shape, offset = descriptor["shape"], descriptor["offset"]
    count = _element_count(name, shape)
    if type(offset) is not int or offset < 0 or offset % 8:
        raise _bad(f"array {name}: offset must be a non-negative multiple of 8")
    if offset + 8 * count > len(data):
        raise _bad(f"array {name} ({count} numbers at offset {offset}) runs past the body")
    return np.frombuffer(data, dtype="<f8", count=count, offset=offset).reshape(shape)


def _element_count(name: str, shape: Any) -> int:
    """The number of entries of a declared shape, checked before anything is allocated: a list
    of at most 3 non-negative integers whose product (zeros counted as ones) is at most
    MAX_ARRAY_ELEMENTS."""
    if (not isinstance(shape, list) or len(shape) > 3
            or not all(type(n) is int and n >= 0 for n in shape)):
        raise _bad(f"array {name}: shape must be a list of at most 3 non-negative integers")
    if math.prod(max(n, 1) for n in shape) > MAX_ARRAY_ELEMENTS:
        raise _bad(f"array {name}: the shape declares more than {MAX_ARRAY_ELEMENTS} numbers "
                   "(each dimension, and their product with zeros counted as ones, is at most "
                   "that)")
    return math.prod(shape)


def _aligned(n: int) -> int:
    return (n + 7) & ~7


def encode(values: Mapping[str, Any]) -> bytes:
    """Encode an answer: numpy arrays go to the data section, everything else to `fields`."""
    fields: dict[str, Any] = {}
    descriptors: dict[str, dict[str, Any]] = {}
    chunks: list[Any] = []
    offset = 0
    for name, value in values.items():
        if isinstance(value, np.ndarray | np.generic):
            array = np.asarray(value, dtype="<f8")
            if not array.flags.c_contiguous:  # (not np.ascontiguousarray: it makes 0-d 1-d)
                array = array.copy(order="C")
            descriptors[name] = {"shape": list(array.shape), "offset": offset}
            chunks.append(array.data.cast("B"))
            offset += array.nbytes
        else:
            fields[name] = value
    header = orjson.dumps({"fields": fields, "arrays": descriptors})
    padding = b"\0" * (_aligned(_PREFIX.size + len(header)) - _PREFIX.size - len(header))
    return b"".join([_PREFIX.pack(MAGIC, len(header)), header, padding, *chunks])
