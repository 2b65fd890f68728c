"""Fast JSON answers: orjson with numpy arrays serialized natively."""

from __future__ import annotations

from typing import Any

import orjson
from starlette.responses import Response


def json_bytes(content: Any) -> bytes:
    """The JSON text of an answer (numpy arrays as nested lists)."""
    return orjson.dumps(content, option=orjson.OPT_SERIALIZE_NUMPY)


class JSONAnswer(Response):
    media_type = "application/json"

    def render(self, content: Any) -> bytes:
        return json_bytes(content)
