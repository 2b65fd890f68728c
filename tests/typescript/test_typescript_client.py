"""A TypeScript client generated from /openapi.json compiles and works.

openapi-typescript (default settings) turns the service's OpenAPI document into types, and the
small client `client.ts`, written only against those types, must type-check under `strict` with
no cast and no `any`: fields with defaults optional, operationIds named after the quantity,
`Problem.code` an enum with its extension members typed. The compiled client then calls a real
server. The npm packages are pinned in package-lock.json; `.ci/run` installs them
(`npm ci --prefix tests/typescript`) before running pytest.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from tests.servers import running_server
from tests.typescript.dump_openapi import openapi_document

HERE = Path(__file__).parent
BIN = HERE / "node_modules" / ".bin"
ROOT = HERE.parent.parent

pytestmark = pytest.mark.skipif(
    shutil.which("node") is None
    or not (BIN / "tsc").exists()
    or not (BIN / "openapi-typescript").exists(),
    reason="the TypeScript check needs node and the pinned npm packages: "
    "`npm ci --prefix tests/typescript` (as .ci/run does)",
)


def _run(*args: str | Path) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(
        [str(a) for a in args], cwd=HERE, capture_output=True, text=True, timeout=300, check=False
    )
    assert done.returncode == 0, f"{args[0]} failed:\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def compiled() -> Path:
    """Types generated from the current document, then the client compiled (out/)."""
    generated = HERE / "generated"
    generated.mkdir(exist_ok=True)
    (generated / "openapi.json").write_text(json.dumps(openapi_document(), indent=1))
    _run(BIN / "openapi-typescript", "generated/openapi.json", "-o", "generated/robodyn.d.ts")
    shutil.rmtree(HERE / "out", ignore_errors=True)
    _run(BIN / "tsc", "-p", ".")
    return HERE / "out" / "client.js"


def test_the_client_has_no_cast_and_no_any() -> None:
    code = re.sub(r"//[^\n]*|/\*.*?\*/", "", (HERE / "client.ts").read_text(), flags=re.S)
    assert not re.search(r"\bany\b", code)
    assert not re.search(r"\bas\s+[A-Za-z{\[(]", code), "a type assertion (`x as T`)"
    assert not re.search(r"(?:[=(,:?]|\breturn)\s*<\s*[A-Z]\w*\s*>\s*[\w(]", code), "`<T>x`"
    assert "@ts-" not in code and "!." not in code and "!;" not in code


def test_the_generated_types_compile_with_the_client(compiled: Path) -> None:
    assert compiled.exists()
    types = (HERE / "generated" / "robodyn.d.ts").read_text()
    assert "massMatrix: {" in types and "uploadRobot: {" in types  # operationIds
    assert '"robot_not_found"' in types  # Problem.code is an enum


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with running_server(tmp_path_factory.mktemp("ts-server"), catalog="ur5") as url:
        yield url


def test_the_compiled_client_talks_to_a_server(compiled: Path, server: str) -> None:
    urdf = ROOT / "robots" / "textbook" / "planar_arm.urdf"
    out = _run("node", "run.mjs", server, urdf).stdout
    summary = json.loads(out)
    assert "ur5" in summary["robots"] and summary["nq"] == 6
    assert summary["jointNames"][0] == "shoulder_pan_joint"
    expected = httpx.post(
        f"{server}/v1/robots/ur5/mass-matrix", json={"q": [0, -1.57, 1.57, 0, 0, 0]}
    ).json()["mass_matrix"]
    assert summary["single"] == expected
    assert summary["batchShape"] == [2, 6, 6]
    assert summary["uploadStatus"] == 201 and summary["uploadId"].startswith("u-")
    assert summary["problemCode"] == "dimension_mismatch"
    assert summary["problemDetail"].startswith("q has 5 entries; robot 'ur5' has nq = 6; ")
    assert summary["problemLocations"] == ["q"]  # one entry for one mistake
    assert summary["robotNotFound"] is True
