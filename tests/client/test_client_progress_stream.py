"""Progress of one long computation (a trajectory check, a retiming, an identification): the
client asks the server for its progress stream, reports the server's counts, and returns the
same result as without progress; errors in the stream raise the error of their code."""

from __future__ import annotations

import asyncio
import re
import time
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import AsyncClient, Client

from tests.client.helpers import API_KEY
from tests.service.dynamics.identification_logs import synthetic_log


def _motion(n: int, seconds: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, seconds, n)
    return t, np.stack([0.4 * np.sin((j + 1) * 0.3 * t) for j in range(6)], axis=1)


def test_a_long_check_reports_the_servers_evaluated_points(server: str) -> None:
    t, q = _motion(20_000)
    seen: list[tuple[int, int]] = []
    with Client(server) as client:
        plain = client.trajectory_check("ur5", t, q, samples_per_interval=16)
        check = client.trajectory_check(
            "ur5", t, q, samples_per_interval=16, progress=lambda *a: seen.append(a)
        )
    evaluated = (t.size - 1) * 16 + 1
    assert len(seen) >= 2 and all(total == evaluated for _, total in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert seen[-1] == (evaluated, evaluated)  # completed once the answer is in
    assert check.feasible == plain.feasible and check.violations == plain.violations
    np.testing.assert_array_equal(check.tau, plain.tau)


def test_identify_reports_its_stages_and_the_async_client_too(server: str, registry: Any) -> None:
    log = synthetic_log(registry.get("ur5").model, seed=5, duration=8.0, rate=200.0, noise=0.05)
    seen: list[tuple[int, int]] = []

    async def identified() -> robodyn.Identification:
        async with AsyncClient(server, api_key=API_KEY) as client:
            return await client.identify(
                "ur5", log.t, log.q, log.tau, store=False, progress=lambda *a: seen.append(a)
            )

    with Client(server, api_key=API_KEY) as client:
        plain = client.identify("ur5", log.t, log.q, log.tau, store=False)
    result = asyncio.run(identified())
    assert seen and all(total == 5 for _, total in seen) and seen[-1] == (5, 5)
    np.testing.assert_array_equal(result.parameters, plain.parameters)


def test_a_refused_request_raises_before_any_progress(server: str) -> None:
    seen: list[tuple[int, int]] = []
    t, q = _motion(100)
    with Client(server) as client, pytest.raises(robodyn.DimensionMismatchError):
        client.trajectory_check("ur5", t, q[:, :5], progress=lambda *a: seen.append(a))
    assert seen == []


def test_a_problem_line_raises_its_error_after_the_progress_before_it() -> None:
    stream = (
        b'{"progress":{"done":1,"total":3,"unit":"step","stage":"path"}}\n'
        b'{"problem":{"type":"about:blank","title":"Deadline exceeded","status":504,'
        b'"detail":"retime: stopped","code":"deadline_exceeded"}}\n'
    )

    def handler(request: httpx.Request) -> httpx.Response:
        assert request.headers["accept"].startswith("application/x-ndjson")
        return httpx.Response(200, content=stream, headers={"content-type": "application/x-ndjson"})

    seen: list[tuple[int, int]] = []
    http = httpx.Client(transport=httpx.MockTransport(handler), base_url="http://robodyn.test")
    with Client(http_client=http) as client, pytest.raises(robodyn.DeadlineExceededError) as raised:
        client.retime("ur5", np.zeros((2, 6)), progress=lambda *a: seen.append(a))
    assert seen == [(1, 3)]
    assert raised.value.status == 504 and raised.value.detail == "retime: stopped"


def test_a_stream_cut_before_its_answer_is_a_format_error() -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        return httpx.Response(
            200,
            content=b'{"progress":{"done":1,"total":3,"unit":"x"}}\n',
            headers={"content-type": "application/x-ndjson"},
        )

    http = httpx.Client(transport=httpx.MockTransport(handler), base_url="http://robodyn.test")
    with (
        Client(http_client=http) as client,
        pytest.raises(robodyn.ResponseFormatError, match="ended before the answer"),
    ):
        client.retime("ur5", np.zeros((2, 6)), progress=lambda *a: None)


def test_progress_true_shows_the_stage_in_a_tqdm_bar(
    server: str, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("tqdm")
    t, q = _motion(20_000)
    with Client(server, progress=True) as client:
        client.trajectory_check("ur5", t, q, samples_per_interval=16)
    evaluated = (t.size - 1) * 16 + 1
    err = capsys.readouterr().err
    assert "inverse dynamics" in err and f"{evaluated}/{evaluated}" in err


def _stopped_by_disconnect(server: str) -> float:
    text = httpx.get(server + "/metrics", timeout=10).text
    found = re.search(r'robodyn_computations_stopped_total\{reason="disconnect"\} (\S+)', text)
    return float(found.group(1)) if found else 0.0


def test_leaving_a_stream_stops_its_computation(server: str) -> None:
    """A client that reads the first progress line and closes the connection: the check stops
    (counted as stopped by a disconnect) and the server keeps answering."""
    t, q = _motion(30_000, seconds=100.0)
    body = {"t": t.tolist(), "q": q.tolist(), "samples_per_interval": 32}
    before = _stopped_by_disconnect(server)
    with (
        httpx.Client(timeout=60) as http,
        http.stream(
            "POST",
            server + "/v1/robots/ur5/trajectory-check",
            json=body,
            headers={"accept": "application/x-ndjson"},
        ) as response,
    ):
        first = next(response.iter_lines())
    assert first.startswith('{"progress":'), first[:200]
    deadline = time.monotonic() + 20
    while _stopped_by_disconnect(server) == before and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _stopped_by_disconnect(server) == before + 1
    assert httpx.get(server + "/health/live", timeout=10).status_code == 200
