"""MJCF uploads read as MuJoCo compiles them: over HTTP, M(q) equals MuJoCo's `mj_fullM` and the
nonlinear effects equal its `qfrc_bias` (relative 1e-10) at random states, on small models for
each compiler option and default-class rule and on the URDF twins; hostile or invalid MJCF is a
422 carrying MuJoCo's own message (or robodyn's, naming the element) while the server keeps
serving. The unmodified models shipped in PyPI packages are in test_mjcf_published.py."""

from __future__ import annotations

import re

import mujoco
import numpy as np
import pytest
from fastapi.testclient import TestClient

from service.errors import InvalidModel
from service.main import create_app
from service.registry import Registry
from service.settings import Settings
from tests.helpers import planar_arm_closed_form, random_state, unless_starved
from tests.service.registry.mjcf_models import (
    FLOATING_URDF,
    MULTI_JOINT_MJCF,
    PLANAR_ARM_MJCF,
    TWINS,
    floating_mjcf,
)
from tests.service.registry.mjcf_reference import (
    cube_stl,
    encoded,
    pinocchio_q,
    random_states,
    relative_error,
)

LEAK = re.compile(r"Traceback|\.hxx|\.hpp|\.cpp|\.py\b|/usr/|/work/|/tmp/|site-packages|File \"")
TOL = 1e-9
EXACT = 1e-10
UPLOAD_LIMIT = 32 * 1024 * 1024


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    reg = Registry(tmp_path_factory.mktemp("mjcf"), ["ur5", "planar_arm"])
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry: Registry) -> TestClient:
    app = create_app(
        Settings(data_dir=registry.store.dir.parent, max_upload_bytes=UPLOAD_LIMIT),
        registry=registry,
    )
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def _upload(client: TestClient, **body) -> dict:
    r = unless_starved(lambda: client.post("/v1/robots", json=body))
    assert r.status_code in (200, 201), r.text
    return r.json()


def _dynamics(client: TestClient, robot_id: str, q, v, a) -> dict[str, np.ndarray]:
    q, v, a = (np.asarray(x).tolist() for x in (q, v, a))
    out = {}
    for quantity, body in (
        ("mass-matrix", {"q": q}),
        ("gravity", {"q": q}),
        ("coriolis", {"q": q, "v": v}),
        ("nonlinear-effects", {"q": q, "v": v}),
        ("inverse-dynamics", {"q": q, "v": v, "a": a}),
    ):
        r = client.post(f"/v1/robots/{robot_id}/{quantity}", json=body)
        assert r.status_code == 200, r.text
        out.update({k: np.array(val) for k, val in r.json().items()})
    return out


def assert_as_mujoco(
    client: TestClient,
    text: str,
    files: dict[str, bytes] | None = None,
    states: int = 4,
    seed: int = 0,
) -> dict:
    """Upload `text` with `files`; M and C v + g over HTTP equal MuJoCo's at random states."""
    files = files or {}
    info = _upload(client, mjcf=text, assets=encoded(files), inertia_check="warn")
    mj = mujoco.MjModel.from_xml_string(text, files)
    assert (info["nq"], info["nv"]) == (mj.nq, mj.nv)
    for qpos, qvel, M, bias in random_states(mj, np.random.default_rng(seed), states):
        q = qpos.tolist()  # q is MuJoCo's qpos
        got_M = client.post(f"/v1/robots/{info['id']}/mass-matrix", json={"q": q})
        got_h = client.post(
            f"/v1/robots/{info['id']}/nonlinear-effects", json={"q": q, "v": qvel.tolist()}
        )
        assert got_M.status_code == got_h.status_code == 200, (got_M.text, got_h.text)
        assert relative_error(np.array(got_M.json()["mass_matrix"]), M) < EXACT
        assert relative_error(np.array(got_h.json()["nonlinear_effects"]), bias) < EXACT
    return info


def _one_hinge(
    joint: str = "", default: str = "", body: str = "", geoms: str = "", compiler: str = ""
) -> str:
    inertial = geoms or '<inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>'
    return (
        f'<mujoco model="m">{compiler}<default>{default}</default><worldbody>'
        f'<body name="b" {body}><joint name="j" axis="0 0 1" {joint}/>{inertial}</body>'
        "</worldbody></mujoco>"
    )


# Two rules where a naive reading of MJCF differs from MuJoCo's compiler: a joint position from
# a default class counts, and visual geoms weigh (they have mass and inertia).
def test_joint_position_from_a_default_class_counts(client: TestClient) -> None:
    on_joint = _upload(client, mjcf=_one_hinge(joint='pos="0.05 0.02 0"'))
    for text in (
        _one_hinge(default='<joint pos="0.05 0.02 0"/>'),
        _one_hinge(
            default='<default class="c"><joint pos="0.05 0.02 0"/></default>', body='childclass="c"'
        ),
        _one_hinge(
            default='<default class="c"><joint pos="0.05 0.02 0"/></default>', joint='class="c"'
        ),
    ):
        info = assert_as_mujoco(client, text)
        for got in (info, on_joint):
            M = client.post(f"/v1/robots/{got['id']}/mass-matrix", json={"q": [0.3]}).json()
            # 0.01 kg·m² + 1 kg · ((0.1 − 0.05)² + 0.02²) m², as MuJoCo computes it
            assert M["mass_matrix"] == [[pytest.approx(0.0129, rel=1e-12)]]


def test_visual_geoms_weigh_as_in_mujoco(client: TestClient) -> None:
    geoms = (
        '<geom type="box" size="0.05 0.05 0.05" pos="0.1 0 0" contype="0" '
        'conaffinity="0" group="1"/><geom type="sphere" size="0.03" pos="0.2 0 0"/>'
    )
    info = assert_as_mujoco(client, _one_hinge(geoms=geoms))
    M = client.post(f"/v1/robots/{info['id']}/mass-matrix", json={"q": [0.0]}).json()
    box = 1000 * 0.1**3  # kg: MuJoCo's default density 1000 kg/m³, visual or not
    ball = 1000 * 4 / 3 * np.pi * 0.03**3
    closed_form = (
        box * (0.1**2 + 0.1**2) / 12 + box * 0.1**2 + 2 / 5 * ball * 0.03**2 + ball * 0.2**2
    )
    assert M["mass_matrix"][0][0] == pytest.approx(closed_form, rel=1e-12)


COMPILER_CASES = {
    "inertiafromgeom true overrides <inertial>": _one_hinge(
        geoms='<inertial pos="0 0 0" mass="5" diaginertia="1 1 1"/><geom size="0.1 0.2" '
        'type="capsule" pos="0.1 0 0"/>',
        compiler='<compiler inertiafromgeom="true"/>',
    ),
    "angle radian": _one_hinge(
        joint='range="-1 1" ref="0.3"',
        body='euler="0.2 0.4 0.1"',
        compiler='<compiler angle="radian"/>',
    ),
    "angle degree (default)": _one_hinge(joint='range="-60 60" ref="20"', body='euler="10 20 30"'),
    "eulerseq fixed-axis XYZ": _one_hinge(
        body='euler="10 20 30"', compiler='<compiler eulerseq="XYZ"/>'
    ),
    "eulerseq zyx": _one_hinge(
        body='euler="10 20 30" pos="0.1 0.2 0.3"', compiler='<compiler eulerseq="zyx"/>'
    ),
    "settotalmass": _one_hinge(compiler='<compiler settotalmass="3"/>'),
    "slide with ref": _one_hinge(joint='type="slide" ref="0.2" range="-1 1"').replace(
        'axis="0 0 1"', 'axis="1 1 0"'
    ),
    "several joints, ball and armature in one body": MULTI_JOINT_MJCF,
    "free joint": floating_mjcf(free_joint=True, torso_pos="1 2 3"),
    "balanceinertia": _one_hinge(
        geoms='<inertial pos="0 0 0.1" mass="1" diaginertia="0.1 0.1 0.5"/>',
        compiler='<compiler balanceinertia="true"/>',
    ),
    "boundmass": _one_hinge(
        geoms='<inertial pos="0 0 0.1" mass="1e-9" diaginertia="1 1 1"/>',
        compiler='<compiler boundmass="0.5"/>',
    ),
}


@pytest.mark.parametrize("case", sorted(COMPILER_CASES))
def test_compiler_options_as_mujoco(client: TestClient, case: str) -> None:
    assert_as_mujoco(client, COMPILER_CASES[case])


def test_meshdir_and_includes_come_from_the_assets(client: TestClient) -> None:
    text = (
        '<mujoco model="meshy"><compiler meshdir="assets"/><include file="parts/arm.xml"/></mujoco>'
    )
    part = (
        b'<mujoco><asset><mesh name="cube" file="./cube.stl"/></asset><worldbody>'
        b'<body name="b"><joint axis="0 1 0"/><geom type="mesh" mesh="cube" density="900"/>'
        b"</body></worldbody></mujoco>"
    )
    files = {"assets/cube.stl": cube_stl(), "parts/arm.xml": part}
    info = assert_as_mujoco(client, text, files)
    # the mesh's volume (float32 vertices)
    assert info["total_mass"] == pytest.approx(900 * 0.1**3, rel=1e-6)
    again = _upload(client, mjcf=text, assets=encoded(files))
    assert again["id"] == info["id"]
    other = _upload(client, mjcf=text, assets=encoded({**files, "assets/cube.stl": cube_stl(0.06)}))
    assert other["id"] != info["id"]  # the assets are part of the id


@pytest.mark.parametrize("name", sorted(TWINS))
def test_mjcf_gives_the_dynamics_of_its_urdf_twin(
    client: TestClient, registry: Registry, name: str
) -> None:
    mjcf, urdf, root_joint = TWINS[name]
    from_mjcf = assert_as_mujoco(client, mjcf)
    from_urdf = _upload(client, urdf=urdf, root_joint=root_joint)
    assert (from_mjcf["nq"], from_mjcf["nv"]) == (from_urdf["nq"], from_urdf["nv"])
    assert from_mjcf["total_mass"] == pytest.approx(from_urdf["total_mass"], rel=1e-12)
    model = registry.get(from_urdf["id"]).model
    rng = np.random.default_rng(7)
    states = [random_state(model, rng) for _ in range(4)]
    q, v, a = (np.array([s[i] for s in states]) for i in range(3))
    got, expected = (_dynamics(client, info["id"], q, v, a) for info in (from_mjcf, from_urdf))
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
    joints = [
        _upload(client, **{kind: text})["joints"] for kind, text in (("mjcf", mjcf), ("urdf", urdf))
    ]
    for mine, theirs in zip(*joints, strict=True):
        assert mine["name"] == theirs["name"]
        np.testing.assert_allclose(mine["lower"], theirs["lower"], rtol=1e-12)
        np.testing.assert_allclose(mine["upper"], theirs["upper"], rtol=1e-12)
    assert joints[0][2]["type"] == "prismatic" and joints[0][2]["lower"] == [-0.1]


def test_a_free_joint_is_a_translation_and_a_rotation(client: TestClient) -> None:
    text = floating_mjcf(free_joint=True, torso_pos="1 2 3")
    default = _upload(client, mjcf=text)
    explicit = _upload(client, mjcf=text, root_joint="free-flyer")
    assert default["root_joint"] == explicit["root_joint"] == "free-flyer"
    assert [(j["name"], j["type"], j["nq"], j["nv"]) for j in default["joints"]] == [
        ("root", "translation", 3, 3),
        ("root_rotation", "spherical", 4, 3),
        ("shoulder", "revolute", 1, 1),
    ]
    assert default["joints"][0]["lower"] == [None] * 3  # unbounded
    assert default["joints"][1]["upper"] == [None] * 4
    # keyframes: MuJoCo's qpos as they are, quaternion w first
    refs = default["reference_configurations"]
    np.testing.assert_allclose(refs["home"], [0.1, 0.2, 0.9, 1, 0, 0, 0, 0.5])
    np.testing.assert_allclose(refs["qpos0"], [1, 2, 3, 1, 0, 0, 0, 0])  # the body's pose
    assert default["neutral_configuration"] == [0, 0, 0, 1, 0, 0, 0, 0]
    assert default["gravity"] == [0, 0, -9.81]  # MuJoCo's default <option gravity>
    r = client.post("/v1/robots", json={"mjcf": text, "root_joint": "planar"})
    assert r.status_code == 422 and "single top body without joints" in r.json()["detail"]


def test_gravity_is_the_models_own_unless_given(client: TestClient) -> None:
    text = _one_hinge(body='euler="90 0 0"').replace(
        "<default>", '<option gravity="0 -3 -1"/><default>'
    )
    assert _upload(client, mjcf=text)["gravity"] == [0, -3, -1]
    assert _upload(client, mjcf=text, gravity=[0, 0, -9.81])["gravity"] == [0, 0, -9.81]
    off = text.replace(
        '<option gravity="0 -3 -1"/>',
        '<option gravity="0 -3 -1"><flag gravity="disable"/></option>',
    )
    assert _upload(client, mjcf=off)["gravity"] == [0, 0, 0]
    assert_as_mujoco(client, off)


def test_root_joint_is_added_above_a_jointless_top_body(
    client: TestClient, registry: Registry
) -> None:
    text = floating_mjcf(free_joint=False).replace(
        '<keyframe><key name="home" qpos="0.1 0.2 0.9 1 0 0 0 0.5"/></keyframe>', ""
    )
    info = _upload(client, mjcf=text, root_joint="free-flyer")
    twin = _upload(client, urdf=FLOATING_URDF, root_joint="free-flyer")
    assert info["joints"][0]["name"] == "root_joint" and info["nq"] == 8
    model = registry.get(twin["id"]).model
    q, v, a = random_state(model, np.random.default_rng(3))
    got, expected = (_dynamics(client, i["id"], q, v, a) for i in (info, twin))
    for key in got:
        np.testing.assert_allclose(got[key], expected[key], rtol=TOL, atol=TOL)
    assert _upload(client, mjcf=text)["nq"] == 1
    r = client.post("/v1/robots", json={"mjcf": PLANAR_ARM_MJCF, "root_joint": "free-flyer"})
    assert r.status_code == 422 and "single top body without joints" in r.json()["detail"]


def test_multi_joint_body_is_a_chain(client: TestClient, registry: Registry) -> None:
    info = assert_as_mujoco(client, MULTI_JOINT_MJCF)
    assert [(j["name"], j["type"]) for j in info["joints"]] == [
        ("hip_x", "revolute"),
        ("torso_joint1", "prismatic"),
        ("hip_ball", "spherical"),
        ("knee", "revolute"),
    ]
    assert [j["armature"] for j in info["joints"]] == [[0.02], [0.02], [0.02] * 3, [0.02]]
    np.testing.assert_allclose(info["joints"][0]["upper"], [np.pi / 3])
    frames = {f["name"]: f["parent_joint"] for f in info["frames"] if f["type"] != "joint"}
    assert frames["torso"] == frames["grip"] == "hip_ball"
    np.testing.assert_allclose(
        info["reference_configurations"]["bent"],
        [0.1, 0.05, 0.9238795, 0, 0.3826834, 0, -0.5],
        atol=1e-7,
    )
    robot = registry.get(info["id"])  # its q is MuJoCo's qpos: Pinocchio's q → robot.api_q
    served = robot.model
    rng = np.random.default_rng(5)
    import pinocchio as pin

    q, v, a = random_state(served, rng)
    eps = 1e-6  # the Coriolis matrix of the chain is right: Ṁ = C + Cᵀ (central differences)
    M_dot = (
        _dynamics(client, info["id"], robot.api_q(pin.integrate(served, q, eps * v)), v, a)[
            "mass_matrix"
        ]
        - _dynamics(client, info["id"], robot.api_q(pin.integrate(served, q, -eps * v)), v, a)[
            "mass_matrix"
        ]
    ) / (2 * eps)
    C = _dynamics(client, info["id"], robot.api_q(q), v, a)["coriolis_matrix"]
    np.testing.assert_allclose(M_dot, C + C.T, atol=1e-6)


def test_equality_constraints_and_tendons_are_noted(client: TestClient) -> None:
    text = PLANAR_ARM_MJCF.replace(
        "</worldbody>",
        "</worldbody><equality><connect name='loop' body1='link2' "
        "anchor='0 0 0'/></equality><tendon><fixed name='t'><joint joint='shoulder' "
        "coef='1'/></fixed></tendon>",
    )
    noted = _upload(client, mjcf=text)  # inertia_check "reject": notes never reject
    assert [(w["code"], w["name"]) for w in noted["warnings"]] == [
        ("ignored_equality", "loop"),
        ("ignored_tendon", "t"),
    ]


def test_implausible_inertia_is_mujocos_error(client: TestClient) -> None:
    text = PLANAR_ARM_MJCF.replace(
        'mass="1.5" diaginertia="1e-14 1e-14 1e-14"', 'mass="1.5" diaginertia="0.1 0.1 0.5"'
    )
    for check in ("reject", "warn"):  # MuJoCo itself refuses it
        r = client.post("/v1/robots", json={"mjcf": text, "inertia_check": check})
        assert r.status_code == 422 and r.json()["code"] == "invalid_model"
        assert "A + B >= C" in r.json()["detail"] and "'link2'" in r.json()["detail"]


def _body(inner: str, extra: str = "", compiler: str = "") -> str:
    return (
        f'<mujoco model="m">{compiler}<worldbody><body name="b"><joint name="j"/>'
        f'<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>{inner}</body>{extra}'
        "</worldbody></mujoco>"
    )


def _nested(depth: int) -> str:
    inner = "".join(f'<body name="b{i}"><joint/><geom size="0.1"/>' for i in range(depth))
    return f'<mujoco model="m"><worldbody>{inner}{"</body>" * depth}</worldbody></mujoco>'


BILLION_LAUGHS = (
    '<?xml version="1.0"?><!DOCTYPE m [<!ENTITY a "aaaaaaaaaa">'
    '<!ENTITY b "&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><mujoco model="&b;"/>'
)
EXTERNAL = (
    '<?xml version="1.0"?><!DOCTYPE m [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
    "<mujoco model='&x;'/>"
)

HOSTILE = {  # case → (MJCF text, a fragment the detail must contain)
    "unparsable number": (
        _body('<geom size="0.1" pos="0 0 1x"/>'),
        "bad format in attribute 'pos'",
    ),
    "overflow": (
        _body("").replace('diaginertia="1 1 1"', 'diaginertia="1 1 1e400"'),
        "attribute 'diaginertia'",
    ),
    "too few numbers": (
        _body("").replace('diaginertia="1 1 1"', 'diaginertia="1 1"'),
        "'diaginertia' does not have enough data",
    ),
    "NaN mass": (_body("").replace('mass="1"', 'mass="nan"'), "'b'"),
    "too many velocity coordinates": (_nested(130), "the limit is 128"),
    "deep XML nesting": (_nested(5000), "nested deeper than"),
    "include of a system file": (
        '<mujoco model="m"><include file="/etc/passwd"/></mujoco>',
        "points outside the upload",
    ),
    "include climbing out": (
        '<mujoco model="m"><include file="../../etc/passwd"/></mujoco>',
        "points outside the upload",
    ),
    "absolute meshdir": ('<mujoco><compiler meshdir="/etc"/></mujoco>', "meshdir='/etc'"),
    "include not given": ('<mujoco model="m"><include file="a.xml"/></mujoco>', "a.xml"),
    "mesh not given": (
        _body('<geom type="mesh" mesh="m"/>', extra="").replace(
            "<worldbody>", '<asset><mesh name="m" file="m.stl"/></asset><worldbody>'
        ),
        "m.stl",
    ),
    "DTD with entities": (BILLION_LAUGHS, "DTD"),
    "external entity": (EXTERNAL, "DTD"),
    "wrong root": ('<robot name="r"><link name="a"/></robot>', "<robot>"),
    "not XML": ("<mujoco model='m'><worldbody>", "not well-formed"),
    "huge element count": (
        "<mujoco model='m'>" + "<custom/>" * 200_001 + "</mujoco>",
        "XML elements",
    ),
    "free joint below the top": (
        _body('<body name="c"><freejoint/><geom size="1"/></body>'),
        "free joint can only be used on top level",
    ),
    "zero axis": (
        _body("").replace('<joint name="j"/>', '<joint name="j" axis="0 0 0"/>'),
        "axis too small",
    ),
    "unknown class": (_body('<geom class="nope" size="1"/>'), "'nope'"),
    "unknown joint type": (
        _body("").replace('<joint name="j"/>', '<joint name="j" type="x"/>'),
        "invalid keyword: 'x'",
    ),
    "duplicate joint": (
        _body('<body name="c"><joint name="j"/><geom size="1"/></body>'),
        "repeated name 'j'",
    ),
    "nothing moves": ('<mujoco model="m"/>', "nothing can move"),
    "massless moving body": (_body('<body name="c"><joint name="k"/></body>'), "'c'"),
    # MuJoCo's compiler accepts `nan` anywhere (with a warning): refused naming the element
    "NaN gravity": (
        _body("", compiler='<option gravity="nan 0 0"/>'),
        "<option gravity> holds a non-finite number (nan 0 0)",
    ),
    "NaN keyframe": (
        _body("").replace(
            "</mujoco>", '<keyframe><key name="home" qpos="nan"/></keyframe></mujoco>'
        ),
        "<key name='home'> qpos holds a non-finite number",
    ),
    "NaN body position": (
        _body('<body name="c" pos="0 0 nan"><joint name="k"/><geom size="0.1"/></body>'),
        "<body name='c'> pos holds a non-finite number",
    ),
    # an allocation MuJoCo cannot make within the builder's memory (a 1.6 GB height field)
    "more memory than the builder has": (
        _body("").replace(
            "<worldbody>",
            '<asset><hfield name="h" nrow="20000" ncol="20000" size="1 1 1 1"/></asset><worldbody>',
        ),
        "MuJoCo could not build a model from this MJCF",
    ),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_mjcf_is_refused_by_name(client: TestClient, registry: Registry, case: str) -> None:
    text, fragment = HOSTILE[case]
    stored = set(registry.store.ids())
    r = unless_starved(lambda: client.post("/v1/robots", json={"mjcf": text}))
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


def test_request_level_errors(client: TestClient) -> None:
    both = client.post("/v1/robots", json={"mjcf": PLANAR_ARM_MJCF, "urdf": "<robot/>"})
    neither = client.post("/v1/robots", json={"root_joint": "fixed"})
    for r in (both, neither):
        assert r.status_code == 422 and r.json()["code"] == "validation_error", r.text
    assert "exactly one" in both.json()["detail"]
    huge = client.post("/v1/robots", json={"mjcf": " " * (UPLOAD_LIMIT + 1)})
    assert huge.status_code == 413 and huge.json()["code"] == "payload_too_large", huge.text
    assert "ROBODYN_MAX_UPLOAD_BYTES" in huge.json()["detail"]


def test_caps_follow_the_limits(tmp_path) -> None:
    from service.registry.urdf_check import Limits

    registry = Registry(tmp_path, ["ur5"], limits=Limits(max_links=3, max_nv=2))
    registry.load()
    for text, fragment in (
        (_nested(3), "nv = 3 velocity coordinates; the limit is 2"),
        (
            _nested(2)
            .replace("<joint/>", "", 1)
            .replace("</body></body>", '<body name="x"/><body name="y"/></body></body>'),
            "4 bodies; the limit is 3",
        ),
    ):
        with pytest.raises(InvalidModel, match=fragment):
            registry.upload(
                mjcf=text, root_joint="fixed", gravity=None, name=None, inertia_check="reject"
            )


def test_mjcf_uploads_survive_a_restart(registry: Registry, client: TestClient) -> None:
    text = (
        '<mujoco model="meshy"><compiler meshdir="assets"/><asset><mesh name="cube" '
        'file="cube.stl"/></asset><worldbody><body name="b"><freejoint name="f"/>'
        '<geom type="mesh" mesh="cube"/></body></worldbody></mujoco>'
    )
    info = _upload(
        client, mjcf=text, name="floater", assets=encoded({"assets/cube.stl": cube_stl()})
    )
    restarted = Registry(registry.store.dir.parent, ["ur5"])
    restarted.load()
    again = restarted.get(info["id"])
    assert again.info() == info
    assert again.asset_paths["assets/cube.stl"].read_bytes() == cube_stl()


def test_visuals_are_placed_where_mujoco_draws_them(client: TestClient, registry: Registry) -> None:
    import pinocchio as pin

    text = (
        '<mujoco model="drawn"><compiler meshdir="assets"/><asset><mesh name="cube" '
        'file="./cube.stl" scale="1 1 2"/><material name="red" rgba="1 0 0 1"/></asset>'
        '<worldbody><body name="b" pos="0 0 1"><joint axis="0 1 0"/><geom type="mesh" '
        'mesh="cube" pos="0 0 0.5" euler="0 0 90" material="red"/><body name="c" '
        'pos="0.3 0 0"><joint type="ball"/><geom name="box" type="box" size="0.1 0.2 0.3" '
        'pos="0.1 0 0"/><geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.05"/>'
        '<geom type="sphere" size="0.1" group="3"/></body></body></worldbody></mujoco>'
    )
    files = {"assets/cube.stl": cube_stl(), "assets/unused.stl": cube_stl(0.01)}
    info = _upload(client, mjcf=text, assets=encoded(files))
    assert [(w["code"], w["name"]) for w in info["warnings"]] == [
        ("unreferenced_asset", "assets/unused.stl")
    ]
    robot = registry.get(info["id"])
    visuals = robot.visuals
    assert [v["geometry"]["type"] for v in visuals] == ["mesh", "box", "capsule"]  # not group 3
    assert visuals[0]["geometry"] == {
        "type": "mesh",
        "asset": "assets/cube.stl",
        "scale": [1.0, 1.0, 2.0],
    }
    assert visuals[0]["color"] == [1.0, 0.0, 0.0, 1.0] and visuals[0]["frame"] == "b"
    np.testing.assert_allclose(visuals[0]["placement"]["translation"], [0, 0, 0.5], atol=1e-12)
    assert visuals[1]["geometry"] == {"type": "box", "size": [0.2, 0.4, 0.6]}
    assert visuals[2]["geometry"]["length"] == pytest.approx(0.2)
    assert set(robot.asset_paths) == {"assets/cube.stl"}  # only what the visuals name
    # world poses: Pinocchio's frame · placement (· the mesh's own offset) = MuJoCo's geom pose
    mj = mujoco.MjModel.from_xml_string(text, files)
    model, data, mjd = robot.model, robot.model.createData(), mujoco.MjData(mj)
    drawn = [g for g in range(mj.ngeom) if mj.geom_group[g] < 3]
    for qpos, _qvel, _M, _bias in random_states(mj, np.random.default_rng(2), 3):
        mjd.qpos[:] = qpos
        mujoco.mj_kinematics(mj, mjd)
        pin.framesForwardKinematics(model, data, pinocchio_q(mj, qpos))
        for visual, g in zip(visuals, drawn, strict=True):
            frame = data.oMf[model.getFrameId(visual["frame"], pin.BODY)]
            pose = frame * pin.SE3(
                np.array(visual["placement"]["rotation"]),
                np.array(visual["placement"]["translation"]),
            )
            if visual["geometry"]["type"] == "mesh":
                pose = pose * pin.SE3(pin.Quaternion(*mj.mesh_quat[0]).matrix(), mj.mesh_pos[0])
            np.testing.assert_allclose(pose.translation, mjd.geom_xpos[g], atol=1e-12)
            np.testing.assert_allclose(pose.rotation, mjd.geom_xmat[g].reshape(3, 3), atol=1e-12)
    restarted = Registry(registry.store.dir.parent, ["ur5"])
    restarted.load()
    assert restarted.get(info["id"]).visuals == visuals


def test_a_body_and_its_joint_may_share_a_name(client: TestClient) -> None:
    text = (
        '<mujoco model="same"><worldbody><body name="arm" pos="0 0 1"><joint name="arm" '
        'axis="0 1 0" pos="0 0 0.1"/><geom type="capsule" fromto="0 0 0 0.4 0 0" '
        'size="0.05"/></body></worldbody></mujoco>'
    )
    info = assert_as_mujoco(client, text)
    mj = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(mj)
    data.qpos[:] = [0.4]
    mujoco.mj_kinematics(mj, data)
    mujoco.mj_comPos(mj, data)
    jacp, jacr = np.zeros((3, 1)), np.zeros((3, 1))
    mujoco.mj_jacBody(mj, data, jacp, jacr, mj.body("arm").id)
    r = client.post(
        f"/v1/robots/{info['id']}/jacobian",
        json={"q": [0.4], "frame": "arm", "reference_frame": "world"},
    )
    assert r.status_code == 200, r.text  # the body's frame (not an ambiguity error)
    J = np.array(r.json()["jacobian"])
    np.testing.assert_allclose(J[3:], jacr, atol=1e-12)
    # MuJoCo's jacp is the velocity of the point at the body origin; Pinocchio's world-frame
    # linear rows are those of the point at the world origin: v_o = v_p − ω × p
    np.testing.assert_allclose(J[:3], jacp - np.cross(jacr.T, data.xpos[1]).T, atol=1e-12)
