"""Every example of the README runs, as a newcomer would run it, against a real server: the
Python block with the client the set-up command installs, the JavaScript block with node, the
curl commands with curl."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.servers import running_server

ROOT = Path(__file__).resolve().parents[1]
BLOCKS = re.findall(r"```(\w+)\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)


def _blocks(lang: str) -> list[str]:
    return [body for kind, body in BLOCKS if kind == lang]


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with running_server(tmp_path_factory.mktemp("readme"), catalog="ur5,solo12,planar_arm") as url:
        yield url


def _run(args: list[str]) -> str:
    done = subprocess.run(args, capture_output=True, text=True, timeout=120, cwd=ROOT, check=False)
    assert done.returncode == 0, f"{args[0]}:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    return done.stdout


def test_the_python_example_runs(server: str) -> None:
    code = _blocks("python")[0]
    out = _run([sys.executable, "-c", code.replace("http://127.0.0.1:8000", server)])
    assert "(1000, 6, 6)" in out


def test_the_identification_example_runs(server: str) -> None:
    (code,) = [body for body in _blocks("python") if "client.identify(" in body]
    out = _run([sys.executable, "-c", code.replace("http://127.0.0.1:8000", server)])
    before, after = out.strip().splitlines()[-2:]
    assert min(float(x) for x in before.strip("[]").split()) > 0.5  # the model lacks friction
    assert max(float(x) for x in after.strip("[]").split()) < 0.02  # the identified has it


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
def test_the_javascript_example_runs(server: str, tmp_path: Path) -> None:
    (code,) = _blocks("js")
    script = tmp_path / "first.mjs"
    script.write_text(code.replace("http://127.0.0.1:8000", server))
    out = _run(["node", str(script)])
    assert out.count("[") == 7  # a 6 × 6 matrix, printed by console.log


@pytest.mark.skipif(shutil.which("curl") is None, reason="curl is not installed")
def _curl_commands() -> list[str]:
    """Each curl command of the README's sh blocks: from a line starting with `curl ` to the
    next such line, comment or end of block (a JSON body may span lines)."""
    commands: list[str] = []
    for body in _blocks("sh"):
        current: list[str] | None = None
        for line in body.splitlines():
            if line.startswith("curl "):
                current = [line]
                commands.append("")
            elif current is not None and line.strip() and not line.startswith("#"):
                current.append(line)
            else:
                current = None
            if current is not None:
                commands[-1] = "\n".join(current)
    return commands


def test_the_curl_examples_run(server: str) -> None:
    commands = _curl_commands()
    assert len(commands) == 8
    host = server.removeprefix("http://")
    answers = [
        json.loads(_run(["bash", "-c", c.replace("localhost:8000", host)])) for c in commands
    ]
    assert len(answers[0]["mass_matrix"]) == 6
    check, retimed = answers[4], answers[5]  # a violation between samples; a timed path
    assert not check["feasible"] and len(check["violations"]) == 1
    violation = check["violations"][0]
    assert violation["joint"] == "shoulder_pan_joint" and violation["kind"] == "velocity"
    assert 0.5 < violation["t_start"] <= violation["t_end"] < 1.0
    assert abs(retimed["duration"] - 0.5738) < 1e-4 and retimed["check"]["feasible"]
    assert retimed["t"][-1] == retimed["duration"] and len(retimed["q"]) == len(retimed["t"])
    standing = answers[1]  # Solo-12 on its four feet: the base needs no torque
    assert standing["tau"][:6] == [0.0] * 6 and standing["residual"] < 1e-9
    readme = (ROOT / "README.md").read_text()
    shown = float(re.search(r'"residual": ([0-9.e+-]+)\}', readme).group(1))  # type: ignore[union-attr]
    assert (
        shown == standing["residual"] == 0.0
        or 1e-3 < shown / max(standing["residual"], 1e-300) < 1e3
    ), (shown, standing["residual"])  # the README shows what the server answers, roughly
    mass = json.loads(_run(["curl", "-s", f"{server}/v1/robots/solo12"]))["total_mass"]
    assert abs(sum(standing["contact_forces"][2::3]) - mass * 9.81) < 1e-9 * mass * 9.81
    _check_payload_examples(server, answers[2], answers[3])
    equations = answers[6]  # the planar arm's M(q) as the README shows it
    assert equations["mass_matrix"]["expressions"] == [
        ["4.235 + 2.1*cos(q2)", "0.735 + 1.05*cos(q2)"],
        ["0.735 + 1.05*cos(q2)", "0.735"],
    ]
    assert equations["gravity"]["expressions"] == [
        "34.335*cos(q1) + 10.3005*cos(q1 + q2)",
        "10.3005*cos(q1 + q2)",
    ]
    assert answers[7]["id"].startswith("u-") and answers[7]["name"] == "my arm"


def _check_payload_examples(server: str, holding: dict, capacity: dict) -> None:
    """The UR5 holding 3 kg needs more shoulder and elbow torque than without it (about 3 kg ×
    g × a 0.39 m lever); at its capacity the shoulder is exactly at its 150 N·m, and the
    capacity is where the affine τ(m) = τ₀ + m τ₁ of the two answers meets that limit."""
    import httpx

    q = [0, -1.57, 1.57, 0, 0, 0]
    bare = httpx.post(f"{server}/v1/robots/ur5/gravity", json={"q": q}).json()["gravity"]
    per_kg = [(h - b) / 3.0 for h, b in zip(holding["gravity"], bare, strict=True)]
    assert per_kg[1] < -3.0 and per_kg[2] < -3.0  # N·m/kg: a lever of over 0.3 m
    assert capacity["limiting_joint"] == "shoulder_lift_joint" and capacity["tau"][1] == -150.0
    assert abs(capacity["mass"] - (-150.0 - bare[1]) / per_kg[1]) < 1e-9 * capacity["mass"]
    at = httpx.post(
        f"{server}/v1/robots/ur5/gravity",
        json={"q": q, "payloads": [{"frame": "tool0", "mass": capacity["mass"]}]},
    ).json()["gravity"]
    assert abs(at[1] + 150.0) < 1e-9 and abs(at[2]) <= 150.0
