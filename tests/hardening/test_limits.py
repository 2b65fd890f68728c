"""Caps and calibration: the default caps admit every catalog robot, every cap is a setting that
takes effect, the upload body limit is separate from the compute one, and the inertia checks on
real files find what they should (and not rounding noise), with rejections that name the link,
the numbers and the option that accepts them."""

from __future__ import annotations

import pytest

from service.registry.catalog import catalog_entries
from service.registry.urdf_check import Limits, check_urdf
from service.settings import Settings
from tests.helpers import planar_arm_urdf

ROOT_NV = {"fixed": 0, "planar": 3, "free-flyer": 6}
ARM = planar_arm_urdf(1.0, 0.5, 2.0, 1.0)


def catalog_urdfs():
    for entry in catalog_entries():
        if "urdf" in entry.spec:
            yield entry.name, entry.spec.get("root_joint", "fixed"), entry.path("urdf")


def test_default_caps_admit_every_catalog_robot():
    settings = Settings()
    limits = Limits(**settings.model_limits())
    largest = 0
    for name, root_joint, path in catalog_urdfs():
        text = path.read_text(encoding="utf-8")
        assert len(text.encode()) < settings.max_upload_bytes // 4, name
        summary = check_urdf(text, limits, lenient=True)
        nv = summary.nv + ROOT_NV[root_joint]
        assert nv <= settings.max_nv, name
        largest = max(largest, nv)
    assert largest >= 100  # tiago_dual: the cap is not vacuous


@pytest.mark.parametrize(
    "setting, value, fragment",
    [
        ("max_links", 2, "ROBODYN_MAX_LINKS"),
        ("max_nv", 1, "ROBODYN_MAX_NV"),
        ("max_depth", 1, "ROBODYN_MAX_DEPTH"),
        ("max_xml_elements", 12, "ROBODYN_MAX_XML_ELEMENTS"),
    ],
)
def test_every_cap_is_a_setting(app_factory, setting, value, fragment):
    client = app_factory(**{setting: value})
    r = client.post("/v1/robots", json={"urdf": ARM})
    assert r.status_code == 422 and r.json()["code"] == "invalid_model", r.text
    assert fragment in r.json()["detail"]
    relaxed = app_factory(catalog="planar_arm")
    assert relaxed.post("/v1/robots", json={"urdf": ARM}).status_code == 201


def test_the_nv_cap_counts_the_root_joint(app_factory):
    client = app_factory(max_nv=7)  # the arm has nv = 2; a free-flyer adds 6
    assert client.post("/v1/robots", json={"urdf": ARM, "root_joint": "planar"}).status_code == 201
    r = client.post("/v1/robots", json={"urdf": ARM, "root_joint": "free-flyer"})
    assert r.status_code == 422 and "nv = 8" in r.json()["detail"], r.text
    assert "ROBODYN_MAX_NV" in r.json()["detail"]


def test_upload_and_compute_body_limits_are_separate(app_factory):
    client = app_factory(max_upload_bytes=1500)
    big = client.post("/v1/robots", json={"urdf": ARM + " " * 2000})
    assert big.status_code == 413 and "ROBODYN_MAX_UPLOAD_BYTES" in big.json()["detail"]
    q = [[0.0] * 6] * 100  # a 2.5 kB compute body is fine
    assert client.post("/v1/robots/ur5/gravity", json={"q": q}).status_code == 200
    tight = app_factory(max_body_bytes=1024, max_upload_bytes=1_000_000)
    r = tight.post("/v1/robots", json={"urdf": ARM + " " * 2000})
    assert r.status_code == 413 and "ROBODYN_MAX_BODY_BYTES" in r.json()["detail"]


def test_limits_defaults_match_the_settings():
    assert Limits(**Settings().model_limits()) == Limits()


def test_real_findings_are_rejected_with_names_numbers_and_the_option(api):
    pr2 = next(path for name, _, path in catalog_urdfs() if name == "pr2").read_text()
    r = api.post("/v1/robots", json={"urdf": pr2})
    assert r.status_code == 422 and r.json()["code"] == "invalid_model"
    detail = r.json()["detail"]
    assert "link 'sensor_mount_link'" in detail and "0.001, 0.001, 0.01 kg·m²" in detail
    assert "short by 80 %" in detail and '"inertia_check": "warn"' in detail
    accepted = api.post("/v1/robots", json={"urdf": pr2, "inertia_check": "warn"})
    assert accepted.status_code in (200, 201), accepted.text
    catalog = api.get("/v1/robots/pr2").json()
    # the upload sends the URDF without its meshes: one missing_mesh warning per mesh file
    # besides the physical findings, which are the catalog robot's
    uploaded = accepted.json()["warnings"]
    findings = [w for w in uploaded if w.get("code") != "missing_mesh"]
    missing = [w for w in uploaded if w.get("code") == "missing_mesh"]
    assert findings == catalog["warnings"]
    assert missing and all(w["file"].endswith((".dae", ".stl", ".DAE", ".STL")) for w in missing)
    assert {w["name"] for w in catalog["warnings"]} == {"sensor_mount_link", "double_stereo_link"}


def test_rounding_noise_is_not_a_finding_but_real_negatives_are(api):
    # go1's base tensor (0, 0, 3e-6) has eigenvalue noise of -2.5e-22: only the real problem
    # (a violated triangle inequality) is reported, not a negative moment
    go1 = api.get("/v1/robots/go1").json()["warnings"]
    assert [(w["code"], w["name"]) for w in go1] == [("triangle_inequality", "base")]
    romeo = api.get("/v1/robots/romeo_laas_small").json()["warnings"]
    body = [w for w in romeo if w["name"] == "body"]
    assert body[0]["code"] == "negative_principal_moment" and "-0.0213" in body[0]["message"]
