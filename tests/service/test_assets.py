"""Upload assets: keys normalized and refused when they could escape the upload, unknown or
unreadable files refused naming the key (422 invalid_model), stored content-addressed, part of
the id, and unreferenced ones listed in warnings."""

from __future__ import annotations

import base64
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from service.registry import Registry
from service.registry.assets import MAX_ASSETS, normalize_key
from tests.helpers import registry_client
from tests.service.mjcf_reference import cube_stl, encoded

URDF = ('<robot name="r"><link name="a"/><link name="b"><visual><geometry><mesh '
        'filename="package://pkg/meshes/b.stl"/></geometry></visual><inertial><mass value="1"/>'
        '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link><joint '
        'name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>')


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    reg = Registry(tmp_path_factory.mktemp("assets"), ["ur5"])
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry: Registry) -> Iterator[TestClient]:
    with registry_client(registry) as c:
        yield c


def test_keys_are_normalized() -> None:
    assert normalize_key("package://pkg/meshes/./b.stl") == "pkg/meshes/b.stl"
    assert normalize_key("./a//b.stl") == "a/b.stl"


def test_urdf_assets_are_stored_with_the_model(client: TestClient, registry: Registry) -> None:
    files = {"package://pkg/meshes/b.stl": cube_stl(), "pkg/meshes/spare.stl": cube_stl(0.2)}
    r = client.post("/v1/robots", json={"urdf": URDF, "assets": encoded(files)})
    assert r.status_code == 201, r.text
    info = r.json()
    assert [(w["code"], w["name"]) for w in info["warnings"]] == [
        ("unreferenced_asset", "pkg/meshes/spare.stl")]
    without = client.post("/v1/robots", json={"urdf": URDF}).json()
    assert without["id"] != info["id"]  # assets are part of the id
    robot = registry.get(info["id"])
    stored = robot.asset_paths["pkg/meshes/b.stl"]
    assert stored.read_bytes() == cube_stl() and stored.parent.name == "assets"
    record = registry.store.read(info["id"])
    assert set(record["assets"]) == {"pkg/meshes/b.stl", "pkg/meshes/spare.stl"}


BAD = {  # case → (assets, a fragment of the detail)
    "absolute path": ({"/etc/passwd.stl": cube_stl()}, "'/etc/passwd.stl'"),
    "climbing out": ({"meshes/../../x.stl": cube_stl()}, "'meshes/../../x.stl'"),
    "backslash": ({"meshes\\x.stl": cube_stl()}, "'meshes\\x.stl'"),
    "unknown type": ({"tool.exe": b"MZ"}, "'.exe' is not a known file type"),
    "no extension": ({"meshes/x": cube_stl()}, "is not a known file type"),
    "not base64": ({"x.stl": "%%%"}, "'x.stl' is not valid base64"),
    "empty": ({"x.stl": b""}, "'x.stl' is empty"),
    "not an STL": ({"x.stl": b"\x00" * 100}, "'x.stl' is unreadable as .stl"),
    "not XML": ({"part.xml": b"<mujoco>"}, "'part.xml' is unreadable as .xml"),
    "XML with entities": ({"part.xml": b'<!DOCTYPE m [<!ENTITY a "b">]><m>&a;</m>'},
                          "'part.xml' is unreadable as .xml"),
    "not a PNG": ({"t.png": b"GIF89a"}, "'t.png' is unreadable as .png"),
    "twice after normalization": ({"a/x.stl": cube_stl(), "a/./x.stl": cube_stl()},
                                  "given twice"),
    "too many": ({f"m{i}.stl": cube_stl() for i in range(MAX_ASSETS + 1)}, "the limit is"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_assets_are_refused_by_key(client: TestClient, registry: Registry,
                                       case: str) -> None:
    files, fragment = BAD[case]
    stored = set(registry.store.ids())
    assets = {k: v if isinstance(v, str) else base64.b64encode(v).decode()
              for k, v in files.items()}
    r = client.post("/v1/robots", json={"urdf": URDF, "assets": assets})
    assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
    assert fragment in r.json()["detail"], r.json()["detail"]
    assert set(registry.store.ids()) == stored
    assert client.get("/health/live").status_code == 200


def test_a_urdf_uploads_visual_meshes_are_served_and_nothing_else(client: TestClient) -> None:
    """Visuals of a URDF upload name its own mesh (by the key the upload gave it), the assets
    route serves exactly those bytes, and a collision mesh or an unreferenced asset is a 404."""
    urdf = URDF.replace("</visual>", "</visual><collision><geometry><mesh filename="
                        '"package://pkg/meshes/hull.stl"/></geometry></collision>')
    files = {"pkg/meshes/b.stl": cube_stl(), "pkg/meshes/hull.stl": cube_stl(0.3),
             "pkg/meshes/spare.stl": cube_stl(0.2)}
    r = client.post("/v1/robots", json={"urdf": urdf, "assets": encoded(files)})
    assert r.status_code == 201, r.text
    robot_id = r.json()["id"]
    visuals = client.get(f"/v1/robots/{robot_id}/visuals").json()["visuals"]
    assert [(v["frame"], v["geometry"]["type"], v["geometry"].get("asset")) for v in visuals] == [
        ("b", "mesh", "pkg/meshes/b.stl")]
    mesh = client.get(f"/v1/robots/{robot_id}/assets/pkg/meshes/b.stl")
    assert mesh.status_code == 200 and mesh.content == cube_stl()
    assert mesh.headers["content-type"] == "model/stl"
    for other in ("pkg/meshes/hull.stl", "pkg/meshes/spare.stl"):
        gone = client.get(f"/v1/robots/{robot_id}/assets/{other}")
        assert gone.status_code == 404 and gone.json()["code"] == "asset_not_found", other
