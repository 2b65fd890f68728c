"""MJCF uploads: the same dynamics as the equivalent URDF over HTTP, MuJoCo's conventions read
right (degrees, w-first quaternions, Euler sequences, geom inertias, free joints, keyframes), and
hostile MJCF refused with a 422 naming the element while the server keeps serving."""

from __future__ import annotations

import re

import numpy as np
import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.registry.mjcf_check import XML_DEPTH_MARGIN
from service.registry.urdf_check import Limits
from service.settings import Settings
from tests.helpers import planar_arm_closed_form, random_state
from tests.service.mjcf_models import (
    FLOATING_URDF,
    MULTI_JOINT_MJCF,
    PLANAR_ARM_MJCF,
    TWINS,
    floating_mjcf,
)

LEAK = re.compile(r"Traceback|\.hxx|\.hpp|\.cpp|\.py\b|/usr/|/work/|/tmp/|site-packages|File \"")
TOL = 1e-9


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    reg = Registry(tmp_path_factory.mktemp("mjcf"), ["ur5", "planar_arm"])
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry: Registry) -> TestClient:
    app = create_app(Settings(data_dir=registry.store.dir.parent), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def _upload(client: TestClient, **body) -> dict:
    r = client.post("/v1/robots", json=body)
    assert r.status_code in (200, 201), r.text
    return r.json()


def _dynamics(client: TestClient, robot_id: str, q, v, a) -> dict[str, np.ndarray]:
    q, v, a = (np.asarray(x).tolist() for x in (q, v, a))
    out = {}
    for quantity, body in (("mass-matrix", {"q": q}), ("gravity", {"q": q}),
                           ("coriolis", {"q": q, "v": v}),
                           ("inverse-dynamics", {"q": q, "v": v, "a": a})):
        r = client.post(f"/v1/robots/{robot_id}/{quantity}", json=body)
        assert r.status_code == 200, r.text
        out.update({k: np.array(val) for k, val in r.json().items()})
    return out


@pytest.mark.parametrize("name", sorted(TWINS))
def test_mjcf_gives_the_dynamics_of_its_urdf_twin(client: TestClient, registry: Registry,
                                                   name: str) -> None:
    mjcf, urdf, root_joint = TWINS[name]
    from_mjcf = _upload(client, mjcf=mjcf, root_joint="fixed" if name == "floating"
                        else root_joint)
    from_urdf = _upload(client, urdf=urdf, root_joint=root_joint)
    assert from_mjcf["id"] != from_urdf["id"]
    assert from_mjcf["root_joint"] == from_urdf["root_joint"] == root_joint
    assert (from_mjcf["nq"], from_mjcf["nv"]) == (from_urdf["nq"], from_urdf["nv"])
    assert from_mjcf["total_mass"] == pytest.approx(from_urdf["total_mass"], rel=1e-12)
    model = registry.get(from_urdf["id"]).model
    rng = np.random.default_rng(7)
    states = [random_state(model, rng) for _ in range(6)]
    q, v, a = (np.array([s[i] for s in states]) for i in range(3))
    got, expected = (_dynamics(client, info["id"], q, v, a) for info in (from_mjcf, from_urdf))
    assert set(got) == {"mass_matrix", "gravity", "coriolis_matrix", "coriolis_forces", "tau"}
    for key in got:
        np.testing.assert_allclose(got[key], expected[key], rtol=TOL, atol=TOL, err_msg=key)


def test_planar_arm_mjcf_has_the_closed_form_dynamics(client: TestClient) -> None:
    info = _upload(client, mjcf=PLANAR_ARM_MJCF)
    assert [j["name"] for j in info["joints"]] == ["shoulder", "elbow"]
    assert "tip" in {f["name"] for f in info["frames"]}
    q, v = np.array([0.4, -1.1]), np.array([0.7, -0.3])
    M, C, g = planar_arm_closed_form(1.0, 0.7, 2.0, 1.5, q, v)
    got = _dynamics(client, info["id"], q, v, np.zeros(2))
    np.testing.assert_allclose(got["mass_matrix"], M, atol=1e-12)
    np.testing.assert_allclose(got["coriolis_matrix"], C, atol=1e-12)
    np.testing.assert_allclose(got["gravity"], g, atol=1e-12)


def test_limits_are_read_in_degrees_and_metres(client: TestClient) -> None:
    mjcf, urdf, _ = TWINS["spatial_arm"]
    joints = [_upload(client, **{kind: text})["joints"] for kind, text in
              (("mjcf", mjcf), ("urdf", urdf))]
    for mine, theirs in zip(*joints, strict=True):
        assert mine["name"] == theirs["name"]
        np.testing.assert_allclose(mine["lower"], theirs["lower"], rtol=1e-12)
        np.testing.assert_allclose(mine["upper"], theirs["upper"], rtol=1e-12)
    assert joints[0][2]["type"] == "prismatic" and joints[0][2]["lower"] == [-0.1]


def test_a_free_joint_is_its_own_root(client: TestClient) -> None:
    text = floating_mjcf(free_joint=True, torso_pos="1 2 3")
    default = _upload(client, mjcf=text)
    explicit = _upload(client, mjcf=text, root_joint="free-flyer")
    assert default["id"] == explicit["id"] and default["root_joint"] == "free-flyer"
    assert default["joints"][0] == {**default["joints"][0], "name": "root",
                                    "type": "free_flyer", "nq": 7, "nv": 6}
    # keyframes: MuJoCo's w-first quaternion becomes Pinocchio's w-last one
    refs = default["reference_configurations"]
    np.testing.assert_allclose(refs["home"], [0.1, 0.2, 0.9, 0, 0, 0, 1, 0.5])
    np.testing.assert_allclose(refs["qpos0"], [1, 2, 3, 0, 0, 0, 1, 0])  # the body's pose
    r = client.post("/v1/robots", json={"mjcf": text, "root_joint": "planar"})
    assert r.status_code == 422 and "free joint" in r.json()["detail"]


def test_root_joint_is_added_above_a_jointless_top_body(client: TestClient,
                                                        registry: Registry) -> None:
    text = floating_mjcf(free_joint=False).replace(
        '<keyframe><key name="home" qpos="0.1 0.2 0.9 1 0 0 0 0.5"/></keyframe>', "")
    info = _upload(client, mjcf=text, root_joint="free-flyer")
    twin = _upload(client, urdf=FLOATING_URDF, root_joint="free-flyer")
    assert info["joints"][0]["name"] == "root_joint" and info["nq"] == 8
    model = registry.get(twin["id"]).model
    q, v, a = random_state(model, np.random.default_rng(3))
    got, expected = (_dynamics(client, i["id"], q, v, a) for i in (info, twin))
    for key in got:
        np.testing.assert_allclose(got[key], expected[key], rtol=TOL, atol=TOL)
    fixed = _upload(client, mjcf=text)
    assert fixed["root_joint"] == "fixed" and fixed["nq"] == 1
    warned = _upload(client, mjcf=text.replace('name="torso" pos="0 0 0"',
                                               'name="torso" pos="0 0 0.5"'))
    assert [w["code"] for w in warned["warnings"]] == ["ignored_root_placement"]




def _composite_reference(text: str, tmp_path) -> object:
    """Pinocchio's own composite-joint model of `text` (its M, g and RNEA are right)."""
    import pinocchio as pin

    path = tmp_path / "multi.xml"
    path.write_text(text)
    return pin.buildModelFromMJCF(str(path))


def test_multi_joint_body_is_a_chain_with_the_same_dynamics(client: TestClient,
                                                           registry: Registry,
                                                           tmp_path) -> None:
    import pinocchio as pin

    info = _upload(client, mjcf=MULTI_JOINT_MJCF)
    assert [(j["name"], j["type"]) for j in info["joints"]] == [
        ("hip_x", "revolute"), ("torsoJoint_1", "prismatic"), ("hip_ball", "spherical"),
        ("knee", "revolute")]
    assert [j["armature"] for j in info["joints"]] == [[0.02], [0.02], [0.02] * 3, [0.02]]
    np.testing.assert_allclose(info["joints"][0]["upper"], [np.pi / 3])
    assert info["joints"][1]["upper"] == [0.1]
    frames = {f["name"]: f["parent_joint"] for f in info["frames"]}
    assert frames["torso#1"] == "hip_x" and frames["torso#2"] == "torsoJoint_1"
    assert frames["torso"] == frames["grip"] == "hip_ball"
    np.testing.assert_allclose(info["reference_configurations"]["bent"],
                               [0.1, 0.05, 0, 0.3826834, 0, 0.9238795, -0.5], atol=1e-7)
    reference = _composite_reference(MULTI_JOINT_MJCF, tmp_path)
    assert reference.joints[1].shortname() == "JointModelComposite"
    served = registry.get(info["id"]).model
    assert (served.nq, served.nv) == (reference.nq, reference.nv) == (7, 6)
    rng = np.random.default_rng(5)
    for _ in range(4):
        q, v, a = random_state(served, rng)
        got = _dynamics(client, info["id"], q, v, a)
        data = reference.createData()
        M = pin.crba(reference, data, q)
        np.testing.assert_allclose(got["mass_matrix"], np.triu(M) + np.triu(M, 1).T, atol=TOL)
        np.testing.assert_allclose(got["gravity"], pin.computeGeneralizedGravity(
            reference, data, q), atol=TOL)
        np.testing.assert_allclose(got["tau"], pin.rnea(reference, data, q, v, a), atol=TOL)
        # the Coriolis matrix of the chain is right: Ṁ = C + Cᵀ (central differences)
        eps = 1e-6
        M_dot = (_dynamics(client, info["id"], pin.integrate(served, q, eps * v), v, a)[
            "mass_matrix"] - _dynamics(client, info["id"], pin.integrate(served, q, -eps * v),
                                       v, a)["mass_matrix"]) / (2 * eps)
        C = got["coriolis_matrix"]
        np.testing.assert_allclose(M_dot, C + C.T, atol=1e-6)


def test_asset_files_are_never_read(client: TestClient, tmp_path) -> None:
    missing = tmp_path / "does-not-exist"
    text = PLANAR_ARM_MJCF.replace("<worldbody>", f"""<asset>
      <mesh name="shell" file="{missing}/shell.stl"/><texture name="t" file="{missing}/t.png"/>
      <material name="paint" texture="t"/></asset><worldbody>""").replace(
        '<site name="tip"', '<geom type="mesh" mesh="shell" material="paint"/><site name="tip"')
    info = _upload(client, mjcf=text)  # the mesh and texture files do not exist
    assert info["total_mass"] == pytest.approx(3.5)  # the <inertial>s, not the mesh


def test_equality_constraints_are_noted(client: TestClient) -> None:
    text = PLANAR_ARM_MJCF.replace(
        "</worldbody>", "</worldbody><equality><connect body1='link2' anchor='0 0 0'/></equality>")
    noted = _upload(client, mjcf=text)  # inertia_check "reject": notes never reject
    assert [w["code"] for w in noted["warnings"]] == ["ignored_equality"]


def test_inertia_findings_reject_or_warn(client: TestClient) -> None:
    text = PLANAR_ARM_MJCF.replace('mass="1.5" diaginertia="0 0 0"',
                                   'mass="1.5" diaginertia="0.1 0.1 0.5"')
    r = client.post("/v1/robots", json={"mjcf": text})
    assert r.status_code == 422 and r.json()["code"] == "invalid_model"
    assert "body 'link2'" in r.json()["detail"] and "triangle" in r.json()["detail"]
    warned = _upload(client, mjcf=text, inertia_check="warn")
    assert [(w["code"], w["element"], w["name"]) for w in warned["warnings"]] == [
        ("triangle_inequality", "body", "link2")]


def _body(inner: str, extra: str = "", compiler: str = "") -> str:
    return (f'<mujoco model="m">{compiler}<worldbody><body name="b"><joint name="j"/>'
            f'<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>{inner}</body>{extra}'
            "</worldbody></mujoco>")


def _nested(depth: int, tag: str = "body") -> str:
    if tag == "body":
        inner = "".join(f'<body name="b{i}"><joint/><geom size="0.1"/>' for i in range(depth))
        return f'<mujoco model="m"><worldbody>{inner}{"</body>" * depth}</worldbody></mujoco>'
    inner = "".join(f'<default class="c{i}">' for i in range(depth))
    return f'<mujoco model="m"><default>{inner}{"</default>" * depth}</default></mujoco>'


_DEPTH = Limits().max_depth
_XML_DEPTH = _DEPTH + XML_DEPTH_MARGIN

BILLION_LAUGHS = ('<?xml version="1.0"?><!DOCTYPE m [<!ENTITY a "aaaaaaaaaa">'
                  '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><mujoco model="&b;"/>')
EXTERNAL = ('<?xml version="1.0"?><!DOCTYPE m [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
            "<mujoco model='&x;'/>")

HOSTILE = {  # case → (MJCF text, a fragment the detail must contain)
    "unparsable number": (_body('<geom size="0.1" pos="0 0 1x"/>'), "pos is not a number"),
    "NaN": (_body("").replace('mass="1"', 'mass="nan"'), "mass must be finite"),
    "infinity": (_body('<geom size="inf"/>'), "size must be finite"),
    "overflow": (_body("").replace('diaginertia="1 1 1"', 'diaginertia="1 1 1e400"'),
                 "diaginertia must be finite"),
    "hex number": (_body('<site pos="0x1 0 0"/>'), "pos is not a number"),
    "non-ASCII digit": (_body('<site pos="0 0 \u0661"/>'), "pos is not a number"),
    "too few numbers": (_body("").replace('diaginertia="1 1 1"', 'diaginertia="1 1"'),
                        "diaginertia must have 3 numbers"),
    "box with one size": (_body('<geom type="box" size="0.1"/>'), "body 'b'"),
    # the caps follow `Limits`: a body tree deeper than max_depth still within the XML nesting
    # cap (max_depth + XML_DEPTH_MARGIN), and XML nested past that cap
    "deep body tree": (_nested(_DEPTH + 2), f"body 'b{_DEPTH}': the body tree is deeper than "
                       f"{_DEPTH}"),
    "deep XML nesting": (_nested(5000), f"<body> 'b{_XML_DEPTH - 2}' is nested deeper than "
                         f"{_XML_DEPTH} XML levels"),
    "deep default nesting": (_nested(_XML_DEPTH + 40, "default"),
                             f"<default> 'c{_XML_DEPTH - 2}' is nested deeper"),
    "include": ('<mujoco model="m"><include file="/etc/passwd"/></mujoco>', "<include>"),
    "DTD with entities": (BILLION_LAUGHS, "DTD"),
    "external entity": (EXTERNAL, "DTD"),
    "wrong root": ('<robot name="r"><link name="a"/></robot>', "<robot>"),
    "not XML": ("<mujoco model='m'><worldbody>", "not well-formed"),
    "huge element count": ("<mujoco model='m'>" + "<custom/>" * 200_001 + "</mujoco>",
                           "XML elements"),
    "two top bodies": (_body("", extra='<body name="c"><joint/><geom size="1"/></body>'),
                       "2 top-level bodies"),
    "colliding unnamed bodies": (_body('<body><joint/><geom size="1"/></body>' * 2),
                                 "body 'bBis'"),
    "unknown section": ('<mujoco model="m"><extension/></mujoco>', "<extension>"),
    "frame element": (_body('<frame pos="0 0 1"/>'), "<frame>"),
    "non-zero ref": (_body("").replace('<joint name="j"/>', '<joint name="j" ref="10"/>'),
                     "joint 'j': a non-zero ref"),
    "free joint below the top": (_body('<body name="c"><freejoint/><geom size="1"/></body>'),
                                 "body 'c': only the top body"),
    "free joint sharing a body": (_body("<freejoint/>"), "body 'b': a free joint"),
    "negative mass": (_body("").replace('mass="1"', 'mass="-1"'), "body 'b': mass"),
    "zero axis": (_body("").replace('<joint name="j"/>', '<joint name="j" axis="0 0 0"/>'),
                  "joint 'j': axis is zero"),
    "hfield geom": (_body('<geom type="hfield" size="1 1 1"/>'), "hfield"),
    "mesh inertia": (_body('<body name="c"><joint/><geom type="mesh" mesh="m"/></body>'),
                     "body 'c'"),
    "unknown class": (_body('<geom class="nope" size="1"/>'), "class 'nope'"),
    "fixed-axis Euler": (_body("", compiler='<compiler eulerseq="XYZ"/>'), "eulerseq"),
    "settotalmass": (_body("", compiler='<compiler settotalmass="5"/>'), "settotalmass"),
    "non-unit axisangle": (_body('<site axisangle="0 0 2 30"/>'), "axisangle"),
    "zero quaternion": (_body('<site quat="0 0 0 0"/>'), "quat is zero"),
    "inertial without inertia": (_body("").replace(' diaginertia="1 1 1"', ""),
                                 "diaginertia or fullinertia"),
    "unknown joint type": (_body("").replace('<joint name="j"/>', '<joint name="j" type="x"/>'),
                           "joint 'j': type"),
    "duplicate joint": (_body('<body name="c"><joint name="j"/><geom size="1"/></body>'),
                        "joint 'j'"),
    "no worldbody": ('<mujoco model="m"/>', "<worldbody>"),
    "keyframe length": (_body("", extra="").replace(
        "</mujoco>", '<keyframe><key name="k" qpos="1 2"/></keyframe></mujoco>'),
        "keyframe 'k'"),
    "massless moving body": (_body('<body name="c"><joint name="k"/></body>').replace(
        "<joint name=\"k\"/>", '<joint name="k"/><inertial pos="0 0 0" mass="0" '
        'diaginertia="0 0 0"/>'), "joint 'k' moves a subtree without mass"),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_mjcf_is_refused_by_name(client: TestClient, registry: Registry,
                                         case: str) -> None:
    text, fragment = HOSTILE[case]
    stored = set(registry.store.ids())
    r = client.post("/v1/robots", json={"mjcf": text})
    assert r.status_code == 422, (case, r.text)
    body = r.json()
    assert body["code"] == "invalid_model", body
    assert fragment in body["detail"], body["detail"]
    assert not LEAK.search(r.text) and len(r.text) < 2000, r.text
    assert set(registry.store.ids()) == stored
    # the server keeps serving
    assert client.get("/health/live").status_code == 200
    g = client.post("/v1/robots/ur5/gravity", json={"q": [0, -1, 1, 0, 0, 0]})
    assert g.status_code == 200


def test_root_joint_on_a_top_body_with_a_joint_is_refused(client: TestClient) -> None:
    r = client.post("/v1/robots", json={"mjcf": PLANAR_ARM_MJCF, "root_joint": "free-flyer"})
    assert r.status_code == 422 and "top body 'link1' has joint 'shoulder'" in r.json()["detail"]


def test_request_level_errors(client: TestClient) -> None:
    both = client.post("/v1/robots", json={"mjcf": PLANAR_ARM_MJCF, "urdf": "<robot/>"})
    neither = client.post("/v1/robots", json={"root_joint": "fixed"})
    for r in (both, neither):
        assert r.status_code == 422 and r.json()["code"] == "validation_error", r.text
    assert "exactly one" in both.json()["detail"]
    huge = client.post("/v1/robots", json={"mjcf": " " * (4 * 1024 * 1024 + 1)})
    assert huge.status_code == 413 and huge.json()["code"] == "payload_too_large", huge.text
    assert "ROBODYN_MAX_UPLOAD_BYTES" in huge.json()["detail"]


def test_mjcf_uploads_survive_a_restart(registry: Registry, client: TestClient) -> None:
    info = _upload(client, mjcf=floating_mjcf(free_joint=True), name="floater")
    restarted = Registry(registry.store.dir.parent, ["ur5"])
    restarted.load()
    again = restarted.get(info["id"]).info()
    assert again == info


def test_caps_follow_the_shared_limits_object() -> None:
    from types import SimpleNamespace

    from service.errors import InvalidModel
    from service.registry.mjcf_check import check_mjcf

    text = TWINS["spatial_arm"][0]  # 3 joints, 3 bodies, nv = 3
    assert check_mjcf(text).nq == 3
    caps = {"max_links": 1000, "max_depth": 128, "max_elements": 50_000, "max_name_length": 256}
    for extra, fragment in (({"max_nv": 2}, "more than 2 velocity coordinates"),
                            ({"max_moving_joints": 2}, "more than 2 joints"),
                            ({"max_links": 2}, "more than 2 bodies"),
                            ({"max_elements": 5}, "the limit is 5")):
        with pytest.raises(InvalidModel, match=fragment):
            check_mjcf(text, "fixed", SimpleNamespace(**{**caps, **extra}))
    # a free-flyer added above a joint-less top body counts its 6 velocity coordinates
    floating = floating_mjcf(free_joint=False).split("<keyframe>")[0] + "</mujoco>"
    with pytest.raises(InvalidModel, match="nv = 7"):
        check_mjcf(floating, "free-flyer", SimpleNamespace(**caps, max_nv=6))
