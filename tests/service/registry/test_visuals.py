"""Seeing the robot: visuals, assets and frame placements against in-process Pinocchio."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from service.registry.catalog import catalog_entries, erd_robots_dir
from service.registry.visuals import asset_key, rpy_matrix, urdf_visuals
from tests.helpers import random_configuration

# talos_full writes `package:///...`, alex_sake_hands reuses visual names across its hands
CATALOG = "ur5,planar_arm,talos,solo12,talos_full,alex_sake_hands"


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    from fastapi.testclient import TestClient

    from service.main import create_app
    from service.registry import Registry
    from service.settings import Settings

    settings = Settings(data_dir=tmp_path_factory.mktemp("visuals"), catalog=CATALOG)
    registry = Registry(settings.data_dir, settings.catalog_names(), settings.build_timeout_s)
    registry.load()
    with TestClient(create_app(settings, registry=registry), raise_server_exceptions=False) as c:
        c.registry = registry  # type: ignore[attr-defined]
        yield c


def _model(client, name):
    return client.registry.get(name).model


def _urdf_path(name):
    entry = next(e for e in catalog_entries() if e.name == name)
    return entry.path("urdf")


# ---- frame placements ---------------------------------------------------------------------


@pytest.mark.parametrize("name", ["ur5", "talos", "solo12"])
def test_placements_equal_pinocchio_frames_forward_kinematics(client, name) -> None:
    model = _model(client, name)
    data = model.createData()
    rng = np.random.default_rng(7)
    body = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
    qs = np.array([random_configuration(model, rng) for _ in range(3)])
    one = client.post(f"/v1/robots/{name}/frame-placements", json={"q": qs[0].tolist()})
    batch = client.post(f"/v1/robots/{name}/frame-placements", json={"q": qs.tolist()})
    assert one.status_code == 200 and batch.status_code == 200, (one.text, batch.text)
    assert one.json()["frames"] == body == batch.json()["frames"]
    positions, rotations = np.array(batch.json()["positions"]), np.array(batch.json()["rotations"])
    assert positions.shape == (3, len(body), 3) and rotations.shape == (3, len(body), 3, 3)
    for i, q in enumerate(qs):
        pin.framesForwardKinematics(model, data, q)
        for k, frame in enumerate(body):
            placement = data.oMf[model.getFrameId(frame)]
            np.testing.assert_allclose(positions[i, k], placement.translation, atol=1e-12)
            np.testing.assert_allclose(rotations[i, k], placement.rotation, atol=1e-12)
    np.testing.assert_allclose(one.json()["positions"], positions[0], atol=1e-12)
    np.testing.assert_allclose(one.json()["rotations"], rotations[0], atol=1e-12)


def test_named_frames_in_the_order_asked(client) -> None:
    model = _model(client, "ur5")
    q = random_configuration(model, np.random.default_rng(1))
    names = ["wrist_3_joint", "tool0", "base_link"]
    answer = client.post(
        "/v1/robots/ur5/frame-placements", json={"q": q.tolist(), "frames": names}
    ).json()
    assert answer["frames"] == names
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    for k, name in enumerate(names):
        placement = data.oMf[model.getFrameId(name)]
        np.testing.assert_allclose(answer["positions"][k], placement.translation, atol=1e-12)
        np.testing.assert_allclose(answer["rotations"][k], placement.rotation, atol=1e-12)


def test_placements_errors_follow_the_contract(client) -> None:
    q = [0.0] * 6
    url = "/v1/robots/ur5/frame-placements"
    unknown = client.post(url, json={"q": q, "frames": ["tool0", "no_such_link"]})
    assert unknown.status_code == 422 and unknown.json()["code"] == "unknown_frame"
    assert "frames[1]" in unknown.json()["detail"]
    short = client.post(url, json={"q": q[:5]})
    assert short.status_code == 422 and short.json()["code"] == "dimension_mismatch"
    nan = client.post(
        url, content=b'{"q": [NaN, 0, 0, 0, 0, 0]}', headers={"Content-Type": "application/json"}
    )
    assert nan.status_code == 422 and nan.json()["code"] == "validation_error"
    huge = client.post(url, json={"q": [1e308] * 6})  # cos/sin of 1e308 are finite: fine
    assert huge.status_code in (200, 422)
    quaternion = client.post(
        "/v1/robots/talos/frame-placements", json={"q": [0.0] * _model(client, "talos").nq}
    )
    assert quaternion.status_code == 422
    assert quaternion.json()["code"] == "invalid_configuration"
    missing = client.post("/v1/robots/nobody/frame-placements", json={"q": q})
    assert missing.status_code == 404 and missing.json()["code"] == "robot_not_found"
    assert client.post(url, json={"q": q, "frames": []}).json()["positions"] == []


def test_placements_in_the_openapi_document(client) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    assert "post" in paths["/v1/robots/{robot_id}/frame-placements"]
    assert "get" in paths["/v1/robots/{robot_id}/visuals"]
    assert "get" in paths["/v1/robots/{robot_id}/assets/{path}"]


# ---- visuals --------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["ur5", "talos", "solo12", "talos_full", "alex_sake_hands"])
def test_visuals_are_pinocchios_visual_geometries(client, name) -> None:
    """Every visual geometry Pinocchio reads from the description is listed, on the same
    frame, at the same world placement, with the same mesh file and scale."""
    model = _model(client, name)
    share = erd_robots_dir().parent.parent
    geometry = pin.buildGeomFromUrdf(
        model, str(_urdf_path(name)), pin.GeometryType.VISUAL, package_dirs=[str(share)]
    )
    visuals = client.get(f"/v1/robots/{name}/visuals").json()["visuals"]
    assert len(visuals) == len(geometry.geometryObjects) > 0
    robot = client.registry.get(name)
    q = random_configuration(model, np.random.default_rng(3))
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    by_name = {obj.name: obj for obj in geometry.geometryObjects}  # `<link>_<index>`
    assert {v["name"] for v in visuals} == set(by_name)
    for visual in visuals:
        obj = by_name[visual["name"]]
        assert visual["frame"] == model.frames[obj.parentFrame].name
        local = pin.SE3(
            np.array(visual["placement"]["rotation"]), np.array(visual["placement"]["translation"])
        )
        world = data.oMf[obj.parentFrame] * local
        expected = data.oMi[obj.parentJoint] * obj.placement
        np.testing.assert_allclose(world.homogeneous, expected.homogeneous, atol=1e-9)
        if visual["geometry"]["type"] == "mesh":
            served = robot.asset_paths[visual["geometry"]["asset"]]
            assert served.samefile(obj.meshPath)
            np.testing.assert_allclose(visual["geometry"]["scale"], obj.meshScale)


def test_robot_without_visuals_has_an_empty_list(client) -> None:
    assert client.get("/v1/robots/planar_arm/visuals").json() == {"visuals": []}
    missing = client.get("/v1/robots/nobody/visuals")
    assert missing.status_code == 404 and missing.json()["code"] == "robot_not_found"


# ---- assets ---------------------------------------------------------------------------------


def test_every_referenced_mesh_is_served_with_type_etag_and_cache(client) -> None:
    visuals = client.get("/v1/robots/ur5/visuals").json()["visuals"]
    robot = client.registry.get("ur5")
    keys = {v["geometry"]["asset"] for v in visuals if v["geometry"]["type"] == "mesh"}
    assert keys == set(robot.asset_paths) and len(keys) == 7
    for key in keys:
        answer = client.get(f"/v1/robots/ur5/assets/{key}")
        assert answer.status_code == 200, key
        assert answer.headers["content-type"] == "model/vnd.collada+xml"
        assert answer.content == robot.asset_paths[key].read_bytes()
        assert "max-age=" in answer.headers["cache-control"]
        etag = answer.headers["etag"]
        again = client.get(f"/v1/robots/ur5/assets/{key}", headers={"If-None-Match": etag})
        assert again.status_code == 304 and again.content == b""
        weak = client.get(
            f"/v1/robots/ur5/assets/{key}", headers={"If-None-Match": f'"other", W/{etag}'}
        )
        assert weak.status_code == 304
        stale = client.get(f"/v1/robots/ur5/assets/{key}", headers={"If-None-Match": '"x"'})
        assert stale.status_code == 200 and stale.content == answer.content
    stl = next(k for k in client.registry.get("talos").asset_paths if k.endswith(".STL"))
    assert client.get(f"/v1/robots/talos/assets/{stl}").headers["content-type"] == "model/stl"


def test_only_referenced_files_are_reachable(client) -> None:
    visual = client.get("/v1/robots/ur5/visuals").json()["visuals"][0]["geometry"]["asset"]
    collision = visual.replace("/visual/", "/collision/").replace(".dae", ".stl")
    assert (erd_robots_dir().parent.parent / collision).is_file()  # it exists, yet:
    description = "example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"
    assert (erd_robots_dir().parent.parent / description).is_file()
    attempts = [
        collision,
        description,
        visual.upper(),
        visual + "/",
        "/" + visual,
        f"example-robot-data/robots/ur_description/meshes/ur5/visual/../collision/"
        f"{collision.rsplit('/', 1)[1]}",
        "..%2F..%2F..%2Fetc%2Fpasswd",
        "%2e%2e/%2e%2e/etc/passwd",
        "%2Fetc%2Fpasswd",
        "..%5C..%5Cservice%5Cmain.py",
        "service/main.py",
        "",
    ]
    for path in attempts:
        answer = client.get(f"/v1/robots/ur5/assets/{path}")
        assert answer.status_code == 404, path
        assert answer.headers["content-type"] == "application/problem+json", path
        assert answer.json()["code"] in ("asset_not_found", "not_found"), path
    # the same file is no asset of a robot whose visuals do not name it
    other = client.get(f"/v1/robots/talos/assets/{visual}")
    assert other.status_code == 404 and other.json()["code"] == "asset_not_found"
    nobody = client.get(f"/v1/robots/nobody/assets/{visual}")
    assert nobody.status_code == 404 and nobody.json()["code"] == "robot_not_found"


# ---- uploads and the parser -----------------------------------------------------------------

UPLOAD = """<?xml version="1.0"?>
<robot name="shapes">
  <material name="red"><color rgba="1 0 0 1"/></material>
  <link name="base"><visual name="plate"><origin xyz="0 0 0.05"/>
    <geometry><box size="0.4 0.3 0.1"/></geometry><material name="red"/></visual></link>
  <link name="arm">
    <inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0"
      izz="0.01"/></inertial>
    <visual><origin xyz="0 0 0.25" rpy="0.1 0.2 0.3"/>
      <geometry><cylinder radius="0.03" length="0.5"/></geometry>
      <material name="g"><color rgba="0 1 0 0.5"/></material></visual>
    <visual><geometry><mesh filename="package://shapes/meshes/arm.stl" scale="2 2 2"/>
      </geometry></visual>
    <collision><geometry><sphere radius="1"/></geometry></collision>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
</robot>"""


def test_upload_visuals_come_from_its_description(client) -> None:
    stored = client.post("/v1/robots", json={"urdf": UPLOAD})
    assert stored.status_code in (200, 201), stored.text
    robot_id = stored.json()["id"]
    visuals = client.get(f"/v1/robots/{robot_id}/visuals").json()["visuals"]
    assert [(v["name"], v["frame"], v["geometry"]["type"]) for v in visuals] == [
        ("base_0", "base", "box"),
        ("arm_0", "arm", "cylinder"),
        ("arm_1", "arm", "mesh"),
    ]
    assert visuals[0]["color"] == [1, 0, 0, 1] and visuals[1]["color"] == [0, 1, 0, 0.5]
    assert visuals[2]["geometry"] == {
        "type": "mesh",
        "asset": "shapes/meshes/arm.stl",
        "scale": [2, 2, 2],
    }
    np.testing.assert_allclose(
        visuals[1]["placement"]["rotation"], pin.rpy.rpyToMatrix(0.1, 0.2, 0.3), atol=1e-15
    )
    # no asset was uploaded with it: nothing to serve
    mesh = client.get(f"/v1/robots/{robot_id}/assets/shapes/meshes/arm.stl")
    assert mesh.status_code == 404 and mesh.json()["code"] == "asset_not_found"
    placements = client.post(f"/v1/robots/{robot_id}/frame-placements", json={"q": [0.5]}).json()
    assert placements["frames"] == ["base", "arm"]


def test_asset_keys_and_rotations() -> None:
    assert asset_key("package://pkg/meshes/./a.stl") == "pkg/meshes/a.stl"
    assert asset_key("meshes/a.dae") == "meshes/a.dae"
    assert asset_key("package:///pkg/a.stl") == "pkg/a.stl"
    for refused in (
        "/etc/passwd",
        "file:///etc/passwd",
        "package://../x.stl",
        "a/../../b.stl",
        "http://example.com/a.stl",
        "a\\b.stl",
        "",
    ):
        assert asset_key(refused) is None, refused
    rng = np.random.default_rng(0)
    for rpy in rng.uniform(-3, 3, (5, 3)):
        np.testing.assert_allclose(rpy_matrix(*rpy), pin.rpy.rpyToMatrix(*rpy), atol=1e-14)


def test_unreadable_visuals_are_left_out() -> None:
    text = UPLOAD.replace('size="0.4 0.3 0.1"', 'size="0.4 nan"')
    names = [v["name"] for v in urdf_visuals(text)]
    assert names == ["arm_0", "arm_1"]
    triple = UPLOAD.replace("package://shapes", "package:///shapes")
    assert urdf_visuals(triple)[-1]["geometry"]["asset"] == "shapes/meshes/arm.stl"


def test_placements_in_binary_by_joint_name_and_on_the_stream(client) -> None:
    """frame-placements is a dynamics quantity like the others: binary bodies and answers,
    name-keyed q, and the WebSocket stream give the same answer as plain JSON."""
    import orjson

    from service.api.encoding import binary

    model = _model(client, "ur5")
    q = random_configuration(model, np.random.default_rng(5))
    url = "/v1/robots/ur5/frame-placements"
    expected = client.post(url, json={"q": q.tolist(), "frames": ["tool0"]}).json()
    answer = client.post(
        url,
        content=binary.encode({"q": q, "frames": ["tool0"]}),
        headers={"Content-Type": binary.BINARY_MEDIA_TYPE, "Accept": binary.BINARY_MEDIA_TYPE},
    )
    assert answer.status_code == 200, answer.text
    fields, arrays = binary.decode(answer.content)
    assert fields["frames"] == ["tool0"]
    np.testing.assert_array_equal(arrays["positions"], expected["positions"])
    np.testing.assert_array_equal(arrays["rotations"], expected["rotations"])
    names = [model.names[j] for j in range(1, model.njoints)]
    named = client.post(
        url, json={"q": dict(zip(names, q.tolist(), strict=True)), "frames": ["tool0"]}
    ).json()
    assert named == expected
    with client.websocket_connect("/v1/robots/ur5/stream") as ws:
        ws.send_text(
            orjson.dumps(
                {"quantity": "frame-placements", "q": q.tolist(), "frames": ["tool0"]}
            ).decode()
        )
        assert ws.receive_json() == expected


def test_a_reduced_model_shows_its_bases_visuals_and_meshes(client) -> None:
    reduced = client.post(
        "/v1/robots/ur5/reduce",
        json={"locked_joints": {"wrist_1_joint": 0.3, "wrist_2_joint": -0.2}},
    )
    assert reduced.status_code in (200, 201), reduced.text
    robot_id = reduced.json()["id"]
    base = client.get("/v1/robots/ur5/visuals").json()["visuals"]
    visuals = client.get(f"/v1/robots/{robot_id}/visuals").json()["visuals"]
    assert visuals == base  # locking joints keeps every link as a body frame
    model = client.registry.get(robot_id).model
    q = random_configuration(model, np.random.default_rng(2))
    answer = client.post(f"/v1/robots/{robot_id}/frame-placements", json={"q": q.tolist()})
    assert {v["frame"] for v in visuals} <= set(answer.json()["frames"])
    asset = visuals[-1]["geometry"]["asset"]
    served = client.get(f"/v1/robots/{robot_id}/assets/{asset}")
    assert served.status_code == 200
    assert served.content == client.get(f"/v1/robots/ur5/assets/{asset}").content


@pytest.mark.slow  # Pinocchio's reader loads every mesh: about a minute for the catalog
def test_every_catalog_robot_lists_pinocchios_visual_geometries(catalog_registry) -> None:
    """Across the whole catalog: the same visuals as Pinocchio's own URDF reader finds (where
    it can read the description with the model as loaded), at the same world placements."""
    share = str(erd_robots_dir().parent.parent)
    entries = {e.name: e for e in catalog_entries()}
    compared = 0
    for name, robot in sorted(catalog_registry.catalog.items()):
        model = robot.model
        try:
            geometry = pin.buildGeomFromUrdf(
                model,
                str(entries[name].path("urdf")),
                pin.GeometryType.VISUAL,
                package_dirs=[share],
            )
        except Exception:  # a reduced catalog model (talos_legs) or a mesh assimp cannot read
            continue
        by_name = {obj.name: obj for obj in geometry.geometryObjects}
        assert {v["name"] for v in robot.visuals} == set(by_name), name
        data = model.createData()
        pin.framesForwardKinematics(model, data, pin.neutral(model))
        for visual in robot.visuals:
            obj = by_name[visual["name"]]
            local = pin.SE3(
                np.array(visual["placement"]["rotation"]),
                np.array(visual["placement"]["translation"]),
            )
            expected = data.oMi[obj.parentJoint] * obj.placement
            np.testing.assert_allclose(
                (data.oMf[obj.parentFrame] * local).homogeneous,
                expected.homogeneous,
                atol=1e-9,
                err_msg=name,
            )
        compared += 1
    assert compared >= 60
