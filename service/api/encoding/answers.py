"""Fast JSON answers: orjson with numpy arrays serialized natively, whole or in pieces."""

from __future__ import annotations

from typing import Any

import numpy as np
import orjson
from starlette.responses import Response

_NUMPY = orjson.OPT_SERIALIZE_NUMPY
PIECE_NUMBERS = 1 << 16  # numbers per piece of a large answer: ~1.5 MB, ~3 ms of orjson


def json_bytes(content: Any) -> bytes:
    """The JSON text of an answer (numpy arrays as nested lists)."""
    return orjson.dumps(content, option=_NUMPY)


def json_pieces(content: dict[str, Any]) -> list[bytes]:
    """The JSON text of an answer (an object) as pieces whose concatenation is
    `json_bytes(content)`. Each piece is made by one short orjson call (at most about
    `PIECE_NUMBERS` numbers): orjson holds the GIL for a whole call, so a worker thread encoding
    a large answer this way lets the event loop run between pieces, where one call for a
    300 MB answer would freeze it for a second."""
    pieces: list[bytes] = []
    separator = b"{"
    for key, value in content.items():
        pieces.append(separator + orjson.dumps(key) + b":")
        separator = b","
        _value_pieces(value, pieces)
    pieces.append(b"}" if pieces else b"{}")
    return pieces


def _value_pieces(value: Any, out: list[bytes]) -> None:
    if isinstance(value, np.ndarray) and value.ndim >= 1 and value.size > PIECE_NUMBERS:
        row = value[0].size or 1
        if row <= PIECE_NUMBERS:  # whole rows per piece: the inner text of a slice
            step = PIECE_NUMBERS // row
            for start in range(0, value.shape[0], step):
                text = orjson.dumps(value[start : start + step], option=_NUMPY)
                out.append((b"[" if start == 0 else b",") + text[1:-1])
            out.append(b"]")
        else:  # rows larger than a piece (long trajectories): one row at a time
            for i in range(value.shape[0]):
                out.append(b"[" if i == 0 else b",")
                _value_pieces(value[i], out)
            out.append(b"]")
    elif isinstance(value, list) and value and isinstance(value[0], list) and len(value[0]) > 1024:
        for i, item in enumerate(value):  # lists of long lists (trajectories keyed by name)
            out.append(b"[" if i == 0 else b",")
            _value_pieces(item, out)
        out.append(b"]")
    elif isinstance(value, list) and len(value) > 1024:  # e.g. answers keyed by joint name
        step = 1024
        for start in range(0, len(value), step):
            text = orjson.dumps(value[start : start + step], option=_NUMPY)
            out.append((b"[" if start == 0 else b",") + text[1:-1])
        out.append(b"]")
    else:
        out.append(orjson.dumps(value, option=_NUMPY))


class JSONAnswer(Response):
    media_type = "application/json"

    def render(self, content: Any) -> bytes:
        return json_bytes(content)
