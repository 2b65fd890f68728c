"""MuJoCo itself as the reference of MJCF uploads: its mass matrix (`mj_fullM`) and bias forces
(`qfrc_bias` = C(q, v) v + g(q)) at random states, and the documented q mapping.

Coordinates as documented (docs/uploads.md): over the API q is MuJoCo's qpos and v its qvel
exactly. Inside, the Pinocchio model holds every quaternion of a ball or free joint w last
(`pinocchio_q`, for tests that call the built `pin.Model` directly).
"""

from __future__ import annotations

import base64
import importlib.util
from pathlib import Path

import mujoco
import numpy as np

DM_SUITE = Path(importlib.util.find_spec("dm_control").submodule_search_locations[0]) / "suite"
MUJOCO_TESTDATA = Path(mujoco.__file__).parent / "testdata"
FREE, BALL = int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL)


def pinocchio_q(mj: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """The built Pinocchio model's q of MuJoCo's qpos: every quaternion's w moved last, the
    rest unchanged (the API takes qpos itself)."""
    q = np.array(qpos, dtype=float)
    for j in range(mj.njnt):
        kind, adr = int(mj.jnt_type[j]), int(mj.jnt_qposadr[j])
        start = adr + 3 if kind == FREE else adr if kind == BALL else None
        if start is not None:
            w, x, y, z = qpos[start : start + 4]
            q[start : start + 4] = (x, y, z, w)
    return q


def random_states(
    mj: mujoco.MjModel, rng: np.random.Generator, count: int
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """`count` states (qpos, qvel) near qpos0 with MuJoCo's M and qfrc_bias there."""
    data = mujoco.MjData(mj)
    out = []
    for _ in range(count):
        data.qpos[:] = mj.qpos0
        mujoco.mj_integratePos(mj, data.qpos, rng.normal(size=mj.nv), 1.0)
        data.qvel[:] = rng.normal(size=mj.nv)
        mujoco.mj_forward(mj, data)
        M = np.zeros((mj.nv, mj.nv))
        mujoco.mj_fullM(mj, data, M)
        out.append((data.qpos.copy(), data.qvel.copy(), M, data.qfrc_bias.copy()))
    return out


def encoded(files: dict[str, bytes]) -> dict[str, str]:
    return {key: base64.b64encode(data).decode() for key, data in files.items()}


def directory_assets(root: Path, *folders: str) -> dict[str, bytes]:
    """Every file under `root/folder` (for each folder) by its path relative to `root`."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for folder in folders
        for p in sorted((root / folder).rglob("*"))
        if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".py"
    }


def relative_error(got: np.ndarray, expected: np.ndarray) -> float:
    """max |got − expected| over max(1, max |expected|)."""
    return float(
        np.max(np.abs(got - expected), initial=0.0)
        / max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    )


def cube_stl(half: float = 0.05) -> bytes:
    """A binary STL of a closed cube of half size `half` centred at (0.02, 0, 0)."""
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    corners[:, 0] += 0.02
    faces = [
        (0, 1, 3),
        (0, 3, 2),
        (4, 6, 7),
        (4, 7, 5),
        (0, 4, 5),
        (0, 5, 1),
        (2, 3, 7),
        (2, 7, 6),
        (0, 2, 6),
        (0, 6, 4),
        (1, 5, 7),
        (1, 7, 3),
    ]
    out = bytearray(b"\0" * 80) + len(faces).to_bytes(4, "little")
    for face in faces:
        out += np.zeros(3, np.float32).tobytes()
        out += corners[list(face)].astype(np.float32).tobytes() + b"\0\0"
    return bytes(out)
