"""How long the equations of motion in explicit form take to derive, cold.

    .venv/bin/python bench/equations.py            # catalog arms and skewed arms up to 5 joints
    .venv/bin/python bench/equations.py --worst    # also the skewed 6-joint arm (~20 s)
    .venv/bin/python bench/equations.py --http     # GET /v1/robots/ur5/equations on a server

For each robot: the derivation (M, U, then g, Christoffel symbols, C, T), the rendering of the
answer (text and LaTeX of every entry), its JSON size, and the whole of it in a child process
as the service runs it (`derive_isolated`: process start, model transfer, derivation, JSON) —
every figure from a cold start (nothing is cached between runs). `--http` starts
`python -m service` and times `GET /v1/robots/{id}/equations`: the first request (cold: the
forkserver starts, the child derives) and the cached answer (median of 50). The requirement:
a 6-DoF arm like the UR5 within 60 s on a 2-core machine, a cached answer within 50 ms. A
"skewed" arm has random joint placements, axes and full inertia tensors (no two axes
parallel): the worst case for the size of the explicit form.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import tempfile
import time

import numpy as np
import orjson
import pinocchio as pin

from service.dynamics.equations import derive_equations, equations_answer
from service.dynamics.equations.isolated import derive_isolated
from service.registry.catalog import load_catalog

CATALOG = ["double_pendulum", "finger_edu", "ur3", "ur5", "ur10"]


def skewed_arm(joints: int, seed: int = 1) -> object:
    rng = np.random.default_rng(seed)
    links, chain = ['<link name="l0"/>'], []
    for i in range(1, joints + 1):
        ii = rng.uniform(0.06, 0.1, 3)  # principal moments: triangle inequality
        c, rpy = rng.uniform(-0.2, 0.2, 3), rng.uniform(-1, 1, 3)
        links.append(
            f'<link name="l{i}"><inertial><origin xyz="{c[0]} {c[1]} {c[2]}" '
            f'rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/><mass value="{rng.uniform(0.5, 3)}"/>'
            f'<inertia ixx="{ii[0]}" ixy="0.001" ixz="0" iyy="{ii[1]}" iyz="0.002" '
            f'izz="{ii[2]}"/></inertial></link>')
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        p, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-2, 2, 3)
        chain.append(
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            f'<origin xyz="{p[0]} {p[1]} {p[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/>'
            f'<axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
            f'<limit lower="-3" upper="3" effort="10" velocity="1"/></joint>')
    return pin.buildModelFromXML(f'<robot name="skewed">{"".join(links + chain)}</robot>')


def measure(model: object, repeats: int) -> dict[str, float]:
    derive, render, isolated, size = [], [], [], 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        eq = derive_equations(model)
        t1 = time.perf_counter()
        size = len(orjson.dumps(equations_answer(eq)))
        t2 = time.perf_counter()
        derive_isolated(model, time_limit_s=120)
        t3 = time.perf_counter()
        derive.append(t1 - t0)
        render.append(t2 - t1)
        isolated.append(t3 - t2)
    return {"derive": statistics.median(derive), "render": statistics.median(render),
            "isolated": statistics.median(isolated), "kB": size / 1e3}


def http_figures(robots: list[str]) -> None:
    import httpx

    from bench.run import server

    with tempfile.TemporaryDirectory() as data, server(
            ["-m", "service"], env={"ROBODYN_CATALOG": ",".join(robots),
                                    "ROBODYN_DATA_DIR": data}) as url, \
            httpx.Client(base_url=url, timeout=120) as http:
        print(f"{'GET …/equations':<22} {'cold s':>9} {'cached ms':>10} {'JSON kB':>9}")
        for robot in robots:
            t0 = time.perf_counter()
            first = http.get(f"/v1/robots/{robot}/equations")
            cold = time.perf_counter() - t0
            first.raise_for_status()
            cached = []
            for _ in range(50):
                t0 = time.perf_counter()
                http.get(f"/v1/robots/{robot}/equations").raise_for_status()
                cached.append(time.perf_counter() - t0)
            print(f"{robot:<22} {cold:>9.3f} {1e3 * statistics.median(cached):>10.2f} "
                  f"{len(first.content) / 1e3:>9.0f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worst", action="store_true", help="include the skewed 6-joint arm")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--http", action="store_true",
                        help="time the route on a real server (cold and cached) instead")
    args = parser.parse_args()
    if args.http:
        http_figures(["ur5", "planar_arm", "ur10"])
        return
    robots, _ = load_catalog(CATALOG)
    cases: list[tuple[str, object, int]] = [
        (name, robots[name].model, args.repeats) for name in CATALOG]
    cases += [(f"skewed {n}-joint arm", skewed_arm(n), 1) for n in (3, 4, 5)]
    if args.worst:
        cases.append(("skewed 6-joint arm", skewed_arm(6), 1))
    derive_isolated(robots["double_pendulum"].model, 60)  # start the forkserver once
    print(f"{platform.node()} · {platform.python_version()} · Pinocchio {pin.__version__}")
    print(f"{'robot':<22} {'nv':>3} {'derive s':>9} {'render s':>9} {'child s':>8} {'JSON kB':>9}")
    for name, model, repeats in cases:
        m = measure(model, repeats)
        print(f"{name:<22} {model.nv:>3} {m['derive']:>9.3f} {m['render']:>9.3f} "
              f"{m['isolated']:>8.3f} {m['kB']:>9.0f}")


if __name__ == "__main__":
    main()
