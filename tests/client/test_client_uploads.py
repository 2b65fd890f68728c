"""`upload(path_or_text, assets=...)`: a directory or a file is sent with the files it references
(MJCF meshdir and includes; package:// and $(find pkg) of URDF and xacro), by the keys the server
matches; the same model uploaded with explicit assets has the same id; sync and async."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
import robodyn
from fastapi.testclient import TestClient
from robodyn import AsyncClient, Client
from robodyn.uploads import upload_body

from service.main import create_app
from service.registry import Registry
from service.registry.catalog import erd_robots_dir
from service.settings import Settings
from tests.client.helpers import two_link_urdf
from tests.service.registry.mjcf_reference import cube_stl
from tests.service.registry.test_xacro import ARGS_XACRO, PART

MODEL = '<mujoco model="meshy"><compiler meshdir="assets"/><include file="parts/arm.xml"/></mujoco>'
ARM = (
    '<mujoco><asset><mesh name="cube" file="./cube.stl"/></asset><worldbody><body name="b">'
    '<joint axis="0 1 0"/><geom type="mesh" mesh="cube" density="900"/></body></worldbody>'
    "</mujoco>"
)


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory):
    data = tmp_path_factory.mktemp("client-uploads")
    registry = Registry(data, ["ur5"])
    registry.load()
    return create_app(Settings(data_dir=data), registry=registry)


@pytest.fixture(scope="module")
def client(app) -> Iterator[Client]:
    with TestClient(app) as http, Client(http_client=http) as c:
        yield c


def _mjcf_dir(root: Path) -> Path:
    (root / "assets").mkdir(parents=True)
    (root / "parts").mkdir()
    (root / "model.xml").write_text(MODEL)
    (root / "parts" / "arm.xml").write_text(ARM)
    (root / "assets" / "cube.stl").write_bytes(cube_stl())
    (root / "notes.txt").write_text("not a description")
    return root


def test_a_directory_is_sent_with_what_it_references(client: Client, tmp_path: Path) -> None:
    root = _mjcf_dir(tmp_path / "robot")
    body = upload_body(root)
    assert set(body) == {"mjcf", "assets"}
    assert set(body["assets"]) == {"parts/arm.xml", "assets/cube.stl"}
    info = client.upload(root)
    assert info.created and info.total_mass == pytest.approx(0.9, rel=1e-6)
    assert client.upload(root / "model.xml").id == info.id
    explicit = client.upload(
        MODEL, assets={"parts/arm.xml": ARM, "assets/cube.stl": root / "assets" / "cube.stl"}
    )
    assert explicit.id == info.id and not explicit.created
    with pytest.raises(robodyn.InvalidModelError, match=r"arm\.xml"):
        client.upload(MODEL)  # text alone: nothing collected, the include is missing


def test_a_xacro_package_tree(client: Client, tmp_path: Path) -> None:
    ws = tmp_path / "ws" / "src"
    (ws / "parts" / "urdf").mkdir(parents=True)
    (ws / "parts" / "config").mkdir()
    (ws / "bar" / "urdf").mkdir(parents=True)
    (ws / "parts" / "urdf" / "link.xacro").write_bytes(PART)
    (ws / "parts" / "config" / "params.yaml").write_text("length: 0.5\n")
    main = ws / "bar" / "urdf" / "bar.urdf.xacro"
    main.write_text(ARGS_XACRO)
    body = upload_body(main)
    assert set(body["assets"]) == {"parts/urdf/link.xacro", "parts/config/params.yaml"}
    info = client.upload(main, xacro_args={"mass": "2"})
    M = client.mass_matrix(info.id, [0.1])
    np.testing.assert_allclose(M, [[0.001 + 2 * 0.25**2]], rtol=1e-12)


def test_a_urdf_with_package_meshes(client: Client, tmp_path: Path) -> None:
    erd = erd_robots_dir().parent  # .../share/example-robot-data
    copy = tmp_path / "example-robot-data" / "robots" / "ur_description"
    shutil.copytree(erd / "robots" / "ur_description", copy)
    urdf = copy / "urdf" / "ur5_robot.urdf"
    body = upload_body(urdf)
    keys = set(body["assets"])
    assert keys and all(
        k.startswith("example-robot-data/robots/ur_description/meshes/") for k in keys
    )
    info = client.upload(urdf)
    assert not [w for w in info.raw["warnings"] if w["code"] == "unreferenced_asset"]
    q = np.array([0.1, -0.5, 0.7, 0.2, 0.3, -0.1])
    np.testing.assert_allclose(
        client.mass_matrix(info.id, q), client.mass_matrix("ur5", q), rtol=1e-12
    )


def _ros_package(
    root: Path, folder: str = "arm_description", package: str = "arm_description"
) -> Path:
    """A ROS package as cloned: package.xml, urdf/arm.urdf whose upper link's visual is
    `package://<package>/meshes/upper.stl`, the mesh, and a launch file (XML, not a model)."""
    pkg = root / folder
    for sub in ("urdf", "meshes", "launch"):
        (pkg / sub).mkdir(parents=True)
    (pkg / "package.xml").write_text(
        f'<?xml version="1.0"?>\n<package format="3">'
        f"<name>{package}</name><version>1.0.0</version></package>"
    )
    (pkg / "launch" / "view.launch.xml").write_text("<launch><arg name='gui'/></launch>")
    visual = (
        f'<visual><geometry><mesh filename="package://{package}/meshes/upper.stl"/>'
        "</geometry></visual>"
    )
    urdf = two_link_urdf(name="ros_arm").replace(
        '<link name="upper">', f'<link name="upper">{visual}'
    )
    (pkg / "urdf" / "arm.urdf").write_text(urdf)
    (pkg / "meshes" / "upper.stl").write_bytes(cube_stl())
    return pkg


def test_a_ros_package_layout_is_found_and_its_meshes_resolve(
    app, client: Client, tmp_path: Path
) -> None:
    ws = tmp_path / "ws"
    pkg = _ros_package(ws / "src")
    for given in (ws, ws / "src", pkg):  # a workspace, its src folder, or the package itself
        body = upload_body(given)
        assert body["urdf"] == (pkg / "urdf" / "arm.urdf").read_text(), given
        assert set(body["assets"]) == {"arm_description/meshes/upper.stl"}, given
    info = client.upload(ws)
    assert info.id == client.upload(pkg / "urdf" / "arm.urdf").id  # the file itself: the same
    assert not [w for w in info.raw["warnings"] if w["code"] == "unreferenced_asset"]
    with TestClient(app) as http:  # the server serves the mesh under the key it was sent as
        visuals = http.get(f"/v1/robots/{info.id}/visuals").json()
        meshes = {v["geometry"].get("asset") for v in visuals["visuals"]} - {None}
        assert meshes == {"arm_description/meshes/upper.stl"}
        mesh = http.get(f"/v1/robots/{info.id}/assets/arm_description/meshes/upper.stl")
        assert mesh.status_code == 200 and mesh.content == cube_stl()


def test_a_package_folder_named_otherwise_is_found_by_its_package_xml(tmp_path: Path) -> None:
    _ros_package(tmp_path, folder="arm_description-main")  # a checkout of a release archive
    body = upload_body(tmp_path)
    assert set(body["assets"]) == {"arm_description/meshes/upper.stl"}


def test_the_tree_search_prefers_urdf_folders_and_skips_included_files(tmp_path: Path) -> None:
    pkg = _ros_package(tmp_path)
    (pkg / "test").mkdir()
    (pkg / "test" / "fixture.urdf").write_text("<robot name='fixture'/>")
    assert upload_body(tmp_path)["urdf"].startswith('<?xml version="1.0"?>\n<robot name="ros_arm"')
    (pkg / "urdf" / "arm.urdf").unlink()
    (pkg / "urdf" / "arm.urdf.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="x">'
        '<xacro:include filename="$(find arm_description)/urdf/arm.macro.xacro"/></robot>'
    )
    (pkg / "urdf" / "arm.macro.xacro").write_text(
        '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="l"/></robot>'
    )
    body = upload_body(tmp_path)
    assert "arm.macro.xacro" in body["xacro"]
    assert set(body["assets"]) == {"arm_description/urdf/arm.macro.xacro"}
    (pkg / "urdf" / "other.urdf").write_text("<robot name='other'/>")
    with pytest.raises(robodyn.InputError, match=r"urdf/arm\.urdf\.xacro, .*urdf/other\.urdf"):
        upload_body(tmp_path)


def test_the_format_is_told_from_the_text() -> None:
    from robodyn.uploads import detect_format

    generated = (
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="a"/></robot>'
    )
    assert detect_format(generated) == "urdf"  # xacro's output keeps the namespace
    assert detect_format(ARGS_XACRO) == "xacro"
    assert detect_format(MODEL) == "mjcf"


def test_local_errors(tmp_path: Path) -> None:
    root = _mjcf_dir(tmp_path / "two")
    (root / "other.urdf").write_text("<robot name='x'/>")
    with pytest.raises(robodyn.InputError, match="exactly one description"):
        upload_body(root)
    with pytest.raises(robodyn.InputError, match="exactly one description"):
        upload_body(None)
    with pytest.raises(robodyn.InputError, match="no description file"):
        upload_body(tmp_path / "missing.urdf")


@pytest.mark.anyio
async def test_async_client_uploads_a_directory(app, tmp_path: Path) -> None:
    root = _mjcf_dir(tmp_path / "async")
    transport = httpx.ASGITransport(app=app)
    async with (
        httpx.AsyncClient(transport=transport, base_url="http://robodyn.test") as http,
        AsyncClient(http_client=http) as client,
    ):
        info = await client.upload(root, gravity=[0, 0, -1])
        assert info.raw["gravity"] == [0, 0, -1]
        M = await client.mass_matrix(info.id, [0.2])
        assert M.shape == (1, 1) and M[0, 0] > 0
