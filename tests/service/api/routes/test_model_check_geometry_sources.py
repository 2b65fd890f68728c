"""The model check's geometry where the description is not a URDF with STL-like meshes: an MJCF
upload's geoms (read through MuJoCo's compiled model), a URDF's MuJoCo `.msh` mesh, and the
variants of a robot (payloads, identified inertial parameters), which keep its geometry.

Independent references: MuJoCo's own mass properties from geometry (the same MJCF compiled
with `<compiler inertiafromgeom="true"/>`: `body_mass`, `body_ipos`, `body_iquat`,
`body_inertia` at the geoms' density), to 1e-9 for primitives and 1e-6 for meshes (MuJoCo
keeps a mesh's vertices in single precision); the closed form of a box for the `.msh` mesh."""

from __future__ import annotations

import base64
import struct
from collections.abc import Iterator
from pathlib import Path

import mujoco
import numpy as np
import pytest
import trimesh
from fastapi.testclient import TestClient

from service.dynamics.identification import inertial_parameters
from service.main import create_app
from service.registry import Registry
from service.registry.variants import Fitted
from service.settings import Settings

DENSITY = 1000.0  # kg/m³, MuJoCo's default geom density


def _msh(mesh: trimesh.Trimesh) -> bytes:
    """MuJoCo's binary .msh: nvertex, nnormal, ntexcoord, nface (int32), then float32
    vertices and int32 faces."""
    vertices = np.asarray(mesh.vertices, dtype="<f4")
    faces = np.asarray(mesh.faces, dtype="<i4")
    return (
        struct.pack("<4i", len(vertices), 0, 0, len(faces)) + vertices.tobytes() + faces.tobytes()
    )


RING = trimesh.creation.annulus(r_min=0.03, r_max=0.06, height=0.04, sections=48)  # not convex
CUBE_SIDES = np.array([0.08, 0.05, 0.12])
CUBE_OFFSET = np.array([0.03, -0.01, 0.02])
CUBE = trimesh.creation.box(extents=CUBE_SIDES)
CUBE.apply_translation(CUBE_OFFSET)
FILES = {"meshes/ring.stl": RING.export(file_type="stl"), "meshes/cube.msh": _msh(CUBE)}

# Geoms in groups 0–3 count in MuJoCo's inertia (inertiagrouprange 0 3); the visual sphere of
# "arm" is in group 4: neither it nor the check (collision geoms first) counts it.
MJCF = """<mujoco model="shapes">
  <compiler angle="radian" meshdir="meshes" inertiagrouprange="0 3" {inertia}/>
  <asset>
    <mesh name="ring" file="ring.stl" scale="1.5 1 2" inertia="exact"/>
    <mesh name="cube" file="cube.msh" inertia="exact"/>
  </asset>
  <worldbody>
    <body name="arm" pos="0 0 0.5">
      <joint name="j_arm" type="hinge" axis="0 0 1"/>
      {arm_inertial}
      <geom type="box" size="0.1 0.05 0.02" pos="0.02 0.01 0" quat="0.9 0.1 0.3 0.2"/>
      <geom type="capsule" fromto="0 0 0 0.3 0.05 0.02" size="0.02"/>
      <geom type="sphere" size="0.2" contype="0" conaffinity="0" group="4"/>
      <body name="wrist" pos="0.3 0 0">
        <joint name="j_wrist" type="hinge" axis="0 1 0"/>
        {wrist_inertial}
        <geom type="ellipsoid" size="0.03 0.05 0.02" pos="0 0.02 0" euler="0.3 0.2 0.1"/>
        <geom type="cylinder" size="0.02 0.04" pos="0.05 0 0" density="3000"/>
        <body name="ring_link" pos="0.1 0 0">
          <joint name="j_ring" type="hinge" axis="1 0 0"/>
          {ring_inertial}
          <geom type="mesh" mesh="ring" pos="0.01 0 0.02" euler="0.5 0 0.4"/>
          <body name="cube_link" pos="0.1 0 0">
            <joint name="j_cube" type="slide" axis="1 0 0"/>
            <geom type="mesh" mesh="cube" pos="0 0.02 0" euler="0 0.3 0"/>
          </body>
        </body>
        <body name="cover" pos="0 0 0.1" quat="0.8 0 0.6 0">
          <joint name="j_cover" type="hinge" axis="0 0 1"/>
          <geom type="box" size="0.04 0.03 0.01" pos="0.01 0 0" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""
PRIMITIVE_BODIES = ("arm", "wrist", "cover")
MESH_BODIES = ("ring_link", "cube_link")


def mjcf(inertia: str = 'inertiafromgeom="true"', **inertials: str) -> str:
    parts = {f"{b}_inertial": inertials.get(b, "") for b in ("arm", "wrist", "ring")}
    return MJCF.format(inertia=inertia, **parts)


def _reference(text: str) -> dict[str, tuple[float, np.ndarray, np.ndarray]]:
    """MuJoCo's mass, centre of mass and inertia (about it, body axes) of each body."""
    mj = mujoco.MjModel.from_xml_string(text, FILES)
    out = {}
    for b in range(1, mj.nbody):
        rotation = np.empty(9)
        mujoco.mju_quat2Mat(rotation, mj.body_iquat[b])
        R = rotation.reshape(3, 3)
        out[mj.body(b).name] = (
            float(mj.body_mass[b]),
            np.array(mj.body_ipos[b]),
            R @ np.diag(mj.body_inertia[b]) @ R.T,
        )
    return out


def _encoded(files: dict[str, bytes]) -> dict[str, str]:
    return {key: base64.b64encode(data).decode() for key, data in files.items()}


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[TestClient, Registry]]:
    data = tmp_path_factory.mktemp("model-check-sources")
    settings = Settings(data_dir=data, catalog="ur5")
    registry = Registry(Path(data), settings.catalog_names(), settings.build_timeout_s)
    registry.load()
    with TestClient(create_app(settings, registry=registry), raise_server_exceptions=False) as c:
        yield c, registry


def _post(client: TestClient, path: str, body: dict) -> dict:
    answer = client.post(path, json=body)
    assert answer.status_code in (200, 201), answer.text
    return answer.json()


def _check(client: TestClient, robot_id: str) -> dict:
    answer = client.get(f"/v1/robots/{robot_id}/model-check")
    assert answer.status_code == 200, answer.text
    return answer.json()


def _geometry_mass_properties(link: dict) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass at DENSITY, centre, inertia at DENSITY) of a check's link geometry."""
    shape = link["geometry"]
    scale = DENSITY / shape["density"]  # the inertia given is the declared mass's
    return (
        shape["volume"] * DENSITY,
        np.array(shape["center_of_mass"]),
        np.array(shape["inertia"]) * scale,
    )


def test_an_mjcf_uploads_geoms_have_mujocos_mass_properties(served):
    client, _ = served
    text = mjcf()
    robot = _post(client, "/v1/robots", {"mjcf": text, "assets": _encoded(FILES)})
    check = _check(client, robot["id"])
    links = {link["name"]: link for link in check["links"]}
    reference = _reference(text)
    assert set(links) == set(reference)
    sources = {name: links[name]["geometry"]["source"] for name in links}
    assert sources == {**dict.fromkeys(reference, "collision"), "cover": "visual"}
    for name, (mass, center, inertia) in reference.items():
        tolerance = 1e-9 if name in PRIMITIVE_BODIES else 1e-6
        if name == "wrist":  # two densities: the check spreads its mass uniformly
            continue
        got_mass, got_center, got_inertia = _geometry_mass_properties(links[name])
        np.testing.assert_allclose(got_mass, mass, rtol=tolerance, err_msg=name)
        np.testing.assert_allclose(got_center, center, rtol=0, atol=tolerance * 0.1, err_msg=name)
        np.testing.assert_allclose(
            got_inertia, inertia, rtol=0, atol=tolerance * np.abs(inertia).max(), err_msg=name
        )
    # the wrist's geoms at one density, MuJoCo's again
    uniform = _reference(text.replace(' density="3000"', ""))["wrist"]
    got = _geometry_mass_properties(links["wrist"])
    np.testing.assert_allclose(got[0], uniform[0], rtol=1e-9)
    np.testing.assert_allclose(got[1], uniform[1], rtol=0, atol=1e-10)
    np.testing.assert_allclose(got[2], uniform[2], rtol=0, atol=1e-9 * np.abs(uniform[2]).max())
    # MuJoCo's own inertias from the same geoms: nothing to report
    assert check["findings"] == []


def test_an_mjcfs_wrong_inertials_are_found_and_repaired_from_its_geoms(served):
    client, _ = served
    reference = _reference(mjcf())
    arm_mass, _, arm_inertia = reference["arm"]
    moments = np.linalg.eigvalsh(arm_inertia) * 30  # a unit slipped: 30 × its shape's
    ring_mass, ring_center, ring_inertia = reference["ring_link"]
    light = ring_inertia * 1e-3  # the ring's shape, a thousandth of its mass: 1 kg/m³
    full = [light[0, 0], light[1, 1], light[2, 2], light[0, 1], light[0, 2], light[1, 2]]
    text = mjcf(
        'inertiafromgeom="auto"',
        arm=f'<inertial pos="0 0 0" mass="{arm_mass!r}" '
        f'diaginertia="{" ".join(repr(float(m)) for m in moments)}"/>',
        wrist='<inertial pos="0.9 0 0" mass="0.5" diaginertia="1e-4 1e-4 1e-4"/>',
        ring=f'<inertial pos="{" ".join(repr(float(x)) for x in ring_center)}" '
        f'mass="{ring_mass * 1e-3!r}" fullinertia="{" ".join(repr(float(x)) for x in full)}"/>',
    )
    robot = _post(client, "/v1/robots", {"mjcf": text, "assets": _encoded(FILES)})
    found = {(f["link"], f["code"]) for f in _check(client, robot["id"])["findings"]}
    assert found == {
        ("arm", "inertia_geometry_mismatch"),
        ("wrist", "center_of_mass_outside_geometry"),
        ("ring_link", "implausible_density"),
    }
    variant = _post(
        client,
        f"/v1/robots/{robot['id']}/variants",
        {"inertias": {"links": ["arm", "wrist"], "from": "geometry"}},
    )
    repaired = {link["name"]: link for link in _check(client, variant["id"])["links"]}
    # MuJoCo's inertia from geometry, scaled to the declared mass (the wrist at one density)
    for name, mass, source in (("arm", arm_mass, mjcf()), ("wrist", 0.5, mjcf())):
        if name == "wrist":
            source = source.replace(' density="3000"', "")
        ref_mass, ref_center, ref_inertia = _reference(source)[name]
        np.testing.assert_allclose(repaired[name]["center_of_mass"], ref_center, atol=1e-10)
        np.testing.assert_allclose(
            np.array(repaired[name]["inertia"]),
            ref_inertia * mass / ref_mass,
            rtol=0,
            atol=1e-9 * np.abs(ref_inertia).max() * mass / ref_mass,
        )


def _box_urdf(mesh: str) -> str:
    return (
        '<robot name="msh"><link name="base"/>'
        '<link name="block"><inertial><mass value="1.0"/>'
        '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>'
        f'<collision><geometry><mesh filename="{mesh}" scale="2 1 1"/></geometry></collision>'
        "</link>"
        '<joint name="j" type="revolute"><parent link="base"/><child link="block"/>'
        '<axis xyz="0 0 1"/><limit effort="1" velocity="1" lower="-1" upper="1"/></joint>'
        "</robot>"
    )


def test_a_urdfs_msh_mesh_is_read_through_mujoco(served):
    client, _ = served
    robot = _post(
        client,
        "/v1/robots",
        {
            "urdf": _box_urdf("meshes/cube.msh"),
            "assets": _encoded({"meshes/cube.msh": FILES["meshes/cube.msh"]}),
        },
    )
    block = next(x for x in _check(client, robot["id"])["links"] if x["name"] == "block")
    scale = np.array([2.0, 1.0, 1.0])
    a, b, c = CUBE_SIDES * scale
    volume = a * b * c
    assert block["geometry"]["source"] == "collision"
    np.testing.assert_allclose(block["geometry"]["volume"], volume, rtol=1e-6)
    np.testing.assert_allclose(block["geometry"]["center_of_mass"], CUBE_OFFSET * scale, atol=1e-8)
    box = 1.0 / 12 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])  # mass 1 kg
    np.testing.assert_allclose(block["geometry"]["inertia"], box, rtol=0, atol=1e-6 * box.max())


ARM = """<robot name="held">
  <link name="base"><collision><geometry><box size="0.2 0.2 0.1"/></geometry></collision></link>
  <link name="upper"><inertial><origin xyz="0.1 0 0"/><mass value="2.0"/>
    <inertia ixx="0.001" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0.1 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.03" length="0.2"/></geometry></collision></link>
  <link name="hand"><inertial><mass value="0.5"/>
    <inertia ixx="0.0001" iyy="0.0001" izz="0.0001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.04"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit effort="10" velocity="1" lower="-3" upper="3"/></joint>
  <joint name="wrist_fixed" type="fixed"><origin xyz="0.2 0 0.01" rpy="0.2 0 0.3"/>
    <parent link="upper"/><child link="hand"/></joint>
</robot>"""


def _combined(parts: list[tuple[float, np.ndarray, np.ndarray]]) -> tuple[float, np.ndarray]:
    """Volume and centre of volume of parts given as (volume, centre, _)."""
    volume = sum(p[0] for p in parts)
    return volume, sum(p[0] * p[1] for p in parts) / volume


def test_variants_keep_the_robots_geometry_and_repair_from_it(served):
    client, registry = served
    parent = _post(client, "/v1/robots", {"urdf": ARM})
    base = {link["name"]: link for link in _check(client, parent["id"])["links"]}
    # a payload variant: the description's links, their geometry unchanged
    held = _post(
        client,
        f"/v1/robots/{parent['id']}/variants",
        {"payloads": [{"frame": "hand", "mass": 1.0}]},
    )
    links = {link["name"]: link for link in _check(client, held["id"])["links"]}
    for name in ("upper", "hand"):
        assert links[name]["geometry"] == base[name]["geometry"]
    repaired = _post(
        client,
        f"/v1/robots/{held['id']}/variants",
        {"inertias": {"links": ["upper"], "from": "geometry"}},
    )
    upper = next(x for x in _check(client, repaired["id"])["links"] if x["name"] == "upper")
    # a cylinder r = 0.03, l = 0.2 along x about its centre, 2 kg
    r, length = 0.03, 0.2
    side = 2.0 * (3 * r * r + length * length) / 12
    np.testing.assert_allclose(upper["center_of_mass"], [0.1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(upper["inertia"], np.diag([r * r, side, side]), atol=1e-15)
    # an identified variant: one body per joint, the geometry of every link it carries
    model = registry.get(parent["id"]).model
    fitted = Fitted(tuple(float(x) for x in inertial_parameters(model) * 1.2), ())
    identified, _ = registry.variant(parent["id"], fitted=fitted)
    check = _check(client, identified.id)
    body = next(x for x in check["links"] if x["name"] == "upper")
    cylinder = np.pi * r * r * length
    sphere = 4 / 3 * np.pi * 0.04**3
    hand_center = np.array([0.2, 0, 0.01])  # the sphere's centre in the upper link's frame
    volume, center = _combined(
        [(cylinder, np.array([0.1, 0, 0]), None), (sphere, hand_center, None)]
    )
    np.testing.assert_allclose(body["geometry"]["volume"], volume, rtol=1e-12)
    np.testing.assert_allclose(body["geometry"]["center_of_mass"], center, atol=1e-15)
    np.testing.assert_allclose(body["mass"], 2.5 * 1.2, rtol=1e-12)
    fixed = _post(
        client,
        f"/v1/robots/{identified.id}/variants",
        {"inertias": {"links": ["upper"], "from": "geometry"}},
    )
    after = next(x for x in _check(client, fixed["id"])["links"] if x["name"] == "upper")
    np.testing.assert_allclose(after["center_of_mass"], center, atol=1e-12)
    np.testing.assert_allclose(after["inertia"], body["geometry"]["inertia"], atol=1e-12)


def test_a_catalog_robots_payload_variant_keeps_its_mesh_geometry(served):
    client, _ = served
    base = {link["name"]: link for link in _check(client, "ur5")["links"]}
    held = _post(client, "/v1/robots/ur5/variants", {"payloads": [{"frame": "tool0", "mass": 2.0}]})
    links = {link["name"]: link for link in _check(client, held["id"])["links"]}
    assert links["forearm_link"]["geometry"] is not None
    for name, link in base.items():
        assert links[name]["geometry"] == link["geometry"], name
    _post(
        client,
        f"/v1/robots/{held['id']}/variants",
        {"inertias": {"links": ["forearm_link"], "from": "geometry"}},
    )
