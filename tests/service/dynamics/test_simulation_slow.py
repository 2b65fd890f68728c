"""Long simulations against a real server (marker `slow`): a rollout at the step limit runs off
the event loop, so other requests keep being answered quickly meanwhile."""

from __future__ import annotations

import threading
import time

import httpx
import numpy as np
import pytest

from tests.client.helpers import running_server

pytestmark = pytest.mark.slow


def test_a_long_simulation_does_not_stall_other_requests(tmp_path) -> None:
    with running_server(tmp_path, catalog="ur5,talos") as url:
        body = {
            "q": [0.1, -1.0, 1.0, 0.0, 0.5, 0.0],
            "v": [0.0] * 6,
            "dt": 1e-4,
            "steps": 100_000,
            "integrator": "rk4",
        }
        result: dict[str, object] = {}

        def long_run() -> None:
            began = time.perf_counter()
            r = httpx.post(f"{url}/v1/robots/ur5/simulate", json=body, timeout=300)
            result.update(
                status=r.status_code,
                seconds=time.perf_counter() - began,
                energy=np.asarray(r.json()["mechanical_energy"]),
            )

        worker = threading.Thread(target=long_run)
        worker.start()
        time.sleep(0.5)  # let the rollout start
        latencies = []
        with httpx.Client(base_url=url, timeout=30) as client:
            while worker.is_alive() and len(latencies) < 200:
                began = time.perf_counter()
                r = client.post("/v1/robots/ur5/gravity", json={"q": [0.0] * 6})
                latencies.append(time.perf_counter() - began)
                assert r.status_code == 200
        worker.join(timeout=300)
        assert result["status"] == 200, result
        assert len(latencies) >= 5, "the rollout ended before it could be observed"
        print(
            f"\nrollout of 100000 rk4 steps: {result['seconds']:.1f} s; "
            f"{len(latencies)} gravity requests meanwhile, median "
            f"{1e3 * float(np.median(latencies)):.1f} ms, max {1e3 * max(latencies):.1f} ms"
        )
        assert float(np.median(latencies)) < 0.1
        energy = result["energy"]
        assert isinstance(energy, np.ndarray) and energy.shape == (100_001,)
        assert np.abs(energy - energy[0]).max() <= 1e-6 * abs(energy[0])


def test_the_largest_allowed_talos_rollout_finishes(tmp_path) -> None:
    """talos, 100000 rk4 steps: 1e5 × 38 × 4 = 1.5e7 work, under the default limit of 2e7."""
    with running_server(tmp_path, catalog="talos") as url:
        info = httpx.get(f"{url}/v1/robots/talos").json()
        body = {
            "q": info["default_configuration"],
            "v": [0.0] * info["nv"],
            "dt": 1e-4,
            "steps": 100_000,
            "integrator": "rk4",
        }
        began = time.perf_counter()
        r = httpx.post(f"{url}/v1/robots/talos/simulate", json=body, timeout=600)
        print(
            f"\ntalos 100000 rk4 steps: {time.perf_counter() - began:.1f} s, "
            f"{len(r.content) / 1e6:.0f} MB of JSON"
        )
        assert r.status_code == 200
        q = np.asarray(r.json()["q"])
        np.testing.assert_allclose(np.linalg.norm(q[:, 3:7], axis=1), 1.0, atol=1e-12)
