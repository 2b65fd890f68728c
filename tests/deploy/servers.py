"""Real `python -m service` processes on free loopback ports, for the deployment tests."""

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

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_ready(base: str, timeout: float = 90, proc: subprocess.Popen | None = None) -> None:
    """Poll `base`/health/ready until it answers 200 (bounded by `timeout` seconds)."""
    deadline = time.monotonic() + timeout
    while True:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"the server exited with status {proc.returncode}")
        try:
            if httpx.get(f"{base}/health/ready", timeout=2).status_code == 200:
                return
        except httpx.TransportError:
            pass
        if time.monotonic() > deadline:
            raise TimeoutError(f"{base} was not ready within {timeout} s")
        time.sleep(0.2)


def start_server(data_dir: Path, env: dict[str, str], log_path: Path,
                 port: int | None = None) -> tuple[subprocess.Popen, str]:
    """Start `python -m service` on 127.0.0.1:`port` with its stderr going to `log_path`."""
    port = port or free_port()
    full_env = {**os.environ, "ROBODYN_DATA_DIR": str(data_dir), **env}
    with open(log_path, "ab") as log:
        proc = subprocess.Popen([sys.executable, "-m", "service", "--port", str(port)],
                                env=full_env, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)
    return proc, f"http://127.0.0.1:{port}"


def stop_server(proc: subprocess.Popen, timeout: float = 30) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=10)


@contextmanager
def running_server(data_dir: Path, env: dict[str, str], log_path: Path) -> Iterator[str]:
    """A ready server for the duration of the block; its base URL."""
    proc, base = start_server(data_dir, env, log_path)
    try:
        wait_ready(base, proc=proc)
        yield base
    finally:
        stop_server(proc)
