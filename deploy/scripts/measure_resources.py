"""Measure what one robodyn server process needs, to size Kubernetes requests and limits.

    .venv/bin/python deploy/scripts/measure_resources.py [--seconds 20] [--clients 8]

Starts `python -m service` (one worker, the whole catalog, as in deploy/k8s) and reports, as
one JSON line:

- `idle_rss_mib`: resident memory once the catalog is loaded and the server is ready;
- `single_state`: RSS peak and CPU while `clients` threads send single-state requests
  (mixed robots and quantities) as fast as the server answers;
- `batch`: RSS peak and CPU while `clients` threads send large batches (talos mass matrices
  and inverse dynamics of 2,000 states: 23 MB answers) at the same time;
- `largest_answer`: RSS peak for one talos mass-matrix batch of 7,435 states (an 86 MB array,
  about 256 MiB of JSON: the largest the default answer budget ROBODYN_MAX_ANSWER_BYTES
  admits), and for two of them at once: what one answer of the largest admitted batch costs.

CPU is the process's user + system time over wall time (1.0 = one core busy). The load
generator runs on the same machine, so on a small machine the server's figures are a lower
bound of what it would use with the machine to itself.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from localrun import (
    ROOT,
    free_port,
    load_models,
    process_tree_rss_kib,
    random_state,
    request_body,
    stop_group,
    wait_ready,
)

ROBOTS = ["ur5", "panda", "talos", "solo12", "anymal"]
QUANTITIES = ["mass-matrix", "gravity", "nonlinear-effects", "inverse-dynamics", "forward-dynamics"]


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    import os

    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


class Sampler:
    """Samples the RSS of a process tree every 50 ms in a thread; keeps the peak."""

    def __init__(self, pid: int) -> None:
        self.pid, self.peak_kib, self._stop = pid, 0, threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak_kib = max(self.peak_kib, process_tree_rss_kib(self.pid))
            time.sleep(0.05)

    def __enter__(self) -> Sampler:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()


def load_phase(
    base: str, pid: int, bodies: list[tuple[str, dict[str, Any]]], clients: int, seconds: float
) -> dict[str, Any]:
    """`clients` threads cycle through `bodies` for `seconds`; RSS peak, CPU, throughput."""
    deadline = time.monotonic() + seconds
    counts = [0] * clients
    errors: list[str] = []

    def client(i: int) -> None:
        with httpx.Client(base_url=base, timeout=120) as http:
            k = i
            while time.monotonic() < deadline:
                path, body = bodies[k % len(bodies)]
                r = http.post(path, json=body)
                if r.status_code != 200:
                    errors.append(f"{r.status_code} {r.text[:200]}")
                counts[i] += 1
                k += 1

    cpu0, wall0 = cpu_seconds(pid), time.monotonic()
    with Sampler(pid) as sampler, ThreadPoolExecutor(clients) as pool:
        list(pool.map(client, range(clients)))
    wall = time.monotonic() - wall0
    return {
        "rss_peak_mib": round(sampler.peak_kib / 1024),
        "requests": sum(counts),
        "requests_per_s": round(sum(counts) / wall, 1),
        "cpu_cores": round((cpu_seconds(pid) - cpu0) / wall, 2),
        "errors": len(errors),
        "first_error": errors[0] if errors else None,
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20, help="length of each load phase")
    parser.add_argument("--clients", type=int, default=8, help="concurrent client threads")
    args = parser.parse_args(argv)

    import os
    import subprocess

    port = free_port()
    data = Path(tempfile.mkdtemp(prefix="robodyn-measure-"))
    env = {
        **os.environ,
        "ROBODYN_DATA_DIR": str(data),
        "ROBODYN_LOG_LEVEL": "warning",
        "ROBODYN_CATALOG": "",
        "ROBODYN_WORKERS": "1",
    }
    proc = subprocess.Popen(
        [sys.executable, "-m", "service", "--port", str(port)],
        env=env,
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    base = f"http://127.0.0.1:{port}"
    out: dict[str, Any] = {"python": sys.version.split()[0]}
    try:
        out["ready_seconds"] = round(wait_ready(base, timeout=120, proc=proc), 1)
        time.sleep(1)
        out["idle_rss_mib"] = round(process_tree_rss_kib(proc.pid) / 1024)
        models = load_models(ROBOTS)
        rng = np.random.default_rng(3)
        singles = []
        for i in range(200):
            robot, quantity = ROBOTS[i % len(ROBOTS)], QUANTITIES[(i // 5) % len(QUANTITIES)]
            q, v, a = random_state(models[robot], rng)
            singles.append((f"/v1/robots/{robot}/{quantity}", request_body(quantity, q, v, a)))
        out["single_state"] = load_phase(base, proc.pid, singles, args.clients, args.seconds)
        talos = models["talos"]
        states = [random_state(talos, rng) for _ in range(2000)]
        qs, vs, as_ = (np.stack(x) for x in zip(*states, strict=True))
        batches = [
            ("/v1/robots/talos/mass-matrix", {"q": qs.tolist()}),
            (
                "/v1/robots/talos/inverse-dynamics",
                {"q": qs.tolist(), "v": vs.tolist(), "a": as_.tolist()},
            ),
        ]
        out["batch"] = load_phase(base, proc.pid, batches, args.clients, args.seconds)
        largest = 7435  # 256 MiB // (38² numbers × 25 bytes): the default answer budget's
        big = {"q": np.resize(qs, (largest, qs.shape[1])).tolist()}
        out["largest_answer"] = {"states": largest}
        for at_once in (1, 2):

            def one(_: int) -> httpx.Response:
                with httpx.Client(timeout=300) as http:
                    return http.post(f"{base}/v1/robots/talos/mass-matrix", json=big)

            with Sampler(proc.pid) as sampler, ThreadPoolExecutor(at_once) as pool:
                answers = list(pool.map(one, range(at_once)))
            assert all(r.status_code == 200 for r in answers), answers[0].text[:300]
            out["largest_answer"]["answer_mb"] = round(len(answers[0].content) / 1e6)
            out["largest_answer"][f"rss_peak_mib_{at_once}_at_once"] = round(
                sampler.peak_kib / 1024
            )
        time.sleep(1)
        out["rss_after_mib"] = round(process_tree_rss_kib(proc.pid) / 1024)
    finally:
        stop_group(proc)
        shutil.rmtree(data, ignore_errors=True)
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
