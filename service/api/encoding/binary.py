"""The binary encoding of dynamics requests and answers: a safetensors file (`BINARY_MEDIA_TYPE`).

Large batches as JSON text cost more to format and parse than to compute. The binary form has
the same field names and shapes as the JSON form and is a valid safetensors file, so
`safetensors.numpy.load(body)`, `safetensors.torch.load(body)` and the safetensors readers of
other languages read it with no robodyn code:

    bytes 0–7    N, uint64 little-endian      length of the header
    bytes 8…8+N  header, UTF-8 JSON object    {"__metadata__": {name: JSON text}, name:
                                               {"dtype": "F64", "shape": [...],
                                                "data_offsets": [begin, end]}, ...}
                 (padded with spaces so that the data starts at a multiple of 8)
    data         the tensors' float64 values, little-endian, row-major, back to back: each at
                 data start + begin, end − begin = 8 × the product of its shape

Every non-array member (e.g. `"frame": "tool0"`) is in `__metadata__` under its name, as its
JSON text (safetensors metadata maps strings to strings): `{"frame": "\\"tool0\\""}`.

The decoder reads the header itself (no dependency, no copy of the data): the arrays are
numpy views of the body. Everything in the header is checked before it is used — dtype,
shapes (non-negative integers, each dimension and their product bounded by the body's size),
offsets (contiguous from 0 and ending exactly at the end of the body) — so a hostile header
is a 422 naming the fault and never an allocation. docs/binary-format.md describes the format.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np
import orjson

from service.errors import InvalidInput

BINARY_MEDIA_TYPE = "application/vnd.robodyn.safetensors"
MAX_HEADER_BYTES = 1 << 20
MAX_NDIM = 3
MAX_ARRAY_ELEMENTS = 1 << 24
"""The most numbers a tensor may declare: the product of its dimensions, zeros counted as ones
(so `[0, 2**63]` is refused too), and so also each single dimension. 2**24 float64 are
128 MiB, more than any request body the server accepts."""
METADATA = "__metadata__"
DTYPE = "F64"
_LENGTH = struct.Struct("<Q")
_TENSOR_KEYS = frozenset(("dtype", "shape", "data_offsets"))


def _bad(detail: str) -> InvalidInput:
    return InvalidInput(
        f"binary body: {detail} (a safetensors file of F64 tensors; format: docs/binary-format.md)"
    )


def decode(body: bytes | bytearray) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Split a binary body into its fields (decoded from `__metadata__`) and its arrays (float64
    views of the body, no copy unless the data section is not 8-byte aligned)."""
    if len(body) < _LENGTH.size:
        raise _bad("shorter than its 8-byte header length")
    (header_size,) = _LENGTH.unpack_from(body)
    if header_size > MAX_HEADER_BYTES:
        raise _bad(f"the header length {header_size} is over the cap of {MAX_HEADER_BYTES} bytes")
    if header_size > len(body) - _LENGTH.size:
        raise _bad(f"the header length {header_size} runs past the body")
    raw = bytes(body[_LENGTH.size : _LENGTH.size + header_size])
    if not raw.startswith(b"{"):
        raise _bad("the header must be a JSON object")
    try:
        header = orjson.loads(raw)
    except orjson.JSONDecodeError:
        raise _bad("the header is not valid JSON") from None
    if not isinstance(header, dict):
        raise _bad("the header must be a JSON object")
    _refuse_duplicate_keys(raw)
    fields = _fields(header.pop(METADATA, {}))
    start = _LENGTH.size + header_size
    data = memoryview(body)[start:]
    if start % 8 and header:  # unaligned float64 would be copied by every consumer anyway
        data = memoryview(bytearray(data))
    arrays = _arrays(header, data)
    overlap = set(arrays) & set(fields)
    if overlap:
        raise _bad(f"{sorted(overlap)[0]} is both in __metadata__ and a tensor")
    return fields, arrays


def _refuse_duplicate_keys(raw: bytes) -> None:
    """A name given twice in the header (or in `__metadata__`, or in a tensor's entry) is a
    422: JSON parsers keep the last one silently. `raw` parsed as JSON already (≤ 1 MiB)."""

    def pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in items:
            if key in out:
                raise _bad(f"the name {key[:64]!r} is given twice in the header")
            out[key] = value
        return out

    try:
        json.loads(raw, object_pairs_hook=pairs)
    except RecursionError:
        raise _bad("the header is nested too deeply") from None
    except ValueError:  # orjson read it; the standard parser's own disagreements are not ours
        pass


def _fields(metadata: Any) -> dict[str, Any]:
    if not isinstance(metadata, dict) or not all(isinstance(v, str) for v in metadata.values()):
        raise _bad("__metadata__ must map names to strings (each a JSON text)")
    fields = {}
    for name, text in metadata.items():
        try:
            fields[name] = orjson.loads(text)
        except orjson.JSONDecodeError:
            raise _bad(f"__metadata__[{name!r}] is not a JSON text") from None
    return fields


def _arrays(header: dict[str, Any], data: memoryview) -> dict[str, np.ndarray]:
    """The tensors of `header` as views of `data`, checked in order of their offsets."""
    limit = len(data) // 8  # no tensor can hold more numbers than the body carries
    spans = []
    for name, descriptor in header.items():
        if not isinstance(descriptor, dict) or set(descriptor) != _TENSOR_KEYS:
            raise _bad(f'tensor {name} needs exactly "dtype", "shape" and "data_offsets"')
        if descriptor["dtype"] != DTYPE:
            raise _bad(
                f"tensor {name} has dtype {str(descriptor['dtype'])[:20]!r}; "
                f"every tensor is {DTYPE} (float64)"
            )
        shape, offsets = descriptor["shape"], descriptor["data_offsets"]
        if (
            not isinstance(shape, list)
            or len(shape) > MAX_NDIM
            or not all(type(n) is int and 0 <= n <= MAX_ARRAY_ELEMENTS for n in shape)
            or math.prod(max(n, 1) for n in shape) > MAX_ARRAY_ELEMENTS
        ):
            # zeros count as ones: an empty batch [0, n] is a shape, [0, 2**63] is not
            raise _bad(
                f"tensor {name}: shape must be a list of at most {MAX_NDIM} "
                "non-negative integers whose product (zeros counted as ones) is at "
                f"most {MAX_ARRAY_ELEMENTS}"
            )
        count = math.prod(shape)  # each factor bounded: a small integer
        if count > limit:
            raise _bad(f"tensor {name} has {count} numbers; the body carries {limit}")
        if (
            not isinstance(offsets, list)
            or len(offsets) != 2
            or not all(type(n) is int for n in offsets)
        ):
            raise _bad(f"tensor {name}: data_offsets must be [begin, end], two integers")
        spans.append((offsets[0], offsets[1], name, shape, count))
    spans.sort(key=lambda span: (span[0], span[1]))
    arrays = {}
    position = 0
    for begin, end, name, shape, count in spans:
        if begin != position or end - begin != 8 * count:
            raise _bad(
                f"tensor {name}: data_offsets [{begin}, {end}] must start where the "
                f"previous tensor ends ({position}) and span 8 × {count} bytes"
            )
        arrays[name] = np.frombuffer(data, dtype="<f8", count=count, offset=begin).reshape(shape)
        position = end
    if position != len(data):
        raise _bad(f"the tensors end at byte {position} of the data, which has {len(data)}")
    return arrays


def header_bytes(fields: Mapping[str, Any], shapes: Mapping[str, tuple[int, ...]]) -> bytes:
    """The 8-byte length and the header (padded with spaces to a multiple of 8) for `shapes`
    stored back to back in this order, and `fields` in `__metadata__`."""
    header: dict[str, Any] = {}
    if fields:
        header[METADATA] = {name: orjson.dumps(value).decode() for name, value in fields.items()}
    offset = 0
    for name, shape in shapes.items():
        size = 8 * math.prod(shape)
        header[name] = {
            "dtype": DTYPE,
            "shape": list(shape),
            "data_offsets": [offset, offset + size],
        }
        offset += size
    text = orjson.dumps(header)
    text += b" " * (-len(text) % 8)
    return _LENGTH.pack(len(text)) + text


def encode_parts(values: Mapping[str, Any]) -> list[bytes | memoryview]:
    """Encode an answer as parts to send or write one after the other: the header, then each
    array's own memory. Numpy arrays (and numpy scalars) become F64 tensors, everything else
    goes to `__metadata__`."""
    fields: dict[str, Any] = {}
    arrays: dict[str, np.ndarray] = {}
    for name, value in values.items():
        if isinstance(value, np.ndarray | np.generic):
            array = np.asarray(value, dtype="<f8")
            if not array.flags.c_contiguous:  # (not np.ascontiguousarray: it makes 0-d 1-d)
                array = array.copy(order="C")
            arrays[name] = array
        else:
            fields[name] = value
    head = header_bytes(fields, {name: a.shape for name, a in arrays.items()})
    return [head, *(a.data.cast("B") for a in arrays.values())]


def encode(values: Mapping[str, Any]) -> bytes:
    """Encode an answer in one piece (`encode_parts` joined)."""
    return b"".join(encode_parts(values))
