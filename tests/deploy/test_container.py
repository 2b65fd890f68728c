"""Slow: build the image with buildah, run its CMD as its user, check what it serves
(deploy/scripts/container_check.py does the work and the checks; this asserts its summary).

Needs buildah (and, without a python:3.11-slim image, deploy/scripts/container-base.sh,
which installs it): `pytest -m slow tests/deploy/test_container.py`."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow


def test_image_builds_runs_and_answers_like_pinocchio():
    if shutil.which("buildah") is None:
        pytest.skip("buildah is not installed (deploy/scripts/container-base.sh installs it)")
    result = subprocess.run(
        [sys.executable, str(ROOT / "deploy/scripts/container_check.py")],
        capture_output=True,
        text=True,
        timeout=1800,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-5000:]
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["catalog_robots"] >= 60
    assert summary["max_relative_error"] < 1e-10
    assert summary["upload_status"] == 201
    assert summary["log_lines"] > 10
    assert summary["stop_seconds"] < 30
