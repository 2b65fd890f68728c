"""A large JSON body whose beginning already shows mistakes is refused with them, in constant
work (`prefix_errors`), with the errors the whole body's validation gives; never a body the
whole validation accepts, nor one whose errors the cut could change."""

from __future__ import annotations

import orjson
import pytest
from pydantic import Field, ValidationError

from service.api.problems.validation_errors import _PREFIX_BYTES, prefix_errors
from service.api.routes.dynamics import ENDPOINTS
from service.api.schemas.common import StrictRequest

GRAVITY = ENDPOINTS["gravity"].model
ROWS = [[0.1, 0.2]] * 20_000  # 240 kB


def _full_errors(model, body: bytes) -> list[dict]:
    with pytest.raises(ValidationError) as caught:
        model.model_validate_json(body)
    return [
        dict(e)
        for e in caught.value.errors(include_url=False, include_context=False, include_input=False)
    ]


@pytest.mark.parametrize(
    "q",
    [
        [["x", "y"]] * 20_000,  # the batch of strings: ~1 s for 5 MB when validated whole
        [[0.1, "x"], *ROWS],
        ["x"] * 50_000,
    ],
    ids=["rows-of-strings", "a-string-in-the-first-row", "strings"],
)
def test_the_beginning_of_a_large_body_gives_the_whole_bodys_errors(q):
    body = orjson.dumps({"q": q})
    assert len(body) > _PREFIX_BYTES
    errors = prefix_errors(GRAVITY, body)
    assert errors and errors == _full_errors(GRAVITY, body)


@pytest.mark.parametrize(
    "body",
    [
        orjson.dumps({"q": ROWS}),  # valid
        orjson.dumps({"q": [*ROWS, ["x", 0.1]]}),  # its mistake is past the beginning
        orjson.dumps({"q": ROWS, **{f"m{i}": 1 for i in range(100)}}),  # counted in all
        orjson.dumps({"q": [*ROWS[:6000], "x"], "qq": 1}),  # cut off: member missing
        b'{"q": [[NaN, 0.1]' + orjson.dumps(ROWS)[1:] + b"}",  # refused as JSON by pydantic
        # a JointState lacks `name` in every object: "missing" could also be the cut's doing
        orjson.dumps({"q": [{"shoulder": "x", "elbow": 0.1}] * 10_000}),
    ],
    ids=["valid", "late-mistake", "many-unknown-members", "field-cut-off", "nan", "named"],
)
def test_a_body_whose_beginning_is_not_conclusive_is_validated_whole(body):
    assert prefix_errors(GRAVITY, body) is None


class _Step(StrictRequest):
    x: list[float]
    dt: float = Field(gt=0)


def test_a_number_cut_at_the_end_of_the_beginning_is_not_read_as_another():
    head = b'{"x": [], "dt": 0'
    padding = _PREFIX_BYTES - len(head)  # the cut falls between "0" and ".5"
    body = b'{"x": [' + b" " * padding + b'], "dt": 0.5}'
    assert body[:_PREFIX_BYTES].endswith(b'"dt": 0')
    _Step.model_validate_json(body)  # valid whole
    assert prefix_errors(_Step, body) is None
