"""The explorer's Payload view in a real browser: a payload at a frame (mass, offset) gives the
g(q) and the payload capacity the API gives for that state, both follow the joints and the
payload as they change, and the limiting joint is highlighted."""

from __future__ import annotations

import json

import numpy as np

from tests.browser.test_explorer import (
    CONTRAST_JS,
    close,
    open_explorer,
    set_slider,
    shown_bars,
    wait_computed,
)


def wait_payload(page, *, mass: float | None = None) -> list[float]:
    """Wait until the Payload view has drawn its answers (for `mass` kg, if given): its q."""
    page.wait_for_function(
        """(mass) => {
        const s = document.querySelector('#payload-status');
        const view = document.querySelector('#payload-view');
        return s.textContent.startsWith('Computed') && view.dataset.q &&
          (mass === null || document.querySelector('#payload-share').dataset.value ==
             String(mass / +document.querySelector('#payload-capacity').dataset.value));
    }""",
        arg=mass,
    )
    return json.loads(page.locator("#payload-view").get_attribute("data-q"))


def assert_matches_api(page, api, q, frame: str, mass: float, com: list[float]) -> None:
    payloads = [{"frame": frame, "mass": mass, "center_of_mass": com}]
    g = api.post("/v1/robots/ur5/gravity", json={"q": q, "payloads": payloads}).json()
    cap = api.post(
        "/v1/robots/ur5/payload-capacity", json={"q": q, "frame": frame, "center_of_mass": com}
    ).json()
    assert close(shown_bars(page, "payload-gravity-chart"), g["gravity"])
    shown = float(page.locator("#payload-capacity").get_attribute("data-value"))
    assert np.isclose(shown, cap["mass"], rtol=1e-12)
    assert page.locator("#payload-limiting").text_content() == cap["limiting_joint"]
    shown_range = json.loads(page.locator("#payload-range").get_attribute("data-value"))
    assert shown_range == cap["mass_range"]  # the masses within every limit
    limiting = page.eval_on_selector_all(
        "#payload-gravity-chart .bar-row.limiting", "rows => rows.map(r => +r.dataset.index)"
    )
    names = [j["name"] for j in api.get("/v1/robots/ur5").json()["joints"]]
    assert [names[i] for i in limiting] == [cap["limiting_joint"]]
    row = page.locator("#payload-table tr.limiting")
    assert row.count() == 1 and row.get_attribute("data-joint") == cap["limiting_joint"]


def test_a_payload_shows_gravity_and_capacity_and_follows_the_state(page, server, api) -> None:
    open_explorer(page, server, "ur5")
    page.click("#payload-view-button")
    assert page.locator("#payload-view").is_visible()
    assert not page.locator("#mass-matrix-figure").is_visible()  # the Dynamics view's
    assert page.locator("#payload-frame").input_value() == "tool0"
    q = wait_payload(page, mass=3.0)
    assert_matches_api(page, api, q, "tool0", 3.0, [0.0, 0.0, 0.0])

    # a heavier payload, off the flange's axis: g(q) changes, the capacity does not depend on
    # the payload's mass (it is the heaviest point mass at that offset)
    page.fill("#payload-mass", "5")
    page.fill("#payload-z", "0.2")
    page.fill("#payload-x", "0.1")
    q = wait_payload(page, mass=5.0)
    assert_matches_api(page, api, q, "tool0", 5.0, [0.1, 0.0, 0.2])

    # a joint moves: both follow
    info = api.get("/v1/robots/ur5").json()
    shoulder = next(i for i, j in enumerate(info["joints"]) if j["name"] == "shoulder_lift_joint")
    set_slider(page, f"#q-{shoulder}", -0.4)
    page.wait_for_function(
        "(k) => JSON.parse(document.querySelector('#payload-view').dataset.q || '[]')[k] === -0.4",
        arg=shoulder,
    )
    wait_computed(page)
    q = wait_payload(page, mass=5.0)
    assert q[shoulder] == -0.4
    assert_matches_api(page, api, q, "tool0", 5.0, [0.1, 0.0, 0.2])

    # a bad mass is said, not sent
    page.fill("#payload-mass", "-1")
    page.wait_for_function(
        "() => document.querySelector('#payload-status').classList.contains('error')"
    )
    page.click("#dynamics-view-button")
    assert page.locator("#mass-matrix-figure").is_visible()
    assert not page.locator("#payload-view").is_visible()
    assert page.log.console_errors == [] and page.log.page_errors == []
    assert page.log.foreign_requests(server) == []


def test_the_payload_view_has_readable_contrast(page, server) -> None:
    open_explorer(page, server, "ur5")
    page.click("#payload-view-button")
    wait_payload(page)
    measured = page.evaluate(CONTRAST_JS)
    assert any(tag == "DD#payload-limiting" for tag, _, _ in measured)
    poor = [(tag, text, round(ratio, 2)) for tag, text, ratio in measured if ratio < 4.5]
    assert poor == []


# The payload frame's mark in the 3-D view: its placement (column-major 4×4), whether it is
# shown, each axis's direction and colour (AxesHelper: two vertices per axis), and the ball's
# position in the frame.
MARK_JS = """() => {
  const view = document.querySelector('#view3d').robotDrawing;
  const mark = view.frameMark;
  if (!mark) return null;
  const axes = mark.userData.axes.geometry.attributes;
  const axis = (k) => ({
    direction: [0, 1, 2].map((c) => axes.position.getComponent(2 * k + 1, c) -
                                    axes.position.getComponent(2 * k, c)),
    colours: [2 * k, 2 * k + 1].map((v) => [0, 1, 2].map((c) => axes.color.getComponent(v, c))),
  });
  return { matrix: [...mark.matrix.elements], visible: mark.visible,
           frame: view.container.dataset.markedFrame || null,
           q: JSON.parse(view.container.dataset.q),
           axes: [0, 1, 2].map(axis), point: mark.userData.point.position.toArray() };
}"""

# Pixels of the canvas that change when the mark is hidden, by colour: the drawn axes.
MARK_PIXELS_JS = """() => {
  const view = document.querySelector('#view3d').robotDrawing;
  const grab = () => {
    view.renderer.render(view.scene, view.camera);
    const c = view.renderer.domElement, off = document.createElement('canvas');
    [off.width, off.height] = [c.width, c.height];
    const ctx = off.getContext('2d');
    ctx.drawImage(c, 0, 0);
    return ctx.getImageData(0, 0, c.width, c.height).data;
  };
  const shown = grab();
  view.frameMark.visible = false;
  const hidden = grab();
  view.frameMark.visible = true;
  grab();
  const n = { red: 0, green: 0, blue: 0 };
  for (let i = 0; i < shown.length; i += 4) {
    const [r, g, b] = [shown[i], shown[i + 1], shown[i + 2]];
    if (Math.abs(r - hidden[i]) + Math.abs(g - hidden[i + 1]) + Math.abs(b - hidden[i + 2]) < 24) {
      continue;
    }
    if (r > 150 && g < 90 && b < 90) n.red++;
    if (g > 150 && r < 90 && b < 90) n.green++;
    if (b > 150 && r < 90 && g < 90) n.blue++;
  }
  return n;
}"""


def wait_marked(page, frame: str) -> dict:
    """Wait until the 3-D view marks `frame` at the Payload view's q: the mark's state."""
    page.wait_for_function(
        """(f) => {
        const v = document.querySelector('#view3d'), p = document.querySelector('#payload-view');
        return v.dataset.markedFrame === f && v.dataset.q === p.dataset.q }""",
        arg=frame,
    )
    return page.evaluate(MARK_JS)


def assert_marked_where_the_service_places(api, mark: dict, frame: str) -> None:
    answer = api.post(
        "/v1/robots/ur5/frame-placements", json={"q": mark["q"], "frames": [frame]}
    ).json()
    M = np.array(mark["matrix"]).reshape(4, 4).T  # three.js stores column-major
    assert mark["visible"] and mark["frame"] == frame
    assert np.allclose(M[:3, 3], answer["positions"][0], atol=1e-6)  # float32 in three.js
    assert np.allclose(M[:3, :3], answer["rotations"][0], atol=1e-6)


def test_the_payload_frames_axes_are_drawn_at_that_frame(page, server, api) -> None:
    """The centre of mass is given in the payload frame's axes: the 3-D view draws them at that
    frame (x red, y green, z blue) with the centre of mass, following the joints, and the text
    says so; they go with the Payload view."""
    open_explorer(page, server, "ur5")
    page.click("#payload-view-button")
    wait_payload(page)
    mark = wait_marked(page, "tool0")
    assert_marked_where_the_service_places(api, mark, "tool0")
    for k, (axis, colour) in enumerate(zip(mark["axes"], ("red", "green", "blue"), strict=True)):
        unit = np.eye(3)[k]
        assert np.allclose(np.array(axis["direction"]) / np.linalg.norm(axis["direction"]), unit)
        for c in axis["colours"]:  # both ends: only that primary
            assert c[k] > 0.3 and np.allclose(np.delete(c, k), 0), (colour, c)
    assert "tool0's axes" in page.locator("#payload-axes").inner_text()
    shown = page.evaluate(MARK_PIXELS_JS)
    assert min(shown.values()) >= 5, shown  # each axis shows in its colour

    # the centre of mass, in those axes
    page.fill("#payload-x", "0.1")
    page.fill("#payload-z", "0.2")
    page.wait_for_function(
        "() => document.querySelector('#view3d').robotDrawing.frameMark"
        ".userData.point.position.z === 0.2"
    )
    assert page.evaluate(MARK_JS)["point"] == [0.1, 0.0, 0.2]

    # the mark follows the joints
    info = api.get("/v1/robots/ur5").json()
    shoulder = next(i for i, j in enumerate(info["joints"]) if j["name"] == "shoulder_lift_joint")
    set_slider(page, f"#q-{shoulder}", -0.7)
    page.wait_for_function(
        "(k) => JSON.parse(document.querySelector('#view3d').dataset.q)[k] === -0.7", arg=shoulder
    )
    wait_computed(page)
    wait_payload(page)
    mark = wait_marked(page, "tool0")
    assert mark["q"][shoulder] == -0.7
    assert_marked_where_the_service_places(api, mark, "tool0")

    # another frame
    page.select_option("#payload-frame", "forearm_link")
    wait_payload(page)
    assert_marked_where_the_service_places(api, wait_marked(page, "forearm_link"), "forearm_link")
    assert "forearm_link's axes" in page.locator("#payload-axes").inner_text()

    page.click("#dynamics-view-button")
    page.wait_for_function("() => !document.querySelector('#view3d').dataset.markedFrame")
    assert not page.evaluate(MARK_JS)["visible"]
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_nulls_of_the_capacity_show_as_not_available(page, server, api) -> None:
    """payload-capacity answers null where nothing limits: the page shows n/a with a title
    saying why, in the summary (a frame fixed to the world: no capacity at all) and per joint
    (mass_per_joint), never a number."""
    open_explorer(page, server, "ur5")
    page.click("#payload-view-button")
    q = wait_payload(page)
    cap = api.post(
        "/v1/robots/ur5/payload-capacity",
        json={"q": q, "frame": "tool0", "center_of_mass": [0] * 3},
    ).json()
    assert None in cap["mass_per_joint"]  # the shoulder pan and wrists, holding still
    cells = page.locator("#payload-table tr[data-joint] td:nth-child(5)")
    for k, value in enumerate(cap["mass_per_joint"]):
        cell = cells.nth(k)
        if value is None:
            assert cell.inner_text() == "n/a"
            assert "never limits" in cell.locator(".no-value").get_attribute("title")
        else:
            assert float(cell.inner_text()) == float(f"{value:.5g}")

    page.select_option("#payload-frame", "base_link")
    page.wait_for_function(
        "() => document.querySelector('#payload-capacity').textContent.includes('base_link')"
    )
    q = wait_payload(page)
    cap = api.post(
        "/v1/robots/ur5/payload-capacity",
        json={"q": q, "frame": "base_link", "center_of_mass": [0] * 3},
    ).json()
    assert cap["mass"] is None and set(cap["mass_per_joint"]) == {None}
    summary = page.locator("#payload-capacity")
    assert summary.inner_text().startswith("n/a at base_link")
    assert "fixed to the world" in summary.locator(".no-value").get_attribute("title")
    assert cells.all_inner_texts() == ["n/a"] * 6
    assert page.log.console_errors == [] and page.log.page_errors == []
