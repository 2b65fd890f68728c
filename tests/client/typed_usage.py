"""A user's script that calls every method of the client, checked by `mypy --strict`
(test_client_ecosystem.py) and run against a real server. Options are Literal-typed, so a
type checker lists their choices and refuses a misspelt one."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field

import numpy as np
import robodyn
from robodyn import AsyncClient, Client, Payload, Retry


@dataclass
class JointState:
    """What a ROS `sensor_msgs/JointState` message holds."""

    name: list[str]
    position: list[float]
    velocity: list[float] = field(default_factory=list)
    effort: list[float] = field(default_factory=list)


def main(url: str, api_key: str, urdf: str) -> dict[str, float]:
    """Every client method once; returns a few numbers so that the run is checked."""
    done: list[tuple[int, int]] = []
    with Client(
        url,
        api_key=api_key,
        retry=Retry(attempts=3, timeout=10.0),
        progress=lambda n, total: done.append((n, total)),
        fill="neutral",
    ) as client:
        assert client.health()["status"] == "ok" and client.ready()
        assert "ur5" in client.robots().ids
        info: robodyn.RobotInfo = client.robot("ur5")
        q = np.zeros(info.nq)
        v = np.ones(info.nv, dtype=np.float32)  # float32: converted exactly to float64
        M: np.ndarray = client.mass_matrix("ur5", q)
        g: np.ndarray = client.gravity("ur5", q.tolist())
        C, Cv = client.coriolis("ur5", q, v)
        h = client.nonlinear_effects("ur5", q, v)
        tau = client.inverse_dynamics(
            "ur5",
            q,
            v,
            v,
            external_forces=[
                {"frame": "tool0", "wrench": [0, 0, 10, 0, 0, 0], "reference_frame": "world"}
            ],
        )
        a = client.forward_dynamics("ur5", q, v, tau)
        Minv = client.mass_matrix_inverse("ur5", q)
        energy = client.energy("ur5", q, v)
        com = client.center_of_mass("ur5", q, v)
        J = client.jacobian("ur5", q, "tool0", reference_frame="world", v=v)
        osd = client.operational_space(
            "ur5", q, "tool0", v=v, reference_frame="local", task="linear", damping=1e-3
        )
        inertias = client.inertias("ur5")
        did = client.inverse_dynamics_derivatives("ur5", q, v, a)
        fdd = client.forward_dynamics_derivatives("ur5", q, v, tau)
        cen = client.centroidal("ur5", q, v)
        traj = client.simulate(
            "ur5", q, np.zeros(info.nv), dt=1e-3, steps=10, integrator="rk4", progress=None
        )
        state = JointState(name=["shoulder_lift_joint", "elbow_joint"], position=[-1.0, 1.0])
        g_ros = client.gravity("ur5", state)  # the other joints at neutral (fill)
        arm = client.upload(urdf, root_joint="fixed", inertia_check="warn", name="typed")
        reduced = client.reduce("ur5", {"wrist_3_joint": 0.0}, name="ur5_no_wrist3")
        client.delete(arm.id)
        client.delete(reduced.id)
    return {
        "M00": float(M[0, 0]),
        "g1": float(g[1]),
        "C": float(C.sum() + Cv.sum()),
        "h": float(h.sum()),
        "Minv": float(Minv[0, 0]),
        "T": float(energy.kinetic_energy),
        "com": float(com.position[2]),
        "J": float(J.jacobian.sum()),
        "osd": float(osd.inertia[0, 0]),
        "mass": inertias.total_mass,
        "did": float(did.dtau_dq.sum()),
        "fdd": float(fdd.da_dq.sum()),
        "cen": float(cen.momentum.sum()),
        "traj": float(traj.q[-1, 1]),
        "g_ros": float(g_ros[1]),
        "chunks": float(len(done)),
    }


def carrying(client: Client, q: np.ndarray) -> float:
    """`payloads=`, a 1-DoF joint's limit, the payload capacity and a variant (type-checked
    only)."""
    tool = Payload("tool0", 2.0, center_of_mass=(0.0, 0.0, 0.05))
    g = client.gravity("ur5", q, payloads=[tool, {"frame": "wrist_3_link", "mass": 0.5}])
    limit = client.robot("ur5").joint("elbow_joint").effort_limit
    cap = client.payload_capacity(
        "ur5", q, "tool0", center_of_mass=[0.0, 0.0, 0.05], payloads=[tool]
    )
    variant = client.variant("ur5", payloads=[tool], name="ur5 with a tool")
    assert variant.parent == "ur5" and cap.minimum is None
    held: tuple[float, float] | np.ndarray | None = cap.mass_range
    assert held is not None
    tau, wrenches = client.joint_wrenches("ur5", q, q, q, payloads=[tool])
    bending: np.ndarray = np.linalg.norm(wrenches[:, 3:], axis=-1)
    return (
        float(g[1]) / (limit if isinstance(limit, float) else 1.0)
        + float(cap.mass)
        + float(bending.max() + tau[0])
    )


def identifying(client: Client, t: np.ndarray, q: np.ndarray, tau: np.ndarray) -> float:
    """The identification methods (type-checked only: a fit needs a real log)."""
    params: robodyn.InertialParameters = client.inertial_parameters("ur5")
    Y: np.ndarray = client.regressor("ur5", q[0], q[0], q[0])
    result: robodyn.Identification = client.identify(
        "ur5",
        t,
        q,
        tau,
        friction="viscous",
        method="least-squares",
        filter_hz=5.0,
        store=False,
        payload_frame="tool0",
    )
    friction: robodyn.JointFriction | None = result.friction[0]  # None: a joint in warnings
    warned: tuple[robodyn.IdentificationWarning, ...] = result.warnings
    viscous = 0.0 if friction is None else friction.viscous
    return float(Y @ params.parameters @ result.rmse.validation) + viscous + len(warned)


async def main_async(url: str) -> float:
    async with AsyncClient(url, retry=None, array_type="numpy") as client:
        info = await client.robot("ur5")
        tau = await client.inverse_dynamics(
            "ur5", np.zeros(info.nq), np.zeros(info.nv), np.zeros(info.nv)
        )
        _, wrenches = await client.joint_wrenches(
            "ur5", np.zeros(info.nq), np.zeros(info.nv), np.zeros(info.nv)
        )
        return float(tau[1]) + float(wrenches[0, 2])


if __name__ == "__main__":
    import sys

    with open(sys.argv[3]) as description:
        print(main(sys.argv[1], sys.argv[2], description.read()))
    print(asyncio.run(main_async(sys.argv[1])))
