"""xacro uploads: expanded by ROS's xacro in the builder process with nothing but the upload's
assets, so the xacro that ships in example-robot-data gives the catalog robot's dynamics, its
arguments and `$(find pkg)` work, and hostile xacro (system files, processes, escapes from
xacro's expression sandbox, recursion, memory and CPU bombs, unknown packages) is a 422 naming
what was refused while the server keeps serving."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from service.registry import Registry
from service.registry.catalog import erd_robots_dir
from tests.helpers import random_state, registry_client, unless_starved
from tests.service.registry.mjcf_reference import encoded

LEAK = re.compile(r"Traceback|\.py\b|/usr/|/work/|/tmp/|site-packages|File \"|robodyn-xacro")
HECTOR = erd_robots_dir() / "hector_description"
PREFIX = "example-robot-data/robots/hector_description/"


@pytest.fixture(scope="module")
def registry(tmp_path_factory: pytest.TempPathFactory) -> Registry:
    reg = Registry(
        tmp_path_factory.mktemp("xacro"),
        ["ur5", "hector"],
        build_limits={"cpu_s": 3, "memory_mb": 768},
    )
    reg.load()
    return reg


@pytest.fixture(scope="module")
def client(registry: Registry) -> Iterator[TestClient]:
    with registry_client(registry) as c:
        yield c


def _upload(client: TestClient, **body) -> dict:
    r = client.post("/v1/robots", json=body)
    assert r.status_code in (200, 201), r.text
    return r.json()


def _hector_assets(include_at: str) -> dict[str, bytes]:
    files = {
        PREFIX + str(p.relative_to(HECTOR)): p.read_bytes()
        for p in HECTOR.rglob("*")
        if p.is_file() and p.suffix in (".xacro", ".stl", ".dae")
    }
    files[PREFIX + include_at] = (HECTOR / "robots" / "quadrotor_base.urdf.xacro").read_bytes()
    return files


def test_the_shipped_xacro_gives_the_catalog_robot(client: TestClient, registry: Registry) -> None:
    text = (HECTOR / "robots" / "quadrotor_base.xacro").read_text()
    # as shipped, it includes urdf/quadrotor_base.urdf.xacro, which the package has under robots/
    r = client.post(
        "/v1/robots",
        json={
            "xacro": text,
            "root_joint": "free-flyer",
            "assets": encoded(_hector_assets("robots/x.xacro")),
        },
    )
    assert r.status_code == 422 and "urdf/quadrotor_base.urdf.xacro" in r.json()["detail"]
    assert not LEAK.search(r.text), r.text
    info = _upload(
        client,
        xacro=text,
        root_joint="free-flyer",
        assets=encoded(_hector_assets("urdf/quadrotor_base.urdf.xacro")),
    )
    catalog = client.get("/v1/robots/hector").json()
    assert info["name"] == "hector" and info["root_joint"] == catalog["root_joint"]
    assert (info["nq"], info["nv"]) == (catalog["nq"], catalog["nv"])
    assert info["total_mass"] == pytest.approx(catalog["total_mass"], rel=1e-15)
    assert not [w for w in info["warnings"] if w["code"] != "unreferenced_asset"]
    model = registry.get("hector").model
    rng = np.random.default_rng(1)
    for _ in range(3):
        q, v, _a = random_state(model, rng)
        got, expected = (
            client.post(
                f"/v1/robots/{rid}/nonlinear-effects", json={"q": q.tolist(), "v": v.tolist()}
            ).json()
            for rid in (info["id"], "hector")
        )
        np.testing.assert_allclose(
            got["nonlinear_effects"], expected["nonlinear_effects"], rtol=1e-12, atol=1e-12
        )
    # a restart rebuilds it from its stored expansion (xacro never runs in the server)
    restarted = Registry(registry.store.dir.parent, ["ur5"])
    restarted.load()
    assert restarted.get(info["id"]).info() == info


ARGS_XACRO = """<robot name="bar" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="mass" default="1.0"/>
  <xacro:include filename="$(find parts)/urdf/link.xacro"/>
  <xacro:property name="params" value="${xacro.load_yaml('$(find parts)/config/params.yaml')}"/>
  <link name="base"/>
  <xacro:heavy_link name="bar" mass="$(arg mass)" length="${params['length']}"/>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="bar"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""
PART = b"""<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:macro name="heavy_link" params="name mass length">
    <link name="${name}"><inertial><origin xyz="${length / 2} 0 0"/><mass value="${mass}"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial></link>
  </xacro:macro>
</robot>"""
PARTS = {"parts/urdf/link.xacro": PART, "parts/config/params.yaml": b"length: 0.5\n"}


def test_arguments_find_and_yaml(client: TestClient) -> None:
    default = _upload(client, xacro=ARGS_XACRO, assets=encoded(PARTS))
    heavy = _upload(client, xacro=ARGS_XACRO, xacro_args={"mass": "3"}, assets=encoded(PARTS))
    assert default["total_mass"] == pytest.approx(1.0) and heavy["total_mass"] == 3.0
    assert heavy["id"] != default["id"]  # the arguments are part of the id
    M = client.post(f"/v1/robots/{heavy['id']}/mass-matrix", json={"q": [0.2]}).json()
    assert M["mass_matrix"] == [[pytest.approx(0.001 + 3 * 0.25**2, rel=1e-12)]]
    unused = _upload(
        client,
        xacro=ARGS_XACRO,
        assets=encoded({**PARTS, "parts/meshes/unused.stl": b"solid x\nfacet\n"}),
    )
    assert [(w["code"], w["name"]) for w in unused["warnings"]] == [
        ("unreferenced_asset", "parts/meshes/unused.stl")
    ]


def _xacro(body: str) -> str:
    return (
        f'<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">{body}'
        '<link name="a"/><link name="b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" '
        'ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link><joint name="j" '
        'type="continuous"><parent link="a"/><child link="b"/></joint></robot>'
    )


def _escape(statement: str) -> str:
    """An expression that leaves xacro's sandbox through a running generator's frame (it
    reaches xacro's module globals) and runs `statement` on them (`G`)."""
    return (
        "${list((g := ("
        + statement.replace("G", "g.gi_frame.f_back.f_back.f_globals")
        + " for _ in [1])))}"
    )


MARKER = Path("/tmp/robodyn-xacro-escape-marker")
HOSTILE = {
    "include a system file": (
        _xacro('<xacro:include filename="/etc/passwd"/>'),
        "opening '/etc/passwd'",
    ),
    "YAML from a system file": (
        _xacro(
            '<xacro:property name="p" value="${xacro.load_yaml(\'/etc/passwd\')}"/>'
            '<link name="x${p}"/>'
        ),
        "opening '/etc/passwd'",
    ),
    "__import__": (
        _xacro('<xacro:property name="p" value="${__import__(\'os\')}"/><link name="x${p}"/>'),
        "invalid name",
    ),
    "os.system via an escape": (
        _xacro(
            '<xacro:property name="p" value="'
            + _escape(f"G['os'].system('touch {MARKER}')")
            + '"/><link name="x${p}"/>'
        ),
        "'os.system'",
    ),
    "open for writing via an escape": (
        _xacro(
            '<xacro:property name="p" value="'
            + _escape(f"G['__builtins__']['open']('{MARKER}', 'w')")
            + '"/><link name="x${p}"/>'
        ),
        "opening",
    ),
    "a subprocess via an escape": (
        _xacro(
            '<xacro:property name="p" value="'
            + _escape("G['__builtins__']['__import__']('subprocess').run(['id'])")
            + '"/><link name="x${p}"/>'
        ),
        "subprocess",
    ),
    "the network via an escape": (
        _xacro(
            '<xacro:property name="p" value="'
            + _escape("G['__builtins__']['__import__']('socket').socket()")
            + '"/><link name="x${p}"/>'
        ),
        "socket",
    ),
    "the environment": (_xacro('<link name="x$(env HOME)"/>'), "HOME"),
    "infinite macro recursion": (
        _xacro('<xacro:macro name="m"><xacro:m/></xacro:macro><xacro:m/>'),
        "recursed",
    ),
    "memory bomb": (
        _xacro('<xacro:property name="p" value="${len(\'x\' * 10**10)}"/><link name="x${p}"/>'),
        "memory limit",
    ),
    "CPU bomb": (
        _xacro('<xacro:property name="p" value="${len(str(7**(10**9)))}"/><link name="x${p}"/>'),
        "CPU limit",
    ),
    "unknown package": (
        _xacro('<xacro:include filename="$(find ros_secrets)/x.xacro"/>'),
        "$(find ros_secrets)",
    ),
    "entity expansion": (
        '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="&a;"/>',
        "DTD",
    ),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_xacro_is_refused(client: TestClient, registry: Registry, case: str) -> None:
    text, fragment = HOSTILE[case]
    MARKER.unlink(missing_ok=True)
    stored = set(registry.store.ids())
    r = unless_starved(lambda: client.post("/v1/robots", json={"xacro": text}))
    assert r.status_code == 422 and r.json()["code"] == "invalid_model", (case, r.text)
    assert fragment in r.json()["detail"], r.json()["detail"]
    assert not LEAK.search(r.json()["detail"].replace(str(MARKER), "")), r.text
    assert not MARKER.exists()
    assert set(registry.store.ids()) == stored
    assert client.get("/health/live").status_code == 200
    g = client.post("/v1/robots/ur5/gravity", json={"q": [0, -1, 1, 0, 0, 0]})
    assert g.status_code == 200


def test_the_expansion_meets_the_servers_caps(tmp_path: Path) -> None:
    from service.errors import InvalidModel
    from service.registry.urdf_check import Limits

    registry = Registry(tmp_path, ["ur5"], limits=Limits(max_links=1))
    registry.load()
    with pytest.raises(InvalidModel, match="the limit is 1"):
        registry.upload(
            xacro=ARGS_XACRO,
            assets=encoded(PARTS),
            root_joint="fixed",
            gravity=None,
            name=None,
            inertia_check="reject",
        )


def test_request_level_errors(client: TestClient) -> None:
    r = client.post("/v1/robots", json={"urdf": "<robot/>", "xacro_args": {"a": "1"}})
    assert r.status_code == 422 and "xacro_args" in r.json()["detail"]
    r = client.post("/v1/robots", json={"xacro": "<robot/>", "mjcf": "<mujoco/>"})
    assert r.status_code == 422 and "exactly one" in r.json()["detail"]
