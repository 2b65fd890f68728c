"""What a request may cost while it runs: a long computation stops at the request's deadline
(ROBODYN_REQUEST_DEADLINE_S, 504 `deadline_exceeded`) and when its client disconnects —
rollouts between steps, contact batches between states, other batches between chunks; and
the bytes of large answers held for their clients are bounded in total
(ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT)."""

from __future__ import annotations

import asyncio
import time

import numpy as np
import orjson
import pinocchio as pin
import pytest

from service.api.cancellation import STOPPED
from service.api.encoding.in_flight import LARGE_ANSWER_BYTES
from service.registry.catalog import load_catalog
from tests.service.api.encoding.test_binary import BIN, encode_request
from tests.service.api.problems.test_errors import assert_problem
from tests.service.dynamics.contacts.test_quantities import contacts_of

UR5_Q = [0.1, -1.0, 1.2, 0.3, 0.5, -0.2]
STATE_ARRAYS = ("q", "v", "a", "tau")
SOLO_Q = [0, 0, 0.235, 0, 0, 0, 1, 0.1, 0.8, -1.6, -0.1, 0.8, -1.6, 0.1, -0.8, 1.6, -0.1, -0.8, 1.6]
# Each takes seconds on one core (measured: 2-10 s), far past the deadlines set below.
LONG = {
    "simulate": (
        "ur5",
        {"q": UR5_Q, "v": [0.0] * 6, "dt": 1e-4, "steps": 100_000, "integrator": "rk4"},
    ),
    "contact-dynamics": (
        "solo12",
        {
            "q": [SOLO_Q] * 60_000,
            "v": [[0.0] * 18] * 60_000,
            "tau": [[0.0] * 18] * 60_000,
            "contacts": contacts_of("solo12"),
        },
    ),
    "forward-dynamics-derivatives": (
        "ur5",
        {"q": [UR5_Q] * 90_000, "v": [[0.1] * 6] * 90_000, "tau": [[0.0] * 6] * 90_000},
    ),
}


@pytest.fixture(scope="module")
def bodies() -> dict[str, tuple[bytes, str]]:
    """Each long request's body and content type: the batches in the binary form (read in
    milliseconds, where their JSON takes seconds to parse: a request's time is then its
    computing), the rollout as JSON."""
    out = {"simulate": (orjson.dumps(LONG["simulate"][1]), "application/json")}
    for quantity, (_, body) in LONG.items():
        if quantity != "simulate":
            arrays = {k: np.array(v, dtype=float) for k, v in body.items() if k in STATE_ARRAYS}
            options = {k: v for k, v in body.items() if k not in STATE_ARRAYS}
            out[quantity] = (encode_request(arrays, options), BIN)
    return out


@pytest.mark.parametrize("quantity", list(LONG))
def test_a_long_computation_stops_at_the_request_deadline(small_app_factory, bodies, quantity):
    api = small_app_factory(catalog="ur5,solo12", request_deadline_s=0.2)
    robot = LONG[quantity][0]
    before = STOPPED["deadline"]
    content, content_type = bodies[quantity]
    started = time.perf_counter()
    r = api.post(
        f"/v1/robots/{robot}/{quantity}", content=content, headers={"content-type": content_type}
    )
    elapsed = time.perf_counter() - started
    problem = assert_problem(r, 504, "deadline_exceeded")
    assert "retry-after" not in r.headers  # the same request would stop again
    assert "ROBODYN_REQUEST_DEADLINE_S" in problem["detail"] and problem["deadline_s"] == 0.2
    assert STOPPED["deadline"] == before + 1
    # Reading the body and 0.2 s of computing: well under a second, and far from the bound on a
    # loaded machine too; the 504 and the counter are what show the stop.
    assert elapsed < 10.0


def test_a_short_computation_is_not_concerned_by_the_deadline(small_app_factory):
    api = small_app_factory(catalog="ur5", request_deadline_s=5.0)
    r = api.post("/v1/robots/ur5/simulate", json={**LONG["simulate"][1], "steps": 2_000})
    assert r.status_code == 200, r.text
    assert len(r.json()["q"]) == 2_001
    rng = np.random.default_rng(7)
    q, v, a = (rng.uniform(-2, 2, (30_000, 6)) for _ in range(3))
    chunked = api.post(
        "/v1/robots/ur5/inverse-dynamics", json={"q": q.tolist(), "v": v.tolist(), "a": a.tolist()}
    )
    assert chunked.status_code == 200  # computed in chunks of 8,333 states, each in its place
    tau = np.array(chunked.json()["tau"])
    assert tau.shape == (30_000, 6)
    ur5 = load_catalog(["ur5"])[0]["ur5"]
    data = ur5.model.createData()
    for i in (0, 8_332, 8_333, 16_666, 29_999):
        expected = pin.rnea(ur5.model, data, q[i], v[i], a[i])
        np.testing.assert_allclose(tau[i], expected, rtol=1e-12, atol=1e-9)


def _scope(path: str, body: bytes, content_type: str) -> dict:
    return {
        "type": "http",
        "asgi": {"version": "3.0"},
        "http_version": "1.1",
        "method": "POST",
        "scheme": "http",
        "path": path,
        "raw_path": path.encode(),
        "root_path": "",
        "query_string": b"",
        "server": ("testserver", 80),
        "client": ("127.0.0.1", 5000),
        "headers": [
            (b"host", b"testserver"),
            (b"content-type", content_type.encode()),
            (b"content-length", str(len(body)).encode()),
        ],
    }


async def _call_then_disconnect(
    app, path: str, body: bytes, content_type: str, after_s: float
) -> tuple:
    """Call the ASGI app with `body`, the client disconnecting `after_s` s after the body
    was read: (seconds the app took, messages it sent)."""
    gone = asyncio.Event()
    sent: list[dict] = []
    read = False

    async def receive() -> dict:
        nonlocal read
        if not read:
            read = True
            asyncio.get_running_loop().call_later(after_s, gone.set)
            return {"type": "http.request", "body": body, "more_body": False}
        await gone.wait()
        return {"type": "http.disconnect"}

    async def send(message: dict) -> None:
        sent.append(message)

    started = time.perf_counter()
    await app(_scope(path, body, content_type), receive, send)
    return time.perf_counter() - started, sent


@pytest.mark.parametrize("quantity", list(LONG))
def test_a_disconnect_stops_the_computation(small_app_factory, bodies, quantity):
    """The client goes away 0.3 s after sending: the worker stops (the counter of stopped
    computations says so) and the app returns well before the computation would end."""
    api = small_app_factory(catalog="ur5,solo12")  # the default deadline: 60 s
    robot = LONG[quantity][0]
    before = STOPPED["disconnect"]
    content, content_type = bodies[quantity]
    elapsed, sent = asyncio.run(
        _call_then_disconnect(api.app, f"/v1/robots/{robot}/{quantity}", content, content_type, 0.3)
    )
    assert STOPPED["disconnect"] == before + 1  # asked while computing: it had not finished
    assert elapsed < 10.0, elapsed
    assert api.app.state.batches_in_flight == 0 and api.app.state.answers_in_flight.held == 0
    assert sent[0]["status"] == 503  # (written to a connection that is gone)


def test_answer_bytes_in_flight_are_bounded_in_total(small_app_factory):
    """Large answers reserve their size until sent: past the limit in total a request is
    503 overloaded with Retry-After before computing; once the others are sent it passes."""
    limit = 8 * LARGE_ANSWER_BYTES
    api = small_app_factory(catalog="ur5", max_answer_bytes_in_flight=limit)
    in_flight = api.app.state.answers_in_flight
    body = {"q": [UR5_Q] * 20_000}  # mass matrices: 720,000 numbers, ~18 MB of JSON
    small = {"q": [UR5_Q] * 2_000}  # ~1.8 MB
    held = in_flight.reserve(limit - LARGE_ANSWER_BYTES)  # answers not read by their clients
    try:
        problem = assert_problem(
            api.post("/v1/robots/ur5/mass-matrix", json=small), 503, "overloaded"
        )
        assert "ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT" in problem["detail"]
        assert problem["answer_bytes_in_flight"] == held
        assert problem["answer_bytes"] >= 2_000 * 36 * 20  # at least 20 bytes a number
    finally:
        in_flight.release(held)
    for request in (small, body):  # alone, even one over the limit passes (it is bounded
        r = api.post("/v1/robots/ur5/mass-matrix", json=request)  # by the answer budget)
        assert r.status_code == 200
        assert in_flight.held == 0  # released once sent
    bad = api.post("/v1/robots/ur5/mass-matrix", json={"q": [[0.0] * 5] * 20_000})
    assert bad.status_code == 422 and in_flight.held == 0


def test_a_refused_work_names_what_fits_and_that_passes(small_app_factory):
    """Over ROBODYN_MAX_WORK (contacts) or ROBODYN_MAX_SIMULATION_WORK (a plain rollout), the
    422 names the limit and the steps or states that fit; those are admitted, one more not."""
    contact_api = small_app_factory(catalog="solo12", max_work=200_000)
    plain_api = small_app_factory(catalog="solo12", max_simulation_work=20_000)
    start = {"q": SOLO_Q, "v": [0.0] * 18, "dt": 1e-3, "integrator": "rk4"}
    for api, extra, limit in (
        (contact_api, {"contacts": contacts_of("solo12")}, "ROBODYN_MAX_WORK"),
        (plain_api, {}, "ROBODYN_MAX_SIMULATION_WORK"),
    ):
        body = {**start, **extra, "steps": 50_000}
        problem = assert_problem(
            api.post("/v1/robots/solo12/simulate", json=body), 422, "validation_error"
        )
        fits = problem["largest_steps"]
        assert limit in problem["detail"] and f"at most {fits:,} steps" in problem["detail"]
        assert 1 <= fits < 50_000 and problem["work"] > problem["max_work"]
        ok = api.post("/v1/robots/solo12/simulate", json={**body, "steps": fits})
        assert ok.status_code == 200, ok.text[:300]
        assert (
            api.post("/v1/robots/solo12/simulate", json={**body, "steps": fits + 1}).status_code
            == 422
        )
    batch = {
        "q": [SOLO_Q] * 5_000,
        "v": [[0.0] * 18] * 5_000,
        "tau": [[0.0] * 18] * 5_000,
        "contacts": contacts_of("solo12"),
    }
    problem = assert_problem(
        contact_api.post("/v1/robots/solo12/contact-dynamics", json=batch), 422, "validation_error"
    )
    fits = problem["largest_batch"]
    assert 1 <= fits < 5_000 and f"at most {fits:,} states" in problem["detail"]
    assert (
        contact_api.post(
            "/v1/robots/solo12/contact-dynamics",
            json={
                k: v[:fits] if isinstance(v, list) and k != "contacts" else v
                for k, v in batch.items()
            },
        ).status_code
        == 200
    )


def test_a_100000_state_contact_batch_is_refused_at_once(api, catalog_registry):
    """100,000 Solo-12 states with 16 damped 6d contacts (minutes of computing; its answer
    fits the answer budget in the binary form): refused by its estimated work before anything
    is computed, naming the states that fit."""
    solo = catalog_registry.catalog["solo12"]
    n = 100_000
    q = np.repeat(np.array(SOLO_Q, dtype=float)[None], n, 0)
    six_d = [
        {"frame": f.name, "type": "6d"}
        for f in solo.model.frames
        if f.type == pin.FrameType.BODY and f.parentJoint > 1
    ]
    body = encode_request(
        {"q": q, "v": np.zeros((n, 18)), "tau": np.zeros((n, 18))},
        {"contacts": (six_d * 16)[:16], "damping": 0.1},
    )
    started = time.perf_counter()
    r = api.post(
        "/v1/robots/solo12/contact-dynamics",
        content=body,
        headers={"content-type": BIN, "accept": BIN},
    )
    problem = assert_problem(r, 422, "validation_error")
    assert "ROBODYN_MAX_WORK" in problem["detail"] and "100000 states" in problem["detail"]
    assert 0 < problem["largest_batch"] < 100_000 and problem["work"] > problem["max_work"]
    assert time.perf_counter() - started < 5.0
