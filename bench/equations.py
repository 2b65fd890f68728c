"""How long the equations of motion in explicit form take to derive, cold.

    PYTHONPATH=$PWD .venv/bin/python bench/equations.py          # catalog, skewed arms to 5 joints
    PYTHONPATH=$PWD .venv/bin/python bench/equations.py --worst  # also the skewed 6-joint arm
    PYTHONPATH=$PWD .venv/bin/python bench/equations.py --http   # GET .../ur5/equations, a server

(from the repository root: the skewed arms are the tests' `tests.helpers.skewed_arm_urdf`)

For each robot: the derivation (M, U, then g, Christoffel symbols, C, T), the rendering of the
answer (every entry as a SymPy expression, printed by `sp.sstr` and `sp.latex`), its JSON size,
and the whole of it in a child process as the service runs it (`derive_isolated`: process
start, model transfer, derivation, printing, JSON) — every figure from a cold start (nothing is
cached between runs). A child past its time limit (60 s, `--time-limit`) is the service's 422
and is shown as such, its rendering not timed. `--http` starts
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

import orjson
import pinocchio as pin

from service.api.workers.equations import derive_isolated
from service.dynamics.equations import derive_equations, equations_answer
from service.errors import Overloaded, UnsupportedModel
from service.registry.catalog import load_catalog
from tests.helpers import skewed_arm_urdf

CATALOG = ["double_pendulum", "finger_edu", "ur3", "ur5", "ur10"]


def skewed_arm(joints: int, seed: int = 1) -> object:
    """The tests' skewed arm (no two axes parallel: the worst case) as a Pinocchio model."""
    return pin.buildModelFromXML(skewed_arm_urdf(joints, seed))


def measure(model: object, repeats: int, time_limit_s: float) -> dict[str, float | None]:
    """Medians over `repeats` cold runs; the in-process rendering is timed only when the child
    finished within `time_limit_s` (the service's limit: past it the answer is a 422, or a 503
    when the machine starved the child of CPU)."""
    derive, render, isolated, size = [], [], [], 0
    for _ in range(repeats):
        t0 = time.perf_counter()
        eq = derive_equations(model)
        t1 = time.perf_counter()
        try:
            derive_isolated(model, time_limit_s=time_limit_s)
        except (UnsupportedModel, Overloaded) as exc:  # 422 past the limit, 503 if starved
            status = 422 if isinstance(exc, UnsupportedModel) else 503
            return {
                "derive": t1 - t0,
                "render": None,
                "isolated": None,
                "kB": None,
                "status": status,
            }
        t2 = time.perf_counter()
        size = len(orjson.dumps(equations_answer(eq)))
        t3 = time.perf_counter()
        derive.append(t1 - t0)
        isolated.append(t2 - t1)
        render.append(t3 - t2)
    return {
        "derive": statistics.median(derive),
        "render": statistics.median(render),
        "isolated": statistics.median(isolated),
        "kB": size / 1e3,
    }


def http_figures(robots: list[str]) -> None:
    import httpx

    from bench.run import server

    with (
        tempfile.TemporaryDirectory() as data,
        server(
            ["-m", "service"], env={"ROBODYN_CATALOG": ",".join(robots), "ROBODYN_DATA_DIR": data}
        ) as url,
        httpx.Client(base_url=url, timeout=120) as http,
    ):
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
            print(
                f"{robot:<22} {cold:>9.3f} {1e3 * statistics.median(cached):>10.2f} "
                f"{len(first.content) / 1e3:>9.0f}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--worst", action="store_true", help="include the skewed 6-joint arm")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument(
        "--time-limit",
        type=float,
        default=60,
        help="the child's time limit, s (the service's default: 60)",
    )
    parser.add_argument(
        "--http",
        action="store_true",
        help="time the route on a real server (cold and cached) instead",
    )
    args = parser.parse_args()
    if args.http:
        http_figures(["ur5", "planar_arm", "ur10"])
        return
    robots, _ = load_catalog(CATALOG)
    cases: list[tuple[str, object, int]] = [
        (name, robots[name].model, args.repeats) for name in CATALOG
    ]
    cases += [(f"skewed {n}-joint arm", skewed_arm(n), 1) for n in (3, 4, 5)]
    if args.worst:
        cases.append(("skewed 6-joint arm", skewed_arm(6), 1))
    derive_isolated(robots["double_pendulum"].model, 60)  # start the forkserver once
    print(f"{platform.node()} · {platform.python_version()} · Pinocchio {pin.__version__}")
    print(f"{'robot':<22} {'nv':>3} {'derive s':>9} {'render s':>9} {'child s':>8} {'JSON kB':>9}")
    for name, model, repeats in cases:
        m = measure(model, repeats, args.time_limit)
        if m["isolated"] is None:
            print(
                f"{name:<22} {model.nv:>3} {m['derive']:>9.3f} {'—':>9} "
                f"{'> ' + format(args.time_limit, 'g'):>8} {m['status']:>9}"
            )
            continue
        print(
            f"{name:<22} {model.nv:>3} {m['derive']:>9.3f} {m['render']:>9.3f} "
            f"{m['isolated']:>8.3f} {m['kB']:>9.0f}"
        )


if __name__ == "__main__":
    main()
