"""The physics is usable from a script without HTTP: importing `service.dynamics` (with its
equations and identification, the fit included) imports nothing of the API layer, nor FastAPI
or Starlette (imports run api → dynamics → registry, never upward)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
SCRIPT = """
import sys
import service.dynamics
import service.dynamics.equations
from service.dynamics.identification import identify
print(sorted(m for m in sys.modules if m.split(".")[0] in ("fastapi", "starlette")
             or m == "service.api" or m.startswith("service.api.")))
"""


def test_dynamics_imports_nothing_of_the_api_layer():
    done = subprocess.run(
        [sys.executable, "-c", SCRIPT], cwd=REPO, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "[]"
