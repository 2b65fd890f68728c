"""The test environment is pinned: requirements/test.lock (written by requirements/lock-test.sh)
pins every dependency the project, its `test` extra and the Python client declare, each within
its declared range; the README's test command and .ci/run install with it, word for word the
same; pre-commit's ruff is the locked one."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
import yaml
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements" / "test.lock"
RELOCK = "run requirements/lock-test.sh"


def _pins() -> dict[str, str]:
    pins = {}
    for line in LOCK.read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, version = line.partition("==")
            assert version, f"not pinned with ==: {line}"
            pins[canonicalize_name(name)] = version.strip()
    return pins


def _declared() -> list[str]:
    server = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    client = tomllib.loads((ROOT / "clients" / "python" / "pyproject.toml").read_text())["project"]
    return [
        *server["dependencies"],
        *server["optional-dependencies"]["test"],
        *client["dependencies"],
    ]


@pytest.mark.parametrize("spec", _declared())
def test_the_lock_pins_every_declared_dependency_within_its_range(spec: str) -> None:
    requirement = Requirement(spec)
    pins = _pins()
    name = canonicalize_name(requirement.name)
    assert name in pins, f"{name} is not in requirements/test.lock: {RELOCK}"
    assert requirement.specifier.contains(pins[name], prereleases=True), (
        f"{name}=={pins[name]} does not satisfy {requirement}: {RELOCK}"
    )


def test_the_lock_holds_what_the_dependencies_bring_not_this_repositorys_projects() -> None:
    pins = _pins()
    assert {"uvloop", "httptools"} <= pins.keys()  # uvicorn[standard]'s extras
    assert not {"robodyn", "robodyn-service"} & pins.keys()


def test_readme_and_ci_install_the_tests_with_the_lock_in_the_same_words() -> None:
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    commands = [
        line.strip()
        for line in readme.splitlines()
        if line.strip().startswith("python3 -m venv") and "pytest" in line
    ]
    assert len(commands) == 1, commands
    command = commands[0]
    assert "-c requirements/test.lock" in command and "'.[test]'" in command
    assert command in ci.splitlines()


def test_pre_commit_runs_the_locked_ruff() -> None:
    config = yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text())
    hooks = [hook for repo in config["repos"] for hook in repo["hooks"]]
    ruff = [hook for hook in hooks if hook["entry"].split()[0] == "ruff"]
    assert {hook["id"] for hook in ruff} == {"ruff-check", "ruff-format"}
    for hook in ruff:
        assert hook["additional_dependencies"] == [f"ruff=={_pins()['ruff']}"], (
            "set ruff's version in .pre-commit-config.yaml to the one requirements/test.lock pins"
        )


def test_the_lock_names_the_platform_it_was_made_on() -> None:
    header = LOCK.read_text().split("\n", 3)[:3]
    assert re.search(r"Python 3\.11\.\d+ on Linux x86_64", " ".join(header)), header
