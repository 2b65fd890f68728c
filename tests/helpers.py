"""Shared test helpers: random joint states, in-process reference values, URDF builders."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TypeVar

import numpy as np
import pinocchio as pin
from fastapi.testclient import TestClient

from service.errors import Overloaded
from service.main import create_app
from service.registry.robot import joint_type
from service.settings import Settings


def random_configuration(model, rng: np.random.Generator) -> np.ndarray:
    """A valid random q: bounded joints within their limits (clipped to ±π or ±1 m), unit
    quaternions and (cos, sin) pairs, free-flyer positions in [-1, 1] m."""
    q = pin.neutral(model)
    for jid in range(1, model.njoints):
        jm = model.joints[jid]
        i, kind = jm.idx_q, joint_type(jm)
        if kind in ("revolute", "prismatic"):
            bound = np.pi if kind == "revolute" else 1.0
            lo = max(float(model.lowerPositionLimit[i]), -bound)
            hi = min(float(model.upperPositionLimit[i]), bound)
            if hi <= lo:
                lo, hi = -bound, bound
            q[i] = rng.uniform(lo, hi)
        elif kind == "continuous":
            t = rng.uniform(-np.pi, np.pi)
            q[i : i + 2] = np.cos(t), np.sin(t)
        elif kind == "free_flyer":
            q[i : i + 3] = rng.uniform(-1, 1, 3)
            quat = rng.normal(size=4)
            q[i + 3 : i + 7] = quat / np.linalg.norm(quat)
        elif kind == "planar":
            t = rng.uniform(-np.pi, np.pi)
            q[i : i + 4] = *rng.uniform(-1, 1, 2), np.cos(t), np.sin(t)
        elif kind == "spherical":
            quat = rng.normal(size=4)
            q[i : i + 4] = quat / np.linalg.norm(quat)
    return q


def random_state(model, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, v, a) with v and a of standard deviation 1."""
    return random_configuration(model, rng), rng.normal(size=model.nv), rng.normal(size=model.nv)


def mass_matrix(model, q: np.ndarray) -> np.ndarray:
    M = pin.crba(model, model.createData(), q)
    return np.triu(M) + np.triu(M, 1).T


def planar_arm_urdf(l1: float, l2: float, m1: float, m2: float) -> str:
    """A two-link arm in the x-z plane (axes -y), point masses m1, m2 at the link tips."""
    return f"""<?xml version="1.0"?>
<robot name="arm_{l1}_{l2}_{m1}_{m2}">
  <link name="base"/>
  <link name="link1"><inertial><origin xyz="{l1} 0 0"/><mass value="{m1}"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <link name="link2"><inertial><origin xyz="{l2} 0 0"/><mass value="{m2}"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="link1"/>
    <axis xyz="0 -1 0"/><limit lower="-3.2" upper="3.2" effort="100" velocity="5"/></joint>
  <joint name="elbow" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="{l1} 0 0"/><axis xyz="0 -1 0"/>
    <limit lower="-3.2" upper="3.2" effort="100" velocity="5"/></joint>
</robot>
"""


def planar_arm_closed_form(l1, l2, m1, m2, q, v, g0=9.81):
    """Hand-derived M, C (Christoffel form), g of the point-mass two-link arm.

    Positions of the masses: p1 = l1 (c1, s1), p2 = p1 + l2 (c12, s12) in the (x, z) plane, with
    height z; T = ½ Σ m |ṗ|², U = g0 Σ m z.
    """
    c1, c2, c12 = np.cos(q[0]), np.cos(q[1]), np.cos(q[0] + q[1])
    s2 = np.sin(q[1])
    M = np.array(
        [
            [m1 * l1**2 + m2 * (l1**2 + 2 * l1 * l2 * c2 + l2**2), m2 * (l1 * l2 * c2 + l2**2)],
            [m2 * (l1 * l2 * c2 + l2**2), m2 * l2**2],
        ]
    )
    h = -m2 * l1 * l2 * s2
    C = np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0]])
    g = np.array([(m1 + m2) * g0 * l1 * c1 + m2 * g0 * l2 * c12, m2 * g0 * l2 * c12])
    return M, C, g


def record_off_loop(monkeypatch, module) -> list[str]:
    """Wrap `module.off_loop` (what runs work in a worker thread) so that the names of the
    functions sent there are recorded, in order, in the returned list."""
    calls: list[str] = []
    original = module.off_loop

    async def recording(connection, fn, *args, **options):
        calls.append(getattr(fn, "__name__", str(fn)))
        return await original(connection, fn, *args, **options)

    monkeypatch.setattr(module, "off_loop", recording)
    return calls


@contextmanager
def registry_client(registry) -> Iterator[TestClient]:
    """A TestClient over the production app wired to `registry` (its data directory as the
    settings' data_dir); errors answered, not raised."""
    app = create_app(Settings(data_dir=registry.store.dir.parent), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as client:
        yield client


def skewed_arm_urdf(joints: int, seed: int = 1) -> str:
    """A chain of `joints` revolute joints with random placements, rpy and axes, and bodies
    with random centres of mass and full inertia tensors: no two axes parallel, the worst case
    for the size of the explicit form."""
    rng = np.random.default_rng(seed)
    links, chain = ['<link name="l0"/>'], []
    for i in range(1, joints + 1):
        ii = rng.uniform(0.06, 0.1, 3)  # principal moments: triangle inequality
        c, rpy = rng.uniform(-0.2, 0.2, 3), rng.uniform(-1, 1, 3)
        links.append(
            f'<link name="l{i}"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}" '
            f'rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/><mass value="{rng.uniform(0.5, 3)}"/>'
            f'<inertia ixx="{ii[0]}" ixy="0.001" ixz="0" iyy="{ii[1]}" iyz="0.002" '
            f'izz="{ii[2]}"/></inertial></link>'
        )
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        p, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-2, 2, 3)
        chain.append(
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            f'<origin xyz="{p[0]} {p[1]} {p[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
            f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
            f'<limit lower="-3" upper="3" effort="10" velocity="1"/></joint>'
        )
    return f'<robot name="skewed">{"".join(links + chain)}</robot>'


def alternating_arm_urdf(joints: int = 6) -> str:
    """A chain of `joints` revolute joints with axes alternating z, y, z, …, 0.2 m apart along
    z, each link 1 kg with its centre of mass 0.1 m up its length: a plain arm whose explicit
    form is large (every angle couples with its neighbours)."""
    links, chain = ['<link name="l0"/>'], []
    for i in range(1, joints + 1):
        links.append(
            f'<link name="l{i}"><inertial><origin xyz="0 0 0.1"/><mass value="1"/>'
            '<inertia ixx="0.004" ixy="0" ixz="0" iyy="0.004" iyz="0" izz="0.001"/>'
            "</inertial></link>"
        )
        axis = "0 0 1" if i % 2 else "0 1 0"
        chain.append(
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            f'<origin xyz="0 0 {0 if i == 1 else 0.2}"/><axis xyz="{axis}"/>'
            '<limit lower="-3" upper="3" effort="10" velocity="1"/></joint>'
        )
    return f'<robot name="alternating">{"".join(links + chain)}</robot>'


def _top_level_terms(text: str) -> list[tuple[float, str]]:
    """A printed sum split at its " + " and " - " outside parentheses: (sign, term)."""
    terms, depth, start, sign = [], 0, 0, 1.0
    if text.startswith("-"):
        sign, start = -1.0, 1
    i = start
    while i < len(text):
        ch = text[i]
        depth += (ch == "(") - (ch == ")")
        if depth == 0 and text.startswith((" + ", " - "), i):
            terms.append((sign, text[start:i]))
            sign, start = (1.0 if text[i + 1] == "+" else -1.0), i + 3
            i += 3
            continue
        i += 1
    terms.append((sign, text[start:]))
    return terms


def evaluate_printed(text: str, values: dict[str, float]) -> float:
    """The value of an expression of the equations' text (Python syntax: numbers, names q1…,
    dq1…, p1…, `*`, `**`, cos, sin, parentheses) with the names' `values`: an evaluator of
    its own, term by term (a sum of thousands of terms is too deep for one `eval`)."""
    env = {"cos": math.cos, "sin": math.sin, **values}
    total = 0.0
    for sign, term in _top_level_terms(text):
        cut = term.find("*(")
        if term.endswith(")") and cut > 0 and "(" not in term[:cut]:
            value = eval(term[:cut], {"__builtins__": {}}, env) * evaluate_printed(
                term[cut + 2 : -1], values
            )
        else:
            value = eval(term, {"__builtins__": {}}, env)
        total += sign * value
    return total


STARVED = "of CPU time in its"  # in the detail of an `overloaded` answer for a starved child
T = TypeVar("T")


def unless_starved(send: Callable[[], T], attempts: int = 3) -> T:
    """`send()`, sent again (`attempts` times in all) while the service answers that the
    process building a model or deriving equations was starved of CPU by the machine's load
    (503 `overloaded`, or `Overloaded` raised, "got only x s of CPU time in its y s"): the
    verdict on the model itself comes from a try that had the CPU, as a client retrying that
    503 would get. A test of the verdict then holds on a busy machine."""
    for attempt in range(1, attempts + 1):
        try:
            answer = send()
        except Overloaded as exc:
            if STARVED not in exc.detail or attempt == attempts:
                raise
            continue
        status, body = getattr(answer, "status_code", None), getattr(answer, "text", "")
        if status != 503 or STARVED not in body or attempt == attempts:
            return answer
    raise AssertionError("unreachable: the last attempt returns or raises")
