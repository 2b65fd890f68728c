"""Error mapping with a mock transport: every server code, fallbacks, transport failures."""

from __future__ import annotations

import asyncio
import builtins
import pickle
import warnings
from collections.abc import Callable
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import errors

from service.api.problems.handlers import STATUS_BY_CODE, problem

# code → (status, class, a builtin or parent it must also be): written out, not derived.
EXPECTED: dict[str, tuple[int, type[robodyn.APIError], type[BaseException]]] = {
    "robot_not_found": (404, robodyn.RobotNotFoundError, LookupError),
    "asset_not_found": (404, robodyn.AssetNotFoundError, LookupError),
    "catalog_robot": (409, robodyn.CatalogRobotError, robodyn.ConflictError),
    "validation_error": (422, robodyn.ValidationError, ValueError),
    "dimension_mismatch": (422, robodyn.DimensionMismatchError, ValueError),
    "invalid_configuration": (422, robodyn.InvalidConfigurationError, ValueError),
    "invalid_model": (422, robodyn.InvalidModelError, ValueError),
    "unknown_frame": (422, robodyn.UnknownFrameError, LookupError),
    "singular_configuration": (422, robodyn.SingularConfigurationError, ValueError),
    "non_finite_result": (422, robodyn.NonFiniteResultError, ArithmeticError),
    "unsupported_model": (422, robodyn.UnsupportedModelError, ValueError),
    "infeasible_path": (422, robodyn.InfeasiblePathError, ValueError),
    "payload_too_large": (413, robodyn.PayloadTooLargeError, ValueError),
    "unauthorized": (401, robodyn.UnauthorizedError, PermissionError),
    "not_ready": (503, robodyn.NotReadyError, robodyn.ServiceUnavailableError),
    "overloaded": (503, robodyn.OverloadedError, robodyn.ServiceUnavailableError),
    "deadline_exceeded": (504, robodyn.DeadlineExceededError, TimeoutError),
    "internal_error": (500, robodyn.InternalServerError, robodyn.ServerError),
    "bad_request": (400, robodyn.BadRequestError, robodyn.APIError),
    "not_found": (404, robodyn.NotFoundError, LookupError),
    "method_not_allowed": (405, robodyn.MethodNotAllowedError, robodyn.APIError),
    "unsupported_media_type": (415, robodyn.UnsupportedMediaTypeError, robodyn.APIError),
}


def mock_client(handler: Callable[[httpx.Request], httpx.Response]) -> robodyn.Client:
    http = httpx.Client(transport=httpx.MockTransport(handler), base_url="http://mock")
    return robodyn.Client(http_client=http)


def server_problem(code: str, detail: str = "what went wrong", **headers: str) -> httpx.Response:
    """The answer the server itself gives for `code` (built by its own `problem`)."""
    answer = problem(code, code.replace("_", " ").capitalize(), detail, headers or None)
    return httpx.Response(
        answer.status_code, content=bytes(answer.body), headers=dict(answer.headers)
    )


def test_every_server_code_is_listed_here_with_its_status() -> None:
    assert set(EXPECTED) == set(STATUS_BY_CODE)
    assert {code: e[0] for code, e in EXPECTED.items()} == STATUS_BY_CODE


@pytest.mark.parametrize("code", sorted(EXPECTED))
def test_each_code_raises_its_class(code: str) -> None:
    status, cls, also = EXPECTED[code]
    with (
        mock_client(lambda request: server_problem(code, f"detail of {code}")) as client,
        pytest.raises(robodyn.APIError) as raised,
    ):
        client.robot("ur5")
    err = raised.value
    assert type(err) is cls and isinstance(err, also) and isinstance(err, robodyn.RobodynError)
    assert (err.status, err.code, err.detail) == (status, code, f"detail of {code}")
    assert err.title == code.replace("_", " ").capitalize()
    assert err.body["code"] == code and err.body["status"] == status
    assert str(err) == f"{status} {code}: detail of {code}"


def test_async_client_maps_errors_the_same_way() -> None:
    async def run() -> list[type[BaseException]]:
        raised: list[type[BaseException]] = []
        for code in EXPECTED:
            http = httpx.AsyncClient(
                transport=httpx.MockTransport(lambda request, code=code: server_problem(code)),
                base_url="http://mock",
            )
            async with http, robodyn.AsyncClient(http_client=http) as client:
                try:
                    await client.gravity("ur5", np.zeros(6))
                except robodyn.APIError as exc:
                    raised.append(type(exc))
        return raised

    assert asyncio.run(run()) == [cls for _, cls, _ in EXPECTED.values()]


@pytest.mark.parametrize(
    ("status", "body", "cls"),
    [
        (422, {"code": "joint_locked", "detail": "new"}, robodyn.UnprocessableError),
        (503, {"code": "maintenance", "detail": "new"}, robodyn.ServiceUnavailableError),
        (409, {"detail": "no code at all"}, robodyn.ConflictError),
        (404, "plain text, not JSON", robodyn.NotFoundError),
        (502, "<html>Bad Gateway</html>", robodyn.ServerError),
        (
            418,
            {"code": "teapot", "title": "I'm a teapot", "detail": "short and stout"},
            robodyn.APIError,
        ),
    ],
)
def test_unknown_codes_fall_back_by_status(status: int, body: Any, cls: type) -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        if isinstance(body, str):
            return httpx.Response(status, text=body)
        return httpx.Response(status, json=body)

    with mock_client(handler) as client, pytest.raises(robodyn.APIError) as raised:
        client.robots()
    err = raised.value
    assert type(err) is cls and err.status == status
    assert err.body == body
    if isinstance(body, str):
        assert err.code is None and err.detail == body
    else:
        assert err.code == body.get("code") and err.detail == body["detail"]


def test_retry_after_is_read() -> None:
    with (
        mock_client(
            lambda request: server_problem("overloaded", **{"Retry-After": "2.5"})
        ) as client,
        pytest.raises(robodyn.OverloadedError) as raised,
    ):
        client.robots()
    assert raised.value.retry_after == 2.5


@pytest.mark.parametrize(
    ("exc", "cls"),
    [
        (httpx.ConnectError("refused"), robodyn.TransportError),
        (httpx.RemoteProtocolError("peer closed"), robodyn.TransportError),
        (httpx.ReadTimeout("slow"), robodyn.TimeoutError),
        (httpx.ConnectTimeout("slow"), robodyn.TimeoutError),
        (httpx.PoolTimeout("busy"), robodyn.TimeoutError),
    ],
)
def test_transport_failures_are_wrapped_from_the_httpx_error(exc: Exception, cls: type) -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        raise exc

    with mock_client(handler) as client, pytest.raises(robodyn.TransportError) as raised:
        client.mass_matrix("ur5", np.zeros(6))
    err = raised.value
    assert type(err) is cls and err.__cause__ is exc
    assert err.method == "POST" and err.url == "http://mock/v1/robots/ur5/mass-matrix"
    assert isinstance(err, builtins.TimeoutError) == (cls is robodyn.TimeoutError)
    assert not isinstance(err, robodyn.APIError)


@pytest.mark.parametrize(
    ("answer", "match"),
    [
        (httpx.Response(200, text="not json"), "not JSON"),
        (httpx.Response(200, json={"M": [[1.0]]}), "mass_matrix"),
        (httpx.Response(200, json={"mass_matrix": [1.0, 2.0]}), "dimensions"),
        (httpx.Response(200, json={"mass_matrix": [[1.0, 2.0]]}), "not square"),
    ],
)
def test_unreadable_success_answers_raise_response_format_error(
    answer: httpx.Response, match: str
) -> None:
    with (
        mock_client(lambda request: answer) as client,
        pytest.raises(robodyn.ResponseFormatError, match=match) as raised,
    ):
        client.mass_matrix("ur5", np.zeros(6))
    assert raised.value.status == 200 and not isinstance(raised.value, robodyn.APIError)


def test_a_batch_answered_with_the_wrong_count_is_refused() -> None:
    answer = httpx.Response(200, json={"gravity": [[0.0] * 6] * 2})
    with (
        mock_client(lambda request: answer) as client,
        pytest.raises(robodyn.ResponseFormatError, match="2 states; 3 were sent"),
    ):
        client.gravity("ur5", np.zeros((3, 6)))


def test_error_classes_are_exported_and_in_the_docstring_tree() -> None:
    tree = errors.__doc__ or ""
    for cls in {*errors.ERROR_BY_CODE.values(), *errors.ERROR_BY_STATUS.values()}:
        assert getattr(robodyn, cls.__name__) is cls
        assert cls.__name__ in tree


def test_errors_survive_pickling() -> None:
    api = robodyn.UnauthorizedError(
        401, "unauthorized", "Unauthorized", "send a key", {"code": "unauthorized"}, 1.0
    )
    transport = robodyn.TimeoutError("slow", method="GET", url="http://x/v1/robots")
    shape = robodyn.ResponseFormatError("odd", status=200, body={"a": 1})
    for err in (api, transport, shape):
        copy = pickle.loads(pickle.dumps(err))
        assert type(copy) is type(err) and str(copy) == str(err)
        assert vars(copy) == vars(err)
    assert str(api) == "401 unauthorized: send a key" and api.errno is None


def test_an_angle_in_degrees_is_computed_with_a_warning(server: str) -> None:
    """The server computes q as given and says in `Robodyn-Warning` that an angle lies many
    turns outside its joint's range; the client turns that into a RobodynWarning, and the
    answer is the one of the same q without a warning filter."""
    q = np.array([0.0, -1.2, 90.0, 0.0, 0.0, 0.0])  # the elbow at "90"
    with robodyn.Client(server) as client:
        with pytest.warns(robodyn.RobodynWarning, match=r"elbow_joint.*90 degrees would be 1.5708"):
            g = client.gravity("ur5", q)
        with warnings.catch_warnings():
            warnings.simplefilter("error", robodyn.RobodynWarning)
            plain = client.gravity("ur5", np.array([0.0, -1.2, 1.5, 0.0, 0.0, 0.0]))
            with pytest.raises(robodyn.RobodynWarning):
                client.gravity("ur5", q)
    assert g.shape == plain.shape == (6,)
