"""Schemathesis against /openapi.json: generated requests, valid and invalid, to every operation
of the document; no answer is a 5xx, and answers conform to the document (status codes, content
types, bodies). Driven through hypothesis directly (schemathesis' own pytest plugin does not run
on the installed pytest 9).

A short run is in the default suite; `pytest -m slow` runs the long one."""

from __future__ import annotations

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable
from schemathesis import GenerationMode, checks
from schemathesis.specs.openapi import checks as openapi_checks

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import planar_arm_urdf

CHECKS = [
    checks.not_a_server_error,
    openapi_checks.response_schema_conformance,
    openapi_checks.status_code_conformance,
    openapi_checks.content_type_conformance,
]


def _schema(data_dir):
    settings_ = Settings(data_dir=data_dir, catalog="ur5,planar_arm")
    registry = Registry(data_dir, settings_.catalog_names())
    registry.load()
    registry.upload(
        urdf=planar_arm_urdf(1, 1, 1, 1),
        root_joint="fixed",
        gravity=[0, 0, -9.81],
        name=None,
        inertia_check="reject",
    )
    return schemathesis.openapi.from_asgi("/openapi.json", create_app(settings_, registry))


@pytest.fixture(scope="module")
def operations(tmp_path_factory):
    schema = _schema(tmp_path_factory.mktemp("schemathesis"))
    return {result.ok().label: result.ok() for result in schema.get_all_operations()}


LABELS = [
    "GET /health/live",
    "GET /health/ready",
    "GET /metrics",
    "GET /v1/robots",
    "POST /v1/robots",
    "GET /v1/robots/{robot_id}",
    "DELETE /v1/robots/{robot_id}",
]


def test_the_document_has_the_operations_we_fuzz(operations):
    assert set(LABELS) <= set(operations)
    assert len([label for label in operations if label.startswith("POST /v1/robots/{")]) >= 6


def _fuzz(operations, examples: int) -> None:
    for label, operation in sorted(operations.items()):
        robot_ids = (
            st.sampled_from(["ur5", "planar_arm", "u-0", "nope"])
            if "{robot_id}" in label
            else st.none()
        )
        for mode in (GenerationMode.POSITIVE, GenerationMode.NEGATIVE):
            strategy = operation.as_strategy(generation_mode=mode)

            @settings(
                max_examples=examples,
                deadline=None,
                database=None,
                suppress_health_check=list(HealthCheck),
            )
            @given(case=strategy, robot_id=robot_ids, real=st.booleans())
            def run(case, robot_id, real):
                if robot_id is not None and real:
                    case.path_parameters = {**(case.path_parameters or {}), "robot_id": robot_id}
                case.call_and_validate(checks=CHECKS)

            try:
                run()
            except Unsatisfiable:  # no invalid input exists (e.g. a path of plain strings)
                assert mode is GenerationMode.NEGATIVE, label
            except Exception as exc:
                raise AssertionError(f"{label} ({mode.value}): {exc}") from exc


def test_api_short(operations):
    _fuzz(operations, 15)


@pytest.mark.slow
def test_api_long(operations):
    _fuzz(operations, 300)
