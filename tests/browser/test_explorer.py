"""The explorer page in a real browser, used as a person would: it loads cleanly, lists the
robots, and what it draws for a configuration equals what the API answers for it."""

from __future__ import annotations

import json
import math
from itertools import pairwise
from pathlib import Path
from urllib.parse import urlsplit

import httpx
import numpy as np
import pytest

from tests.browser.conftest import ARTIFACTS

ROBOTS_DIR = Path(__file__).resolve().parents[2] / "robots" / "textbook"
TOL = 1e-9


def close(a, b) -> bool:
    return np.allclose(np.asarray(a, float), np.asarray(b, float), rtol=TOL, atol=TOL)


def open_explorer(page, server: str, robot: str | None = None) -> None:
    page.goto(server + "/")
    wait_computed(page)
    if robot is not None and page.locator("#robot").input_value() != robot:
        before = page.locator("#heatmap").get_attribute("data-robot")
        page.select_option("#robot", robot)
        page.wait_for_function(
            "(r) => document.querySelector('#heatmap').dataset.robot === r", arg=robot
        )
        assert before != robot
        wait_computed(page)


def wait_computed(page) -> None:
    """Wait until the page has drawn the answers for the state its controls show."""
    page.wait_for_function("""() => {
        const s = document.querySelector('#status');
        return document.querySelector('#heatmap').dataset.q && s.textContent.startsWith('Computed')
    }""")


def shown_state(page) -> tuple[list[float], list[float]]:
    """The q and v the page says its drawing was computed for."""
    box = page.locator("#heatmap")
    return json.loads(box.get_attribute("data-q")), json.loads(box.get_attribute("data-v"))


def shown_mass_matrix(page) -> np.ndarray:
    cells = page.eval_on_selector_all(
        "#heatmap rect.cell", "rs => rs.map(r => [+r.dataset.row, +r.dataset.col, r.dataset.value])"
    )
    n = math.isqrt(len(cells))
    assert n * n == len(cells) and n > 0
    M = np.full((n, n), np.nan)
    for i, j, value in cells:
        M[i, j] = float(value)
    return M


def shown_bars(page, chart: str) -> list[float]:
    return page.eval_on_selector_all(
        f"#{chart} .bar-row", "rows => rows.map(r => parseFloat(r.dataset.value))"
    )


def set_slider(page, selector: str, value: float) -> None:
    """Drag-equivalent: set a range input and fire the `input` event a drag fires."""
    page.eval_on_selector(
        selector,
        """(input, value) => {
        input.value = String(value);
        input.dispatchEvent(new Event('input', {bubbles: true}));
    }""",
        value,
    )


def position_sliders(page) -> list[float]:
    return [
        float(x)
        for x in page.eval_on_selector_all("#joints input[id^='q-']", "xs => xs.map(x => x.value)")
    ]


def velocity_sliders(page) -> list[float]:
    return [
        float(x)
        for x in page.eval_on_selector_all("#joints input[id^='v-']", "xs => xs.map(x => x.value)")
    ]


def assert_matches_api(page, api: httpx.Client, robot: str, q, v) -> None:
    """Heat map, bar charts, mass and kinetic energy equal the API's answers for (q, v)."""
    M = np.array(api.post(f"/v1/robots/{robot}/mass-matrix", json={"q": q}).json()["mass_matrix"])
    g = api.post(f"/v1/robots/{robot}/gravity", json={"q": q}).json()["gravity"]
    Cv = api.post(f"/v1/robots/{robot}/coriolis", json={"q": q, "v": v}).json()["coriolis_forces"]
    info = api.get(f"/v1/robots/{robot}").json()
    assert close(shown_mass_matrix(page), M)
    assert close(shown_bars(page, "gravity-chart"), g)
    assert close(shown_bars(page, "coriolis-chart"), Cv)
    T = float(page.locator("#kinetic-energy").get_attribute("data-value"))
    assert math.isclose(T, 0.5 * np.asarray(v) @ M @ np.asarray(v), rel_tol=TOL, abs_tol=TOL)
    mass = float(page.locator("#total-mass").get_attribute("data-value"))
    assert mass == info["total_mass"]


def test_page_loads_cleanly_and_lists_every_robot(page, server, api) -> None:
    open_explorer(page, server)
    listed = page.eval_on_selector_all("#robot option", "os => os.map(o => o.value)")
    expected = {r["id"] for r in api.get("/v1/robots").json()["robots"]}
    assert set(listed) == expected and len(listed) == len(expected)
    assert page.locator("#robot").input_value() == "ur5"  # the default choice
    assert page.title() == "robodyn explorer"
    assert page.log.console_errors == [] and page.log.page_errors == []
    assert page.log.failed == []
    assert page.log.foreign_requests(server) == []
    # Every control is labelled: a <label for> names each input and select.
    unlabelled = page.eval_on_selector_all(
        "input, select",
        "xs => xs.filter(x => !x.labels || x.labels.length === 0).map(x => x.id || x.name)",
    )
    assert unlabelled == []


def test_moving_a_slider_redraws_the_api_values_for_that_configuration(page, server, api):
    open_explorer(page, server, "ur5")
    q0, v0 = shown_state(page)
    M0 = shown_mass_matrix(page)
    assert_matches_api(page, api, "ur5", q0, v0)

    info = api.get("/v1/robots/ur5").json()
    elbow = next(i for i, j in enumerate(info["joints"]) if j["name"] == "elbow_joint")
    set_slider(page, f"#q-{elbow}", 1.234)
    page.wait_for_function(
        "(k) => JSON.parse(document.querySelector('#heatmap').dataset.q)[k] === 1.234",
        arg=info["joints"][elbow]["idx_q"],
    )
    wait_computed(page)
    q, v = shown_state(page)
    # ur5's joints are all revolute: q is exactly what the sliders show.
    assert q == position_sliders(page) and v == velocity_sliders(page)
    assert q[elbow] == 1.234 and q[:elbow] == q0[:elbow]
    assert not close(shown_mass_matrix(page), M0)  # the move changed M(q) ...
    assert_matches_api(page, api, "ur5", q, v)  # ... to what the service says it is

    # A velocity slider changes C(q, v) v and T, not M(q).
    set_slider(page, "#v-0", -2.0)
    page.wait_for_function(
        "() => JSON.parse(document.querySelector('#heatmap').dataset.v)[0] === -2"
    )
    wait_computed(page)
    q2, v2 = shown_state(page)
    assert q2 == q and v2[0] == -2.0
    assert_matches_api(page, api, "ur5", q2, v2)
    assert page.log.console_errors == [] and page.log.foreign_requests(server) == []


def test_hovering_a_cell_shows_its_value_and_joint_pair(page, server, api) -> None:
    open_explorer(page, server, "ur5")
    q, _ = shown_state(page)
    M = api.post("/v1/robots/ur5/mass-matrix", json={"q": q}).json()["mass_matrix"]
    names = [j["name"] for j in api.get("/v1/robots/ur5").json()["joints"]]
    page.hover("#heatmap rect[data-row='1'][data-col='2']")
    tip = page.locator("#tooltip")
    assert tip.is_visible()
    label, value = tip.inner_text().split(" = ")
    assert label == f"M[{names[1]}, {names[2]}]"
    assert math.isclose(float(value), M[1][2], rel_tol=1e-5)
    page.screenshot(
        path=str(ARTIFACTS / "tooltip.png"), clip=page.locator("#mass-matrix-figure").bounding_box()
    )
    page.mouse.move(1, 1)
    assert tip.is_hidden()


def test_sliders_are_bounded_by_the_joint_limits(page, server, api) -> None:
    open_explorer(page, server, "panda")
    info = api.get("/v1/robots/panda").json()
    bounds = page.eval_on_selector_all(
        "#joints input[id^='q-']", "xs => xs.map(x => [+x.min, +x.max])"
    )
    joints = [j for j in info["joints"] if j["nv"] == 1]
    assert len(bounds) == len(joints) == info["nv"]
    for (lo, hi), j in zip(bounds, joints, strict=True):
        assert (lo, hi) == (j["lower"][0], j["upper"][0]), j["name"]


def test_keyboard_moves_a_slider_and_the_page_recomputes(page, server, api) -> None:
    open_explorer(page, server, "ur5")
    slider = page.locator("#q-1")
    lo, hi = float(slider.get_attribute("min")), float(slider.get_attribute("max"))
    start = float(slider.input_value())
    page.focus("#robot")  # Tab reaches the sliders in reading order
    reached = []
    for _ in range(10):
        page.keyboard.press("Tab")
        reached.append(page.evaluate("document.activeElement.id"))
        if reached[-1] == "q-1":
            break
    assert reached[:4] == ["posture", "q-0", "v-0", "q-1"], reached
    for _ in range(3):
        page.keyboard.press("ArrowRight")
    moved = float(slider.input_value())
    assert moved == pytest.approx(start + 3 * (hi - lo) / 100)  # step "any": 1 % per key
    page.wait_for_function(
        "(x) => JSON.parse(document.querySelector('#heatmap').dataset.q)[1] === x", arg=moved
    )
    wait_computed(page)
    q, v = shown_state(page)
    assert_matches_api(page, api, "ur5", q, v)
    page.keyboard.press("PageDown")  # 10 % of the range
    assert float(slider.input_value()) == pytest.approx(moved - (hi - lo) / 10)
    page.keyboard.press("End")  # the slider stops at the joint's upper limit
    assert float(slider.input_value()) == hi
    page.keyboard.press("Home")
    assert float(slider.input_value()) == lo
    page.wait_for_function(
        "(x) => JSON.parse(document.querySelector('#heatmap').dataset.q)[1] === x", arg=lo
    )
    wait_computed(page)
    assert_matches_api(page, api, "ur5", *shown_state(page))


def test_free_flyer_base_gives_a_unit_quaternion(page, server, api) -> None:
    open_explorer(page, server, "solo12")
    info = api.get("/v1/robots/solo12").json()
    base = info["joints"][0]
    assert base["type"] == "free_flyer"
    labels = page.eval_on_selector_all(
        "#joints input[id^='q-']", "xs => xs.map(x => x.labels[0].textContent)"
    )
    assert len(labels) == info["nv"]  # one position control per velocity coordinate
    yaw = next(i for i, t in enumerate(labels) if t.startswith(f"{base['name']} yaw"))
    set_slider(page, f"#q-{yaw}", 0.9)
    page.wait_for_function("""() => {
        const q = JSON.parse(document.querySelector('#heatmap').dataset.q);
        return Math.abs(q[5] - Math.sin(0.45)) < 1e-12 }""")
    wait_computed(page)
    q, v = shown_state(page)
    # From the neutral base orientation, a yaw of 0.9 rad is the quaternion (0, 0, sin, cos).
    assert np.allclose(q[3:7], [0, 0, math.sin(0.45), math.cos(0.45)], atol=1e-12)
    assert_matches_api(page, api, "solo12", q, v)


BALL_MJCF = """<mujoco model="ball"><worldbody><body name="bob" pos="0 0 1">
  <joint name="socket" type="ball"/>
  <inertial pos="0.05 0.02 -0.3" mass="2" diaginertia="0.05 0.06 0.02"/>
</body></worldbody></mujoco>"""


def test_mjcf_ball_joint_gives_a_w_first_quaternion(page, server, api) -> None:
    """An MJCF model's q is MuJoCo's qpos: the page writes a ball joint's quaternion w first."""
    r = api.post("/v1/robots", json={"mjcf": BALL_MJCF, "name": "ball"})
    assert r.status_code in (200, 201), r.text
    robot = r.json()["id"]
    assert r.json()["neutral_configuration"] == [1, 0, 0, 0]
    open_explorer(page, server, robot)
    labels = page.eval_on_selector_all(
        "#joints input[id^='q-']", "xs => xs.map(x => x.labels[0].textContent)"
    )
    yaw = next(i for i, t in enumerate(labels) if t.startswith("socket yaw"))
    set_slider(page, f"#q-{yaw}", 0.9)
    page.wait_for_function("""() => {
        const q = JSON.parse(document.querySelector('#heatmap').dataset.q);
        return Math.abs(q[3] - Math.sin(0.45)) < 1e-12 }""")
    wait_computed(page)
    q, v = shown_state(page)
    # a yaw of 0.9 rad from the identity is (w, x, y, z) = (cos, 0, 0, sin)
    assert np.allclose(q, [math.cos(0.45), 0, 0, math.sin(0.45)], atol=1e-12)
    assert_matches_api(page, api, robot, q, v)


def test_continuous_joint_angle_becomes_cos_sin(page, server, api) -> None:
    open_explorer(page, server, "double_pendulum_continuous")
    info = api.get("/v1/robots/double_pendulum_continuous").json()
    assert {j["type"] for j in info["joints"]} == {"continuous"}
    set_slider(page, "#q-1", -2.5)
    idx = info["joints"][1]["idx_q"]
    page.wait_for_function(
        "(k) => JSON.parse(document.querySelector('#heatmap').dataset.q)[k + 1] < -0.5", arg=idx
    )
    wait_computed(page)
    q, v = shown_state(page)
    assert q[idx : idx + 2] == pytest.approx([math.cos(-2.5), math.sin(-2.5)], abs=1e-15)
    assert_matches_api(page, api, "double_pendulum_continuous", q, v)


def test_an_invalid_upload_shows_the_servers_error(page, server, api) -> None:
    open_explorer(page, server)
    bad = (
        b'<robot name="broken"><link name="base"/>'
        b'<joint name="j1" type="revolute"><parent link="base"/><child link="nowhere"/>'
        b'<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        b"</robot>"
    )
    expected = api.post(
        "/v1/robots", json={"urdf": bad.decode(), "root_joint": "fixed", "inertia_check": "reject"}
    )
    assert expected.status_code == 422
    page.set_input_files(
        "#urdf-file", files=[{"name": "broken.urdf", "mimeType": "text/xml", "buffer": bad}]
    )
    page.click("#upload button[type=submit]")
    detail = page.locator("#upload-status .detail")
    detail.wait_for()
    assert detail.inner_text() == expected.json()["detail"]
    assert "invalid_model" in page.locator("#upload-status").inner_text()
    assert page.log.page_errors == [] and page.log.foreign_requests(server) == []


def test_a_valid_upload_is_listed_chosen_and_explored(page, server, api) -> None:
    open_explorer(page, server)
    urdf = (ROBOTS_DIR / "planar_arm.urdf").read_bytes()
    page.set_input_files(
        "#urdf-file", files=[{"name": "arm.urdf", "mimeType": "text/xml", "buffer": urdf}]
    )
    page.fill("#upload-name", "my arm")
    page.click("#upload button[type=submit]")
    page.locator("#upload-status.ok").wait_for()
    uploads = [r for r in api.get("/v1/robots").json()["robots"] if r["source"] == "upload"]
    robot = next(r["id"] for r in uploads if r["name"] == "my arm")
    page.wait_for_function(
        "(r) => document.querySelector('#heatmap').dataset.robot === r", arg=robot
    )
    wait_computed(page)
    assert page.locator("#robot").input_value() == robot
    assert robot in page.locator("#upload-status").inner_text()
    q, v = shown_state(page)
    assert_matches_api(page, api, robot, q, v)
    assert page.log.console_errors == [] and page.log.foreign_requests(server) == []


def _cell_colours(page) -> list[tuple[float, tuple[int, int, int]]]:
    cells = page.eval_on_selector_all(
        "#heatmap rect.cell", "rs => rs.map(r => [r.dataset.value, r.getAttribute('fill')])"
    )
    return [(float(v), tuple(int(c) for c in fill[4:-1].split(","))) for v, fill in cells]


@pytest.mark.parametrize("robot", ["ur5", "solo12", "planar_arm"])
def test_colour_scale_follows_the_value(page, server, api, robot) -> None:
    """Largest |M| gets the full end colour of its sign, zero the neutral grey, and the
    colour's distance from grey grows with |M|, on the linear and the log scale. The page
    starts on the log scale when M's diagonal spans more than two decades."""
    open_explorer(page, server, robot)
    q, _ = shown_state(page)
    M = np.array(api.post(f"/v1/robots/{robot}/mass-matrix", json={"q": q}).json()["mass_matrix"])
    diag = np.abs(np.diag(M))
    assert page.locator("#log-scale").is_checked() == bool(diag.max() > 100 * diag.min())
    grey = (247, 247, 247)
    for checked in (True, False):
        page.locator("#log-scale").set_checked(checked)
        cells = _cell_colours(page)
        assert close([v for v, _ in cells], M.ravel())
        top = max(cells, key=lambda c: abs(c[0]))
        assert top[1] == ((178, 24, 43) if top[0] > 0 else (33, 102, 172))
        assert all(colour == grey for value, colour in cells if value == 0)
        # How far each colour is along its arm of the scale (grey → red, or grey → blue):
        # monotone in |M|, up to the rounding of colours to integers.
        full = {True: (178, 24, 43), False: (33, 102, 172)}
        along = sorted(
            (
                abs(v),
                sum(abs(a - b) for a, b in zip(c, grey, strict=True))
                / sum(abs(a - b) for a, b in zip(full[v > 0], grey, strict=True)),
            )
            for v, c in cells
        )
        assert all(f2 >= f1 - 0.01 for (_, f1), (_, f2) in pairwise(along))
        assert along[-1][1] == 1.0
        signs = {(v > 0, c[0] > c[2]) for v, c in cells if c != grey}
        assert signs <= {(True, True), (False, False)}  # red for positive, blue for negative
        page.screenshot(
            path=str(ARTIFACTS / f"heatmap-{robot}-{'log' if checked else 'lin'}.png"),
            clip=page.locator("#mass-matrix-figure").bounding_box(),
        )


def test_zero_velocity_button_zeroes_kinetic_energy_and_coriolis(page, server, api) -> None:
    open_explorer(page, server, "panda")
    assert float(page.locator("#kinetic-energy").get_attribute("data-value")) > 0
    page.click("#zero-velocity")
    page.wait_for_function(
        "() => JSON.parse(document.querySelector('#heatmap').dataset.v).every(x => x === 0)"
    )
    wait_computed(page)
    q, v = shown_state(page)
    assert v == [0.0] * len(v) and velocity_sliders(page) == v
    assert float(page.locator("#kinetic-energy").get_attribute("data-value")) == 0.0
    assert_matches_api(page, api, "panda", q, v)
    assert not any(shown_bars(page, "coriolis-chart"))


def test_page_waits_for_a_service_still_loading_its_catalog(page, server) -> None:
    """Opened right after start, the list answers 503 not_ready: the page says so and asks
    again until the service is ready (simulated by answering the first two lists with 503)."""
    refused = []

    def not_ready_twice(route) -> None:
        if len(refused) < 2:
            refused.append(route.request.url)
            route.fulfill(
                status=503,
                content_type="application/problem+json",
                headers={"Retry-After": "1"},
                body=json.dumps(
                    {
                        "type": "about:blank",
                        "title": "Not ready",
                        "status": 503,
                        "code": "not_ready",
                        "detail": "the robot catalog is still loading",
                    }
                ),
            )
        else:
            route.continue_()

    # the robot list's pages (GET v1/robots?limit=...&cursor=...), whatever their query
    page.route(lambda url: urlsplit(url).path == "/v1/robots", not_ready_twice)
    page.goto(server + "/")
    page.wait_for_function(
        "() => document.querySelector('#status').textContent.includes('still loading')"
    )
    wait_computed(page)
    assert len(refused) == 2
    assert page.locator("#robot").input_value() == "ur5"
    assert page.log.page_errors == [] and page.log.foreign_requests(server) == []


CONTRAST_JS = """() => {
  const rgba = (s) => (s.match(/[\\d.]+/g) || []).map(Number);
  const lum = ([r, g, b]) => {
    const f = (c) => { c /= 255; return c <= 0.03928 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4; };
    return 0.2126 * f(r) + 0.7152 * f(g) + 0.0722 * f(b);
  };
  const background = (el) => {
    for (let e = el; e; e = e.parentElement) {
      const c = rgba(getComputedStyle(e).backgroundColor);
      if (c.length === 3 || c[3] > 0) return c;
    }
    return [255, 255, 255];
  };
  const out = [];
  for (const el of document.querySelectorAll('body *')) {
    const own = [...el.childNodes].some((n) => n.nodeType === 3 && n.textContent.trim());
    if (!own || !el.getClientRects().length) continue;
    if (el.closest('.visually-hidden, [hidden], option, optgroup')) continue;
    const style = getComputedStyle(el);
    const fg = rgba(el instanceof SVGElement ? style.fill : style.color);
    const [a, b] = [lum(fg), lum(background(el))].sort((x, y) => y - x);
    out.push([el.tagName + (el.id ? '#' + el.id : ''), el.textContent.trim().slice(0, 30),
              (a + 0.05) / (b + 0.05)]);
  }
  return out;
}"""


def test_every_visible_text_has_readable_contrast(page, server) -> None:
    """WCAG AA: at least 4.5:1 between each visible text and the background behind it,
    including the heat map's labels, the tooltip and an upload error."""
    open_explorer(page, server, "ur5")
    page.hover("#heatmap rect[data-row='0'][data-col='0']")
    page.set_input_files(
        "#urdf-file", files=[{"name": "x.urdf", "mimeType": "text/xml", "buffer": b"<robot"}]
    )
    page.click("#upload button[type=submit]")
    page.locator("#upload-status .detail").wait_for()
    page.hover("#heatmap rect[data-row='0'][data-col='1']")
    measured = page.evaluate(CONTRAST_JS)
    kinds = {tag.split("#")[0] for tag, _, _ in measured}
    assert {"H1", "LABEL", "OUTPUT", "BUTTON", "text", "SPAN", "DIV", "DD"} <= kinds
    assert any(tag == "DIV#tooltip" for tag, _, _ in measured)
    poor = [(tag, text, round(ratio, 2)) for tag, text, ratio in measured if ratio < 4.5]
    assert poor == []


def test_planar_root_gives_x_y_and_an_angle(page, server, api) -> None:
    """An upload with a planar root: x, y sliders (unbounded limits fall back to ±1 m) and an
    angle θ sent as (cos θ, sin θ)."""
    urdf = (ROBOTS_DIR / "planar_arm.urdf").read_text()
    stored = api.post(
        "/v1/robots", json={"urdf": urdf, "root_joint": "planar", "name": "arm on a plane"}
    )
    assert stored.status_code in (200, 201), stored.text
    robot = stored.json()["id"]
    root = stored.json()["joints"][0]
    assert root["type"] == "planar" and (root["nq"], root["nv"]) == (4, 3)
    open_explorer(page, server, robot)
    bounds = page.eval_on_selector_all(
        "#joints input[id^='q-']", "xs => xs.slice(0, 3).map(x => [+x.min, +x.max])"
    )
    assert bounds[:2] == [[-1, 1], [-1, 1]]
    assert bounds[2] == pytest.approx([-math.pi, math.pi])
    set_slider(page, "#q-0", 0.25)
    set_slider(page, "#q-2", 2.0)
    page.wait_for_function("""() => {
        const q = JSON.parse(document.querySelector('#heatmap').dataset.q);
        return q[0] === 0.25 && q[2] < 0 }""")
    wait_computed(page)
    q, v = shown_state(page)
    assert q[:4] == pytest.approx([0.25, 0.0, math.cos(2.0), math.sin(2.0)], abs=1e-15)
    assert_matches_api(page, api, robot, q, v)


def _listed(page) -> list[str]:
    return page.eval_on_selector_all("#robot option", "os => os.map(o => o.value)")


def test_an_upload_made_through_the_api_appears_when_the_page_comes_back(page, server, api) -> None:
    open_explorer(page, server, "planar_arm")
    urdf = (ROBOTS_DIR / "planar_arm.urdf").read_text().replace("planar_arm", "api_arm")
    robot = api.post("/v1/robots", json={"urdf": urdf, "name": "made by a script"}).json()["id"]
    assert robot not in _listed(page)
    page.evaluate("() => window.dispatchEvent(new Event('focus'))")  # the user comes back
    page.wait_for_function(
        "(r) => [...document.querySelectorAll('#robot option')].some(o => o.value === r)", arg=robot
    )
    assert page.locator("#robot").input_value() == "planar_arm"  # the choice stays
    api.delete(f"/v1/robots/{robot}")
    page.evaluate("() => window.dispatchEvent(new Event('focus'))")
    page.wait_for_function(
        "(r) => ![...document.querySelectorAll('#robot option')].some(o => o.value === r)",
        arg=robot,
    )
    assert page.log.console_errors == []


def test_a_deep_link_to_a_robot_uploaded_after_the_page_loaded_opens_it(page, server, api) -> None:
    open_explorer(page, server)
    urdf = (ROBOTS_DIR / "planar_arm.urdf").read_text().replace("planar_arm", "linked_arm")
    robot = api.post("/v1/robots", json={"urdf": urdf, "name": "linked"}).json()["id"]
    page.evaluate("(r) => { location.hash = 'robot=' + r; }", robot)
    page.wait_for_function(
        "(r) => document.querySelector('#heatmap').dataset.robot === r", arg=robot
    )
    wait_computed(page)
    assert page.locator("#robot").input_value() == robot
    page.evaluate("() => { location.hash = 'robot=no-such-robot'; }")
    page.wait_for_function(
        "() => document.querySelector('#status').textContent.includes(\"No robot 'no-such-robot'\")"
    )
    assert page.locator("#robot").input_value() == robot
    api.delete(f"/v1/robots/{robot}")
