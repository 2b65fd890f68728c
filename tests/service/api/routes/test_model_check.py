"""GET /v1/robots/{id}/model-check and the repairs, over HTTP.

A description with one link per finding answers exactly those findings (and none on its clean
links); the catalog's romeo_small and romeo_laas_small have errors (the same links upload
validation names), ur5 and romeo none; a repaired variant, and an upload repaired with
`inertia_check: "repair"`, compute the mass matrix of a description written with the repaired
inertias, the repairs computed here independently (closed forms, a convex QP); the default
refusal names the link and the suggested value."""

from __future__ import annotations

import base64
import math
from collections.abc import Iterator
from pathlib import Path

import cvxpy as cp
import numpy as np
import pytest
import trimesh
from fastapi.testclient import TestClient

from service.main import create_app
from service.registry import Registry
from service.settings import Settings

A = 0.1  # m, the side of the cubes
CUBE = f'<box size="{A} {A} {A}"/>'


def _diag(x: float, y: float, z: float) -> dict[str, float]:
    return {"ixx": x, "iyy": y, "izz": z, "ixy": 0.0, "ixz": 0.0, "iyz": 0.0}


def _cube(m: float) -> dict[str, float]:
    return _diag(*(m * A * A / 6,) * 3)  # the uniform cube: m a²/6


ARM_MASS = 2700 * math.pi * 0.03**2 * 0.3  # aluminium
ARM_SIDE = ARM_MASS * (3 * 0.03**2 + 0.3**2) / 12

# link → (mass, centre of mass, <inertia> attributes, geometry XML, joint to the base)
LINKS: dict[str, tuple[float | None, list[float], dict[str, float], str, str]] = {
    "base": (
        2.0,
        [0, 0, 0],
        _diag(*(2.0 * 0.08 / 12,) * 3),
        '<collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>',
        "",
    ),
    "arm": (
        ARM_MASS,
        [0.15, 0, 0],
        _diag(ARM_MASS * 0.03**2 / 2, ARM_SIDE, ARM_SIDE),
        '<collision><origin xyz="0.15 0 0" rpy="0 1.5707963267948966 0"/><geometry>'
        '<cylinder radius="0.03" length="0.3"/></geometry></collision>',
        "revolute",
    ),
    "ball": (
        1.0,
        [0, 0, 0],
        _diag(*(0.4 * 0.05**2,) * 3),
        '<collision><geometry><sphere radius="0.05"/></geometry></collision>',
        "revolute",
    ),
    "neg": (1.0, [0, 0, 0], {**_diag(0.01, 0.01, 0.01), "ixy": 0.03}, "", "revolute"),
    "tri": (1.6, [0, 0, 0], _diag(0.0118, 0.0118, 1.676), "", "revolute"),
    "nomass": (0.0, [0, 0, 0], _diag(0.01, 0.01, 0.01), "", "fixed"),
    "point": (
        0.5,
        [0.02, 0, 0],
        _diag(0, 0, 0),
        f"<visual><geometry>{CUBE}</geometry></visual>",
        "revolute",
    ),
    "massless": (
        None,
        [0, 0, 0],
        _diag(0, 0, 0),
        f"<collision><geometry>{CUBE}</geometry></collision>",
        "revolute",
    ),
    "dense": (
        50.0,
        [0, 0, 0],
        _cube(50.0),
        f"<collision><geometry>{CUBE}</geometry></collision>",
        "revolute",
    ),
    "offcom": (
        1.0,
        [0.5, 0, 0],
        _cube(1.0),
        f"<collision><geometry>{CUBE}</geometry></collision>",
        "revolute",
    ),
    "mismatch": (
        1.0,
        [0, 0, 0],
        _cube(100.0),
        f"<collision><geometry>{CUBE}</geometry></collision>",
        "revolute",
    ),
    "l_twin": (1.0, [0, 0, 0], _diag(0.01, 0.01, 0.01), "", "revolute"),
    "r_twin": (1.0, [0, 0, 0], _diag(0.001, 0.01, 0.01), "", "revolute"),
    "open": (
        1.0,
        [0, 0, 0],
        _cube(1.0),
        '<collision><geometry><mesh filename="meshes/open_box.stl"/></geometry></collision>',
        "revolute",
    ),
}
TIP = (0.1, [0, 0, 0], _diag(1e-4, 1e-4, 1e-4), "", "")  # carried by "massless" (fixed)
EXPECTED = {
    ("neg", "negative_principal_moment"),
    ("tri", "triangle_inequality"),
    ("nomass", "inertia_without_mass"),
    ("point", "point_mass_with_geometry"),
    ("massless", "massless_with_geometry"),
    ("dense", "implausible_density"),
    ("offcom", "center_of_mass_outside_geometry"),
    ("mismatch", "inertia_geometry_mismatch"),
    ("l_twin", "mirror_asymmetry"),
    ("open", "open_mesh"),
}
ERRORS = {"negative_principal_moment", "triangle_inequality", "inertia_without_mass"}


def _link(
    name: str, mass: float | None, com: list[float], inertia: dict[str, float], shape: str
) -> str:
    inertial = ""
    if mass is not None:
        attributes = " ".join(f'{k}="{float(v)!r}"' for k, v in inertia.items())
        xyz = " ".join(repr(float(x)) for x in com)
        inertial = (
            f'<inertial><origin xyz="{xyz}"/><mass value="{mass!r}"/>'
            f"<inertia {attributes}/></inertial>"
        )
    return f'<link name="{name}">{inertial}{shape}</link>'


def urdf(changed: dict[str, tuple[list[float], dict[str, float]]] | None = None) -> str:
    """The description, with the (centre of mass, inertia) of `changed` links."""
    parts = []
    for name, (mass, com, inertia, shape, joint) in {**LINKS, "tip": TIP}.items():
        com, inertia = (changed or {}).get(name, (com, inertia))
        parts.append(_link(name, mass, com, inertia, shape))
        if joint:
            parts.append(
                f'<joint name="j_{name}" type="{joint}"><parent link="base"/>'
                f'<child link="{name}"/><axis xyz="0 0 1"/>'
                '<limit effort="10" velocity="1" lower="-3" upper="3"/></joint>'
            )
    parts.append(
        '<joint name="j_tip" type="fixed"><parent link="massless"/><child link="tip"/></joint>'
    )
    return f'<robot name="checked">{"".join(parts)}</robot>'


def _open_box() -> str:
    mesh = trimesh.creation.box(extents=[A, A, A])
    opened = trimesh.Trimesh(mesh.vertices, mesh.faces[2:], process=False)  # a side missing
    return base64.b64encode(opened.export(file_type="stl")).decode()


ASSETS = {"meshes/open_box.stl": _open_box()}


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    data = tmp_path_factory.mktemp("model-check")
    settings = Settings(data_dir=data, catalog="ur5,romeo,romeo_small,romeo_laas_small")
    registry = Registry(Path(data), settings.catalog_names(), settings.build_timeout_s)
    registry.load()
    with TestClient(create_app(settings, registry=registry), raise_server_exceptions=False) as c:
        yield c


def _upload(client: TestClient, text: str, inertia_check: str) -> dict:
    answer = client.post(
        "/v1/robots", json={"urdf": text, "assets": ASSETS, "inertia_check": inertia_check}
    )
    assert answer.status_code in (200, 201), answer.text
    return answer.json()


def _check(client: TestClient, robot_id: str) -> dict:
    answer = client.get(f"/v1/robots/{robot_id}/model-check")
    assert answer.status_code == 200, answer.text
    return answer.json()


def _mass_matrices(client: TestClient, robot_id: str, q: np.ndarray) -> np.ndarray:
    answer = client.post(f"/v1/robots/{robot_id}/mass-matrix", json={"q": q.tolist()})
    assert answer.status_code == 200, answer.text
    return np.asarray(answer.json()["mass_matrix"])


def _states(nq: int) -> np.ndarray:
    return np.random.default_rng(7).uniform(-3, 3, (5, nq))


def test_one_link_per_finding_answers_exactly_those_findings(client):
    robot = _upload(client, urdf(), "warn")
    check = _check(client, robot["id"])
    found = {(f["link"], f["code"]) for f in check["findings"]}
    assert found == EXPECTED
    for finding in check["findings"]:
        assert finding["severity"] == ("error" if finding["code"] in ERRORS else "warning")
    suggestions = {f["link"]: f["suggestion"] for f in check["findings"]}
    assert suggestions["neg"] == {"attribute": "ixy", "value": 0.003}
    assert suggestions["tri"] == {"attribute": "izz", "value": 0.01676}
    assert suggestions["nomass"] is None and suggestions["dense"] is None
    links = {link["name"]: link for link in check["links"]}
    assert set(links) == set(LINKS) | {"tip"}
    arm = links["arm"]["geometry"]
    assert arm["source"] == "collision"
    assert arm["volume"] == pytest.approx(math.pi * 0.03**2 * 0.3, rel=1e-12)
    assert arm["density"] == pytest.approx(2700, rel=1e-12)
    np.testing.assert_allclose(arm["center_of_mass"], [0.15, 0, 0], atol=1e-15)
    np.testing.assert_allclose(
        arm["inertia"],
        np.diag([ARM_MASS * 0.03**2 / 2, ARM_SIDE, ARM_SIDE]),
        rtol=1e-9,
        atol=1e-15,
    )
    opened = links["open"]["geometry"]  # its convex hull: the whole cube (STL: float32)
    assert opened["volume"] == pytest.approx(A**3, rel=1e-6)
    np.testing.assert_allclose(opened["inertia"], np.eye(3) * A * A / 6, rtol=1e-6, atol=1e-12)
    assert links["point"]["geometry"]["source"] == "visual"
    assert links["massless"]["geometry"]["inertia"] is None
    assert links["neg"]["geometry"] is None
    np.testing.assert_allclose(
        links["tri"]["principal_moments"], [0.0118, 0.0118, 1.676], rtol=1e-12
    )


def test_the_default_refusal_names_each_link_and_its_suggested_value(client):
    answer = client.post("/v1/robots", json={"urdf": urdf(), "assets": ASSETS})
    assert answer.status_code == 422 and answer.json()["code"] == "invalid_model"
    detail = answer.json()["detail"]
    assert "link 'neg'" in detail and "ixy = 0.003 " in detail
    assert "link 'tri'" in detail and "izz = 0.01676 " in detail
    assert "link 'nomass'" in detail and '"repair"' in detail


def _nearest_valid(tensor: np.ndarray, mass: float) -> np.ndarray:
    """The repair by its definition: principal axes kept, the moments projected (a QP)."""
    if mass == 0.0:
        return np.zeros((3, 3))
    moments, axes = np.linalg.eigh(tensor)
    scale = float(np.abs(moments).max())
    x = cp.Variable(3)
    rules = [x >= 0] + [x[i] + x[j] >= x[k] for i, j, k in ((0, 1, 2), (0, 2, 1), (1, 2, 0))]
    cp.Problem(cp.Minimize(cp.sum_squares(x - moments / scale)), rules).solve(solver=cp.CLARABEL)
    return axes @ np.diag(np.asarray(x.value) * scale) @ axes.T


def _tensor(a: dict[str, float]) -> np.ndarray:
    return np.array(
        [
            [a["ixx"], a["ixy"], a["ixz"]],
            [a["ixy"], a["iyy"], a["iyz"]],
            [a["ixz"], a["iyz"], a["izz"]],
        ]
    )


def _attributes(t: np.ndarray) -> dict[str, float]:
    return {
        "ixx": t[0, 0],
        "iyy": t[1, 1],
        "izz": t[2, 2],
        "ixy": t[0, 1],
        "ixz": t[0, 2],
        "iyz": t[1, 2],
    }


def _repaired_by_hand() -> dict[str, tuple[list[float], dict[str, float]]]:
    """The errors' links repaired (none has geometry: the nearest valid tensors)."""
    out = {}
    for name in ("neg", "tri", "nomass"):
        mass, com, inertia, _, _ = LINKS[name]
        out[name] = (com, _attributes(_nearest_valid(_tensor(inertia), float(mass or 0.0))))
    return out


def test_a_repaired_variant_computes_with_the_repaired_inertias(client):
    parent = _upload(client, urdf(), "warn")
    answer = client.post(
        f"/v1/robots/{parent['id']}/variants",
        json={"inertias": {"links": "errors", "from": "nearest_valid"}},
    )
    assert answer.status_code == 201, answer.text
    variant = answer.json()
    assert variant["parent"] == parent["id"]
    repairs = variant["modifications"]["inertias"]["repairs"]
    assert {r["link"] for r in repairs} == {"neg", "tri", "nomass"}
    # its warnings: each repair, in place of the error it repairs
    warned = {(w["name"], w["code"]) for w in variant["warnings"]}
    assert {(name, "inertia_repaired") for name in ("neg", "tri", "nomass")} <= warned
    assert not {code for _, code in warned} & ERRORS
    assert not [f for f in _check(client, variant["id"])["findings"] if f["code"] in ERRORS]
    # the same description written with the repaired inertias, built by the URDF parser
    written = _upload(client, urdf(_repaired_by_hand()), "warn")
    q = _states(variant["nq"])
    np.testing.assert_allclose(
        _mass_matrices(client, variant["id"], q),
        _mass_matrices(client, written["id"], q),
        rtol=1e-9,
        atol=1e-12,
    )


def test_a_variant_repaired_from_geometry_takes_the_shapes_mass_properties(client):
    parent = _upload(client, urdf(), "warn")
    answer = client.post(
        f"/v1/robots/{parent['id']}/variants",
        json={"inertias": {"links": ["mismatch", "offcom"], "from": "geometry"}},
    )
    assert answer.status_code == 201, answer.text
    variant = answer.json()
    found = {(f["link"], f["code"]) for f in _check(client, variant["id"])["findings"]}
    assert found == EXPECTED - {
        ("mismatch", "inertia_geometry_mismatch"),
        ("offcom", "center_of_mass_outside_geometry"),
    }
    # the cube's centre and m a²/6
    written = _upload(
        client,
        urdf({"mismatch": ([0, 0, 0], _cube(1.0)), "offcom": ([0, 0, 0], _cube(1.0))}),
        "warn",
    )
    q = _states(variant["nq"])
    np.testing.assert_allclose(
        _mass_matrices(client, variant["id"], q),
        _mass_matrices(client, written["id"], q),
        rtol=1e-9,
        atol=1e-12,
    )


def test_repairs_a_robot_cannot_have_are_refused_naming_the_link(client):
    parent = _upload(client, urdf(), "warn")
    for inertias, named in (
        ({"links": ["neg"], "from": "geometry"}, "link 'neg' has no geometry"),
        ({"links": ["nowhere"], "from": "nearest_valid"}, "'nowhere' is not a link"),
    ):
        answer = client.post(f"/v1/robots/{parent['id']}/variants", json={"inertias": inertias})
        assert answer.status_code == 422, answer.text
        assert answer.json()["code"] == "validation_error" and named in answer.json()["detail"]
    answer = client.post(
        f"/v1/robots/{parent['id']}/variants", json={"inertias": {"links": "some", "from": "x"}}
    )
    assert answer.status_code == 422 and answer.json()["code"] == "validation_error"


def test_an_upload_repaired_on_request_is_stored_without_error(client):
    robot = _upload(client, urdf(), "repair")
    repaired = {w["name"] for w in robot["warnings"] if w["code"] == "inertia_repaired"}
    assert repaired == {"neg", "tri", "nomass"}
    assert not {w["code"] for w in robot["warnings"]} & ERRORS
    check = _check(client, robot["id"])
    assert not [f for f in check["findings"] if f["severity"] == "error"]
    assert robot["id"] != _upload(client, urdf(), "warn")["id"]  # another model
    written = _upload(client, urdf(_repaired_by_hand()), "warn")
    q = _states(robot["nq"])
    np.testing.assert_allclose(
        _mass_matrices(client, robot["id"], q),
        _mass_matrices(client, written["id"], q),
        rtol=1e-9,
        atol=1e-12,
    )


def test_the_catalogs_errors_are_found_where_validation_finds_them(client):
    for name in ("romeo_small", "romeo_laas_small"):
        errors = [f for f in _check(client, name)["findings"] if f["severity"] == "error"]
        assert errors, name
        info = client.get(f"/v1/robots/{name}").json()
        named = {w["name"] for w in info["warnings"] if w["code"] in ERRORS}
        assert {f["link"] for f in errors} == named
    codes = {f["code"] for f in _check(client, "romeo_laas_small")["findings"]}
    assert {"negative_principal_moment", "triangle_inequality"} <= codes
    for name in ("ur5", "romeo"):
        check = _check(client, name)
        assert not [f for f in check["findings"] if f["severity"] == "error"], name
        assert check["links"]


def test_an_unknown_robot_is_a_404(client):
    answer = client.get("/v1/robots/nowhere/model-check")
    assert answer.status_code == 404 and answer.json()["code"] == "robot_not_found"


def test_an_upload_repairs_a_link_with_a_shape_from_its_shape(client):
    # the "tri" slip on a link with a box: repaired to the box's closed form with its mass
    sides, mass = (0.1, 0.2, 0.4), 1.6
    size = " ".join(map(str, sides))
    box = f'<collision><geometry><box size="{size}"/></geometry></collision>'
    text = urdf().replace(
        'izz="1.676" ixy="0.0" ixz="0.0" iyz="0.0"/></inertial></link>',
        f'izz="1.676" ixy="0.0" ixz="0.0" iyz="0.0"/></inertial>{box}</link>',
    )
    assert box in text
    robot = _upload(client, text, "repair")
    messages = {
        w["name"]: w["message"] for w in robot["warnings"] if w["code"] == "inertia_repaired"
    }
    assert "geometry" in messages["tri"] and "nearest valid" in messages["neg"]
    tri = next(link for link in _check(client, robot["id"])["links"] if link["name"] == "tri")
    a, b, c = sides
    expected = sorted(mass / 12 * x for x in (b * b + c * c, a * a + c * c, a * a + b * b))
    np.testing.assert_allclose(tri["principal_moments"], expected, rtol=1e-9)
    np.testing.assert_allclose(tri["center_of_mass"], [0, 0, 0], atol=1e-15)
