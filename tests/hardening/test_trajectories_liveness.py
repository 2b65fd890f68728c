"""A long trajectory check (10,000 samples, 16 points per interval: 160,000 RNEA states plus
the spline) and a retiming keep `/health/live` answering: both run off the event loop."""

from __future__ import annotations

import httpx
import numpy as np
import orjson
import pytest

from tests.hardening.health_probe import health_latencies_during
from tests.servers import running_server


@pytest.mark.slow  # a latency bound: with the other /health/live probes in the slow suite
def test_long_trajectory_work_does_not_stall_health(tmp_path) -> None:
    t = np.linspace(0.0, 20.0, 10_000)
    q = 0.8 * np.sin(0.5 * t[:, None] + np.linspace(0.0, 2.0, 6)[None, :])
    check = orjson.dumps({"t": t.tolist(), "q": q.tolist(), "samples_per_interval": 16})
    waypoints = np.random.default_rng(0).uniform(-2.0, 2.0, (40, 6)).tolist()
    with running_server(tmp_path, catalog="ur5") as base:

        def work() -> list[httpx.Response]:
            with httpx.Client(base_url=base, timeout=300) as client:
                return [
                    client.post(
                        "/v1/robots/ur5/trajectory-check",
                        content=check,
                        headers={"content-type": "application/json"},
                    ),
                    client.post("/v1/robots/ur5/retime", json={"waypoints": waypoints}),
                ]

        answers, latencies = health_latencies_during(base, work)
    assert [a.status_code for a in answers] == [200, 200], [a.text[:200] for a in answers]
    assert len(latencies) > 20
    assert np.percentile(latencies, 99) < 0.25, sorted(latencies)[-5:]
    # every probe within 0.5 s on a machine without other work (alone: under 0.1 s; a probe of
    # 0.53 s was seen with the whole suite running beside other work on two cores)
    assert max(latencies) < 0.5, sorted(latencies)[-5:]


@pytest.mark.slow  # a latency bound
def test_the_largest_json_check_is_parsed_without_stalling_health(tmp_path) -> None:
    """A 15 MB JSON body (100,000 samples) takes ~0.15 s of GIL to parse: it is parsed in the
    helper process (service.api.json_bodies), so /health/live answers in milliseconds."""
    t = np.linspace(0.0, 100.0, 100_000)
    q = 0.8 * np.sin(0.5 * t[:, None] + np.linspace(0.0, 2.0, 6)[None, :])
    check = orjson.dumps({"t": t.tolist(), "q": q.tolist(), "samples_per_interval": 2})
    assert len(check) > 10_000_000
    with running_server(tmp_path, catalog="ur5") as base:

        def work() -> list[httpx.Response]:
            with httpx.Client(base_url=base, timeout=300) as client:
                return [
                    client.post(
                        "/v1/robots/ur5/trajectory-check",
                        content=check,
                        headers={"content-type": "application/json"},
                    )
                    for _ in range(3)
                ]

        answers, latencies = health_latencies_during(base, work)
    assert [a.status_code for a in answers] == [200] * 3, [a.text[:200] for a in answers]
    assert len(latencies) > 20
    # (parsed on the event loop's side a body takes 0.2-0.25 s; in the helper about 0.02 s)
    assert np.percentile(latencies, 99) < 0.1, sorted(latencies)[-5:]
