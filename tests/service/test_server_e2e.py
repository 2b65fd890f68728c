"""A real server (`python -m service`) in a subprocess on a free loopback port: start-up,
readiness, and many threads of mixed robots and quantities compared with in-process Pinocchio."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pinocchio as pin
import pytest

from tests.helpers import mass_matrix, random_state
from tests.servers import running_server

ROBOTS = ["ur5", "panda", "talos", "solo12", "double_pendulum_continuous"]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("e2e"), catalog=",".join(ROBOTS)) as base:
        yield base


def _expected(model, quantity, q, v, a):
    data = model.createData()
    if quantity == "mass-matrix":
        return {"mass_matrix": mass_matrix(model, q)}
    if quantity == "gravity":
        return {"gravity": pin.computeGeneralizedGravity(model, data, q)}
    if quantity == "coriolis":
        C = pin.computeCoriolisMatrix(model, data, q, v)
        return {"coriolis_matrix": C, "coriolis_forces": C @ v}
    if quantity == "nonlinear-effects":
        return {"nonlinear_effects": pin.nonLinearEffects(model, data, q, v)}
    if quantity == "inverse-dynamics":
        return {"tau": pin.rnea(model, data, q, v, a)}
    return {"a": pin.aba(model, data, q, v, a)}


INPUTS = {
    "mass-matrix": "q",
    "gravity": "q",
    "coriolis": "qv",
    "nonlinear-effects": "qv",
    "inverse-dynamics": "qva",
    "forward-dynamics": "qvt",
}


def test_concurrent_mixed_requests_match_pinocchio(server, catalog_registry):
    rng = np.random.default_rng(11)
    jobs = []
    for i in range(240):
        robot = ROBOTS[i % len(ROBOTS)]
        quantity = list(INPUTS)[(i // len(ROBOTS)) % len(INPUTS)]
        model = catalog_registry.catalog[robot].model
        batch = 64 if i % 7 == 0 else 1  # some large enough to be computed in worker threads
        states = [random_state(model, rng) for _ in range(batch)]
        jobs.append((robot, quantity, states))

    def run(job):
        robot, quantity, states = job
        qs, vs, as_ = (np.stack(x) for x in zip(*states, strict=True))
        names = {"q": ("q", qs), "v": ("v", vs), "a": ("a", as_), "t": ("tau", as_)}
        body = {
            names[c][0]: (names[c][1] if len(states) > 1 else names[c][1][0]).tolist()
            for c in INPUTS[quantity]
        }
        with httpx.Client(timeout=30) as http:
            r = http.post(f"{server}/v1/robots/{robot}/{quantity}", json=body)
        return job, r

    with ThreadPoolExecutor(max_workers=16) as pool:
        results = list(pool.map(run, jobs, timeout=120))
    for (robot, quantity, states), r in results:
        assert r.status_code == 200, r.text
        model = catalog_registry.catalog[robot].model
        got = r.json()
        for i, (q, v, a) in enumerate(states):
            for key, value in _expected(model, quantity, q, v, a).items():
                answer = np.asarray(got[key])
                answer = answer[i] if len(states) > 1 else answer
                np.testing.assert_allclose(
                    answer, value, rtol=1e-12, atol=1e-12 * max(1, np.abs(value).max())
                )


def test_real_server_errors_are_problems(server):
    r = httpx.post(
        f"{server}/v1/robots/ur5/gravity",
        content=b'{"q": [0,0,0,0,0,NaN]}',
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 422 and r.json()["code"] == "validation_error"
    assert r.headers["content-type"] == "application/problem+json"


def test_real_server_upload_builds_out_of_process(server):
    from tests.helpers import planar_arm_closed_form, planar_arm_urdf

    r = httpx.post(
        f"{server}/v1/robots", json={"urdf": planar_arm_urdf(1.1, 0.4, 2.0, 1.0)}, timeout=60
    )
    assert r.status_code == 201, r.text
    robot_id = r.json()["id"]
    q = [0.4, -0.9]
    M = httpx.post(f"{server}/v1/robots/{robot_id}/mass-matrix", json={"q": q}).json()
    expected, _, _ = planar_arm_closed_form(1.1, 0.4, 2.0, 1.0, np.array(q), np.zeros(2))
    np.testing.assert_allclose(M["mass_matrix"], expected, rtol=1e-10)
    assert httpx.delete(f"{server}/v1/robots/{robot_id}").status_code == 204
