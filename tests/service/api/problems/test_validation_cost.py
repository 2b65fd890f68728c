"""The cost of refusing a body is bounded by what the answer reports, not by the body: every
array and object of a request schema stops at its first wrong item, pydantic's error objects
are built only when there are few, and many unknown members are counted, not listed."""

from __future__ import annotations

from typing import Any

import orjson
import pytest
from pydantic import BaseModel, ValidationError

from service.api.problems.validation_errors import (
    MAX_ERRORS_READ,
    TOO_MANY,
    json_prefix,
    pydantic_errors,
)
from service.api.quantities import SPECS
from service.api.routes.dynamics import ENDPOINTS
from service.api.schemas.common import MAX_UNKNOWN_MEMBERS
from service.api.schemas.robots import ReduceRequest, UploadRequest

REQUEST_MODELS: list[type[BaseModel]] = [
    *(spec.request for spec in SPECS.values()),
    *(endpoint.options_model for endpoint in ENDPOINTS.values()),
    UploadRequest,
    ReduceRequest,
]


def _sequence_schemas(schema: Any) -> list[dict[str, Any]]:
    out, todo = [], [schema]
    while todo:
        node = todo.pop()
        if isinstance(node, dict):
            if node.get("type") in ("list", "dict", "set", "tuple") and isinstance(
                node.get("type"), str
            ):
                out.append(node)
            todo.extend(v for k, v in node.items() if k != "metadata")
        elif isinstance(node, list):
            todo.extend(node)
    return out


@pytest.mark.parametrize("model", REQUEST_MODELS, ids=lambda m: m.__name__)
def test_every_array_and_object_of_a_request_fails_fast(model):
    sequences = _sequence_schemas(model.__pydantic_core_schema__)
    assert sequences or model.__name__.endswith("Options"), model
    assert all(s.get("fail_fast") for s in sequences), [
        s["type"] for s in sequences if not s.get("fail_fast")
    ]


def _errors(model: type[BaseModel], body: bytes) -> ValidationError:
    with pytest.raises(ValidationError) as caught:
        model.model_validate_json(body)
    return caught.value


@pytest.mark.parametrize("name", sorted(SPECS))
def test_20000_wrong_numbers_are_as_many_errors_as_2(name):
    """Before: one error per string and per member of q's union, 300,000 objects (8.6 s).
    Now each member of the union stops at its first wrong item: as many errors as for a body
    with two wrong numbers."""

    def count(n: int) -> int:
        body = orjson.dumps({"q": ["x"] * n, "v": [["x"] * 3] * n})
        return _errors(SPECS[name].request, body).error_count()

    assert count(20_000) == count(2) <= 20


class _Counting:
    """A ValidationError that records whether its error objects were built."""

    def __init__(self, exc: ValidationError) -> None:
        self.exc, self.built = exc, 0

    def error_count(self) -> int:
        return self.exc.error_count()

    def errors(self, **kw: Any) -> list[Any]:
        self.built += self.exc.error_count()
        return self.exc.errors(**kw)


def test_many_errors_are_counted_and_sampled_without_building_them():
    model = SPECS["gravity"].request
    body = orjson.dumps({"q": [0, 0], **{f"m{i}": 1 for i in range(100_000)}})
    exc = _Counting(_errors(model, body))
    errors = pydantic_errors(exc, model, lambda: json_prefix(body), partial=True)
    assert exc.built == 0  # not one of the 100,000 objects
    assert len(errors) <= MAX_ERRORS_READ + 1
    assert errors[-1]["type"] == TOO_MANY and errors[-1]["ctx"]["count"] == 100_000
    assert [e["loc"] for e in errors[:3]] == [("m0",), ("m1",), ("m2",)]


def test_few_errors_are_reported_one_by_one(api):
    body = {"q": [0] * 6, **{f"m{i}": 1 for i in range(5)}}
    problem = api.post("/v1/robots/ur5/gravity", json=body).json()
    assert [e["loc"] for e in problem["errors"]] == [f"m{i}" for i in range(5)]
    assert problem["detail"].endswith("(and 4 more)")


def test_a_flood_of_unknown_members_answers_its_count_and_the_first_names(api):
    body = {"q": [0] * 6, **{f"m{i}": 1 for i in range(50_000)}}
    problem = api.post("/v1/robots/ur5/gravity", json=body).json()
    assert problem["detail"] == "m0: is not a field of this request (and 49999 more)"
    assert problem["errors"][0] == {"loc": "m0", "msg": "is not a field of this request"}
    assert problem["errors"][-1]["msg"] == "has 50000 mistakes in all (the first are listed)"
    assert len(problem["errors"]) <= 21


def test_an_upload_with_many_unknown_members_is_one_error_before_validation():
    data = {"urdf": "<robot name='r'/>", **{f"m{i}": 1 for i in range(100_000)}}
    with pytest.raises(ValidationError) as caught:
        UploadRequest.model_validate(data)
    assert caught.value.error_count() == 1
    assert "100000 members that are not fields" in str(caught.value)
    few = {"urdf": "<robot name='r'/>", **{f"m{i}": 1 for i in range(MAX_UNKNOWN_MEMBERS)}}
    with pytest.raises(ValidationError) as caught:
        UploadRequest.model_validate(few)
    assert caught.value.error_count() == MAX_UNKNOWN_MEMBERS  # each named, with suggestions


@pytest.mark.parametrize(
    "body",
    [
        {"q": [0] * 6, "x" * 1_000_000: 1},
        {"q": {"x" * 1_000_000: 1}},
        {
            "q": [0] * 6,
            "external_forces": [{"frame": "tool0", "wrench": [0] * 6, "y" * 1_000_000: 1}],
        },
    ],
    ids=["member", "joint-name-key", "nested-member"],
)
def test_a_megabyte_name_is_shortened_in_the_problem(api, body):
    r = api.post(
        "/v1/robots/ur5/gravity"
        if "external_forces" not in body
        else "/v1/robots/ur5/inverse-dynamics",
        json=body if "external_forces" not in body else {**body, "v": [0] * 6, "a": [0] * 6},
    )
    assert r.status_code == 422
    assert len(r.content) < 2000, len(r.content)
    assert "x" * 64 + "…" in r.text or "y" * 64 + "…" in r.text


def test_a_stream_message_flood_is_a_small_problem(api):
    message = {
        "quantity": "gravity",
        "q": ["x"] * 100_000,
        **{f"m{i}": 1 for i in range(50_000)},
    }  # counted before any validation
    with api.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_text(orjson.dumps(message).decode())
        problem = orjson.loads(ws.receive_text())
        assert problem["code"] == "validation_error"
        assert problem["detail"].startswith(
            "the message has 50000 members that are not fields of gravity (the first: 'm0')"
        )
        assert len(orjson.dumps(problem)) < 2000
        ws.send_text(orjson.dumps({"quantity": "gravity", "q": [0] * 6}).decode())
        assert "gravity" in orjson.loads(ws.receive_text())


def test_the_sample_of_a_flood_does_not_blame_what_its_prefix_cut_off(api):
    """The sample comes from the body's first 64 kB: `q`, sent after 100,000 unknown members,
    is not reported missing."""
    body = {**{f"m{i}": 1 for i in range(100_000)}, "q": [0] * 6}
    problem = api.post("/v1/robots/ur5/gravity", json=body).json()
    locs = [e["loc"] for e in problem["errors"]]
    assert "q" not in locs and locs[:2] == ["m0", "m1"], locs
    assert problem["errors"][-1]["msg"].startswith("has 100000 mistakes in all")
