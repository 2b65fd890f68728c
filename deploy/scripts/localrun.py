"""Helpers shared by the deployment scripts: free loopback ports, waiting for readiness,
stopping a process group, and reference answers from in-process Pinocchio.

The scripts run from the project's virtual environment (they import `service` to load robots the
way the server does, and compare its HTTP answers with Pinocchio called directly).
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def port_is_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
        return True


def wait_ready(base: str, timeout: float, proc: subprocess.Popen | None = None) -> float:
    """Poll `base`/health/ready until 200; the seconds it took. Bounded by `timeout`."""
    started = time.monotonic()
    while True:
        if proc is not None and proc.poll() is not None:
            raise RuntimeError(f"the server process exited with status {proc.returncode}")
        try:
            if httpx.get(f"{base}/health/ready", timeout=2).status_code == 200:
                return time.monotonic() - started
        except httpx.TransportError:
            pass
        if time.monotonic() - started > timeout:
            raise TimeoutError(f"{base}/health/ready did not answer 200 within {timeout} s")
        time.sleep(0.25)


def stop_group(proc: subprocess.Popen, timeout: float = 30) -> None:
    """SIGTERM the process group that `proc` leads (started with start_new_session=True), then
    SIGKILL it if it is still there after `timeout` seconds."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    except ProcessLookupError:
        pass


def _processes() -> dict[int, dict[str, str]]:
    out = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
        fields["cmdline"] = cmdline
        out[int(entry.name)] = fields
    return out


def descendants(pid: int) -> dict[int, dict[str, str]]:
    """`pid` and every process below it: pid → /proc status fields plus `cmdline`."""
    processes = _processes()
    children: dict[int, list[int]] = {}
    for child, fields in processes.items():
        children.setdefault(int(fields["PPid"]), []).append(child)
    found, todo = {}, [pid]
    while todo:
        current = todo.pop()
        if current in processes:
            found[current] = processes[current]
        todo.extend(children.get(current, []))
    return found


def process_tree_rss_kib(pid: int) -> int:
    """Resident memory (KiB) of `pid` and all its descendants, from /proc."""
    return sum(int(f.get("VmRSS", "0 kB").split()[0]) for f in descendants(pid).values())


def load_models(names: list[str]) -> dict[str, Any]:
    """The Pinocchio models of catalog robots, loaded as the server loads them."""
    import tempfile

    from service.registry import Registry

    with tempfile.TemporaryDirectory(prefix="robodyn-ref-") as store:
        registry = Registry(Path(store), names)
        registry.load()
        return {name: registry.catalog[name].model for name in names}


def expected(
    model: Any, quantity: str, q: np.ndarray, v: np.ndarray, a: np.ndarray
) -> dict[str, np.ndarray]:
    """What the service must answer for one state, from Pinocchio called directly."""
    import pinocchio as pin

    data = model.createData()
    if quantity == "mass-matrix":
        M = pin.crba(model, data, q)
        return {"mass_matrix": np.triu(M) + np.triu(M, 1).T}
    if quantity == "gravity":
        return {"gravity": pin.computeGeneralizedGravity(model, data, q)}
    if quantity == "nonlinear-effects":
        return {"nonlinear_effects": pin.nonLinearEffects(model, data, q, v)}
    if quantity == "inverse-dynamics":
        return {"tau": pin.rnea(model, data, q, v, a)}
    if quantity == "forward-dynamics":
        return {"a": pin.aba(model, data, q, v, a)}
    raise ValueError(quantity)


INPUTS = {
    "mass-matrix": ("q",),
    "gravity": ("q",),
    "nonlinear-effects": ("q", "v"),
    "inverse-dynamics": ("q", "v", "a"),
    "forward-dynamics": ("q", "v", "tau"),
}


def random_state(model: Any, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """A valid random (q, v, a): q = pin.randomConfiguration within clipped limits."""
    import pinocchio as pin

    lower = np.clip(model.lowerPositionLimit, -3.0, 3.0)
    upper = np.clip(model.upperPositionLimit, -3.0, 3.0)
    q = pin.randomConfiguration(model, lower, upper)
    return q, rng.normal(size=model.nv), rng.normal(size=model.nv)


def request_body(quantity: str, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> dict[str, Any]:
    values = {"q": q, "v": v, "a": a, "tau": a}
    return {name: values[name].tolist() for name in INPUTS[quantity]}


def max_relative_error(answer: dict[str, Any], reference: dict[str, np.ndarray]) -> float:
    """The largest |answer − reference| / max(1, |reference|) over every field."""
    worst = 0.0
    for key, value in reference.items():
        got = np.asarray(answer[key], dtype=float)
        scale = max(1.0, float(np.abs(value).max()))
        worst = max(worst, float(np.abs(got - value).max()) / scale)
    return worst
