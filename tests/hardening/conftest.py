"""Fixtures of the hardening suite: apps wired exactly as `python -m service` wires them, and real
servers in subprocesses on free loopback ports."""

from __future__ import annotations

import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.settings import Settings

LEAK = re.compile(r"Traceback|\.hxx|\.hpp|\.cpp|\.py\b|/usr/|/work/|site-packages|File \"")
REPO = Path(__file__).resolve().parents[2]


def wait_ready(get: Callable[[str], httpx.Response], timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            if get("/health/ready").status_code == 200:
                return
        except httpx.TransportError:
            pass
        assert time.monotonic() < deadline, f"not ready in {timeout_s} s"
        time.sleep(0.1)


@pytest.fixture
def app_factory(tmp_path: Path) -> Iterator[Callable[..., TestClient]]:
    """TestClient over `create_app(Settings(...))`: the production wiring, catalog loaded by
    the lifespan; settings given as keyword arguments."""
    clients: list[TestClient] = []

    def build(catalog: str = "ur5", **settings_kw: object) -> TestClient:
        settings_kw.setdefault("data_dir", tmp_path / "data")
        settings = Settings(catalog=catalog, **settings_kw)  # type: ignore[arg-type]
        client = TestClient(create_app(settings), raise_server_exceptions=False)
        client.__enter__()
        clients.append(client)
        wait_ready(client.get)
        return client

    yield build
    for client in clients:
        client.__exit__(None, None, None)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Server:
    """`python -m service` in a subprocess (its own process group) on a free loopback port."""

    def __init__(
        self,
        data_dir: Path,
        *,
        workers: int = 1,
        catalog: str = "ur5,planar_arm",
        env: dict[str, str] | None = None,
        port: int | None = None,
    ) -> None:
        self.data_dir, self.workers, self.catalog = data_dir, workers, catalog
        self.extra_env = env or {}
        self.port = port or free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.proc: subprocess.Popen[bytes] | None = None
        self.log = data_dir.parent / f"server-{self.port}.log"

    def start(self, ready: bool = True) -> Server:
        env = {
            **os.environ,
            "ROBODYN_DATA_DIR": str(self.data_dir),
            "ROBODYN_CATALOG": self.catalog,
            "ROBODYN_LOG_LEVEL": "warning",
            **self.extra_env,
        }
        with self.log.open("ab") as log:
            self.proc = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "service",
                    "--port",
                    str(self.port),
                    "--workers",
                    str(self.workers),
                ],
                env=env,
                cwd=REPO,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
        if ready:
            wait_ready(lambda path: httpx.get(self.base + path, timeout=2))
        return self

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def kill(self, sig: int = signal.SIGKILL) -> None:
        """Signal the whole process group (server, workers, builder children)."""
        assert self.proc is not None
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, sig)
        self.proc.wait(timeout=60)

    def stop(self) -> None:
        if self.alive():
            self.kill(signal.SIGTERM)
        elif self.proc is not None:  # reap leftover children of a dead group
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGKILL)

    def log_text(self) -> str:
        return self.log.read_text(errors="replace") if self.log.exists() else ""


@pytest.fixture
def server_factory(tmp_path: Path) -> Iterator[Callable[..., Server]]:
    servers: list[Server] = []

    def build(data_dir: Path | None = None, **kw: object) -> Server:
        server = Server(data_dir or tmp_path / "data", **kw)  # type: ignore[arg-type]
        servers.append(server)
        return server

    yield build
    for server in servers:
        server.stop()
