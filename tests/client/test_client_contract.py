"""The client against the server's contract: routes, request schemas, codes, dependencies."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
import robodyn
from robodyn import errors
from robodyn._calls import BUILDERS

from service.api.problems.handlers import STATUS_BY_CODE
from service.api.quantities import SPECS
from service.api.schemas.identification import IdentifyRequest
from service.api.schemas.robots import ReduceRequest, UploadRequest
from service.main import create_app
from service.settings import Settings

CLIENT_DIR = Path(__file__).parents[2] / "clients" / "python"
BLOCKED = (
    "fastapi",
    "pydantic",
    "pydantic_settings",
    "pinocchio",
    "uvicorn",
    "starlette",
    "service",
)
INFO = {
    "id": "r",
    "name": "r",
    "source": "upload",
    "nq": 1,
    "nv": 1,
    "root_joint": "fixed",
    "gravity": [0, 0, -9.81],
    "total_mass": 1.0,
    "neutral_configuration": [0.0],
    "reference_configurations": {},
    "warnings": [],
    "joints": [],
    "frames": [],
}
ANSWERS = {
    "mass_matrix": [[1.0]],
    "gravity": [0.0],
    "coriolis_matrix": [[0.0]],
    "coriolis_forces": [0.0],
    "nonlinear_effects": [0.0],
    "tau": [0.0],
    "joint_wrenches": [[0.0] * 6],
    "a": [0.0],
    "robots": [],
    "unavailable": {},
    "status": "ok",
    **INFO,
    # the Lagrangian quantities, frame Jacobians, operational space, inertias, derivatives,
    # centroidal momentum
    "mass_matrix_inverse": [[1.0]],
    "kinetic_energy": 0.5,
    "potential_energy": 1.0,
    "mechanical_energy": 1.5,
    "position": [0.0, 0.0, 1.0],
    "jacobian": [[0.0]],
    "inertia": [[1.0]],
    "dynamically_consistent_inverse": [[0.0]],
    "coriolis": [0.0],
    "bodies": [],
    "dtau_dq": [[0.0]],
    "dtau_dv": [[0.0]],
    "dtau_da": [[1.0]],
    "da_dq": [[0.0]],
    "da_dv": [[0.0]],
    "da_dtau": [[1.0]],
    "momentum": [0.0] * 6,
    "momentum_matrix": [[0.0]] * 6,
    "center_of_mass": [0.0] * 3,
}
# the equations in explicit form of a 1-joint robot
_ONE = {"expressions": [["0.5"]], "latex": [["0.5"]]}
EQUATIONS = {
    "joints": ["j"],
    "coordinates": ["q1"],
    "velocities": ["dq1"],
    "mass_matrix": _ONE,
    "coriolis_matrix": _ONE,
    "gravity": {"expressions": ["0"], "latex": ["0"]},
    "christoffel": {"expressions": [[["0"]]], "latex": [[["0"]]]},
    "kinetic_energy": {"expressions": "0.25*dq1**2", "latex": r"0.25 \dot{q}_{1}^{2}"},
    "potential_energy": {"expressions": "0", "latex": "0"},
    "structure": {
        "mass_matrix": [[{"depends_on": [], "constant": True, "zero": False}]],
        "gravity": [{"depends_on": [], "constant": True, "zero": True}],
    },
    "accuracy": {
        "digits": 6,
        "tolerance": 1e-9,
        "max_abs_error": dict.fromkeys(
            ("mass_matrix", "gravity", "coriolis_matrix", "kinetic_energy", "potential_energy"),
            0.0,
        ),
    },
}
# a trajectory's mechanical energy has one value per sample (energy's has one per state)
TRAJECTORY = {"t": [0.0], "q": [[0.0]], "v": [[0.0]], "mechanical_energy": [0.0]}
ARGS: dict[str, tuple[Any, ...]] = {
    "health": (),
    "ready": (),
    "robots": (),
    "robot_page": (),
    "robot": ("r",),
    "upload": ("<robot/>",),
    "delete": ("r",),
    "mass_matrix": ("r", [0.0]),
    "gravity": ("r", [0.0]),
    "coriolis": ("r", [0.0], [0.0]),
    "nonlinear_effects": ("r", [0.0], [0.0]),
    "inverse_dynamics": ("r", [0.0], [0.0], [0.0]),
    "joint_wrenches": ("r", [0.0], [0.0], [0.0]),
    "forward_dynamics": ("r", [0.0], [0.0], [0.0]),
    "mass_matrix_inverse": ("r", [0.0]),
    "energy": ("r", [0.0], [0.0]),
    "center_of_mass": ("r", [0.0]),
    "jacobian": ("r", [0.0], "f"),
    "operational_space": ("r", [0.0], "f"),
    "inertias": ("r",),
    "inverse_dynamics_derivatives": ("r", [0.0], [0.0], [0.0]),
    "forward_dynamics_derivatives": ("r", [0.0], [0.0], [0.0]),
    "centroidal": ("r", [0.0], [0.0]),
    "simulate": ("r", [0.0], [0.0]),
    "reduce": ("r", {"elbow": 0.5, "base": [0, 0, 1, 0, 0, 0, 1]}),
    "equations": ("r",),
}
KWARGS: dict[str, dict[str, Any]] = {"simulate": {"dt": 1e-3, "steps": 1}}
# contacts
ANSWERS.update({"contact_forces": [0.0], "residual": 0.0, "contact_impulses": [0.0], "v": [0.0]})
ARGS.update(
    {
        "contact_dynamics": ("r", [0.0], [0.0], [0.0], ["f"]),
        "contact_inverse_dynamics": ("r", [0.0], [0.0], [0.0], ["f"]),
        "impulse_dynamics": ("r", [0.0], [0.0], ["f"]),
    }
)
# payloads
ANSWERS.update({"mass": 1.0, "limiting_joint": "j", "mass_per_joint": [None]})
ARGS.update({"payload_capacity": ("r", [0.0], "f"), "variant": ("r",)})
KWARGS.update(
    {
        "variant": {
            "payloads": [{"frame": "f", "mass": 1.0}],
            "locked_joints": {"elbow": 0.5},
            "inertias": {"links": "errors", "from": "geometry"},
        }
    }
)
# the model check
ANSWERS.update({"findings": [], "links": []})
ARGS.update({"model_check": ("r",)})
# trajectories
CHECK = {
    "feasible": True,
    "tau": [[0.0], [0.0]],
    "v": [[0.0], [0.0]],
    "joints": [],
    "violations": [],
    "work": {"positive": 0.0, "negative": 0.0},
}
RETIMED = {
    "duration": 1.0,
    "t": [0.0, 1.0],
    "q": [[0.0], [1.0]],
    "v": [[0.0], [0.0]],
    "a": [[0.0], [0.0]],
    "tau": [[0.0], [0.0]],
    "check": CHECK,
}
ARGS.update(
    {"trajectory_check": ("r", [0.0, 1.0], [[0.0], [1.0]]), "retime": ("r", [[0.0], [1.0]])}
)

# identification
ANSWERS.update(
    {
        "layout": ["m", "m_cx", "m_cy", "m_cz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz"],
        "parameters": [0.0] * 10,
        "regressor": [[0.0] * 10],
        "friction": [],
        "base_parameters": {"expressions": [], "values": [], "standard_deviation": []},
        "condition_number": 1.0,
        "physically_consistent": True,
        "rmse": {"train": [0.0], "validation": [0.0], "validation_before": [0.0]},
        "filter_hz": None,
        "samples": {"train": 1, "validation": 1, "fit": 1},
        "robot": None,
    }
)
ARGS.update(
    {
        "inertial_parameters": ("r",),
        "regressor": ("r", [0.0], [0.0], [0.0]),
        "identify": ("r", [0.0, 0.1], [[0.0], [0.1]], [[0.0], [0.0]]),
    }
)


def sent_requests() -> dict[str, httpx.Request]:
    """Call every client method against a mock; the request each one sent."""
    seen: list[httpx.Request] = []

    def handler(request: httpx.Request) -> httpx.Response:
        seen.append(request)
        path = request.url.path
        if path.endswith(("/trajectory-check", "/retime")):
            return httpx.Response(200, json=CHECK if path.endswith("-check") else RETIMED)
        simulate = path.endswith("/simulate")
        if path.endswith("/equations"):
            return httpx.Response(200, json=EQUATIONS)
        return httpx.Response(200, json={**ANSWERS, **TRAJECTORY} if simulate else ANSWERS)

    out = {}
    http = httpx.Client(transport=httpx.MockTransport(handler), base_url="http://mock")
    with robodyn.Client(http_client=http) as client:
        for name in BUILDERS:
            getattr(client, name)(*ARGS[name], **KWARGS.get(name, {}))
            out[name] = seen[-1]
    return out


@pytest.fixture(scope="module")
def openapi(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    return create_app(Settings(data_dir=tmp_path_factory.mktemp("openapi"))).openapi()


def test_every_request_the_client_sends_is_a_route_of_the_server(openapi: dict) -> None:
    routes = [
        (re.compile("^" + re.sub(r"\{[^/]+\}", "[^/]+", path) + "$"), method.upper())
        for path, methods in openapi["paths"].items()
        for method in methods
    ]
    requests = sent_requests()
    assert set(requests) == set(ARGS) == set(BUILDERS)
    for name, request in requests.items():
        sent = request.url.raw_path.decode()
        path = sent.partition("?")[0]
        assert any(rx.match(path) and m == request.method for rx, m in routes), (name, path)
        call = BUILDERS[name](*ARGS[name], **KWARGS.get(name, {}))
        assert (call.method, call.path) == (request.method, sent), name
        operation = openapi["paths"][call.route][call.method.lower()]
        declared = {p["name"] for p in operation.get("parameters", []) if p["in"] == "query"}
        assert set(request.url.params) <= declared, (name, set(request.url.params))


def test_request_bodies_validate_against_the_server_schemas() -> None:
    requests = sent_requests()
    UploadRequest.model_validate_json(requests["upload"].content)
    ReduceRequest.model_validate_json(requests["reduce"].content)
    IdentifyRequest.model_validate_json(requests["identify"].content)
    SPECS["regressor"].request.model_validate_json(requests["regressor"].content)
    inputs = {
        "mass_matrix": ("q",),
        "gravity": ("q",),
        "coriolis": ("q", "v"),
        "nonlinear_effects": ("q", "v"),
        "inverse_dynamics": ("q", "v", "a"),
        "forward_dynamics": ("q", "v", "tau"),
    }
    for name, fields in inputs.items():
        body = json.loads(requests[name].content)
        assert tuple(body) == fields
        # strict: no extra or mistyped field
        SPECS[name.replace("_", "-")].request.model_validate(body)
    wrenches = json.loads(requests["joint_wrenches"].content)
    assert wrenches.pop("loads") is True and tuple(wrenches) == ("q", "v", "a")
    SPECS["inverse-dynamics"].request.model_validate({**wrenches, "loads": True})
    for name in ("trajectory_check", "retime"):  # arrays and options alike
        SPECS[name.replace("_", "-")].request.model_validate(json.loads(requests[name].content))


def test_every_server_code_has_a_client_class_with_its_status() -> None:
    for code, status in STATUS_BY_CODE.items():
        cls = errors.ERROR_BY_CODE.get(code)
        assert cls is not None, f"no client class for server code {code!r}"
        assert cls.status_code == status, code
        assert errors.error_class(status, code) is cls


def test_package_imports_without_server_dependencies() -> None:
    script = f"""
import sys
BLOCKED = {BLOCKED!r}
class Blocker:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ImportError(f"{{name}} is blocked")
        return None
sys.meta_path.insert(0, Blocker())
import httpx, numpy as np, robodyn
def handler(request):
    return httpx.Response(200, json={{"gravity": [1.0, 2.0]}})
http = httpx.Client(transport=httpx.MockTransport(handler))
with robodyn.Client("http://x", http_client=http) as client:
    assert client.gravity("r", np.zeros(2)).tolist() == [1.0, 2.0]
robodyn.AsyncClient("http://x")
loaded = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
assert not loaded, loaded
print(robodyn.__file__)
"""
    env = {**os.environ, "PYTHONPATH": str(CLIENT_DIR / "src")}
    done = subprocess.run(
        [sys.executable, "-c", script],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        cwd=CLIENT_DIR,
    )
    assert done.returncode == 0, done.stderr
    assert Path(done.stdout.strip()).is_relative_to(CLIENT_DIR / "src" / "robodyn")


def test_distribution_depends_on_httpx_numpy_and_stamina_only() -> None:
    """No Pinocchio, FastAPI or torch: httpx, numpy and stamina (retries) only."""
    project = tomllib.loads((CLIENT_DIR / "pyproject.toml").read_text())["project"]
    names = {
        re.split(r"[<>=!~\[; ]", dep, maxsplit=1)[0].lower() for dep in project["dependencies"]
    }
    assert project["name"] == "robodyn" and names == {"httpx", "numpy", "stamina"}
    assert project["version"] == robodyn.__version__
    assert (CLIENT_DIR / "src" / "robodyn" / "py.typed").exists()


def test_answers_are_numpy_and_match_the_server_answer_fields() -> None:
    requests = sent_requests()
    paths = {
        BUILDERS[name](*ARGS[name]).quantity: name
        for name in requests
        if name
        in (
            "mass_matrix",
            "gravity",
            "coriolis",
            "nonlinear_effects",
            "joint_wrenches",  # inverse-dynamics with its optional joint_wrenches
            "forward_dynamics",
        )
    }
    assert len(paths) == 6 and set(paths) <= set(SPECS)
    http = httpx.Client(
        transport=httpx.MockTransport(lambda request: httpx.Response(200, json=ANSWERS))
    )
    with robodyn.Client("http://mock", http_client=http) as client:
        for path, name in paths.items():
            fields = list(SPECS[path].answer.model_fields)
            got = getattr(client, name)(*ARGS[name])
            got = got if isinstance(got, tuple) else (got,)
            assert len(got) == len(fields)
            for value, field in zip(got, fields, strict=True):
                assert isinstance(value, np.ndarray)
                np.testing.assert_array_equal(value, ANSWERS[field])
