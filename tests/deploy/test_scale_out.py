"""Slow: two replicas sharing one data directory behind nginx; 200 mixed requests, then 200
more while one replica is stopped (gracefully, or killed). deploy/scripts/scale_out.py does the
work and checks every answer; this asserts its summary.

Needs nginx (Debian: apt-get install -y nginx): `pytest -m slow tests/deploy/test_scale_out.py`."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("stop", ["term", "kill"])
def test_two_replicas_behind_nginx_survive_losing_one(stop):
    if shutil.which("nginx") is None and not Path("/usr/sbin/nginx").exists():
        pytest.skip("nginx is not installed (Debian: apt-get install -y nginx)")
    result = subprocess.run(
        [
            sys.executable,
            str(ROOT / "deploy/scripts/scale_out.py"),
            "--requests",
            "200",
            "--stop",
            stop,
        ],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-5000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    both, one = summary["both_up"], summary["one_stopped"]
    assert both["requests"] == one["requests"] == 200
    assert len(both["answered_by"]) == 2 and min(both["answered_by"].values()) >= 50
    assert both["max_relative_error"] < 1e-10 and one["max_relative_error"] < 1e-10
    # After the stop only the other replica answers; nginx retried what hit the stopped one.
    assert sum(one["answered_by"].values()) == 200 and one["retried_on_next"] >= 1
    assert summary["logged_request_ids"] == 400
