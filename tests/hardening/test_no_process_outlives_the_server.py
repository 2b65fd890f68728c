"""No process of `python -m service` outlives it: with its process-wide helpers all started (the
forkserver, the JSON helper, the identification worker, multiprocessing's resource tracker),
every process of its tree ends when the server is killed with SIGKILL (nothing of it runs any
more) or stopped with SIGTERM, and with `--workers 2` when the supervisor is killed. Only the
server process itself is signalled (its process group is not): what ends, ends by itself."""

from __future__ import annotations

import contextlib
import os
import signal

import httpx
import numpy as np
import orjson
import pytest

from tests.descendants import command_line, descendants, ended, wait_ended
from tests.service.api.encoding.test_binary import BIN, encode_request

pytestmark = pytest.mark.slow

END_S = 30.0  # every process of the tree ends within this once the server is gone
CATALOG = "ur5"


def _start_every_helper(base: str, requests: int = 1) -> None:
    """Requests that start the forkserver (an equations derivation), the JSON helper (a JSON
    body over 2 MiB) and the identification worker (a fit), `requests` times each (one per
    serving process, most likely, with --workers 2)."""
    t = np.linspace(0.0, 20.0, 30_000)
    q = 0.4 * np.sin(t[:, None] * np.linspace(0.3, 1.8, 6)[None, :])
    large = orjson.dumps({"t": t.tolist(), "q": q.tolist()})
    log_t = np.linspace(0.0, 6.0, 301)
    log_q = 0.5 * np.sin(log_t[:, None] * np.linspace(0.5, 2.0, 6)[None, :])
    fit = encode_request(
        {"t": log_t, "q": log_q, "tau": np.cos(log_q)}, {"method": "least-squares", "store": False}
    )
    with httpx.Client(base_url=base, timeout=300) as client:
        for _ in range(requests):
            assert client.get("/v1/robots/ur5/equations").status_code == 200
            checked = client.post(
                "/v1/robots/ur5/trajectory-check",
                content=large,
                headers={"content-type": "application/json"},
            )
            assert checked.status_code == 200, checked.text[:300]
            identified = client.post(
                "/v1/robots/ur5/identify", content=fit, headers={"content-type": BIN}
            )
            assert identified.status_code in (200, 422), identified.text[:300]  # it ran


def _helpers_end_with(server, sig: int, workers: int = 1) -> None:
    _start_every_helper(server.base, requests=2 * workers)
    tree = descendants(server.proc.pid)
    commands = " ".join(tree.values())
    for kind in ("forkserver", "spawn_main", "resource_tracker"):
        assert kind in commands, tree
    try:
        os.kill(server.proc.pid, sig)  # the server process only, not its group
        server.proc.wait(timeout=90)
        left = wait_ended(set(tree), END_S)
        assert not left, {pid: tree[pid] for pid in left}
    finally:
        for pid, command in tree.items():  # nothing of a failed run is left behind
            if not ended(pid) and command_line(pid) == command:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)


def test_every_helper_ends_when_the_server_is_killed(server_factory):
    _helpers_end_with(server_factory(catalog=CATALOG).start(), signal.SIGKILL)


def test_every_helper_ends_when_the_server_is_stopped(server_factory):
    _helpers_end_with(server_factory(catalog=CATALOG).start(), signal.SIGTERM)


def test_every_process_ends_when_the_supervisor_of_two_workers_is_killed(server_factory):
    """uvicorn's supervisor spawns the serving processes: they end with it, and their
    helpers with them."""
    _helpers_end_with(server_factory(catalog=CATALOG, workers=2).start(), signal.SIGKILL, 2)
