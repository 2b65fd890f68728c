"""The progress stream (`Accept: application/x-ndjson`): progress lines counting the work of
the computation, then the very answer the request gives without it; a request refused before
its computation is an ordinary problem+json answer; a failure once the stream began is its
last line, with the status the request would have had."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest

from service.api.progress import PROGRESS_MEDIA_TYPE
from tests.service.dynamics.identification_logs import synthetic_log

STREAM = {"Accept": PROGRESS_MEDIA_TYPE}


def _motion(n: int, nq: int, seconds: float = 20.0) -> dict[str, Any]:
    t = np.linspace(0.0, seconds, n)
    q = np.stack([0.4 * np.sin((j + 1) * 0.3 * t) for j in range(nq)], axis=1)
    return {"t": t.tolist(), "q": q.tolist()}


def _lines(response: Any) -> list[dict[str, Any]]:
    assert response.status_code == 200, response.text[:300]
    assert response.headers["content-type"].startswith(PROGRESS_MEDIA_TYPE)
    assert response.text.endswith("\n")
    return [json.loads(line) for line in response.text.splitlines()]


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory) -> Any:
    from fastapi.testclient import TestClient

    from service.main import create_app
    from service.registry import Registry
    from service.settings import Settings

    def build(**settings: Any) -> TestClient:
        data = tmp_path_factory.mktemp("progress")
        s = Settings(data_dir=data, catalog="ur5", **settings)
        registry = Registry(s.data_dir, s.catalog_names(), s.build_timeout_s)
        registry.load()
        return TestClient(create_app(s, registry=registry), raise_server_exceptions=False)

    return build


def test_a_long_check_streams_its_evaluated_points_then_the_same_answer(api) -> None:
    body = {**_motion(20_000, 6), "samples_per_interval": 16}
    plain = api.post("/v1/robots/ur5/trajectory-check", json=body)
    lines = _lines(api.post("/v1/robots/ur5/trajectory-check", json=body, headers=STREAM))
    progress = [line["progress"] for line in lines[:-1]]
    evaluated = (20_000 - 1) * 16 + 1
    assert progress, "a check of 320,000 points reports its progress"
    assert all(set(p) == {"done", "total", "unit", "stage"} for p in progress)
    assert all(p["total"] == evaluated and p["unit"] == "evaluated point" for p in progress)
    done = [p["done"] for p in progress]
    assert done == sorted(done) and done[0] >= 0 and done[-1] < evaluated
    assert list(lines[-1]) == ["answer"]
    assert lines[-1]["answer"] == plain.json()


def test_a_request_refused_before_computing_is_a_plain_problem(api) -> None:
    body = _motion(50, 5)  # ur5 has nq = 6
    response = api.post("/v1/robots/ur5/trajectory-check", json=body, headers=STREAM)
    assert response.status_code == 422
    assert response.headers["content-type"] == "application/problem+json"
    assert response.json()["code"] == "dimension_mismatch"
    missing = api.post("/v1/robots/nope/trajectory-check", json=_motion(50, 6), headers=STREAM)
    assert missing.status_code == 404 and missing.json()["code"] == "robot_not_found"


def test_a_short_computation_streams_its_answer_alone(api) -> None:
    q = np.zeros((3, 6)).tolist()
    plain = api.post("/v1/robots/ur5/gravity", json={"q": q})
    lines = _lines(api.post("/v1/robots/ur5/gravity", json={"q": q}, headers=STREAM))
    assert lines == [{"answer": plain.json()}]


def test_a_chunked_batch_streams_its_states(api) -> None:
    q = np.random.default_rng(0).uniform(-2, 2, (30_000, 6))
    body = {"q": q.tolist(), "v": q.tolist(), "a": q.tolist()}
    lines = _lines(api.post("/v1/robots/ur5/inverse-dynamics", json=body, headers=STREAM))
    progress = [line["progress"] for line in lines[:-1]]
    assert progress and all(p["total"] == 30_000 and p["unit"] == "state" for p in progress)
    np.testing.assert_array_equal(
        np.array(lines[-1]["answer"]["tau"]),
        np.array(api.post("/v1/robots/ur5/inverse-dynamics", json=body).json()["tau"]),
    )


def test_a_failure_once_streaming_is_the_last_line_with_its_status(small) -> None:
    client = small(request_deadline_s=0.001)
    body = {**_motion(20_000, 6), "samples_per_interval": 32}
    lines = _lines(client.post("/v1/robots/ur5/trajectory-check", json=body, headers=STREAM))
    assert [list(line) for line in lines[:-1]] == [["progress"]] * (len(lines) - 1)
    assert len(lines) >= 2
    problem = lines[-1]["problem"]
    assert problem["status"] == 504 and problem["code"] == "deadline_exceeded"
    assert "ROBODYN_REQUEST_DEADLINE_S" in problem["detail"]


def test_identify_streams_its_stages_then_the_same_answer(small, catalog_registry) -> None:
    client = small()
    log = synthetic_log(
        catalog_registry.get("ur5").model, seed=4, duration=8.0, rate=200.0, noise=0.05
    )
    body = {"t": log.t.tolist(), "q": log.q.tolist(), "tau": log.tau.tolist(), "store": False}
    plain = client.post("/v1/robots/ur5/identify", json=body)
    assert plain.status_code == 200, plain.text[:300]
    lines = _lines(client.post("/v1/robots/ur5/identify", json=body, headers=STREAM))
    progress = [line["progress"] for line in lines[:-1]]
    stages = ["log", "base parameters", "regressor", "fit", "validation"]
    assert progress and all(p["total"] == 5 and p["unit"] == "stage" for p in progress)
    assert all(stages[p["done"]] == p["stage"] and p["done"] >= 1 for p in progress)
    assert [p["done"] for p in progress] == sorted(p["done"] for p in progress)
    answer = lines[-1]["answer"]
    assert answer["parameters"] == plain.json()["parameters"]
    assert answer["rmse"] == plain.json()["rmse"]
    # the log is checked before any progress: a log refused is a plain problem
    refused = client.post(
        "/v1/robots/ur5/identify", json={**body, "tau": body["tau"][:-1]}, headers=STREAM
    )
    assert refused.status_code == 422 and refused.json()["code"] == "dimension_mismatch"
    assert refused.headers["content-type"] == "application/problem+json"


@pytest.mark.parametrize(
    "accept",
    [
        f"{PROGRESS_MEDIA_TYPE}, application/vnd.robodyn.safetensors",
        "application/vnd.robodyn.safetensors, " + PROGRESS_MEDIA_TYPE,
    ],
)
def test_a_stream_asked_beside_the_binary_form_carries_json(api, accept) -> None:
    """The stream is lines of JSON: asked for with the binary form too, its answer is JSON."""
    plain = api.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6})
    lines = _lines(
        api.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6}, headers={"Accept": accept})
    )
    assert lines == [{"answer": plain.json()}]


@pytest.mark.parametrize(
    "accept",
    [f"{PROGRESS_MEDIA_TYPE};q=0, application/json", "application/json", "application/x-ndjsonx"],
)
def test_a_stream_not_asked_for_is_not_sent(api, accept) -> None:
    response = api.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6}, headers={"Accept": accept})
    assert response.status_code == 200
    assert response.headers["content-type"] == "application/json"
