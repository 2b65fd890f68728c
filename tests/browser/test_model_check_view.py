"""The explorer's Model check view in a real browser: the findings are the API's, a chosen link
shows its declared numbers beside its geometry's and draws both inertia ellipsoids at the link
(the geometry's a box's: semi-axes √(5/12) × its sides), and the repair button stores the
repaired variant and opens it, whose check has no error; the upload form refuses such a file by
default and, with "repair them", stores the model the API's `inertia_check: "repair"` stores."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.browser.test_explorer import open_explorer

SIDES = (0.1, 0.2, 0.4)  # m, the arm link's box
# izz a hundred times its box's: λ₁ + λ₂ < λ₃ (the box's with mass 2 kg: 0.00833, 0.02833, 0.03333)
ARM = f"""<robot name="slipped_arm">
  <link name="base"><inertial><mass value="1"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><mass value="2"/>
    <inertia ixx="0.03333" iyy="0.02833" izz="0.833" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="{SIDES[0]} {SIDES[1]} {SIDES[2]}"/></geometry></collision>
    <visual><geometry><box size="{SIDES[0]} {SIDES[1]} {SIDES[2]}"/></geometry></visual></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit effort="10" velocity="1" lower="-3" upper="3"/></joint>
</robot>"""

RADII_JS = """() => {
  const mark = document.querySelector('#view3d').robotDrawing.frameMark;
  return mark.userData.ellipsoids.children.map((mesh) => {
    const e = mesh.matrix.elements;  // column-major: the columns are the scaled axes
    return [0, 1, 2].map((c) => Math.hypot(e[4 * c], e[4 * c + 1], e[4 * c + 2])).sort();
  });
}"""


def test_the_view_shows_the_findings_draws_the_ellipsoids_and_repairs(page, server, api):
    robot = api.post("/v1/robots", json={"urdf": ARM, "inertia_check": "warn"}).json()
    expected = api.get(f"/v1/robots/{robot['id']}/model-check").json()
    assert [(f["link"], f["code"]) for f in expected["findings"]] == [
        ("arm", "triangle_inequality")
    ]
    open_explorer(page, server, robot["id"])
    page.click("#model-check-view-button")
    page.wait_for_function(
        "(id) => document.querySelector('#model-check-view').dataset.robot === id",
        arg=robot["id"],
    )
    assert not page.locator("#mass-matrix-figure").is_visible()
    rows = page.eval_on_selector_all(
        "#model-check-findings tr[data-code]", "rs => rs.map(r => [r.dataset.link, r.dataset.code])"
    )
    assert rows == [[f["link"], f["code"]] for f in expected["findings"]]
    assert "1 error(s)" in page.locator("#model-check-status").text_content()
    assert page.locator("#model-check-link").input_value() == "arm"
    page.wait_for_function(
        "() => document.querySelector('#view3d').dataset.markedFrame === 'arm' && "
        "document.querySelector('#view3d').dataset.ellipsoids === '2'"
    )
    # the geometry's ellipsoid: the box's equivalent ellipsoid, semi-axes √(5/12) × the sides
    radii = page.evaluate(RADII_JS)
    assert len(radii) == 2
    assert np.allclose(radii[1], sorted(math.sqrt(5 / 12) * s for s in SIDES), rtol=1e-9)
    # the declared one: flat along the axis that breaks the triangle inequality
    assert min(radii[0]) <= 1e-4

    page.select_option("#model-check-from", "geometry")
    page.click("#model-check-repair")
    page.wait_for_function(
        "() => (document.querySelector('#model-check-repair-status').dataset.variant || '')"
        ".startsWith('v-')"
    )
    variant = page.locator("#model-check-repair-status").get_attribute("data-variant")
    page.wait_for_function(
        "(id) => document.querySelector('#model-check-view').dataset.robot === id", arg=variant
    )
    assert page.locator("#robot").input_value() == variant
    assert not [
        f
        for f in api.get(f"/v1/robots/{variant}/model-check").json()["findings"]
        if f["severity"] == "error"
    ]
    assert "0 error(s)" in page.locator("#model-check-status").text_content() or (
        "No finding" in page.locator("#model-check-status").text_content()
    )
    page.wait_for_function("() => document.querySelector('#view3d').dataset.ellipsoids === '2'")
    repaired = page.evaluate(RADII_JS)  # both ellipsoids are now the box's
    for axes in repaired:
        assert np.allclose(axes, sorted(math.sqrt(5 / 12) * s for s in SIDES), rtol=1e-9)
    assert not page.log.page_errors and not page.log.console_errors


def test_the_pages_eigen_decomposition_and_ellipsoid_match_numpys(page, server):
    """The view's own linear algebra (Jacobi rotations) on a rotated, full tensor."""
    rng = np.random.default_rng(3)
    axes, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    moments = np.array([0.02, 0.05, 0.06])
    inertia = axes @ np.diag(moments) @ axes.T
    page.goto(server + "/")
    got = page.evaluate(
        """async (inertia) => {
        const m = await import('./static/model_check_view.js');
        const { values, vectors } = m.symmetricEigen(inertia);
        const e = m.inertiaEllipsoid(3.0, inertia, [0, 0, 0], '#000000');
        return { values, vectors, radii: e.radii, axes: e.axes };
    }""",
        inertia.tolist(),
    )
    order = np.argsort(got["values"])
    np.testing.assert_allclose(np.array(got["values"])[order], moments, rtol=1e-12)
    vectors = np.array(got["vectors"])
    np.testing.assert_allclose(vectors @ np.diag(got["values"]) @ vectors.T, inertia, atol=1e-15)
    # the uniform ellipsoid of 3 kg with these moments: aᵢ² = 5/(2m) (λⱼ + λₖ − λᵢ)
    expected = np.sqrt(5 / 6 * (moments.sum() - 2 * moments))
    np.testing.assert_allclose(np.array(got["radii"])[order], expected, rtol=1e-12)
    assert np.linalg.det(np.array(got["axes"])) == pytest.approx(1.0, abs=1e-12)


def _upload_in_page(page, text: str, how: str | None) -> None:
    page.set_input_files(
        "#urdf-file",
        files=[{"name": "slipped.urdf", "mimeType": "text/xml", "buffer": text.encode()}],
    )
    if how is not None:
        page.select_option("#inertia-check", how)
    page.click("#upload button[type=submit]")


def test_the_upload_form_rejects_by_default_and_repairs_on_request(page, server, api):
    text = ARM.replace("slipped_arm", "slipped_arm_form")
    open_explorer(page, server)
    assert page.locator("#inertia-check").input_value() == "reject"
    refused = api.post("/v1/robots", json={"urdf": text, "root_joint": "fixed"})
    assert refused.status_code == 422
    _upload_in_page(page, text, None)
    page.locator("#upload-status .detail").wait_for()
    assert page.locator("#upload-status .detail").inner_text() == refused.json()["detail"]

    _upload_in_page(page, text, "repair")
    page.locator("#upload-status.ok").wait_for()
    # the API's own repaired upload of the same file: the same stored model (ids are derived
    # from the record, repairs included), which the page then shows
    expected = api.post(
        "/v1/robots", json={"urdf": text, "root_joint": "fixed", "inertia_check": "repair"}
    )
    assert expected.status_code == 200, expected.text  # stored already, by the page
    robot = expected.json()
    assert robot["id"] in page.locator("#upload-status").inner_text()
    assert [(w["name"], w["code"]) for w in robot["warnings"]] == [("arm", "inertia_repaired")]
    page.wait_for_function("(id) => document.querySelector('#robot').value === id", arg=robot["id"])
    check = api.get(f"/v1/robots/{robot['id']}/model-check").json()
    assert not [f for f in check["findings"] if f["severity"] == "error"]
    arm = next(link for link in check["links"] if link["name"] == "arm")
    a, b, c = SIDES  # repaired from its box: the box's moments with its 2 kg
    box = sorted(2 / 12 * x for x in (b * b + c * c, a * a + c * c, a * a + b * b))
    np.testing.assert_allclose(arm["principal_moments"], box, rtol=1e-9)
    assert not page.log.page_errors
    assert len(page.log.console_errors) == 1 and "422" in page.log.console_errors[0]  # refused
