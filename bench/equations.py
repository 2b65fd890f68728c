"""How long the equations of motion in explicit form take, cold, in both forms.

    PYTHONPATH=$PWD .venv/bin/python bench/equations.py          # in process and in a child
    PYTHONPATH=$PWD .venv/bin/python bench/equations.py --http   # first requests, a fresh server

(from the repository root: the arms are the tests' `tests.helpers.alternating_arm_urdf` and
`skewed_arm_urdf`)

For each robot and form (numeric, parametric), at the default printing (6 digits, tolerance
1e-9): the derivation (M and U, then g, Christoffel symbols, C, T), the printing of the answer
(text and LaTeX of every entry, `equations_answer`), its JSON size, and the whole of it in a
child process as the service runs it (`derive_isolated`: process start, model transfer,
derivation, printing, JSON; the forkserver already running). `--http` starts `python -m
service` and times the first `GET /v1/robots/{id}/equations?form=…` of each arm (the very first
also starts the forkserver) and a cached answer (median of 20). The requirement: every arm with
at most six revolute or prismatic joints within 10 s on the first request, both forms. The
machine's load average is printed with the figures: the derivation is pure Python, and its
time scales with the CPU share it gets.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time

import orjson
import pinocchio as pin

from service.api.workers.equations import Printing, derive_isolated
from service.dynamics.equations import derive_equations, equations_answer
from service.errors import Overloaded
from service.registry.catalog import load_catalog
from tests.helpers import alternating_arm_urdf, skewed_arm_urdf

FORMS = ("numeric", "parametric")


def arms() -> list[tuple[str, str]]:
    """(name, URDF) of the arms measured besides the catalog's UR5."""
    out = [("alternating 6R", alternating_arm_urdf())]
    out += [(f"skewed 6R (seed {s})", skewed_arm_urdf(6, s)) for s in (1, 2, 3)]
    return out


def load() -> str:
    return "load average " + ", ".join(f"{x:.1f}" for x in os.getloadavg())


def in_process(cases: list[tuple[str, object]]) -> None:
    derive_isolated(cases[0][1], 60)  # start the forkserver once
    print(f"{platform.node()} · {platform.python_version()} · Pinocchio {pin.__version__}")
    print(load())
    print("derive, print: CPU seconds in this process (wall seconds in brackets)")
    print(f"{'robot':<22} {'form':<10} {'derive s':>13} {'print s':>13} {'child s':>8} {'MB':>6}")
    for name, model in cases:
        for form in FORMS:
            c0, t0 = time.process_time(), time.perf_counter()
            eq = derive_equations(model, form=form)
            c1, t1 = time.process_time(), time.perf_counter()
            size = len(orjson.dumps(equations_answer(eq)))
            c2, t2 = time.process_time(), time.perf_counter()
            try:
                derive_isolated(model, 60, printing=Printing(form))
                child = f"{time.perf_counter() - t2:>8.2f}"
            except Overloaded:  # the machine starved the child: a 503, retried by clients
                child = f"{'503':>8}"
            print(
                f"{name:<22} {form:<10} {c1 - c0:>5.2f} ({t1 - t0:>5.2f}) "
                f"{c2 - c1:>5.2f} ({t2 - t1:>5.2f}) {child} {size / 1e6:>6.1f}"
            )
    print(load())


def http_figures() -> None:
    import httpx

    from bench.run import server

    with (
        tempfile.TemporaryDirectory() as data,
        server(["-m", "service"], env={"ROBODYN_CATALOG": "ur5", "ROBODYN_DATA_DIR": data}) as url,
        httpx.Client(base_url=url, timeout=120) as http,
    ):
        print(load())
        print(f"{'GET …/equations':<22} {'form':<10} {'first s':>8} {'cached ms':>10} {'MB':>6}")
        ids = [("ur5", "ur5")]
        for name, urdf in arms():
            ids.append((name, http.post("/v1/robots", json={"urdf": urdf}).json()["id"]))
        for name, robot_id in ids:
            for form in FORMS:
                path = f"/v1/robots/{robot_id}/equations?form={form}"
                t0 = time.perf_counter()
                first = http.get(path)
                cold = time.perf_counter() - t0
                if first.status_code == 503:  # the machine starved the child
                    print(f"{name:<22} {form:<10} {'503':>8} ({first.json()['detail'][:60]})")
                    continue
                first.raise_for_status()
                cached = []
                for _ in range(20):
                    t0 = time.perf_counter()
                    http.get(path).raise_for_status()
                    cached.append(time.perf_counter() - t0)
                print(
                    f"{name:<22} {form:<10} {cold:>8.2f} {1e3 * statistics.median(cached):>10.1f} "
                    f"{len(first.content) / 1e6:>6.1f}"
                )
        print(load())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--http", action="store_true", help="time first requests on a fresh server instead"
    )
    args = parser.parse_args()
    if args.http:
        http_figures()
        return
    robots, _ = load_catalog(["ur5"])
    cases = [("ur5", robots["ur5"].model)]
    cases += [(name, pin.buildModelFromXML(urdf)) for name, urdf in arms()]
    in_process(cases)


if __name__ == "__main__":
    main()
