"""Real `python -m service` processes on free loopback ports, shared by the test suites."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

SERVER_START_S = 90.0


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def running_server(data: Path, **env_settings: str) -> Iterator[str]:
    """A real `python -m service` on a free loopback port, with ROBODYN_* settings
    `env_settings` (e.g. API_KEYS="k"; LOG_LEVEL defaults to warning): yields its URL;
    terminated on exit. Its stdout and stderr go to `data`/server.log."""
    data.mkdir(parents=True, exist_ok=True)
    log_path = data / "server.log"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROBODYN_")}
    env.update(ROBODYN_DATA_DIR=str(data), ROBODYN_LOG_LEVEL="warning")
    env.update({f"ROBODYN_{k.upper()}": v for k, v in env_settings.items()})
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    with open(log_path, "wb") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port)],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            cwd=data,
        )
    try:
        _wait_ready(proc, url, log_path)
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=5)


def _wait_ready(proc: subprocess.Popen[bytes], url: str, log_path: Path) -> None:
    deadline = time.monotonic() + SERVER_START_S
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            pytest.fail(f"server exited with {proc.returncode}:\n{log_path.read_text()[-3000:]}")
        try:
            if httpx.get(url + "/health/ready", timeout=1.0).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.1)
    pytest.fail(f"server not ready within {SERVER_START_S} s:\n{log_path.read_text()[-3000:]}")
