"""Synthetic logs for the identification tests (and the worked example of docs/identification.md).

A "true" robot is a catalog robot whose every body is perturbed physically consistently (scaled
by 1 + u and given an extra small solid box); it is excited by Fourier-series joint
trajectories, and its torques are Pinocchio's RNEA of the true model plus friction
(offset + Coulomb sign(v) + viscous v) plus Gaussian noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from service.dynamics.identification.parameters import inertial_parameters


def perturbed_parameters(model, rng: np.random.Generator, spread: float = 0.15) -> np.ndarray:
    """π of `model` with each body scaled by 1 + u (u uniform in ±spread) plus a solid box of
    mass 5-20 % of the body's (at least 50 g), sides 2-8 cm, at up to 5 cm from the joint
    origin: every body stays physically realizable."""
    out = []
    for j in range(1, model.njoints):
        body = pin.Inertia.FromDynamicParameters(
            model.inertias[j].toDynamicParameters() * (1.0 + rng.uniform(-spread, spread))
        )
        mass = max(0.05, rng.uniform(0.05, 0.2) * model.inertias[j].mass)
        sides = rng.uniform(0.02, 0.08, 3)
        box = pin.Inertia.FromBox(mass, *sides)
        rotation = pin.exp3(rng.normal(size=3))
        placement = pin.SE3(rotation, rng.uniform(-0.05, 0.05, 3))
        out.append((body + placement.act(box)).toDynamicParameters())
    return np.concatenate(out)


def fourier_trajectory(
    model,
    t: np.ndarray,
    rng: np.random.Generator,
    base_hz: float = 0.2,
    harmonics: int = 5,
    amplitude: float = 1.0,
    speed: float = 1.5,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q (N, nq), v, a (N, nv) of a Fourier-series excitation of a robot whose joints are 1-DoF:
    joint j's coordinate x_j = x0_j + Σ_k (α_jk sin(k ω t) + β_jk cos(k ω t)) / (k ω), scaled so
    that each joint stays within `amplitude` (rad or m, and 80 % of its half range) of the middle of
    its limits and below `speed` (rad/s or m/s); v and a are the exact derivatives."""
    nv = model.nv
    omega = 2 * np.pi * base_hz
    k = np.arange(1, harmonics + 1)
    alpha, beta = rng.normal(size=(2, nv, harmonics))
    angle = omega * np.outer(t, k)  # (N, K)
    sin, cos = np.sin(angle), np.cos(angle)
    q = sin @ (alpha / (k * omega)).T + cos @ (beta / (k * omega)).T
    v = cos @ alpha.T - sin @ beta.T
    a = -(sin @ (alpha * k * omega).T + cos @ (beta * k * omega).T)
    lower, upper = np.full(nv, -np.inf), np.full(nv, np.inf)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq == 1:  # (a continuous joint, (cos, sin), has no limits)
            lower[joint.idx_v] = model.lowerPositionLimit[joint.idx_q]
            upper[joint.idx_v] = model.upperPositionLimit[joint.idx_q]
    with np.errstate(invalid="ignore"):
        middle = np.where(np.isfinite(lower + upper), 0.5 * (lower + upper), 0.0)
        half = np.where(np.isfinite(upper - lower), 0.4 * (upper - lower), amplitude)
    gain = np.minimum(
        np.minimum(amplitude, half) / np.abs(q).max(axis=0), speed / np.abs(v).max(axis=0)
    )
    return configuration(model, middle + gain * q), gain * v, gain * a


def configuration(model, x: np.ndarray) -> np.ndarray:
    """q (N, nq) from one coordinate per joint x (N, nv): a continuous joint's angle becomes
    (cos, sin), other 1-DoF joints keep theirs."""
    q = np.empty((x.shape[0], model.nq))
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq == 2:
            q[:, joint.idx_q] = np.cos(x[:, joint.idx_v])
            q[:, joint.idx_q + 1] = np.sin(x[:, joint.idx_v])
        else:
            q[:, joint.idx_q] = x[:, joint.idx_v]
    return q


@dataclass
class SyntheticLog:
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray  # measured: true torques + friction + noise
    pi: np.ndarray  # true inertial parameters
    coulomb: np.ndarray
    viscous: np.ndarray
    offset: np.ndarray
    noise: float


def synthetic_log(
    model,
    seed: int = 0,
    duration: float = 20.0,
    rate: float = 200.0,
    noise: float = 0.05,
    irregular: bool = False,
    pi: np.ndarray | None = None,
    friction: bool = True,
) -> SyntheticLog:
    """A logged motion of the perturbed `model` (see the module docstring); the joint torques
    τ = RNEA(true model) + friction + N(0, noise²) (N·m). `irregular`: sample times jittered
    by up to ±30 % of the interval. `pi` replaces the perturbed true parameters."""
    rng = np.random.default_rng(seed)
    step = 1.0 / rate
    t = np.arange(0.0, duration, step)
    if irregular:
        t = t + rng.uniform(-0.3, 0.3, t.size) * step
    q, v, a = fourier_trajectory(model, t, rng)
    truth = perturbed_parameters(model, rng) if pi is None else pi
    true_model = model.copy()
    for j, block in enumerate(truth.reshape(-1, 10), start=1):
        true_model.inertias[j] = pin.Inertia.FromDynamicParameters(block)
    data = true_model.createData()
    tau = np.array([pin.rnea(true_model, data, q[i], v[i], a[i]) for i in range(t.size)])
    nv = model.nv
    coulomb = rng.uniform(0.5, 2.0, nv) if friction else np.zeros(nv)
    viscous = rng.uniform(0.2, 1.0, nv) if friction else np.zeros(nv)
    offset = rng.uniform(-0.3, 0.3, nv) if friction else np.zeros(nv)
    tau += offset + coulomb * np.sign(v) + viscous * v + rng.normal(0.0, noise, tau.shape)
    return SyntheticLog(
        t=t,
        q=q,
        v=v,
        a=a,
        tau=tau,
        pi=truth,
        coulomb=coulomb,
        viscous=viscous,
        offset=offset,
        noise=noise,
    )


def loaded_parameters(model, frame_name: str, payload) -> np.ndarray:
    """π of `model` carrying `payload` (a pin.Inertia about the frame's origin, in its axes)
    at the frame: the contract's payload, model.inertias[parent] += placement.act(payload)."""
    loaded = model.copy()
    frame = model.frames[model.getFrameId(frame_name)]
    loaded.inertias[frame.parentJoint] += frame.placement.act(payload)
    return inertial_parameters(loaded)
