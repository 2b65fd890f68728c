"""What the client sends: local input checks, URLs, headers, bodies, owned vs injected clients."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import Client
from robodyn.arrays import FINITE_WHEN_SENT_FROM

from tests.client.helpers import two_link_urdf

ANSWERS: dict[str, Any] = {"gravity": [0.0] * 6, "tau": [0.0] * 6}


class Recorder:
    """A mock server that records requests and answers a fixed body."""

    def __init__(self, status: int = 200, body: Any = None) -> None:
        self.requests: list[httpx.Request] = []
        self.status, self.body = status, body if body is not None else ANSWERS

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests.append(request)
        return httpx.Response(self.status, json=self.body)

    def client(self, base_url: str = "http://mock", **options: Any) -> Client:
        http = httpx.Client(transport=httpx.MockTransport(self), base_url=base_url)
        return Client(http_client=http, **options)

    @property
    def last_json(self) -> Any:
        return json.loads(self.requests[-1].content)


@pytest.mark.parametrize(
    ("q", "match"),
    [
        ([0, 0, float("nan"), 0, 0, 0], r"q\[2\] is nan; every entry must be finite"),
        (np.full((2, 6), np.inf), r"q\[0, 0\] is inf"),
        (["a", "b"], "real numbers, not text"),
        ([True, False], "real numbers, not booleans"),
        (np.ones(6) * 1j, "not complex"),
        ([[1.0, 2.0], [3.0]], "ragged"),
        (np.zeros((2, 2, 6)), "not 3-D"),
        (1.5, "not a scalar"),
        (None, "not objects"),
        ([], "q is empty"),
        (np.zeros((0, 6)), "empty batch"),
    ],
)
def test_bad_inputs_raise_input_error_and_send_nothing(q: Any, match: str) -> None:
    mock = Recorder()
    with mock.client() as client, pytest.raises(robodyn.InputError, match=match) as raised:
        client.gravity("ur5", q)
    assert isinstance(raised.value, ValueError) and mock.requests == []


def test_a_large_batch_is_checked_finite_when_sent_and_nothing_is_sent() -> None:
    """A batch of `FINITE_WHEN_SENT_FROM` numbers or more is checked when it is sent (not
    through shared memory here: before anything goes out), in either form."""
    q = np.zeros((2000, 6))
    assert q.size >= FINITE_WHEN_SENT_FROM
    q[1500, 2] = -np.inf
    for binary in (True, False):
        mock = Recorder()
        with (
            mock.client(binary=binary) as client,
            pytest.raises(robodyn.InputError, match=r"q\[1500, 2\] is -inf; every entry"),
        ):
            client.gravity("ur5", q)
        assert mock.requests == []


def test_a_batch_sent_in_chunks_is_checked_whole_before_any_chunk() -> None:
    """With progress, a large batch goes in chunks of states; a non-finite number in a later
    chunk is named by its state in the whole batch, and no chunk is sent."""
    q = np.zeros((3 * robodyn.progress.CHUNK_STATES, 6))
    q[5000, 1] = np.nan
    mock = Recorder()
    with (
        mock.client(progress=lambda done, total: None) as client,
        pytest.raises(robodyn.InputError, match=r"q\[5000, 1\] is nan"),
    ):
        client.gravity("ur5", q)
    assert mock.requests == []


def test_inputs_must_be_equally_batched() -> None:
    mock = Recorder()
    with mock.client() as client:
        with pytest.raises(robodyn.InputError, match="q is 1-D, v is 2-D, a is 1-D"):
            client.inverse_dynamics("ur5", np.zeros(6), np.zeros((1, 6)), np.zeros(6))
        with pytest.raises(robodyn.InputError, match="q has 2, v has 2, a has 3 states"):
            client.inverse_dynamics("ur5", np.zeros((2, 6)), np.zeros((2, 6)), np.zeros((3, 6)))
    assert mock.requests == []


def test_body_is_plain_json_of_floats() -> None:
    mock = Recorder()
    with mock.client() as client:
        tau = client.inverse_dynamics(
            "ur5", [0, 1, 2, 3, 4, 5], np.arange(6, dtype=np.float32), (0.1,) * 6
        )
    request = mock.requests[0]
    assert request.method == "POST" and request.url.path == "/v1/robots/ur5/inverse-dynamics"
    assert request.headers["content-type"] == "application/json"
    assert mock.last_json == {
        "q": [0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
        "v": [0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
        "a": [0.1] * 6,
    }
    assert tau.dtype == np.float64 and tau.shape == (6,)


def test_robot_ids_are_quoted_and_checked() -> None:
    mock = Recorder()
    with mock.client() as client:
        client.gravity("a/b?c d", np.zeros(6))
        with pytest.raises(robodyn.InputError, match="robot_id is empty"):
            client.robot("")
        with pytest.raises(TypeError, match="robot_id must be a str"):
            client.robot(5)  # type: ignore[arg-type]
    assert mock.requests[0].url.raw_path == b"/v1/robots/a%2Fb%3Fc%20d/gravity"
    assert len(mock.requests) == 1


def test_headers_api_key_and_user_agent() -> None:
    mock = Recorder()
    with mock.client(api_key="k-123", headers={"X-Trace": "t1"}) as client:
        client.gravity("ur5", np.zeros(6))
    with mock.client() as client:
        client.gravity("ur5", np.zeros(6))
    keyed, anonymous = mock.requests
    assert keyed.headers["authorization"] == "Bearer k-123" and keyed.headers["x-trace"] == "t1"
    assert "authorization" not in anonymous.headers
    assert anonymous.headers["user-agent"] == f"robodyn-python/{robodyn.__version__}"
    with pytest.raises(ValueError, match="api_key"):
        Client("http://x", api_key="line\nbreak")


def test_base_url_resolution(monkeypatch: pytest.MonkeyPatch) -> None:
    mock = Recorder(body={"robots": [], "unavailable": {}})
    with mock.client(base_url="http://host:9/prefix/") as client:
        client.robots()
    assert str(mock.requests[0].url) == "http://host:9/prefix/v1/robots"
    with Client("http://example:8123/") as client:
        assert client.base_url == "http://example:8123"
    monkeypatch.setenv("ROBODYN_URL", "https://robodyn.example")
    with Client() as client:
        assert client.base_url == "https://robodyn.example"
    monkeypatch.delenv("ROBODYN_URL")
    with Client() as client:
        assert client.base_url == "http://127.0.0.1:8000"
    for bad in ("ftp://host", "not a url", "http://"):
        with pytest.raises(ValueError, match="base_url"):
            Client(bad)


def test_owned_client_is_closed_injected_one_is_not() -> None:
    injected = httpx.Client(transport=httpx.MockTransport(Recorder()))
    with Client("http://mock", http_client=injected) as client:
        client.gravity("ur5", np.zeros(6))
    assert not injected.is_closed
    injected.close()
    owned = Client("http://mock", timeout=3.0)
    assert owned._http.timeout == httpx.Timeout(3.0)
    owned.close()
    assert owned._http.is_closed
    assert Client("http://mock")._http.timeout == robodyn.DEFAULT_TIMEOUT


def test_upload_body_and_created_flag(tmp_path: Path) -> None:
    info = {
        "id": "u-1",
        "name": "arm",
        "source": "upload",
        "nq": 2,
        "nv": 2,
        "root_joint": "fixed",
        "gravity": [0, 0, -1.62],
        "total_mass": 3.5,
        "neutral_configuration": [0, 0],
        "reference_configurations": {},
        "warnings": [],
        "joints": [],
        "frames": [],
        "future_field": {"x": 1},
    }
    urdf = two_link_urdf()
    path = tmp_path / "arm.urdf"
    path.write_text(urdf)
    created, stored = Recorder(201, info), Recorder(200, info)
    with created.client() as client:
        first = client.upload(path, gravity=[0, 0, -1.62])
    with stored.client() as client:
        again = client.upload(urdf.encode(), name="x", root_joint="planar", inertia_check="warn")
        with pytest.raises(robodyn.InputError, match="3 entries"):
            client.upload(urdf, gravity=[0, -9.81])
    assert created.last_json == {"urdf": urdf, "root_joint": "fixed", "gravity": [0, 0, -1.62]}
    assert stored.last_json == {
        "urdf": urdf,
        "root_joint": "planar",
        "name": "x",
        "inertia_check": "warn",
    }
    assert (first.created, again.created) == (True, False)
    assert first.raw["future_field"] == {"x": 1}  # unknown fields stay reachable
    np.testing.assert_array_equal(first.default_configuration, [0.0, 0.0])  # neutral if absent
    assert len(stored.requests) == 1
