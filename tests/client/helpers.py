"""Helpers of the client tests: the robots used, tolerances, in-process Pinocchio as the
reference, a 2-link arm URDF, and a real server in a subprocess."""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from service.registry import Registry
from service.registry.build import build_urdf_model
from tests.servers import free_port, running_server

__all__ = [
    "API_KEY",
    "ATOL",
    "CATALOG",
    "RTOL",
    "Reference",
    "free_port",
    "running_server",
    "two_link_urdf",
]

CATALOG = ["ur5", "panda", "talos", "planar_arm", "double_pendulum_continuous"]
API_KEY = "client-test-key"
RTOL, ATOL = 1e-10, 1e-10


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
        q = np.array([pin.integrate(m, pin.neutral(m), rng.normal(0, 0.6, m.nv)) for _ in range(n)])
        return {
            "q": q,
            "v": rng.normal(0, 1, (n, m.nv)),
            "a": rng.normal(0, 1, (n, m.nv)),
            "tau": rng.normal(0, 5, (n, m.nv)),
        }

    def _each(self, robot_id: str, fn: Any, *arrays: np.ndarray) -> np.ndarray:
        m = self.model(robot_id)
        d = m.createData()
        return np.array([np.array(fn(m, d, *row), copy=True) for row in zip(*arrays, strict=True)])

    def mass_matrix(self, robot_id: str, q: np.ndarray) -> np.ndarray:
        upper = self._each(robot_id, pin.crba, q)
        return np.triu(upper) + np.transpose(np.triu(upper, 1), (0, 2, 1))

    def gravity(self, robot_id: str, q: np.ndarray) -> np.ndarray:
        return self._each(robot_id, pin.computeGeneralizedGravity, q)

    def coriolis(
        self, robot_id: str, q: np.ndarray, v: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        C = self._each(robot_id, pin.computeCoriolisMatrix, q, v)
        return C, np.einsum("nij,nj->ni", C, v)

    def nonlinear_effects(self, robot_id: str, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        return self._each(robot_id, pin.nonLinearEffects, q, v)

    def inverse_dynamics(
        self, robot_id: str, q: np.ndarray, v: np.ndarray, a: np.ndarray
    ) -> np.ndarray:
        return self._each(robot_id, pin.rnea, q, v, a)

    def forward_dynamics(
        self, robot_id: str, q: np.ndarray, v: np.ndarray, tau: np.ndarray
    ) -> np.ndarray:
        return self._each(robot_id, pin.aba, q, v, tau)


def two_link_urdf(
    m1: float = 2.0, m2: float = 1.5, l1: float = 0.6, l2: float = 0.4, name: str = "two_link_arm"
) -> str:
    """A planar 2-link arm: revolute joints about y, uniform rods along x (centre of mass at
    half length), so at q = 0 both links are horizontal and gravity (−z) acts fully."""

    def link(link_name: str, m: float, length: float) -> str:
        i_rod = m * length**2 / 12
        return (
            f'<link name="{link_name}"><inertial><origin xyz="{length / 2} 0 0"/>'
            f'<mass value="{m}"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="{i_rod}" '
            f'iyz="0" izz="{i_rod}"/></inertial></link>'
        )

    return (
        f'<?xml version="1.0"?>\n<robot name="{name}">\n<link name="base"/>\n'
        f"{link('upper', m1, l1)}\n{link('fore', m2, l2)}\n"
        '<joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>'
        '<axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="50" velocity="5"/></joint>\n'
        f'<joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>'
        f'<origin xyz="{l1} 0 0"/><axis xyz="0 1 0"/>'
        '<limit lower="-3" upper="3" effort="20" velocity="5"/></joint>\n</robot>\n'
    )
