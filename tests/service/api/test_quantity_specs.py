"""One spec per quantity: the table of `service.api.quantities` covers every dynamics route,
and the routes, the OpenAPI document and the stream are all derived from it.

`fixtures/openapi_operations.json` is the list of (method, path, operationId) of /openapi.json
recorded from the published API: the document must keep every operation and
its operationId (generated clients call them by it)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from service import dynamics
from service.api.quantities import SPECS
from service.api.routes.dynamics import ENDPOINTS, PREFIX
from service.main import create_app
from service.settings import Settings

ROOT = Path(__file__).resolve().parents[3]
OPERATIONS = json.loads(
    (Path(__file__).parent / "fixtures" / "openapi_operations.json").read_text()
)


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory):
    return create_app(Settings(data_dir=tmp_path_factory.mktemp("data")))


@pytest.fixture(scope="module")
def document(app) -> dict:
    return app.openapi()


def test_every_quantity_has_one_spec_with_one_request_and_one_answer_model() -> None:
    assert list(SPECS) == list(dynamics.QUANTITIES)
    for name, spec in SPECS.items():
        assert spec.quantity is dynamics.QUANTITIES[name]
        assert spec.quantity.name == name
        for array in (*spec.quantity.inputs, *spec.quantity.optional):
            assert array in spec.request.model_fields, (name, array)
        assert {"joint_names", "fill"} <= set(spec.request.model_fields), name
        assert spec.answer.model_fields, name


def test_the_served_routes_are_the_specs(app, document: dict) -> None:
    served = {
        route.path
        for route in app.router.routes
        if getattr(route, "methods", None) == {"POST"}
        and route.path.startswith(f"{PREFIX}/{{robot_id}}/")
    }
    # identify is a lean route of its own (a log, not a batch of states: not a quantity)
    assert served - {f"{PREFIX}/{{robot_id}}/identify"} == {
        f"{PREFIX}/{{robot_id}}/{name}" for name in SPECS
    }
    assert set(ENDPOINTS) == set(SPECS)
    described = {
        path.rsplit("/", 1)[-1]
        for path, item in document["paths"].items()
        if path.startswith(f"{PREFIX}/{{robot_id}}/") and "post" in item
    }
    assert described - {"reduce", "variants", "identify"} == set(SPECS)


def test_openapi_lists_the_same_operations_with_the_same_ids(document: dict) -> None:
    operations = sorted(
        [method.upper(), path, op["operationId"]]
        for path, item in document["paths"].items()
        for method, op in item.items()
    )
    assert operations == OPERATIONS


def test_each_route_is_described_by_its_spec_models(document: dict) -> None:
    for name, spec in SPECS.items():
        op = document["paths"][f"{PREFIX}/{{robot_id}}/{name}"]["post"]
        request = op["requestBody"]["content"]["application/json"]["schema"]["$ref"]
        answer = op["responses"]["200"]["content"]["application/json"]["schema"]["$ref"]
        assert request.rsplit("/", 1)[-1] == spec.request.__name__, name
        assert answer.rsplit("/", 1)[-1] == spec.answer.__name__, name


def test_each_quantity_is_answered_from_the_schema_module_of_its_dynamics_topic() -> None:
    # service.dynamics.<topic> or service.dynamics.<topic>.<module> computes it, and
    # service.api.schemas.<topic> declares its models (requests may be the common ones)
    for name, spec in SPECS.items():
        topic = spec.quantity.compute.__module__.split(".")[2]
        assert spec.answer.__module__ == f"service.api.schemas.{topic}", name
        assert spec.request.__module__ in (
            f"service.api.schemas.{topic}",
            "service.api.schemas.common",
        ), name


def test_a_quantity_is_named_in_at_most_two_files_of_the_service() -> None:
    sources = {path: path.read_text() for path in (ROOT / "service").rglob("*.py")}
    for name in SPECS:
        if "-" not in name:
            continue  # one-word names (gravity, energy, ...) are also field names
        files = [p for p, text in sources.items() if re.search(f"[\"']{name}[\"']", text)]
        assert len(files) <= 2, (name, sorted(str(p.relative_to(ROOT)) for p in files))
