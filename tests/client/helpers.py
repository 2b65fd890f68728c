"""Helpers of the client tests: the robots used, tolerances, in-process Pinocchio as the
reference, a 2-link arm URDF, and a real server in a subprocess."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pinocchio as pin
import pytest

from service.registry import Registry
from service.registry.build import build_urdf_model

CATALOG = ["ur5", "panda", "talos", "planar_arm", "double_pendulum_continuous"]
API_KEY = "client-test-key"
RTOL, ATOL = 1e-10, 1e-10
SERVER_START_S = 90.0


class Reference:
    """In-process Pinocchio on the same models: what every answer must equal."""

    def __init__(self, registry: Registry) -> None:
        self.registry = registry
        self.extra: dict[str, Any] = {}  # robot id → pin.Model of uploads

    def model(self, robot_id: str) -> Any:
        if robot_id in self.extra:
            return self.extra[robot_id]
        return self.registry.get(robot_id).model

    def add_urdf(self, robot_id: str, urdf: str, root_joint: str = "fixed") -> None:
        self.extra[robot_id] = build_urdf_model(urdf, root_joint)

    def states(self, robot_id: str, n: int, seed: int = 0) -> dict[str, np.ndarray]:
        """n random states: q around neutral (unit quaternions, (cos, sin) pairs), v, a, tau."""
        m, rng = self.model(robot_id), np.random.default_rng(seed)
        q = np.array([pin.integrate(m, pin.neutral(m), rng.normal(0, 0.6, m.nv))
                      for _ in range(n)])
        return {"q": q, "v": rng.normal(0, 1, (n, m.nv)), "a": rng.normal(0, 1, (n, m.nv)),
                "tau": rng.normal(0, 5, (n, m.nv))}

    def _each(self, robot_id: str, fn: Any, *arrays: np.ndarray) -> np.ndarray:
        m = self.model(robot_id)
        d = m.createData()
        return np.array([np.array(fn(m, d, *row), copy=True) for row in zip(*arrays, strict=True)])

    def mass_matrix(self, robot_id: str, q: np.ndarray) -> np.ndarray:
        upper = self._each(robot_id, pin.crba, q)
        return np.triu(upper) + np.transpose(np.triu(upper, 1), (0, 2, 1))

    def gravity(self, robot_id: str, q: np.ndarray) -> np.ndarray:
        return self._each(robot_id, pin.computeGeneralizedGravity, q)

    def coriolis(self, robot_id: str, q: np.ndarray, v: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
        C = self._each(robot_id, pin.computeCoriolisMatrix, q, v)
        return C, np.einsum("nij,nj->ni", C, v)

    def nonlinear_effects(self, robot_id: str, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._each(robot_id, pin.nonLinearEffects, q, v)

    def inverse_dynamics(self, robot_id: str, q: np.ndarray, v: np.ndarray, a: np.ndarray
                         ) -> np.ndarray:
        return self._each(robot_id, pin.rnea, q, v, a)

    def forward_dynamics(self, robot_id: str, q: np.ndarray, v: np.ndarray, tau: np.ndarray
                         ) -> np.ndarray:
        return self._each(robot_id, pin.aba, q, v, tau)


def two_link_urdf(m1: float = 2.0, m2: float = 1.5, l1: float = 0.6, l2: float = 0.4,
                  name: str = "two_link_arm") -> str:
    """A planar 2-link arm: revolute joints about y, uniform rods along x (centre of mass at
    half length), so at q = 0 both links are horizontal and gravity (−z) acts fully."""

    def link(link_name: str, m: float, length: float) -> str:
        i_rod = m * length**2 / 12
        return (f'<link name="{link_name}"><inertial><origin xyz="{length / 2} 0 0"/>'
                f'<mass value="{m}"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="{i_rod}" '
                f'iyz="0" izz="{i_rod}"/></inertial></link>')

    return (f'<?xml version="1.0"?>\n<robot name="{name}">\n<link name="base"/>\n'
            f'{link("upper", m1, l1)}\n{link("fore", m2, l2)}\n'
            '<joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>'
            '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>\n'
            f'<joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>'
            f'<origin xyz="{l1} 0 0"/><axis xyz="0 1 0"/>'
            '<limit lower="-3" upper="3" effort="20" velocity="5"/></joint>\n</robot>\n')


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def running_server(data: Path, **env_settings: str) -> Iterator[str]:
    """A real `python -m service` on a free loopback port, with ROBODYN_* settings
    `env_settings` (e.g. API_KEYS="k"): yields its URL; terminated on exit."""
    log_path = data / "server.log"
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROBODYN_")}
    env.update({f"ROBODYN_{k.upper()}": v for k, v in env_settings.items()})
    env.update(ROBODYN_DATA_DIR=str(data), ROBODYN_LOG_LEVEL="warning")
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    with open(log_path, "wb") as log:
        proc = subprocess.Popen([sys.executable, "-m", "service", "--host", "127.0.0.1",
                                 "--port", str(port)], env=env, stdout=log,
                                stderr=subprocess.STDOUT, cwd=data)
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
