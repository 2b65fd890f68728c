"""The explorer's 3-D view in Debian's Chromium (WebGL on SwiftShader): the robot is drawn
where the service places it, moves with the sliders, is coloured by the chosen quantity, and
every mesh comes from this service, once."""

from __future__ import annotations

import base64
import math
import os
from collections import Counter
from pathlib import Path

import numpy as np

from tests.browser.conftest import ARTIFACTS
from tests.browser.test_explorer import ROBOTS_DIR, open_explorer, set_slider, wait_computed

DOCS_SCREENSHOT = Path(__file__).resolve().parents[2] / "docs" / "explorer-talos.png"

# Pixels that differ between the canvas drawn with and without the robot (grid, axes and the
# centre-of-mass ball stay): how much of the picture is the robot.
ROBOT_PIXELS_JS = """() => {
  const view = document.querySelector('#view3d').robotDrawing;
  const grab = () => {
    view.renderer.render(view.scene, view.camera);
    const c = view.renderer.domElement;
    const off = document.createElement('canvas');
    [off.width, off.height] = [c.width, c.height];
    const ctx = off.getContext('2d');
    ctx.drawImage(c, 0, 0);
    return ctx.getImageData(0, 0, c.width, c.height).data;
  };
  const withRobot = grab();
  view.root.visible = false;
  const without = grab();
  view.root.visible = true;
  grab();
  let n = 0;
  for (let i = 0; i < withRobot.length; i += 4) {
    if (Math.abs(withRobot[i] - without[i]) + Math.abs(withRobot[i + 1] - without[i + 1]) +
        Math.abs(withRobot[i + 2] - without[i + 2]) > 24) n++;
  }
  return n;
}"""

CANVAS_JS = """() => {
  const view = document.querySelector('#view3d').robotDrawing;
  view.renderer.render(view.scene, view.camera);
  return view.renderer.domElement.toDataURL('image/png');
}"""


def wait_drawn(page, robot: str) -> None:
    """Wait until the view shows `robot` placed at the sliders' q with every mesh loaded."""
    page.wait_for_function(
        """(r) => {
        const v = document.querySelector('#view3d'), p = document.querySelector('#view-progress');
        return v.dataset.robot === r && v.dataset.q && p.dataset.total !== undefined
          && p.dataset.done === p.dataset.total
          && v.dataset.q === document.querySelector('#heatmap').dataset.q }""",
        arg=robot,
        timeout=60_000,
    )


def frame_matrix(page, frame: str) -> np.ndarray:
    elements = page.evaluate(
        "(f) => document.querySelector('#view3d').robotDrawing.frames.get(f).matrix.elements", frame
    )
    return np.array(elements).reshape(4, 4).T  # three.js stores column-major


def changed_pixels(page, before: str) -> int:
    return page.evaluate(
        """([a, b]) => new Promise((resolve) => {
        const load = (src) => new Promise((ok) => { const i = new Image(); i.onload = () => ok(i);
                                                      i.src = src; });
        Promise.all([load(a), load(b)]).then(([x, y]) => {
          const data = (img) => { const c = document.createElement('canvas');
            [c.width, c.height] = [img.width, img.height];
            const ctx = c.getContext('2d'); ctx.drawImage(img, 0, 0);
            return ctx.getImageData(0, 0, img.width, img.height).data; };
          const [p, q] = [data(x), data(y)];
          let n = 0;
          for (let i = 0; i < p.length; i += 4) if (p[i] !== q[i] || p[i + 1] !== q[i + 1]
                                                    || p[i + 2] !== q[i + 2]) n++;
          resolve(n);
        });
    })""",
        [before, page.evaluate(CANVAS_JS)],
    )


def move_joint(page, api, robot: str, joint: str, value: float) -> list[float]:
    """Set the position slider of a 1-dof joint and wait for the view to be placed there."""
    info = api.get(f"/v1/robots/{robot}").json()
    rows = [j for j in info["joints"] for _ in range(j["nv"])]
    row = next(k for k, j in enumerate(rows) if j["name"] == joint)
    idx_q = next(j["idx_q"] for j in info["joints"] if j["name"] == joint)
    set_slider(page, f"#q-{row}", value)
    page.wait_for_function(
        """([k, x]) => {
        const q = document.querySelector('#view3d').dataset.q;
        return q && JSON.parse(q)[k] === x }""",
        arg=[idx_q, value],
    )
    wait_computed(page)
    wait_drawn(page, robot)
    return page.evaluate("() => JSON.parse(document.querySelector('#view3d').dataset.q)")


def assert_placed_as_the_service_says(page, api, robot: str, q) -> None:
    answer = api.post(f"/v1/robots/{robot}/frame-placements", json={"q": q}).json()
    for name, p, R in zip(answer["frames"], answer["positions"], answer["rotations"], strict=True):
        M = frame_matrix(page, name)
        assert np.allclose(M[:3, 3], p, atol=1e-6), name  # float32 on the GPU side
        assert np.allclose(M[:3, :3], R, atol=1e-6), name


def test_ur5_is_drawn_from_its_meshes_and_moves_with_a_slider(page, server, api) -> None:
    open_explorer(page, server, "ur5")
    wait_drawn(page, "ur5")
    assert page.locator("#view3d").get_attribute("data-mode") == "visuals"
    assert page.evaluate(ROBOT_PIXELS_JS) > 2000
    q = page.evaluate("() => JSON.parse(document.querySelector('#view3d').dataset.q)")
    assert_placed_as_the_service_says(page, api, "ur5", q)
    com = api.post("/v1/robots/ur5/center-of-mass", json={"q": q}).json()["position"]
    shown = page.evaluate(
        "() => document.querySelector('#view3d').robotDrawing.com.position.toArray()"
    )
    assert np.allclose(shown, com, atol=1e-6)
    before = page.evaluate(CANVAS_JS)
    q2 = move_joint(page, api, "ur5", "shoulder_lift_joint", -1.0)
    assert changed_pixels(page, before) > 2000
    assert_placed_as_the_service_says(page, api, "ur5", q2)
    page.locator("#view3d").screenshot(path=str(ARTIFACTS / "robot-view-ur5.png"))
    # Every mesh the visuals name was fetched once, from this service, and nothing else.
    visuals = api.get("/v1/robots/ur5/visuals").json()["visuals"]
    assets = {f"{server}/v1/robots/ur5/assets/{v['geometry']['asset']}" for v in visuals}
    fetched = Counter(u for u in page.log.requests if "/assets/" in u)
    assert set(fetched) == assets and set(fetched.values()) == {1}
    assert page.log.foreign_requests(server) == []
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_talos_bends_its_knee(page, server, api) -> None:
    open_explorer(page, server, "talos")
    wait_drawn(page, "talos")
    assert page.evaluate(ROBOT_PIXELS_JS) > 5000
    before = page.evaluate(CANVAS_JS)
    shin = frame_matrix(page, "leg_right_5_link")
    q = move_joint(page, api, "talos", "leg_right_4_joint", 1.5)  # the right knee
    assert changed_pixels(page, before) > 500
    assert not np.allclose(frame_matrix(page, "leg_right_5_link"), shin)
    assert_placed_as_the_service_says(page, api, "talos", q)
    # Redrawn on the next animation frame: placing ~100 frames costs well under a frame.
    place_ms = float(page.locator("#view3d").get_attribute("data-place-ms"))
    assert place_ms < 8, place_ms
    page.locator("#view3d").screenshot(path=str(ARTIFACTS / "robot-view-talos-knee.png"))
    if os.environ.get("ROBODYN_DOCS_SCREENSHOT"):  # refresh the README's picture on request
        page.locator("#view3d").screenshot(path=str(DOCS_SCREENSHOT))
    # Switching to another robot and back fetches no mesh again.
    for robot in ("ur5", "talos"):
        page.select_option("#robot", robot)
        wait_drawn(page, robot)
    fetched = Counter(u for u in page.log.requests if "/v1/robots/talos/assets/" in u)
    assert fetched and set(fetched.values()) == {1}
    assert page.log.foreign_requests(server) == []
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_an_upload_without_visuals_is_a_stick_figure(page, server, api) -> None:
    # (not planar_arm.urdf: the explorer's tests upload that one under a name of their own,
    # and the same description is the same robot)
    urdf = (ROBOTS_DIR / "cube_pendulum.urdf").read_text()
    stored = api.post("/v1/robots", json={"urdf": urdf, "name": "stick pendulum"})
    robot = stored.json()["id"]
    assert api.get(f"/v1/robots/{robot}/visuals").json() == {"visuals": []}
    open_explorer(page, server, robot)
    wait_drawn(page, robot)
    assert page.locator("#view3d").get_attribute("data-mode") == "stick"
    assert "stick figure" in page.locator("#view-progress").inner_text()
    assert page.evaluate(ROBOT_PIXELS_JS) > 200
    before = page.evaluate(CANVAS_JS)
    info = api.get(f"/v1/robots/{robot}").json()
    move_joint(page, api, robot, info["joints"][0]["name"], 1.2)
    assert changed_pixels(page, before) > 200
    page.locator("#view3d").screenshot(path=str(ARTIFACTS / "robot-view-stick.png"))
    assert page.log.foreign_requests(server) == [] and page.log.page_errors == []


def _heat(t: float) -> list[float]:
    stops = [[255, 255, 204], [253, 141, 60], [189, 0, 38]]
    x = min(1.0, max(0.0, t)) * 2
    k = min(1, math.floor(x))
    f = x - k
    return [(a + (b - a) * f) / 255 for a, b in zip(stops[k], stops[k + 1], strict=True)]


def test_links_coloured_by_gravity_over_effort_limit(page, server, api) -> None:
    open_explorer(page, server, "ur5")
    wait_drawn(page, "ur5")
    before = page.evaluate(CANVAS_JS)
    page.select_option("#link-colour", "gravity-effort")
    page.locator("#link-legend .legend-bar").wait_for()
    q = page.evaluate("() => JSON.parse(document.querySelector('#view3d').dataset.q)")
    g = api.post("/v1/robots/ur5/gravity", json={"q": q}).json()["gravity"]
    info = api.get("/v1/robots/ur5").json()
    for joint in info["joints"]:
        link = next(
            f["name"]
            for f in info["frames"]
            if f["type"] == "body" and f["parent_joint"] == joint["name"]
        )
        colour = page.evaluate(
            "(f) => document.querySelector('#view3d').robotDrawing.frames"
            ".get(f).userData.tint.color.toArray()",
            link,
        )
        ratio = abs(g[joint["idx_v"]]) / joint["effort_limit"][0]
        # three.js keeps colours in linear space: compare after its sRGB → linear conversion
        expected = [
            c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4 for c in _heat(ratio)
        ]
        assert np.allclose(colour, expected, atol=1e-6), joint["name"]
    assert changed_pixels(page, before) > 1000
    page.check("#show-triads")
    with_triads = page.evaluate(CANVAS_JS)
    page.uncheck("#show-triads")
    assert changed_pixels(page, with_triads) > 50
    page.select_option("#link-colour", "own")
    assert page.locator("#link-legend").inner_text() == ""
    assert page.log.page_errors == []


def test_talos_heat_map_and_bars_are_readable(page, server, api) -> None:
    open_explorer(page, server, "talos")
    info = api.get("/v1/robots/talos").json()
    fonts = page.eval_on_selector_all(
        "#heatmap text", "ts => ts.map(t => +t.getAttribute('font-size'))"
    )
    assert min(fonts) >= 11
    # Lines separate the limbs: base | legs | torso | arms | head (each line drawn twice).
    first = [
        "leg_left_1_joint",
        "leg_right_1_joint",
        "torso_1_joint",
        "arm_left_1_joint",
        "arm_right_1_joint",
        "head_1_joint",
    ]
    idx = {j["name"]: j["idx_v"] for j in info["joints"]}
    lines = page.eval_on_selector_all(
        "#heatmap line.limb", "ls => ls.map(l => [+l.getAttribute('y1'), +l.getAttribute('y2')])"
    )
    row_top = dict(
        page.eval_on_selector_all(
            "#heatmap rect.cell[data-col='0']",
            "rs => rs.map(r => [+r.dataset.row, +r.getAttribute('y')])",
        )
    )
    across = sorted(y1 for y1, y2 in lines if y1 == y2)
    assert across == sorted(row_top[idx[name]] for name in first)
    assert len(lines) == 2 * len(first)
    # Normalised colours: Mij / sqrt(Mii Mjj).
    page.check("#normalised")
    q = page.evaluate("() => JSON.parse(document.querySelector('#heatmap').dataset.q)")
    M = np.array(api.post("/v1/robots/talos/mass-matrix", json={"q": q}).json()["mass_matrix"])
    cells = page.eval_on_selector_all(
        "#heatmap rect.cell",
        "rs => rs.map(r => [+r.dataset.row, +r.dataset.col, +r.dataset.normalised])",
    )
    d = np.sqrt(np.diag(M))
    for i, j, value in cells:
        assert math.isclose(value, M[i, j] / (d[i] * d[j]), rel_tol=1e-9, abs_tol=1e-12)
    # The free-flyer's rows have their own scale: the largest joint bar is full width.
    groups = page.eval_on_selector_all(
        "#gravity-chart .bar-group", "ps => ps.map(p => p.textContent)"
    )
    assert len(groups) == 2 and "own scale" in groups[0]
    widths = page.eval_on_selector_all(
        "#gravity-chart .bar-row .bar", "bs => bs.map(b => parseFloat(b.style.width))"
    )
    assert max(widths[:6]) == 50 and max(widths[6:]) == 50
    page.locator("#mass-matrix-figure").screenshot(path=str(ARTIFACTS / "heatmap-talos.png"))


def test_an_upload_whose_meshes_were_not_uploaded_is_a_stick_figure(page, server, api) -> None:
    """Its visuals name meshes the service does not have (404 asset_not_found): once every
    load has failed, the view draws the stick figure instead of nothing."""
    urdf = (
        (ROBOTS_DIR / "planar_arm.urdf")
        .read_text()
        .replace(
            '<link name="link1">',
            '<link name="link1"><visual><geometry>'
            '<mesh filename="package://arm/meshes/link1.stl"/></geometry></visual>',
            1,
        )
    )
    stored = api.post("/v1/robots", json={"urdf": urdf, "name": "arm without its meshes"})
    robot = stored.json()["id"]
    visuals = api.get(f"/v1/robots/{robot}/visuals").json()["visuals"]
    assert [v["geometry"].get("asset") for v in visuals] == ["arm/meshes/link1.stl"]
    open_explorer(page, server, robot)
    wait_drawn(page, robot)
    page.wait_for_function("() => document.querySelector('#view3d').dataset.mode === 'stick'")
    assert page.evaluate(ROBOT_PIXELS_JS) > 100
    assert "stick figure" in page.locator("#view-progress").inner_text()
    assert page.log.page_errors == [] and page.log.foreign_requests(server) == []
    # the upload said the mesh is missing: it is named, and never fetched (no 404 asked for)
    assert "arm/meshes/link1.stl" in page.locator("#view-progress").inner_text()
    assert not [u for u in page.log.requests if f"/{robot}/assets/" in u]


def test_meshes_missing_from_an_upload_are_named_not_claimed_loaded(page, server, api) -> None:
    """Three mesh visuals, one mesh uploaded: the view says 1 of 3 loaded and names the two
    missing files (from the upload's `missing_mesh` warnings, without fetching them), and the
    warnings box counts them."""
    stl = (
        b"\0" * 80
        + (12).to_bytes(4, "little")
        + b"".join(
            np.array([0, 0, 1, 0, 0, 0, 0.1, 0, 0, 0, 0.1, 0], "<f4").tobytes() + b"\0\0"
            for _ in range(12)
        )
    )
    urdf = (ROBOTS_DIR / "planar_arm.urdf").read_text()
    urdf = urdf.replace('<link name="base"/>', '<link name="base"></link>')
    for link in ("base", "link1", "link2"):
        urdf = urdf.replace(
            f'<link name="{link}">',
            f'<link name="{link}"><visual><geometry>'
            f'<mesh filename="package://arm3/meshes/{link}.stl"/></geometry>'
            "</visual>",
            1,
        )
    stored = api.post(
        "/v1/robots",
        json={
            "urdf": urdf,
            "name": "arm with one mesh of three",
            "assets": {"arm3/meshes/link1.stl": base64.b64encode(stl).decode()},
        },
    )
    assert stored.status_code == 201, stored.text
    robot = stored.json()["id"]
    missing = [w["file"] for w in stored.json()["warnings"] if w["code"] == "missing_mesh"]
    assert missing == ["arm3/meshes/base.stl", "arm3/meshes/link2.stl"]
    open_explorer(page, server, robot)
    wait_drawn(page, robot)
    progress = page.locator("#view-progress")
    text = progress.inner_text()
    assert text.startswith("1 of 3 meshes loaded"), text
    assert all(f in text for f in missing) and "meshes loaded." not in text, text
    assert progress.get_attribute("data-failed") == "2"
    assert "2 missing mesh file(s)" in page.locator("#warnings").inner_text()
    fetched = [u for u in page.log.requests if f"/{robot}/assets/" in u]
    assert len(fetched) == 1 and fetched[0].endswith("arm3/meshes/link1.stl"), fetched
    assert page.log.page_errors == []
