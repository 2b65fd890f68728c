"""The loads each joint transmits: the wrenches of RNEA's backward pass and a joint's bearing loads.

After RNEA (`pin.rnea(model, data, q, v, a)`), `data.f[j]` is the spatial force that joint j
transmits from its parent body to its child body — everything the child's subtree needs to move
as it does, against gravity and the external wrenches: f (N) and the moment n (N·m) about the
joint frame's origin, in the joint frame's axes (6 numbers, f then n). The joint torque is its
projection on the joint's motion subspace S (6 × nv_j, constant in the joint frame for every
joint Pinocchio builds from URDF or MJCF): τ_j = Sᵀ f_j (+ armature · a, which the rotor takes,
not the joint).

For a 1-DoF joint with unit axis s (in its frame; the angular part of S for a revolute joint,
the linear part for a prismatic one), the loads its bearings or guides carry are

    axial force      |f · s|               N   (a revolute joint's thrust; a prismatic one's τ)
    bending moment   ‖n − (n · s) s‖       N·m (what tilts the bearing; τ = n · s for revolute)

and the magnitudes ‖f‖ (N) and ‖n‖ (N·m).

A joint friction torque τ_f (offset + Coulomb sign(v) + viscous v, `friction`) acts along the
joint's motion only: it adds S τ_f to the joint's wrench, so that Sᵀ f_j is the torque with
friction.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from service.registry.robot import Robot

Fext = Callable[[object, np.ndarray, int], object]
"""(data, q, state index) → the external forces of `pin.rnea` at that state."""


@dataclass(frozen=True)
class JointAxes:
    """The moving joints of a robot (1 … njoints − 1, model order) and what their loads need:
    `subspaces[j]` S (6, nv_j) in the joint frame and `v_index[j]` its first velocity
    coordinate; for the 1-DoF joints `single` (their positions among the moving joints),
    `axes` (len(single), 3) their unit axes s and `revolute` (whether s is angular)."""

    subspaces: tuple[np.ndarray, ...]
    v_index: tuple[int, ...]
    single: np.ndarray
    axes: np.ndarray
    revolute: np.ndarray


def joint_axes(robot: Robot) -> JointAxes:
    """The motion subspaces and 1-DoF axes of `robot`'s moving joints (microseconds a joint:
    computed per request, from the joint models at the neutral configuration)."""
    model = robot.model
    q0 = pin.neutral(model)
    subspaces, v_index, single, axes, revolute = [], [], [], [], []
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        jdata = joint.createData()
        joint.calc(jdata, q0)
        S = np.array(jdata.S, dtype=float).reshape(6, joint.nv)
        subspaces.append(S)
        v_index.append(int(joint.idx_v))
        if joint.nv == 1:
            angular, linear = S[3:, 0], S[:3, 0]
            turns = bool(np.linalg.norm(angular) > 0)
            axis = angular if turns else linear
            single.append(jid - 1)
            axes.append(axis / np.linalg.norm(axis))
            revolute.append(turns)
    return JointAxes(
        tuple(subspaces),
        tuple(v_index),
        np.array(single, dtype=int),
        np.array(axes, dtype=float).reshape(-1, 3),
        np.array(revolute, dtype=bool),
    )


def moving_joints(robot: Robot) -> int:
    """How many joints move (njoints − 1: every joint but the universe)."""
    return int(robot.model.njoints) - 1


def rnea_with_wrenches(
    robot: Robot,
    q: np.ndarray,
    v: np.ndarray,
    a: np.ndarray,
    fext: Fext | None = None,
    joints: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(τ (N, nv), wrenches (N, J, 6)) by RNEA state by state: τ = M a + C v + g (− Σ Jᵀ w
    with `fext`), and each joint's transmitted wrench `data.f[j]`, [f (N), n (N·m)] about the
    joint frame's origin in its axes. `joints` (indices among the moving joints, default all)
    selects the J joints whose wrenches are returned. q (N, nq) in Pinocchio's order, v, a
    (N, nv)."""
    n = q.shape[0]
    picked = np.arange(moving_joints(robot)) if joints is None else joints
    ids = [int(j) + 1 for j in picked]
    tau = np.empty((n, robot.nv))
    wrenches = np.empty((n, len(ids), 6))
    model = robot.model
    with robot.data() as data:
        forces = data.f
        for i in range(n):
            if fext is None:
                tau[i] = pin.rnea(model, data, q[i], v[i], a[i])
            else:
                tau[i] = pin.rnea(model, data, q[i], v[i], a[i], fext(data, q[i], i))
            if ids:  # (a robot whose only joint is a free-flyer has no 1-DoF joint)
                listed = forces.tolist()  # one call: faster than indexing joint by joint
                wrenches[i] = [listed[j].vector for j in ids]
    return tau, wrenches


def add_friction(
    robot: Robot,
    wrenches: np.ndarray,
    friction_torque: np.ndarray,
    joints: np.ndarray | None = None,
) -> np.ndarray:
    """The wrenches (N, J, 6) with each joint's friction torque τ_f (N, nv) added along its
    motion: f_j + S_j τ_f,j (`joints`: which moving joints the J wrenches are, default all)."""
    axes = joint_axes(robot)
    picked = np.arange(moving_joints(robot)) if joints is None else joints
    out = wrenches.copy()
    for k, j in enumerate(picked):
        S, start = axes.subspaces[j], axes.v_index[j]
        out[:, k] += friction_torque[:, start : start + S.shape[1]] @ S.T
    return out


def bearing_loads(wrenches: np.ndarray, axes: np.ndarray) -> dict[str, np.ndarray]:
    """The loads of 1-DoF joints from their wrenches (N, J, 6) and unit axes s (J, 3), each
    (N, J): `force` ‖f‖ (N), `moment` ‖n‖ (N·m), `axial_force` |f · s| (N) and
    `bending_moment` ‖n − (n · s) s‖ (N·m)."""
    f, n = wrenches[..., :3], wrenches[..., 3:]
    along = np.einsum("njk,jk->nj", n, axes)
    bending = n - along[..., None] * axes
    return {
        "force": np.linalg.norm(f, axis=-1),
        "moment": np.linalg.norm(n, axis=-1),
        "axial_force": np.abs(np.einsum("njk,jk->nj", f, axes)),
        "bending_moment": np.linalg.norm(bending, axis=-1),
    }
