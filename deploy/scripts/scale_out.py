"""Scale-out on one machine: two robodyn replicas sharing one data directory behind nginx.

    .venv/bin/python deploy/scripts/scale_out.py [--requests 200] [--stop term|kill]

Needs nginx (Debian: `apt-get install -y nginx`). Steps, each checked:

1. start two `python -m service` processes on free loopback ports with one ROBODYN_DATA_DIR,
   and nginx (deploy/nginx/scale-out.conf.template: round-robin, retry on the next replica);
2. upload a model through the balancer; each replica, asked directly, serves it;
3. send `--requests` mixed requests through nginx (catalog and uploaded robots, every
   quantity, single states and batches, robot listings, repeated uploads) from 8 threads:
   every one must answer 200/201 and every dynamics answer must equal in-process Pinocchio;
   both replicas must have served some;
4. send as many again, and stop one replica (SIGTERM, or SIGKILL with `--stop kill`) after a
   third of them: every request must still succeed (nginx retries on the other replica);
5. every request id the client sent appears in a replica's JSON access log, with status 200.

Prints one JSON summary line; exits non-zero on the first failed check.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
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
    INPUTS,
    ROOT,
    expected,
    free_port,
    load_models,
    max_relative_error,
    random_state,
    request_body,
    stop_group,
    wait_ready,
)

ROBOTS = ["ur5", "panda", "talos", "solo12"]
TEMPLATE = ROOT / "deploy" / "nginx" / "scale-out.conf.template"


def start_replica(data_dir: Path, work: Path, name: str) -> tuple[subprocess.Popen, int]:
    port = free_port()
    env = {
        **os.environ,
        "ROBODYN_DATA_DIR": str(data_dir),
        "ROBODYN_CATALOG": ",".join(ROBOTS),
        "ROBODYN_LOG_LEVEL": "info",
    }
    with open(work / f"replica-{name}.log", "ab") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "service", "--port", str(port)],
            env=env,
            cwd=ROOT,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    return proc, port


def start_nginx(work: Path, port_a: int, port_b: int) -> tuple[subprocess.Popen, int]:
    nginx = shutil.which("nginx") or "/usr/sbin/nginx"
    if not Path(nginx).exists():
        raise SystemExit("nginx is not installed (Debian: apt-get install -y nginx)")
    port = free_port()
    prefix = work / "nginx"
    prefix.mkdir()
    for sub in ("client_body", "proxy", "fastcgi", "uwsgi", "scgi"):
        (prefix / sub).mkdir()
        (prefix / sub).chmod(0o777)  # nginx's workers run as an unprivileged user under root
    work.chmod(0o755)
    prefix.chmod(0o755)
    conf = TEMPLATE.read_text()
    for key, value in {
        "@PREFIX@": str(prefix),
        "@PORT_A@": str(port_a),
        "@PORT_B@": str(port_b),
        "@PORT_LB@": str(port),
    }.items():
        conf = conf.replace(key, value)
    (prefix / "nginx.conf").write_text(conf)
    check = subprocess.run(
        [nginx, "-t", "-p", str(prefix), "-c", "nginx.conf"], capture_output=True, text=True
    )
    if check.returncode != 0:
        raise SystemExit(f"nginx -t failed:\n{check.stderr}")
    with open(prefix / "stderr.log", "wb") as stderr:
        proc = subprocess.Popen(
            [nginx, "-p", str(prefix), "-c", "nginx.conf", "-g", "daemon off;"],
            stdout=subprocess.DEVNULL,
            stderr=stderr,
            start_new_session=True,
        )
    return proc, port


class Workload:
    """Mixed requests with their expected answers (dynamics checked against Pinocchio)."""

    def __init__(
        self, models: dict[str, Any], upload_id: str, upload_model: Any, urdf: str, seed: int
    ) -> None:
        self.models = {**models, upload_id: upload_model}
        self.upload_id, self.urdf = upload_id, urdf
        self.rng = np.random.default_rng(seed)

    def make(self, i: int) -> dict[str, Any]:
        kind = i % 10
        if kind == 8:
            return {"method": "GET", "path": "/v1/robots", "expect": 200}
        if kind == 9:  # repeated upload: idempotent, 200 with the same id
            return {
                "method": "POST",
                "path": "/v1/robots",
                "expect": 200,
                "json": {"urdf": self.urdf, "name": "scale-out arm"},
                "id": self.upload_id,
            }
        robot = list(self.models)[int(self.rng.integers(len(self.models)))]
        quantity = list(INPUTS)[int(self.rng.integers(len(INPUTS)))]
        batch = 16 if kind == 3 else 1
        states = [random_state(self.models[robot], self.rng) for _ in range(batch)]
        if batch == 1:
            body = request_body(quantity, *states[0])
        else:
            stacked = [np.stack(x) for x in zip(*states, strict=True)]
            body = request_body(quantity, *stacked)
        return {
            "method": "POST",
            "path": f"/v1/robots/{robot}/{quantity}",
            "expect": 200,
            "json": body,
            "robot": robot,
            "quantity": quantity,
            "states": states,
        }

    def check(self, job: dict[str, Any], response: httpx.Response) -> float:
        assert response.status_code == job["expect"], (
            f"{job['method']} {job['path']}: {response.status_code} {response.text[:300]}"
        )
        if "id" in job:
            assert response.json()["id"] == job["id"]
        if "quantity" not in job:
            return 0.0
        answer, worst = response.json(), 0.0
        for k, state in enumerate(job["states"]):
            reference = expected(self.models[job["robot"]], job["quantity"], *state)
            one = answer if len(job["states"]) == 1 else {key: answer[key][k] for key in reference}
            worst = max(worst, max_relative_error(one, reference))
        return worst


def send_all(
    base: str, jobs: list[dict[str, Any]], workload: Workload, tag: str, on_progress: Any = None
) -> dict[str, Any]:
    """Send `jobs` from 8 threads; every one must succeed. Which replicas answered."""
    done = [0]
    lock = threading.Lock()
    upstreams: dict[str, int] = {}
    retried = []
    worst = [0.0]

    def run(item: tuple[int, dict[str, Any]]) -> None:
        i, job = item
        with httpx.Client(base_url=base, timeout=120) as http:
            r = http.request(
                job["method"],
                job["path"],
                json=job.get("json"),
                headers={"X-Request-ID": f"{tag}-{i}"},
            )
        error = workload.check(job, r)
        upstream = r.headers.get("x-upstream", "")
        with lock:
            worst[0] = max(worst[0], error)
            upstreams[upstream.split(", ")[-1]] = upstreams.get(upstream.split(", ")[-1], 0) + 1
            if ", " in upstream:
                retried.append(upstream)
            done[0] += 1
            if on_progress is not None:
                on_progress(done[0])

    with ThreadPoolExecutor(8) as pool:
        list(pool.map(run, enumerate(jobs), timeout=600))
    return {
        "requests": len(jobs),
        "answered_by": upstreams,
        "retried_on_next": len(retried),
        "max_relative_error": worst[0],
    }


def access_log_ids(path: Path) -> dict[str, int]:
    ids = {}
    for line in path.read_text().splitlines():
        record = json.loads(line)  # every line a replica writes is JSON
        if record.get("logger") == "robodyn.access":
            ids[record["request_id"]] = record["status"]
    return ids


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--requests", type=int, default=200)
    parser.add_argument(
        "--stop",
        choices=["term", "kill"],
        default="term",
        help="how to stop one replica mid-run: SIGTERM (graceful) or SIGKILL",
    )
    parser.add_argument(
        "--keep",
        action="store_true",
        help="keep the work directory (logs, nginx config) after a success",
    )
    args = parser.parse_args(argv)

    work = Path(tempfile.mkdtemp(prefix="robodyn-scale-out-"))
    data = work / "data"
    data.mkdir()
    procs: list[subprocess.Popen] = []
    summary: dict[str, Any] = {"stop": args.stop, "work_dir": str(work)}
    try:
        replica_a, port_a = start_replica(data, work, "a")
        replica_b, port_b = start_replica(data, work, "b")
        procs += [replica_a, replica_b]
        nginx, port = start_nginx(work, port_a, port_b)
        procs.append(nginx)
        base = f"http://127.0.0.1:{port}"
        for proc, p in ((replica_a, port_a), (replica_b, port_b)):
            wait_ready(f"http://127.0.0.1:{p}", timeout=120, proc=proc)
        wait_ready(base, timeout=30, proc=nginx)

        import pinocchio as pin

        urdf = (ROOT / "robots" / "textbook" / "planar_arm.urdf").read_text()
        up = httpx.post(
            f"{base}/v1/robots", json={"urdf": urdf, "name": "scale-out arm"}, timeout=120
        )
        assert up.status_code == 201, up.text
        upload_id = up.json()["id"]
        for p in (port_a, port_b):  # the shared data directory: each replica serves it
            r = httpx.get(f"http://127.0.0.1:{p}/v1/robots/{upload_id}", timeout=30)
            assert r.status_code == 200, f"replica on {p}: {r.status_code} {r.text}"
        workload = Workload(
            load_models(ROBOTS), upload_id, pin.buildModelFromXML(urdf), urdf, seed=7
        )

        jobs = [workload.make(i) for i in range(args.requests)]
        summary["both_up"] = send_all(base, jobs, workload, "both")
        assert len(summary["both_up"]["answered_by"]) == 2, summary["both_up"]

        stop_at = args.requests // 3
        stopped = threading.Event()

        def stop_b(done: int) -> None:
            if done >= stop_at and not stopped.is_set():
                stopped.set()
                os.kill(replica_b.pid, signal.SIGTERM if args.stop == "term" else signal.SIGKILL)

        jobs = [workload.make(i) for i in range(args.requests)]
        started = time.monotonic()
        summary["one_stopped"] = send_all(base, jobs, workload, "stop", on_progress=stop_b)
        summary["one_stopped"]["seconds"] = round(time.monotonic() - started, 1)
        assert stopped.is_set() and replica_b.wait(timeout=60) is not None
        summary["replica_b_exit"] = replica_b.returncode

        # Correlation: every request id the client sent reached a replica's access log.
        logged = {
            **access_log_ids(work / "replica-b.log"),
            **access_log_ids(work / "replica-a.log"),
        }
        sent = [f"{tag}-{i}" for tag in ("both", "stop") for i in range(args.requests)]
        missing = [i for i in sent if logged.get(i) not in (200, 201)]
        assert not missing, f"not in any replica's access log with 200/201: {missing[:5]}"
        summary["logged_request_ids"] = len(sent)
    except BaseException:
        print(f"failed; logs and nginx config kept in {work}", file=sys.stderr)
        raise
    finally:
        for proc in reversed(procs):
            stop_group(proc)
    if not args.keep:  # after a failure the directory stays, for its logs
        shutil.rmtree(work)
        del summary["work_dir"]
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
