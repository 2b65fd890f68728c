"""Large JSON bodies of the dynamics routes are parsed in a helper process: the answers, the
validation errors and the domain errors are the ones of the same body parsed in process; a
helper that died, or does not answer in time, is replaced and the body parsed in process."""

from __future__ import annotations

import contextlib
import os
import signal
from typing import Any

import numpy as np
import orjson
import pytest

from service.api import json_bodies
from service.api.routes import dynamics as dynamics_routes
from tests.descendants import wait_ended

JSON = {"content-type": "application/json"}


def _check_body(n: int = 30_000, **extra: Any) -> dict[str, Any]:
    t = np.linspace(0.0, 20.0, n)
    q = np.stack([0.4 * np.sin((j + 1) * 0.3 * t) for j in range(6)], axis=1)
    return {"t": t.tolist(), "q": q.tolist(), **extra}


def _both(api, monkeypatch, route: str, body: bytes) -> tuple[Any, Any]:
    """The answer to `body` parsed in the helper, and parsed in process."""
    assert len(body) > json_bodies.ISOLATED_JSON_BYTES
    calls: list[str] = []
    real = json_bodies.parse_isolated

    def spy(parse: Any, quantity: str, raw: bytes) -> Any:
        calls.append(quantity)
        return real(parse, quantity, raw)

    monkeypatch.setattr(dynamics_routes, "parse_isolated", spy)
    isolated = api.post(route, content=body, headers=JSON)
    assert calls == [route.rsplit("/", 1)[-1]]
    monkeypatch.setattr(dynamics_routes, "ISOLATED_JSON_BYTES", len(body) + 1)
    inline = api.post(route, content=body, headers=JSON)
    assert calls == [route.rsplit("/", 1)[-1]]  # not the helper this time
    return isolated, inline


def test_a_large_body_parsed_in_the_helper_answers_the_same(api, monkeypatch) -> None:
    body = orjson.dumps(_check_body(samples_per_interval=2))
    isolated, inline = _both(api, monkeypatch, "/v1/robots/ur5/trajectory-check", body)
    assert isolated.status_code == 200, isolated.text[:300]
    assert isolated.json() == inline.json()


def test_validation_errors_of_a_large_body_are_the_same(api, monkeypatch) -> None:
    body = _check_body()
    body["q"][20_000][3] = "x"
    body["velocity_scale"] = -1
    isolated, inline = _both(
        api, monkeypatch, "/v1/robots/ur5/trajectory-check", orjson.dumps(body)
    )
    assert isolated.status_code == 422 and isolated.json()["code"] == "validation_error"
    assert isolated.json() == inline.json()
    assert "q[20000][3]" in isolated.json()["detail"] or any(
        "q[20000][3]" in e["loc"] for e in isolated.json()["errors"]
    )


def test_domain_errors_of_a_large_body_are_the_same(api, monkeypatch) -> None:
    names = [j["name"] for j in api.get("/v1/robots/ur5").json()["joints"]]
    row = ", ".join(f'"{name}": 0.1' for name in names)
    twice = f'{{{row}, "{names[0]}": 0.2}}'  # the first joint named twice
    rows = ", ".join([f"{{{row}}}"] * 30_000 + [twice])
    body = f'{{"q": [{rows}]}}'.encode()
    isolated, inline = _both(api, monkeypatch, "/v1/robots/ur5/gravity", body)
    assert isolated.status_code == 422, isolated.text[:300]
    assert isolated.json() == inline.json()
    assert names[0] in isolated.json()["detail"]


def test_a_dead_helper_is_replaced_and_the_body_parsed_in_process(api) -> None:
    body = orjson.dumps(_check_body())
    json_bodies.HELPERS.call(int)  # started
    pool = json_bodies.HELPERS.executor()
    for pid in list(pool._processes):  # (the executor's own table of its processes)
        os.kill(pid, signal.SIGKILL)
    for pid in list(pool._processes):
        with contextlib.suppress(ChildProcessError):
            os.waitpid(pid, 0)
    answer = api.post("/v1/robots/ur5/trajectory-check", content=body, headers=JSON)
    assert answer.status_code == 200, answer.text[:300]
    assert json_bodies.HELPERS.executor() is not pool
    again = api.post("/v1/robots/ur5/trajectory-check", content=body, headers=JSON)
    assert again.json() == answer.json()


def test_a_stopped_helper_is_killed_and_the_body_parsed_in_process(api, monkeypatch) -> None:
    """A helper that does not answer (SIGSTOP) holds no request for longer than the helper's
    time: it is killed, the body parsed in process, and a new helper serves the next body."""
    body = orjson.dumps(_check_body())
    json_bodies.HELPERS.call(int)  # started
    pool = json_bodies.HELPERS.executor()
    (helper,) = list(pool._processes)
    monkeypatch.setattr(json_bodies.HELPERS, "timeout_s", 1.0)
    os.kill(helper, signal.SIGSTOP)
    try:
        answer = api.post("/v1/robots/ur5/trajectory-check", content=body, headers=JSON)
        assert answer.status_code == 200, answer.text[:300]
        assert not wait_ended({helper}, 30.0), "the stopped helper is still there"
        assert json_bodies.HELPERS.executor() is not pool
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(helper, signal.SIGKILL)
    monkeypatch.undo()
    again = api.post("/v1/robots/ur5/trajectory-check", content=body, headers=JSON)
    assert again.json() == answer.json()
    assert json_bodies.HELPERS.call(os.getpid) != os.getpid()  # served by a helper again


@pytest.mark.parametrize("value", [[[0.1] * 6, [0.2] * 5], [], [{"a": 1.0}]])
def test_inputs_that_are_not_rows_of_numbers_stay_as_they_are(value: Any) -> None:
    compact = json_bodies.compact(value)
    assert compact is value


def test_a_large_identify_log_parsed_in_the_helper_fits_the_same(
    small_app_factory, monkeypatch
) -> None:
    from service.api.routes import identification as identification_routes
    from tests.service.dynamics.identification_logs import synthetic_log

    api = small_app_factory(catalog="ur5")
    model = api.app.state.registry.get("ur5").model
    log = synthetic_log(model, seed=2, duration=16.0, rate=1000.0, noise=0.05)
    body = {
        "t": log.t.tolist(),
        "q": log.q.tolist(),
        "tau": log.tau.tolist(),
        "method": "least-squares",
        "store": False,
    }
    raw = orjson.dumps(body)
    assert len(raw) > json_bodies.ISOLATED_JSON_BYTES
    calls: list[Any] = []
    real = json_bodies.parse_isolated
    monkeypatch.setattr(
        identification_routes, "parse_isolated", lambda *args: calls.append(args[0]) or real(*args)
    )
    isolated = api.post("/v1/robots/ur5/identify", content=raw, headers=JSON)
    body["tau"][5000][2] = "NaN"
    refused = api.post("/v1/robots/ur5/identify", content=orjson.dumps(body), headers=JSON)
    assert len(calls) == 2
    monkeypatch.setattr(identification_routes, "ISOLATED_JSON_BYTES", 1 << 40)
    inline = api.post("/v1/robots/ur5/identify", content=raw, headers=JSON)
    refused_inline = api.post("/v1/robots/ur5/identify", content=orjson.dumps(body), headers=JSON)
    assert len(calls) == 2
    assert isolated.status_code == 200, isolated.text[:300]
    assert isolated.json() == inline.json()
    assert refused.status_code == 422 and refused.json() == refused_inline.json()
