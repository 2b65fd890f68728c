"""The OpenAPI document is one that client generators turn into good code."""

from __future__ import annotations

import re

from service.api.encoding.binary import BINARY_MEDIA_TYPE
from service.api.problems.handlers import STATUS_BY_CODE

METHODS = {"get", "put", "post", "delete", "patch"}


def _operations(doc):
    return {
        (method, path): op
        for path, item in doc["paths"].items()
        for method, op in item.items()
        if method in METHODS
    }


def test_operation_ids_are_the_quantity_in_camel_case(api):
    ops = _operations(api.get("/openapi.json").json())
    ids = [op["operationId"] for op in ops.values()]
    assert len(ids) == len(set(ids))
    assert all(re.fullmatch(r"[a-z][a-zA-Z0-9]*", i) for i in ids), ids
    assert ops["post", "/v1/robots/{robot_id}/mass-matrix"]["operationId"] == "massMatrix"
    assert (
        ops["post", "/v1/robots/{robot_id}/inverse-dynamics-derivatives"]["operationId"]
        == "inverseDynamicsDerivatives"
    )
    assert ops["get", "/v1/robots"]["operationId"] == "listRobots"
    assert ops["post", "/v1/robots"]["operationId"] == "uploadRobot"
    assert ops["get", "/health/ready"]["operationId"] == "healthReady"


def test_request_fields_with_defaults_are_optional_and_have_no_default_keyword(api):
    """openapi-typescript (default settings) types a property with a `default` as present."""
    doc = api.get("/openapi.json").json()
    schemas = doc["components"]["schemas"]
    upload = schemas["UploadRequest"]
    assert set(upload.get("required", [])) <= {"urdf", "mjcf", "xacro"}
    for name in ("gravity", "inertia_check", "root_joint"):
        prop = upload["properties"][name]
        assert "default" not in prop and "Default:" in prop["description"], name
    # gravity's default depends on the description (an MJCF's own <option gravity>): said in
    # words, with the usual value as the example
    assert upload["properties"]["gravity"]["examples"] == [[0.0, 0.0, -9.81]]
    for path, item in doc["paths"].items():
        for method, op in item.items():
            body = op.get("requestBody", {}).get("content", {}).get("application/json")
            if body is None:
                continue
            ref = body["schema"]["$ref"].rsplit("/", 1)[1]
            props = schemas[ref]["properties"]
            assert not [n for n, p in props.items() if "default" in p], (method, path)
            assert "joint_names" not in schemas[ref].get("required", []), (method, path)


def test_problem_code_is_an_enum_of_every_code_with_typed_members(api):
    problem = api.get("/openapi.json").json()["components"]["schemas"]["Problem"]
    assert problem["properties"]["code"]["enum"] == sorted(STATUS_BY_CODE)
    assert "`unsupported_media_type` 415" in problem["properties"]["code"]["description"]
    assert problem["properties"]["errors"]["items"]["required"] == ["loc", "msg"]
    assert problem["properties"]["missing"]["items"] == {"type": "string"}
    assert problem["properties"]["unknown"]["items"] == {"type": "string"}


def test_every_error_answer_is_problem_json(api):
    for (_, _), op in _operations(api.get("/openapi.json").json()).items():
        for status, response in op["responses"].items():
            if status == "default" or int(status) >= 400:
                assert list(response["content"]) == ["application/problem+json"]


def test_dynamics_bodies_and_answers_declare_the_binary_form(api):
    ops = _operations(api.get("/openapi.json").json())
    dynamics = [
        op
        for (method, path), op in ops.items()
        if method == "post"
        and path.startswith("/v1/robots/{robot_id}/")
        and path.rsplit("/", 1)[1] not in ("reduce", "variants", "identify")
    ]
    assert len(dynamics) >= 15
    for op in dynamics:
        assert set(op["requestBody"]["content"]) == {"application/json", BINARY_MEDIA_TYPE}
        assert set(op["responses"]["200"]["content"]) == {
            "application/json",
            BINARY_MEDIA_TYPE,
            "application/x-ndjson",
        }  # + progress
    upload = ops["post", "/v1/robots"]
    assert BINARY_MEDIA_TYPE not in upload["requestBody"]["content"]
    assert set(upload["responses"]["201"]["content"]) == {"application/json"}
    identify = ops["post", "/v1/robots/{robot_id}/identify"]
    assert set(identify["responses"]["200"]["content"]) == {
        "application/json",
        "application/x-ndjson",
    }


def test_health_and_metrics_are_described(api):
    doc = api.get("/openapi.json").json()
    ops = _operations(doc)
    schemas = doc["components"]["schemas"]
    live = ops["get", "/health/live"]["responses"]["200"]["content"]["application/json"]
    assert live["schema"]["$ref"].endswith("/Liveness")
    status = schemas["Liveness"]["properties"]["status"]
    assert status.get("const") == "ok" or status.get("enum") == ["ok"]
    ready = ops["get", "/health/ready"]["responses"]
    assert ready["200"]["content"]["application/json"]["schema"]["$ref"].endswith("/Readiness")
    assert "503" in ready
    assert set(schemas["Readiness"]["required"]) == {"status", "robots", "unavailable"}
    metrics = ops["get", "/metrics"]["responses"]["200"]
    assert list(metrics["content"]) == ["text/plain"] and "Prometheus" in metrics["description"]
    assert api.get("/health/ready").json()["status"] == "ready"


def test_the_upload_summary_names_every_format_it_takes(api):
    summary = api.get("/openapi.json").json()["paths"]["/v1/robots"]["post"]["summary"]
    assert summary.startswith("Upload a URDF, xacro or MJCF")
