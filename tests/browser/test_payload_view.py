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
