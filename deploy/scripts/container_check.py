"""Build the robodyn image for real, run it, and check that it serves correct dynamics.

    .venv/bin/python deploy/scripts/container_check.py [--tag robodyn:test] [--no-build]

Without a Docker engine (as on the project's machines), the image is built with buildah
(chroot isolation) on `python:3.11-slim`, or on the local stand-in for it that
`deploy/scripts/container-base.sh` makes when no such image is present. The container is run
the way a container engine would run it: the image's CMD as the image's USER, with its ENV and
WORKDIR (`buildah run` applies none of them by itself). Then:

- the image's configuration: non-root numeric user, port 8000, /data volume, exec-form CMD,
  HEALTHCHECK on /health/live;
- inside the image: no compiler, no pip or apt cache, `import pinocchio` works;
- the server: /health/ready turns 200, the HEALTHCHECK command succeeds, the whole catalog
  loads, mass matrix, inverse and forward dynamics of ur5 and talos equal in-process Pinocchio,
  an upload is stored in the volume by the non-root user, and every log line is JSON.

Prints one JSON summary line at the end; exits non-zero on the first failed check.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from localrun import (
    ROOT,
    descendants,
    expected,
    free_port,
    max_relative_error,
    port_is_free,
    random_state,
    request_body,
    stop_group,
    wait_ready,
)

BASE_IMAGE = "docker.io/library/python:3.11-slim"
BASE_SCRIPT = ROOT / "deploy" / "scripts" / "container-base.sh"
IMAGE_PORT = 8000
WRITABLE = ("/data", "/tmp", "/proc", "/sys", "/dev", "/run")  # volumes and kernel file systems
BUILDAH_FILES = ("/", "/etc", "/etc/hosts", "/etc/resolv.conf", "/etc/hostname")  # run's own


def sh(*args: str, check: bool = True, **kw: Any) -> subprocess.CompletedProcess:
    return subprocess.run(args, check=check, text=True, capture_output=True, **kw)


def ensure_base_image() -> None:
    if sh("buildah", "inspect", "--type", "image", BASE_IMAGE, check=False).returncode == 0:
        return
    if not BASE_SCRIPT.exists():
        raise SystemExit(f"no {BASE_IMAGE} image and no {BASE_SCRIPT} to build a stand-in")
    subprocess.run(["bash", str(BASE_SCRIPT)], check=True)


def build(tag: str) -> float:
    """`buildah bud` the Dockerfile (docker format, so HEALTHCHECK is kept); seconds taken."""
    started = time.monotonic()
    cmd = [
        "buildah",
        "bud",
        "--format",
        "docker",
        "--layers",
        "--isolation",
        "chroot",
        "--pull-never",
        "--ulimit",
        "nofile=20000:20000",
        "-t",
        tag,
    ]
    certs = Path("/etc/ssl/certs/ca-certificates.crt")
    if certs.exists():  # lets pip in the build reach the package index through this machine
        cmd += ["-v", f"{certs}:{certs}:ro"]
    result = subprocess.run([*cmd, str(ROOT)], text=True, capture_output=True)
    if result.returncode != 0:
        raise SystemExit(f"buildah bud failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}")
    return time.monotonic() - started


def image_config(tag: str) -> dict[str, Any]:
    info = json.loads(sh("buildah", "inspect", "--type", "image", tag).stdout)
    config = info["Docker"]["config"]
    return {
        "cmd": config.get("Cmd") or [],
        "entrypoint": config.get("Entrypoint") or [],
        "user": config.get("User", ""),
        "env": config.get("Env") or [],
        "workdir": config.get("WorkingDir") or "/",
        "ports": sorted(config.get("ExposedPorts") or {}),
        "volumes": sorted(config.get("Volumes") or {}),
        "healthcheck": (config.get("Healthcheck") or {}).get("Test") or [],
        "size": json.loads(sh("buildah", "images", "--json", tag).stdout)[0]["size"],
    }


def check_config(config: dict[str, Any]) -> None:
    user = config["user"].split(":")[0]
    assert user.isdigit() and int(user) != 0, f"image user must be numeric non-root: {user!r}"
    assert config["ports"] == [f"{IMAGE_PORT}/tcp"], config["ports"]
    assert config["volumes"] == ["/data"], config["volumes"]
    assert "ROBODYN_DATA_DIR=/data" in config["env"], config["env"]
    assert config["cmd"][:3] == ["python", "-m", "service"], config["cmd"]
    assert "0.0.0.0" in config["cmd"] and str(IMAGE_PORT) in config["cmd"], config["cmd"]
    health = " ".join(config["healthcheck"])
    assert config["healthcheck"][:1] == ["CMD"] and "/health/live" in health, health


def run_args(ctr: str, config: dict[str, Any], user: str | None = None) -> list[str]:
    """`buildah run` as a container engine would run the image: its USER (or `user`), ENV and
    WORKDIR, given explicitly."""
    args = [
        "buildah",
        "run",
        "--isolation",
        "chroot",
        "--workingdir",
        config["workdir"],
        "--user",
        user or config["user"],
    ]
    for item in config["env"]:
        args += ["--env", item]
    return [*args, ctr, "--"]


def check_contents(ctr: str, config: dict[str, Any]) -> None:
    probe = (
        "id -u; "
        "for c in gcc cc g++ c++ clang make; do command -v $c || true; done; "
        "ls /root/.cache /nonexistent/.cache 2>/dev/null || true; "
        "ls /var/cache/apt/archives/*.deb 2>/dev/null | head -3 || true; "
        "ls /var/lib/apt/lists 2>/dev/null | grep -v -e lock -e partial || true"
    )
    out = sh(*run_args(ctr, config, user="root"), "sh", "-c", probe).stdout.split()
    assert out[:1] == ["0"] and len(out) == 1, f"compiler, cache or package list left: {out[1:]}"
    uid = sh(*run_args(ctr, config), "id", "-u").stdout.strip()
    assert uid == config["user"].split(":")[0], uid
    version = sh(
        *run_args(ctr, config), "python", "-c", "import pinocchio; print(pinocchio.__version__)"
    ).stdout.strip()
    assert version, "import pinocchio failed in the image"


def check_server(base: str, log_path: Path) -> dict[str, Any]:
    summary: dict[str, Any] = {}
    with httpx.Client(base_url=base, timeout=60) as http:
        assert http.get("/health/live").json() == {"status": "ok"}
        ready = http.get("/health/ready").json()
        robots = http.get("/v1/robots").json()["robots"]
        summary["catalog_robots"] = ready["robots"]
        assert ready["robots"] >= 60 and len(robots) >= 60, ready  # the whole catalog
        from localrun import load_models

        models = load_models(["ur5", "talos"])
        rng = np.random.default_rng(5)
        worst = 0.0
        for name, model in models.items():
            for quantity in ("mass-matrix", "inverse-dynamics", "forward-dynamics"):
                for _ in range(3):
                    q, v, a = random_state(model, rng)
                    r = http.post(
                        f"/v1/robots/{name}/{quantity}", json=request_body(quantity, q, v, a)
                    )
                    assert r.status_code == 200, r.text
                    assert "compute;dur=" in r.headers["server-timing"]
                    worst = max(
                        worst, max_relative_error(r.json(), expected(model, quantity, q, v, a))
                    )
        summary["max_relative_error"] = worst
        assert worst < 1e-10, f"answers differ from in-process Pinocchio by {worst}"

        urdf = (ROOT / "robots" / "textbook" / "planar_arm.urdf").read_text()
        up = http.post("/v1/robots", json={"urdf": urdf, "name": "container check"})
        assert up.status_code in (200, 201), up.text
        robot_id = up.json()["id"]
        import pinocchio as pin

        arm = pin.buildModelFromXML(urdf)
        q = np.array([0.3, -0.7])
        M = http.post(f"/v1/robots/{robot_id}/mass-matrix", json={"q": q.tolist()}).json()
        reference = expected(arm, "mass-matrix", q, q, q)["mass_matrix"]
        assert np.allclose(M["mass_matrix"], reference, rtol=1e-12, atol=1e-12), M
        summary["upload_status"] = up.status_code
        metrics = http.get("/metrics").text
        assert 'robodyn_compute_seconds_count{quantity="mass-matrix",robot="ur5"}' in metrics
        r = http.get("/health/live", headers={"X-Request-ID": "container-check"})
        assert r.headers["x-request-id"] == "container-check"
    return summary


# What `buildah run` itself says about its process's exit (not the server's output).
BUILDAH_LINES = ("subprocess exited", "Error: exit status")


def check_log(log_path: Path) -> int:
    lines = [
        line
        for line in log_path.read_text().splitlines()
        if line.strip() and not line.startswith(BUILDAH_LINES)
    ]
    records = [json.loads(line) for line in lines]  # every line of the server is JSON
    access = [r for r in records if r.get("logger") == "robodyn.access"]
    assert any(r.get("route") == "/v1/robots/{robot_id}/mass-matrix" for r in access), access[:3]
    return len(records)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tag", default="localhost/robodyn:test")
    parser.add_argument("--no-build", action="store_true", help="use the image already built")
    parser.add_argument("--keep", action="store_true", help="keep the image afterwards")
    args = parser.parse_args(argv)

    summary: dict[str, Any] = {"tag": args.tag}
    if not args.no_build:
        ensure_base_image()
        summary["build_seconds"] = round(build(args.tag), 1)
    config = image_config(args.tag)
    check_config(config)
    summary["size"] = config["size"]
    ctr = sh("buildah", "from", "--pull-never", args.tag).stdout.strip()
    workdir = Path(tempfile.mkdtemp(prefix="robodyn-container-"))
    log_path = workdir / "server.log"
    server = None
    try:
        check_contents(ctr, config)
        # The image's CMD; on 8000 when it is free (as in a container with its own network),
        # else with `--port P` appended, since chroot isolation shares this machine's network.
        sh(*run_args(ctr, config, user="root"), "touch", "/tmp/.before-server")
        port = IMAGE_PORT if port_is_free(IMAGE_PORT) else free_port()
        cmd = [*config["entrypoint"], *config["cmd"]]
        if port != IMAGE_PORT:
            cmd += ["--port", str(port)]
        summary["run"] = shlex.join(cmd)
        with open(log_path, "wb") as log:
            server = subprocess.Popen(
                [*run_args(ctr, config), *cmd],
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )
        base = f"http://127.0.0.1:{port}"
        summary["ready_seconds"] = round(wait_ready(base, timeout=180, proc=server), 1)
        health = [part.replace(str(IMAGE_PORT), str(port)) for part in config["healthcheck"][1:]]
        sh(*run_args(ctr, config), *health)  # the HEALTHCHECK command passes
        summary.update(check_server(base, log_path))
        stored = sh(*run_args(ctr, config), "sh", "-c", "ls /data/models").stdout.split()
        assert any(name.endswith(".json") for name in stored), stored  # written as non-root
        # What `docker stop` does: SIGTERM to the container's main process (the CMD itself, in
        # exec form), which must shut down gracefully by itself well within the grace period.
        # (uvicorn re-raises the signal once it is done, so the exit status says "terminated".)
        main_pid = next(
            pid
            for pid, f in descendants(server.pid).items()
            if "-m service" in f["cmdline"] and "buildah" not in f["cmdline"]
        )
        stopping = time.monotonic()
        os.kill(main_pid, signal.SIGTERM)
        server.wait(timeout=40)
        summary["stop_seconds"] = round(time.monotonic() - stopping, 1)
        assert "Finished server process" in log_path.read_text(), "no graceful shutdown"
        # The server wrote only to /data and /tmp, so a read-only root file system (as in
        # deploy/k8s and docker-compose.yml) does not get in its way.
        written = sh(
            *run_args(ctr, config, user="root"),
            "find",
            "/",
            "-xdev",
            "(",
            *" -o ".join(f"-path {p}" for p in WRITABLE).split(),
            ")",
            "-prune",
            "-o",
            "-newer",
            "/tmp/.before-server",
            "-print",
        ).stdout.split()
        assert not [w for w in written if w not in BUILDAH_FILES], written
    except BaseException:
        print(f"failed; the server's log is {log_path}", file=sys.stderr)
        raise
    finally:
        if server is not None:
            stop_group(server)
        sh("buildah", "rm", ctr, check=False)
    summary["log_lines"] = check_log(log_path)
    shutil.rmtree(workdir)  # after a failure it stays, with the server's log
    if not args.keep and not args.no_build:
        sh("buildah", "rmi", args.tag, check=False)
    print(json.dumps(summary))
    return summary


if __name__ == "__main__":
    main()
