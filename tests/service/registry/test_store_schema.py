"""Store records are read through a schema: a record that is valid JSON but
incomplete or mistyped is skipped with one log line, like a corrupt one, and the listing and
lookups never answer 500."""

from __future__ import annotations

import copy
import json
import logging

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import planar_arm_urdf


def _client(data_dir) -> TestClient:
    settings = Settings(data_dir=data_dir, catalog="planar_arm")
    registry = Registry(settings.data_dir, settings.catalog_names())
    registry.load()
    return TestClient(create_app(settings, registry=registry), raise_server_exceptions=False)


def _drop(key):
    return lambda r: {k: v for k, v in r.items() if k != key}


def _set(path, value):
    def change(r):
        r = copy.deepcopy(r)
        target = r
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
        return r

    return change


BREAKAGES = {
    "no-summary": _drop("summary"),
    "no-description": _drop("description"),
    "no-root-joint": _drop("root_joint"),
    "summary-not-object": _set(["summary"], "ur5"),
    "summary-without-nv": lambda r: {**r, "summary": _drop("nv")(r["summary"])},
    "nv-as-text": _set(["summary", "nv"], "2"),
    "description-not-text": _set(["description"], 42),
    "gravity-short": _set(["gravity"], [0.0, -9.81]),
    "warnings-not-list": _set(["warnings"], "none"),
}


def test_incomplete_records_are_skipped_with_one_line_and_listing_never_fails(tmp_path, caplog):
    client = _client(tmp_path)
    good = client.post("/v1/robots", json={"urdf": planar_arm_urdf(1, 1, 1, 1)})
    assert good.status_code == 201
    good_id = good.json()["id"]
    reduced = client.post(
        f"/v1/robots/{good_id}/reduce", json={"locked_joints": {"elbow": 0.2}}
    ).json()["id"]
    models = tmp_path / "models"
    record = json.loads((models / f"{good_id}.json").read_text())
    reduced_record = json.loads((models / f"{reduced}.json").read_text())
    bad_ids = []
    for name, breakage in BREAKAGES.items():
        bad_id = f"u-bad-{name}"
        bad_ids.append(bad_id)
        (models / f"{bad_id}.json").write_text(json.dumps(breakage({**record, "id": bad_id})))
    for name, breakage in {
        "no-base": _drop("base"),
        "no-locked-joints": _drop("locked_joints"),
        "base-source-unknown": _set(["base", "source"], "elsewhere"),
        "embedded-record-broken": _set(["base", "record", "description"], None),
    }.items():
        bad_id = f"r-bad-{name}"
        bad_ids.append(bad_id)
        (models / f"{bad_id}.json").write_text(
            json.dumps(breakage({**reduced_record, "id": bad_id}))
        )
    (models / "u-not-an-object.json").write_text("[1, 2, 3]")
    bad_ids.append("u-not-an-object")

    with caplog.at_level(logging.ERROR, logger="robodyn.store"):
        for listed_by in (client, _client(tmp_path)):  # this server, and one that restarts
            for _ in range(3):
                listing = listed_by.get("/v1/robots")
                assert listing.status_code == 200, listing.text
                ids = {r["id"] for r in listing.json()["robots"]}
                assert {good_id, reduced} <= ids and not ids & set(bad_ids)
            for bad_id in bad_ids:
                r = listed_by.get(f"/v1/robots/{bad_id}")
                assert r.status_code == 404 and r.json()["code"] == "robot_not_found"
                r = listed_by.post(f"/v1/robots/{bad_id}/gravity", json={"q": [0.0, 0.0]})
                assert r.status_code == 404
            assert (
                listed_by.post(f"/v1/robots/{reduced}/gravity", json={"q": [0.1]}).status_code
                == 200
            )
    for bad_id in bad_ids:
        lines = [r for r in caplog.records if f"{bad_id}.json" in r.getMessage()]
        # one line per record and process (two processes' worth of registries here)
        assert 1 <= len(lines) <= 2, (bad_id, [r.getMessage() for r in lines])
        assert all("\n" not in r.getMessage() for r in lines)
    assert any("incomplete record: summary" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("extra", [{"assets": {"mesh/a.stl": "0" * 64}}, {"visuals": []}])
def test_records_with_members_of_newer_versions_are_still_read(tmp_path, extra):
    client = _client(tmp_path)
    good_id = client.post("/v1/robots", json={"urdf": planar_arm_urdf(1, 1, 1, 1)}).json()["id"]
    path = tmp_path / "models" / f"{good_id}.json"
    path.write_text(json.dumps({**json.loads(path.read_text()), **extra}))
    restarted = _client(tmp_path)
    assert restarted.get(f"/v1/robots/{good_id}").status_code == 200
    assert good_id in {r["id"] for r in restarted.get("/v1/robots").json()["robots"]}


def test_records_of_every_upload_format_are_accepted(tmp_path) -> None:
    """An MJCF record (gravity null: the model's own) and a xacro record (its expansion, its
    arguments, its assets) pass the schema; one whose expansion is not text does not."""
    from service.registry.records import check_record

    summary = {
        "id": "u-1",
        "name": "m",
        "source": "upload",
        "nq": 1,
        "nv": 1,
        "root_joint": "fixed",
    }
    mjcf = {
        "id": "u-1",
        "format": "mjcf",
        "description": "<mujoco/>",
        "root_joint": "fixed",
        "gravity": None,
        "name": "m",
        "summary": summary,
        "visuals": [],
        "assets": {"a/b.stl": "0" * 64},
    }
    assert check_record(mjcf, "u-1") is mjcf
    xacro = {
        **mjcf,
        "format": "xacro",
        "gravity": [0.0, 0.0, -9.81],
        "xacro_args": {"a": "1"},
        "expanded_urdf": "<robot/>",
    }
    assert check_record(xacro, "u-1") is xacro
    with pytest.raises(ValueError, match="expanded_urdf"):
        check_record({**xacro, "expanded_urdf": 3}, "u-1")
