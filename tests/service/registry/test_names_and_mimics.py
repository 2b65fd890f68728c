"""Inputs that are refused at upload: names longer than the cap
(ROBODYN_MAX_NAME_LENGTH, default 256 characters) in URDF and MJCF, and broken mimic graphs (a
joint mimicking itself, a fixed joint, or a cycle), each a 422 `invalid_model` naming the
element."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.registry.urdf_check import Limits
from service.settings import Settings
from tests.service.registry.mjcf_models import PLANAR_ARM_MJCF

INERTIAL = (
    '<inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" '
    'izz="0.1"/></inertial>'
)


def link(name: str) -> str:
    return f'<link name="{name}">{INERTIAL}</link>'


def joint(
    name: str, parent: str, child: str, kind: str = "revolute", mimic: str | None = None
) -> str:
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
    mimic_el = f'<mimic joint="{mimic}" multiplier="1" offset="0"/>' if mimic else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
        f'<child link="{child}"/><axis xyz="0 0 1"/>{limit}{mimic_el}</joint>'
    )


def urdf(*parts: str, robot: str = "r") -> str:
    return f'<robot name="{robot}"><link name="base"/>{"".join(parts)}</robot>'


def chain(
    names: list[str],
    kinds: dict[str, str] | None = None,
    mimics: dict[str, str] | None = None,
    robot: str = "r",
) -> str:
    parts, parent = [], "base"
    for i, name in enumerate(names):
        child = f"l{i}"
        parts += [
            link(child),
            joint(
                name, parent, child, (kinds or {}).get(name, "revolute"), (mimics or {}).get(name)
            ),
        ]
        parent = child
    return urdf(*parts, robot=robot)


@pytest.fixture(scope="module")
def registry(tmp_path_factory):
    reg = Registry(tmp_path_factory.mktemp("names"), ["planar_arm"])
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry):
    app = create_app(Settings(data_dir=registry.store.dir.parent), registry=registry)
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


def _refused(client, body, *needles):
    r = client.post("/v1/robots", json=body)
    assert r.status_code == 422, r.text
    problem = r.json()
    assert problem["code"] == "invalid_model"
    for needle in needles:
        assert needle in problem["detail"], problem["detail"]
    assert len(r.content) < 2000  # the name is never echoed in full
    return problem


@pytest.mark.parametrize("where", ["robot", "link", "joint"])
@pytest.mark.parametrize("length", [257, 1 << 20])
def test_a_name_over_the_cap_is_refused_naming_the_element(client, where, length):
    long = "n" * length
    body = {
        "robot": chain(["j"], robot=long),
        "link": urdf(f'<link name="{long}">{INERTIAL}</link>', joint("j", "base", long)),
        "joint": chain([long]),
    }[where]
    _refused(
        client, {"urdf": body}, f"<{where}> name", f"{length} characters", "ROBODYN_MAX_NAME_LENGTH"
    )


def test_a_name_at_the_cap_is_accepted_and_served(client):
    name = "j" * 256
    r = client.post("/v1/robots", json={"urdf": chain([name], robot="r" * 256)})
    assert r.status_code == 201, r.text
    assert r.json()["joints"][0]["name"] == name
    assert (
        client.post(
            f"/v1/robots/{r.json()['id']}/jacobian", json={"q": [0.1], "frame": name}
        ).status_code
        == 200
    )


def test_mjcf_names_over_the_cap_are_refused(client):
    long = "b" * 300
    for old, new in [
        ('model="planar_arm"', f'model="{long}"'),
        ('<body name="link1"', f'<body name="{long}"'),
    ]:
        assert old in PLANAR_ARM_MJCF
        _refused(client, {"mjcf": PLANAR_ARM_MJCF.replace(old, new)}, "300 characters")


def test_the_cap_is_a_setting(tmp_path):
    settings = Settings(data_dir=tmp_path, max_name_length=100)
    reg = Registry(tmp_path, ["planar_arm"], limits=Limits(**settings.model_limits()))
    reg.load()
    with TestClient(create_app(settings, registry=reg), raise_server_exceptions=False) as c:
        assert c.post("/v1/robots", json={"urdf": chain(["j" * 100])}).status_code == 201
        _refused(c, {"urdf": chain(["j" * 101])}, "101 characters")
    with pytest.raises(ValueError):  # requests name frames and joints in at most 256
        Settings(max_name_length=257)


@pytest.mark.parametrize(
    ("names", "kinds", "mimics", "needles"),
    [
        (["a"], {}, {"a": "a"}, ["joint 'a'", "mimics itself"]),
        (["a", "b"], {"a": "fixed"}, {"b": "a"}, ["joint 'b'", "'a'", "fixed"]),
        (["a", "b"], {}, {"a": "b", "b": "a"}, ["cycle", "'a'", "'b'"]),
        (
            ["a", "b", "c", "d"],
            {},
            {"a": "b", "b": "c", "c": "d", "d": "b"},
            ["cycle", "'b' → 'c' → 'd' → 'b'"],
        ),
    ],
)
def test_broken_mimic_graphs_are_refused_naming_the_joint(client, names, kinds, mimics, needles):
    _refused(client, {"urdf": chain(names, kinds, mimics)}, *needles)


def test_a_mimic_chain_without_a_cycle_is_accepted(client):
    r = client.post("/v1/robots", json={"urdf": chain(["a", "b", "c"], {}, {"b": "a", "c": "b"})})
    assert r.status_code == 201, r.text
