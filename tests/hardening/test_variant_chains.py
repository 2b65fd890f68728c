"""A deep chain of variants on a real server: each level costs about the same to create, and a
server restarted on the store is ready within seconds and serves the deepest level, built on
first use while /health/live keeps answering. Measured times, so in the slow suite; the bounds
are generous for a busy 2-core machine (a level takes milliseconds).
"""

from __future__ import annotations

import time

import httpx
import numpy as np
import pytest

from tests.hardening.health_probe import health_latencies_during
from tests.helpers import planar_arm_closed_form
from tests.servers import running_server

pytestmark = pytest.mark.slow

LEVELS = 22
LEVEL_S = 0.5  # the most one level may take to create
READY_S = 30.0  # the most a restart may take to be ready
MASS = 0.05  # kg added at link2's tip by each level


def test_a_22_level_chain_is_linear_to_create_and_restarts_ready(tmp_path) -> None:
    data = tmp_path / "data"
    chain: list[str] = []
    with running_server(data, catalog="planar_arm") as url, httpx.Client(timeout=60) as http:
        parent = "planar_arm"
        body = {"payloads": [{"frame": "link2", "mass": MASS, "center_of_mass": [0.7, 0, 0]}]}
        costs = []
        for _ in range(LEVELS):
            started = time.perf_counter()
            r = http.post(f"{url}/v1/robots/{parent}/variants", json=body)
            costs.append(time.perf_counter() - started)
            assert r.status_code == 201, r.text
            parent = r.json()["id"]
            chain.append(parent)
        assert max(costs) <= LEVEL_S, [round(c, 3) for c in costs]

    started = time.perf_counter()
    with running_server(data, catalog="planar_arm") as url, httpx.Client(timeout=60) as http:
        ready_after = time.perf_counter() - started
        assert ready_after <= READY_S, ready_after

        # the deepest level, built on first use, while /health/live keeps answering
        q = [0.3, -0.6]
        answer, latencies = health_latencies_during(
            url, lambda: http.post(f"{url}/v1/robots/{chain[-1]}/mass-matrix", json={"q": q})
        )
        assert answer.status_code == 200, answer.text
        # robots/textbook/planar_arm.urdf: l1 = 1 m, l2 = 0.7 m, m1 = 2 kg, m2 = 1.5 kg
        m2 = 1.5 + LEVELS * MASS
        want, _, _ = planar_arm_closed_form(1.0, 0.7, 2.0, m2, np.array(q), np.zeros(2))
        np.testing.assert_allclose(answer.json()["mass_matrix"], want, rtol=1e-12)
        assert max(latencies) <= LEVEL_S, max(latencies)
        listed = http.get(f"{url}/v1/robots").json()
        assert set(chain) <= {r["id"] for r in listed["robots"]}
