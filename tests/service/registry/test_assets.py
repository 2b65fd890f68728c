"""Upload assets: keys normalized and refused when they could escape the upload, unknown or
unreadable files refused naming the key (422 invalid_model), stored content-addressed, part of
the id, and unreferenced ones listed in warnings."""

from __future__ import annotations

import base64
import hashlib
import time
import tracemalloc
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.registry.asset_checks import unreferenced
from service.registry.assets import (
    MAX_ASSETS,
    MAX_KEY_LENGTH,
    MAX_KEY_SEGMENTS,
    decode_assets,
    normalize_key,
)
from service.settings import Settings
from tests.helpers import registry_client
from tests.service.registry.mjcf_reference import cube_stl, encoded

URDF = (
    '<robot name="r"><link name="a"/><link name="b"><visual><geometry><mesh '
    'filename="package://pkg/meshes/b.stl"/></geometry></visual><inertial><mass value="1"/>'
    '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link><joint '
    'name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>'
)


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
        ("unreferenced_asset", "pkg/meshes/spare.stl")
    ]
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
    "XML with entities": (
        {"part.xml": b'<!DOCTYPE m [<!ENTITY a "b">]><m>&a;</m>'},
        "'part.xml' is unreadable as .xml",
    ),
    "not a PNG": ({"t.png": b"GIF89a"}, "'t.png' is unreadable as .png"),
    "twice after normalization": ({"a/x.stl": cube_stl(), "a/./x.stl": cube_stl()}, "given twice"),
    "too many": ({f"m{i}.stl": cube_stl() for i in range(MAX_ASSETS + 1)}, "the limit is"),
    "key too long": (
        {"m/" + "x" * MAX_KEY_LENGTH + ".stl": cube_stl()},
        f"characters long; the limit is {MAX_KEY_LENGTH}",
    ),
    "key of too many segments": (
        {"a/" * MAX_KEY_SEGMENTS + "x.stl": cube_stl()},
        f"{MAX_KEY_SEGMENTS + 1} path segments; the limit is",
    ),
    # the hostile case: 2,000-segment keys (a scan of their tails once took minutes)
    "key of 2000 segments": (
        {f"{i}/" + "s/" * 1999 + "x.stl": cube_stl() for i in range(50)},
        "2001 path segments; the limit is",
    ),
    "glTF nested deeper than JSON parsers go": (
        {"m.gltf": b"[" * 100_000 + b"]" * 100_000},
        "'m.gltf' is unreadable as .gltf: JSON nested",
    ),
    "not UTF-8": ({"m.gltf": b"\xff\xfe{}"}, "'m.gltf' is unreadable as .gltf: not UTF-8"),
    "XML asset over the element cap": (
        {"part.xml": b"<m>" + b"<a/>" * 50_001 + b"</m>"},
        "'part.xml' is unreadable as .xml: it has more than 50000 XML elements",
    ),
    "XML asset nested too deeply": (
        {"part.xml": b"<a>" * 200 + b"</a>" * 200},
        "'part.xml' is unreadable as .xml: it is nested deeper",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_assets_are_refused_by_key(client: TestClient, registry: Registry, case: str) -> None:
    files, fragment = BAD[case]
    stored = set(registry.store.ids())
    assets = {
        k: v if isinstance(v, str) else base64.b64encode(v).decode() for k, v in files.items()
    }
    r = client.post("/v1/robots", json={"urdf": URDF, "assets": assets})
    assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
    assert fragment in r.json()["detail"], r.json()["detail"]
    assert set(registry.store.ids()) == stored
    assert client.get("/health/live").status_code == 200


def test_a_urdf_uploads_visual_meshes_are_served_and_nothing_else(client: TestClient) -> None:
    """Visuals of a URDF upload name its own mesh (by the key the upload gave it), the assets
    route serves exactly those bytes, and a collision mesh or an unreferenced asset is a 404."""
    urdf = URDF.replace(
        "</visual>",
        "</visual><collision><geometry><mesh filename="
        '"package://pkg/meshes/hull.stl"/></geometry></collision>',
    )
    files = {
        "pkg/meshes/b.stl": cube_stl(),
        "pkg/meshes/hull.stl": cube_stl(0.3),
        "pkg/meshes/spare.stl": cube_stl(0.2),
    }
    r = client.post("/v1/robots", json={"urdf": urdf, "assets": encoded(files)})
    assert r.status_code == 201, r.text
    robot_id = r.json()["id"]
    visuals = client.get(f"/v1/robots/{robot_id}/visuals").json()["visuals"]
    assert [(v["frame"], v["geometry"]["type"], v["geometry"].get("asset")) for v in visuals] == [
        ("b", "mesh", "pkg/meshes/b.stl")
    ]
    mesh = client.get(f"/v1/robots/{robot_id}/assets/pkg/meshes/b.stl")
    assert mesh.status_code == 200 and mesh.content == cube_stl()
    assert mesh.headers["content-type"] == "model/stl"
    for other in ("pkg/meshes/hull.stl", "pkg/meshes/spare.stl"):
        gone = client.get(f"/v1/robots/{robot_id}/assets/{other}")
        assert gone.status_code == 404 and gone.json()["code"] == "asset_not_found", other


def test_the_serving_process_never_parses_a_text_asset() -> None:
    """An XML asset of ~1.2 million elements (4.8 MB) is decoded in the serving process with
    memory of about its own size: no tree is built there (it took ~250 bytes per element)."""
    xml = b"<m>" + b"<a/>" * 1_200_000 + b"</m>"
    payload = {"part.xml": base64.b64encode(xml).decode()}
    tracemalloc.start()
    try:
        files = decode_assets(payload)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert files == {"part.xml": xml}
    assert peak < 3 * len(xml), peak


def test_unreferenced_assets_by_file_name_in_linear_time() -> None:
    """An asset is named by a path ending in its file name (not by any text containing it):
    `x.stl` is not named by `box.stl`. The scan cuts the texts into tokens once: 2 MB of text
    and 2,000 keys of 32 segments take well under a second (searching each key's every tail
    in the whole text takes minutes; the bound is loose for a loaded machine)."""
    text = (
        '<mujoco><compiler meshdir="meshes"/><mesh file="box.stl"/>'
        '<include file="$(find pkg)/parts/arm.xml"/></mujoco>'
    )
    keys = ["meshes/box.stl", "meshes/x.stl", "pkg/parts/arm.xml", "other/arm.xml"]
    assert unreferenced(keys, [text]) == ["meshes/x.stl"]
    big = "<a>" + " ".join(f'<mesh file="d{i}/m{i}.stl"/>' for i in range(70_000)) + "</a>"
    assert len(big) > 2_000_000
    many = ["/".join(["s"] * (MAX_KEY_SEGMENTS - 1)) + f"/k{i}.stl" for i in range(2000)]
    started = time.perf_counter()
    assert unreferenced([*many, "q/m7.stl"], [big]) == many
    assert time.perf_counter() - started < 10.0


MESHES_URDF = (
    '<robot name="r"><link name="a"><visual><geometry><mesh filename="package://pkg/meshes/a.stl"/>'
    '</geometry></visual></link><link name="b"><visual><geometry><mesh filename='
    '"package://pkg/meshes/b.stl"/></geometry></visual><visual><geometry><mesh filename='
    '"package://pkg/meshes/b.stl" scale="2 2 2"/></geometry></visual><inertial><mass value="1"/>'
    '<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link><link name="c">'
    '<visual><geometry><mesh filename="meshes/c.stl"/></geometry></visual><inertial><mass '
    'value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
    '<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint>'
    '<joint name="k" type="continuous"><parent link="b"/><child link="c"/></joint></robot>'
)


def test_meshes_missing_from_the_upload_are_warned_by_file_and_link(client: TestClient) -> None:
    """Three mesh files referenced, one uploaded: one `missing_mesh` warning per missing file
    naming it and its link, on the upload's answer and in RobotInfo; their URLs are 404."""
    r = client.post(
        "/v1/robots",
        json={"urdf": MESHES_URDF, "assets": encoded({"pkg/meshes/a.stl": cube_stl()})},
    )
    assert r.status_code == 201, r.text
    info = r.json()
    missing = [w for w in info["warnings"] if w["code"] == "missing_mesh"]
    assert [(w["file"], w["element"], w["name"]) for w in missing] == [
        ("pkg/meshes/b.stl", "link", "b"),
        ("meshes/c.stl", "link", "c"),
    ]
    assert all(w["file"] in w["message"] and f"'{w['name']}'" in w["message"] for w in missing)
    assert client.get(f"/v1/robots/{info['id']}").json()["warnings"] == info["warnings"]
    assert len(info["warnings"]) == 2  # nothing else: a.stl is named and present
    robot = f"/v1/robots/{info['id']}"
    assert client.get(f"{robot}/assets/pkg/meshes/a.stl").status_code == 200
    for gone in ("pkg/meshes/b.stl", "meshes/c.stl"):
        assert client.get(f"{robot}/assets/{gone}").status_code == 404
    # every mesh given: no warning
    complete = client.post(
        "/v1/robots",
        json={
            "urdf": MESHES_URDF,
            "assets": encoded(
                {
                    "pkg/meshes/a.stl": cube_stl(),
                    "pkg/meshes/b.stl": cube_stl(0.1),
                    "meshes/c.stl": cube_stl(0.2),
                }
            ),
        },
    )
    assert complete.status_code == 201 and complete.json()["warnings"] == [], complete.text


def _stored_files(data_dir) -> set[str]:
    return {p.name for p in (data_dir / "assets").iterdir() if not p.name.startswith(".")}


def test_deleting_uploads_removes_the_asset_files_no_stored_model_names(tmp_path) -> None:
    """Over upload/delete rounds the assets directory does not grow: a deletion removes the
    files no remaining record names, and keeps a file another upload (or a reduced model,
    which rebuilds from its base's files) still names."""
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    shared = cube_stl(0.3)
    with registry_client(registry) as client:
        keeper = client.post(
            "/v1/robots", json={"urdf": URDF, "assets": encoded({"pkg/meshes/b.stl": shared})}
        )
        assert keeper.status_code == 201, keeper.text
        baseline = _stored_files(tmp_path)
        assert len(baseline) == 1
        for i in range(3):
            files = {"pkg/meshes/b.stl": cube_stl(0.01 * (i + 1)), "pkg/meshes/s.stl": shared}
            r = client.post("/v1/robots", json={"urdf": URDF, "assets": encoded(files)})
            assert r.status_code == 201, r.text
            assert len(_stored_files(tmp_path)) == 2
            assert client.delete(f"/v1/robots/{r.json()['id']}").status_code == 204
            assert _stored_files(tmp_path) == baseline, i  # the shared file stays
        # the keeper still serves its mesh
        mesh = client.get(f"/v1/robots/{keeper.json()['id']}/assets/pkg/meshes/b.stl")
        assert mesh.status_code == 200 and mesh.content == shared
        # a reduced model keeps its base's files after the base is deleted
        base = client.post(
            "/v1/robots",
            json={
                "urdf": MESHES_URDF,
                "assets": encoded(
                    {
                        "pkg/meshes/a.stl": cube_stl(0.07),
                        "pkg/meshes/b.stl": cube_stl(0.08),
                        "meshes/c.stl": cube_stl(0.09),
                    }
                ),
            },
        ).json()
        reduced = client.post(f"/v1/robots/{base['id']}/reduce", json={"locked_joints": {"k": 0.5}})
        assert reduced.status_code == 201, reduced.text
        assert client.delete(f"/v1/robots/{base['id']}").status_code == 204
        assert len(_stored_files(tmp_path)) == 4
        registry.uploads.clear()  # rebuilt from its record (embedding its base's)
        assert client.get(f"/v1/robots/{reduced.json()['id']}").status_code == 200
        assert client.delete(f"/v1/robots/{reduced.json()['id']}").status_code == 204
        assert _stored_files(tmp_path) == baseline
        assert client.delete(f"/v1/robots/{keeper.json()['id']}").status_code == 204
        assert _stored_files(tmp_path) == set()


class _BodyMessages:
    """ASGI middleware recording the size of every body message an answer is sent in."""

    def __init__(self, app) -> None:
        self.app, self.sizes = app, []

    async def __call__(self, scope, receive, send) -> None:
        async def recording(message) -> None:
            if message["type"] == "http.response.body":
                self.sizes.append(len(message.get("body", b"")))
            await send(message)

        await self.app(scope, receive, recording)


def test_a_mesh_is_streamed_from_its_file_in_chunks(tmp_path) -> None:
    """A 6 MB mesh leaves in chunks of at most 256 KiB (never read whole into memory), with
    its length, media type, ETag and Cache-Control; If-None-Match gives 304."""
    registry = Registry(tmp_path, ["ur5"])
    registry.load()
    triangles = 120_000
    big = bytes(80) + triangles.to_bytes(4, "little") + bytes(50 * triangles)
    app = _BodyMessages(create_app(Settings(data_dir=tmp_path), registry=registry))
    with TestClient(app, raise_server_exceptions=False) as client:
        r = client.post(
            "/v1/robots", json={"urdf": URDF, "assets": encoded({"pkg/meshes/b.stl": big})}
        )
        assert r.status_code == 201, r.text
        url = f"/v1/robots/{r.json()['id']}/assets/pkg/meshes/b.stl"
        app.sizes.clear()
        mesh = client.get(url)
        assert mesh.status_code == 200 and mesh.content == big
        assert mesh.headers["content-type"] == "model/stl"
        assert mesh.headers["content-length"] == str(len(big))
        assert mesh.headers["cache-control"] == "public, max-age=604800"
        assert mesh.headers["etag"] == f'"{hashlib.sha256(big).hexdigest()[:32]}"'
        assert sum(app.sizes) == len(big) and max(app.sizes) <= 256 * 1024, app.sizes[:3]
        again = client.get(url, headers={"If-None-Match": mesh.headers["etag"]})
        assert again.status_code == 304 and again.content == b""
        assert again.headers["etag"] == mesh.headers["etag"]


def test_meshes_outside_the_upload_are_warned_and_the_list_is_bounded(client: TestClient) -> None:
    """A mesh named by an absolute path, a file:// URL or a path climbing out can never be an
    asset: warned as such (not drawn). 150 missing files give 100 warnings and one counting
    the rest."""
    urdf = MESHES_URDF.replace("package://pkg/meshes/a.stl", "file:///home/me/a.stl").replace(
        "meshes/c.stl", "../../c.stl"
    )
    r = client.post(
        "/v1/robots", json={"urdf": urdf, "assets": encoded({"pkg/meshes/b.stl": cube_stl()})}
    )
    assert r.status_code == 201, r.text
    warned = [(w["code"], w["file"], w["name"]) for w in r.json()["warnings"]]
    assert warned == [
        ("missing_mesh", "file:///home/me/a.stl", "a"),
        ("missing_mesh", "../../c.stl", "c"),
    ], warned
    assert all("outside the upload" in w["message"] for w in r.json()["warnings"])
    links = "".join(
        f'<link name="l{i}"><visual><geometry><mesh filename="m/{i}.stl"/>'
        f'</geometry></visual></link><joint name="f{i}" type="fixed"><parent '
        f'link="a"/><child link="l{i}"/></joint>'
        for i in range(150)
    )
    many = URDF.replace("</robot>", links + "</robot>")
    r = client.post("/v1/robots", json={"urdf": many})
    assert r.status_code == 201, r.text
    missing = [w for w in r.json()["warnings"] if w["code"] == "missing_mesh"]
    # in document order: URDF's own link b (pkg/meshes/b.stl) first, then l0, l1, ...
    assert [w.get("file") for w in missing[:100]] == ["pkg/meshes/b.stl"] + [
        f"m/{i}.stl" for i in range(99)
    ]
    assert len(missing) == 101 and "and 51 more mesh files" in missing[-1]["message"]
