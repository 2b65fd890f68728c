"""robodyn benchmarks: every figure is a ratio against a baseline measured in the same run.

    .venv/bin/python bench/run.py            # about 4 minutes; needs `wrk` (apt-get install wrk)
    .venv/bin/python bench/run.py --quick    # shorter runs, noisier figures

Starts the service (and the naive baseline of bench/naive_app.py) on loopback ports, and the
service also on a Unix socket, runs each comparison (single states, batches, latency under
load, streams, workers, contacts, co-located clients) several times, alternating the sides,
and prints one table of medians.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import platform
import re
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from multiprocessing import Pool
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
# The in-process baselines run OpenMP in this process. With libgomp's default policy its threads
# then spin for about 8 ms (measured) on the cores the server and the client need for the next
# measurement; waiting passively, as the service's own threads do, they leave them free. (Read
# when libgomp loads, i.e. before pinocchio is imported; one call of a baseline is unchanged.)
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
UR5_Q = "[0.1, -1.2, 1.3, 0.2, 0.5, -0.3]"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


SOCKET = os.path.join(tempfile.mkdtemp(prefix="robodyn-bench-"), "robodyn.sock")


@contextmanager
def server(args: list[str], env: dict[str, str] | None = None) -> Iterator[str]:
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, *args, "--port", str(port)],
        cwd=ROOT,
        env={**os.environ, **(env or {})},
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}"
    import httpx

    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(url + "/health/ready", timeout=1).status_code in (200, 404):
                break
        except httpx.HTTPError:
            time.sleep(0.2)
    try:
        yield url
    finally:
        proc.terminate()
        proc.wait(10)


def wrk(url: str, seconds: int, body: str | None = None) -> float:
    """Requests per second with wrk: 1 thread, 8 connections."""
    cmd = ["wrk", "-t1", "-c8", f"-d{seconds}s", url]
    with tempfile.TemporaryDirectory() as tmp:
        if body is not None:
            script = Path(tmp) / "post.lua"
            script.write_text(
                f"wrk.method = \"POST\"\nwrk.body = '{body}'\n"
                'wrk.headers["Content-Type"] = "application/json"\n'
            )
            cmd[1:1] = ["-s", str(script)]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    errors = re.search(r"Non-2xx or 3xx responses: (\d+)", out)
    if errors:
        raise RuntimeError(f"wrk saw {errors.group(1)} failed requests on {url}")
    return float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1))  # type: ignore[union-attr]


def median_of(runs: int, fn: Callable[[], float]) -> float:
    return statistics.median(fn() for _ in range(runs))


ROWS: list[tuple[str, str, str, str]] = []


def row(what: str, ours: float, base: float, unit: str, target: str) -> None:
    ROWS.append((what, f"{ours:,.1f} {unit} vs {base:,.1f} {unit}", f"{ours / base:.2f}", target))
    print(f"  {what}: {ours:,.1f} vs {base:,.1f} {unit} → {ours / base:.2f} ({target})", flush=True)


def single_state(url: str, naive: str, seconds: int, rounds: int) -> None:
    print("1. single-state JSON throughput (wrk, 8 connections)", flush=True)
    live, mm, nv = [], [], []
    for _ in range(rounds):
        live.append(wrk(url + "/health/live", seconds))
        mm.append(wrk(url + "/v1/robots/ur5/mass-matrix", seconds, f'{{"q": {UR5_Q}}}'))
        nv.append(wrk(naive + "/v1/robots/ur5/mass-matrix", seconds, f'{{"q": {UR5_Q}}}'))
    row(
        "UR5 mass-matrix vs same server /health/live",
        statistics.median(mm),
        statistics.median(live),
        "req/s",
        "≥ 0.9",
    )
    row(
        "UR5 mass-matrix vs naive endpoint",
        statistics.median(mm),
        statistics.median(nv),
        "req/s",
        "≥ 2.5",
    )


def talos_states(n: int, seed: int = 0) -> tuple[object, dict[str, np.ndarray]]:
    import pinocchio as pin

    from service.registry import Registry

    registry = Registry(tempfile.mkdtemp(), ["talos"])
    registry.load()
    model = registry.get("talos").model
    rng = np.random.default_rng(seed)
    q = np.array(
        [pin.integrate(model, pin.neutral(model), rng.normal(0, 0.4, model.nv)) for _ in range(n)]
    )
    return model, {
        "q": q,
        "v": rng.normal(0, 1, (n, model.nv)),
        "a": rng.normal(0, 1, (n, model.nv)),
        "tau": rng.normal(0, 5, (n, model.nv)),
    }


def batches(url: str, rounds: int) -> None:
    import pinocchio as pin
    import robodyn

    print("2. Talos batches of 10,000 states through the client", flush=True)
    model, s = talos_states(10_000)
    threads = len(os.sched_getaffinity(0))
    pool = pin.ModelPool(model, threads)
    qT, vT, aT = (np.asfortranarray(s[k].T) for k in ("q", "v", "a"))

    def in_process_rnea() -> float:
        t = time.perf_counter()
        pin.rneaInParallel(threads, pool, qT, vT, aT)
        return time.perf_counter() - t

    with (
        robodyn.Client(url, timeout=300) as client,
        robodyn.Client(url, timeout=300, binary=False) as json_client,
    ):

        def through_client() -> float:
            t = time.perf_counter()
            client.inverse_dynamics("talos", s["q"], s["v"], s["a"])
            return time.perf_counter() - t

        tau_bin = client.inverse_dynamics("talos", s["q"], s["v"], s["a"])
        tau_json = json_client.inverse_dynamics("talos", s["q"], s["v"], s["a"])
        assert np.array_equal(tau_bin, tau_json), "binary and JSON answers differ"
        ours, base = [], []
        for _ in range(rounds):
            ours.append(through_client())
            base.append(in_process_rnea())
        row(
            "inverse dynamics, client end to end (binary) vs in-process rneaInParallel",
            1e4 / statistics.median(ours),
            1e4 / statistics.median(base),
            "states/s",
            "≥ 0.75",
        )
        t = time.perf_counter()
        json_client.inverse_dynamics("talos", s["q"], s["v"], s["a"])
        row(
            "same through JSON (for reference) vs in-process rneaInParallel",
            1e4 / (time.perf_counter() - t),
            1e4 / statistics.median(base),
            "states/s",
            "info",
        )

        data = model.createData()
        loops = {
            "mass_matrix": (lambda i: pin.crba(model, data, s["q"][i]), ("q",)),
            "gravity": (lambda i: pin.computeGeneralizedGravity(model, data, s["q"][i]), ("q",)),
            "coriolis": (
                lambda i: pin.computeCoriolisMatrix(model, data, s["q"][i], s["v"][i]),
                ("q", "v"),
            ),
            "nonlinear_effects": (
                lambda i: pin.nonLinearEffects(model, data, s["q"][i], s["v"][i]),
                ("q", "v"),
            ),
            "forward_dynamics": (
                lambda i: pin.aba(model, data, s["q"][i], s["v"][i], s["tau"][i]),
                ("q", "v", "tau"),
            ),
        }
        n = 2000
        computed: list[tuple[str, float, float]] = []
        for name, (step, inputs) in loops.items():
            args = [s[k][:n] for k in inputs]

            def loop(step: Callable[[int], object] = step) -> float:
                # The loop keeps its answers, as the service does (one array for the batch).
                t = time.perf_counter()
                out = [np.array(step(i)) for i in range(n)]  # crba returns data.M itself
                np.stack(out)
                return time.perf_counter() - t

            def served(name: str = name, args: list[np.ndarray] = args) -> float:
                t = time.perf_counter()
                getattr(client, name)("talos", *args)
                return time.perf_counter() - t

            loop_seconds = median_of(rounds, loop)
            row(
                f"{name} batch of {n} via client vs in-process Python loop",
                n / median_of(rounds, served),
                n / loop_seconds,
                "states/s",
                "≥ 1.0",
            )
            body = dict(zip(inputs, args, strict=True))
            computed.append(
                (
                    name,
                    n
                    / median_of(
                        rounds, lambda name=name, body=body: server_compute(url, name, body)
                    ),
                    n / loop_seconds,
                )
            )
        for name, ours, base in computed:  # after the end-to-end rows: one table section
            row(
                f"{name} batch of {n}: the service's compute (Server-Timing) vs in-process "
                "Python loop",
                ours,
                base,
                "states/s",
                "info: per-state cost of the batch",
            )


def server_compute(url: str, name: str, inputs: dict[str, np.ndarray]) -> float:
    """Seconds the service spent computing one batch (its `Server-Timing: compute;dur=`):
    validation and computation of every state, without the transfer of inputs and answers."""
    import httpx
    from robodyn import binary

    response = httpx.post(
        f"{url}/v1/robots/talos/{name.replace('_', '-')}",
        content=binary.encode(inputs),
        timeout=300,
        headers={"content-type": binary.MEDIA_TYPE, "accept": binary.MEDIA_TYPE},
    )
    response.raise_for_status()
    timing = re.search(r"compute;dur=([\d.]+)", response.headers["server-timing"])
    return float(timing.group(1)) / 1e3  # type: ignore[union-attr]


def latency_under_load(url: str, seconds: float) -> None:
    import httpx

    print("3. single-state latency while 10k-state batches run", flush=True)

    def p99(duration: float) -> float:
        times = []
        with httpx.Client() as http:
            end = time.monotonic() + duration
            while time.monotonic() < end:
                t = time.perf_counter()
                r = http.post(
                    url + "/v1/robots/ur5/mass-matrix",
                    content=f'{{"q": {UR5_Q}}}',
                    headers={"content-type": "application/json"},
                )
                times.append(time.perf_counter() - t)
                assert r.status_code == 200
        return float(np.percentile(times, 99)) * 1e3

    idle = p99(seconds)
    # The batches come from another process: a load thread here would hold this process's
    # GIL while it encodes and decodes megabytes, and the figure would measure the client.
    stop = multiprocessing.Event()
    worker = multiprocessing.Process(target=_batch_load, args=(url, stop))
    worker.start()
    time.sleep(1.0)
    busy = p99(seconds)
    stop.set()
    worker.join()
    row("single-state p99 during 10k batches vs idle p99", busy, idle, "ms", "≤ 5")


def _batch_load(url: str, stop: object) -> None:
    """Send 10k-state Talos inverse-dynamics batches back to back until `stop` is set."""
    import robodyn

    _, s = talos_states(10_000, seed=1)
    with robodyn.Client(url, timeout=300) as client:
        while not stop.is_set():  # type: ignore[attr-defined]
            client.inverse_dynamics("talos", s["q"], s["v"], s["a"])


def _stream_worker(args: tuple[str, float]) -> tuple[float, float]:
    import robodyn

    url, duration = args
    q = np.array([0.1, -1.2, 1.3, 0.2, 0.5, -0.3])
    times = []
    with robodyn.Client(url) as client, client.stream("ur5") as s:
        end = time.monotonic() + duration
        while time.monotonic() < end:
            t = time.perf_counter()
            s.inverse_dynamics(q, q, q)
            times.append(time.perf_counter() - t)
    return len(times) / duration, float(np.percentile(times, 99)) * 1e3


def streams(url: str, seconds: float) -> None:
    print("4. WebSocket streams of UR5 inverse dynamics", flush=True)
    with Pool(1) as pool:
        rate, p99 = pool.map(_stream_worker, [(url, seconds)])[0]
    row("one stream: round trips/s vs target 1000", rate, 1000, "rt/s", "≥ 1.0")
    row("one stream: p99 round trip vs 2 ms", p99, 2.0, "ms", "≤ 1.0")
    with Pool(4) as pool:
        rates = [r for r, _ in pool.map(_stream_worker, [(url, seconds)] * 4)]
    row("four streams: slowest stream vs target 500", min(rates), 500, "rt/s", "≥ 1.0")


def workers(seconds: int, rounds: int, env: dict[str, str]) -> None:
    print("5. two workers vs one (wrk shares the 2 cores: see the caveat)", flush=True)
    rates = {}
    for n in (1, 2):
        with server(["-m", "service", "--workers", str(n)], env) as url:
            time.sleep(2)
            rates[n] = median_of(
                rounds,
                lambda url=url: wrk(
                    url + "/v1/robots/ur5/mass-matrix", seconds, f'{{"q": {UR5_Q}}}'
                ),
            )
    row(
        "UR5 mass-matrix, 2 workers vs 1 worker",
        rates[2],
        rates[1],
        "req/s",
        "≥ 1.5 with the load generator elsewhere",
    )


TALOS_SOLES = [
    {"frame": "left_sole_link", "type": "6d"},
    {"frame": "right_sole_link", "type": "6d"},
]


def contacts(url: str, rounds: int) -> None:
    """A contact-dynamics batch (Talos on both soles, 6d contacts) through the client, and the
    service's own compute time, against a Python loop over Pinocchio's constraintDynamics
    (constraint models and data built once, as the service caches them)."""
    import httpx
    import pinocchio as pin
    import robodyn
    from robodyn import binary

    print("6. contact-dynamics batch (Talos, both soles 6d)", flush=True)
    model, s = talos_states(2000, seed=2)
    n = 2000
    data = model.createData()
    models, datas = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
    for c in TALOS_SOLES:
        f = model.frames[model.getFrameId(c["frame"])]
        cm = pin.RigidConstraintModel(
            pin.ContactType.CONTACT_6D,
            model,
            f.parentJoint,
            f.placement,
            pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
        )
        models.append(cm)
        datas.append(cm.createData())
    pin.initConstraintDynamics(model, data, models, datas)
    settings = pin.ProximalSettings(1e-12, 1e-12, 0.0, 1)
    args = {k: s[k][:n] for k in ("q", "v", "tau")}

    def loop() -> float:
        t = time.perf_counter()
        a, lam = np.empty((n, model.nv)), np.empty((n, 12))
        for i in range(n):
            a[i] = pin.constraintDynamics(
                model, data, args["q"][i], args["v"][i], args["tau"][i], models, datas, settings
            )
            lam[i] = data.lambda_c
        return time.perf_counter() - t

    with robodyn.Client(url, timeout=300) as client:

        def served() -> float:
            t = time.perf_counter()
            client.contact_dynamics("talos", args["q"], args["v"], args["tau"], TALOS_SOLES)
            return time.perf_counter() - t

        def compute() -> float:
            response = httpx.post(
                f"{url}/v1/robots/talos/contact-dynamics",
                content=binary.encode(args, {"contacts": TALOS_SOLES}),
                timeout=300,
                headers={"content-type": binary.MEDIA_TYPE, "accept": binary.MEDIA_TYPE},
            )
            response.raise_for_status()
            timing = re.search(r"compute;dur=([\d.]+)", response.headers["server-timing"])
            return float(timing.group(1)) / 1e3  # type: ignore[union-attr]

        loop_seconds = median_of(rounds, loop)
        row(
            f"contact-dynamics batch of {n} (Talos, 2 soles 6d) via client vs in-process "
            "Python loop over constraintDynamics",
            n / median_of(rounds, served),
            n / loop_seconds,
            "states/s",
            "info",
        )
        row(
            f"contact-dynamics batch of {n}: the service's compute (Server-Timing) vs the same "
            "loop",
            n / median_of(rounds, compute),
            n / loop_seconds,
            "states/s",
            "info",
        )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="shorter runs")
    parser.add_argument("--only", default="123456789", help="which comparisons, e.g. 13")
    opts = parser.parse_args()
    if shutil.which("wrk") is None and set(opts.only) & set("15"):
        sys.exit("wrk is needed: apt-get install wrk")
    seconds, rounds = (2, 3) if opts.quick else (5, 5)
    # The JSON reference row of comparison 2 sends 10,000 Talos states as JSON (~23 MB), over
    # the default ROBODYN_MAX_JSON_BODY_BYTES: admitted here so the row stays comparable.
    env = {
        "ROBODYN_CATALOG": "ur5,talos,xarm7",
        "ROBODYN_DATA_DIR": tempfile.mkdtemp(),
        "ROBODYN_LOG_LEVEL": "warning",
        "ROBODYN_MAX_JSON_BODY_BYTES": str(64 << 20),
        "ROBODYN_UNIX_SOCKET": SOCKET,  # co-located clients (comparison 9)
    }
    sys.path.insert(0, str(ROOT))
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, "
        f"{platform.python_implementation()} {platform.python_version()}",
        flush=True,
    )
    with (
        server(["-m", "service"], env) as url,
        server(["-m", "uvicorn", "bench.naive_app:app", "--log-level", "warning"]) as naive,
    ):
        if "1" in opts.only:
            single_state(url, naive, seconds, rounds)
        if "2" in opts.only:
            batches(url, rounds)
        if "3" in opts.only:
            latency_under_load(url, seconds * 2)
        if "4" in opts.only:
            streams(url, seconds * 2)
        if "6" in opts.only:
            contacts(url, rounds)
        if "7" in opts.only:
            from bench.payloads import payload_capacity

            payload_capacity(url, rounds, median_of, row)
        if "8" in opts.only:
            from bench import trajectories

            trajectories.check(url, rounds, median_of, row)
            trajectories.retime(url, rounds, median_of, row)
        if "9" in opts.only:
            from bench.colocated import colocated

            colocated(url, SOCKET, max(rounds, 7), talos_states, row)
    if "5" in opts.only:
        workers(seconds, rounds, env)
    print("\n| comparison | figures (medians) | ratio | target |\n|---|---|---|---|")
    for what, figures, ratio, target in ROWS:
        print(f"| {what} | {figures} | {ratio} | {target} |")


if __name__ == "__main__":
    main()
