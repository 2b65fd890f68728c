"""The explorer's "Equations" view in a real browser: M, C and g typeset by the vendored KaTeX,
readable by default with switches for the exact and parametric forms (the parameters' table
with their values), entries tinted by the coordinates they depend on, hover values equal to the
API's numbers at the sliders' state, refusals shown, nothing loaded from elsewhere."""

from __future__ import annotations

import math
import re

import numpy as np

from tests.browser.conftest import ARTIFACTS
from tests.browser.test_explorer import open_explorer, set_slider, shown_state, wait_computed


def open_equations(page, server: str, robot: str) -> None:
    open_explorer(page, server, robot)
    page.click("#equations-view-button")
    # The first request derives the equations in the server's child process: seconds, and on
    # a loaded machine up to the service's time limit (ROBODYN_EQUATIONS_TIMEOUT_S, 60 s)
    # and its grace, longer than the page's default wait.
    page.wait_for_function(
        """() => document.querySelector('#equations-status')
        .textContent.match(/coordinates|No explicit form|Error/)""",
        timeout=90_000,
    )


def entries(page, quantity: str) -> list[dict]:
    return page.eval_on_selector_all(
        f".eq-block[data-quantity='{quantity}'] .eq-entry",
        """tds => tds.map(td => ({row: +td.dataset.row, col: +td.dataset.col,
                                   depends: td.dataset.depends, text: td.innerText,
                                   katex: !!td.querySelector('.katex'),
                                   background: getComputedStyle(td).backgroundColor}))""",
    )


def test_planar_arm_equations_are_typeset_and_tinted_by_dependence(page, server, api) -> None:
    open_equations(page, server, "planar_arm")
    assert page.locator("#equations-view").is_visible()
    assert page.locator("#mass-matrix-figure").is_hidden()  # the dynamics view's figures
    assert page.locator("#payload-view").is_hidden()
    M = entries(page, "mass_matrix")
    assert len(M) == 4 and all(e["katex"] for e in M)
    by = {(e["row"], e["col"]): e for e in M}
    assert "4.235" in by[0, 0]["text"] and "cos" in by[0, 0]["text"]
    answer = api.get("/v1/robots/planar_arm/equations").json()
    structure = answer["structure"]["mass_matrix"]
    for (i, j), e in by.items():
        assert e["depends"] == " ".join(structure[i][j]["depends_on"])
    # same dependency set, same tint; the constant M22 another one
    assert by[0, 0]["background"] == by[0, 1]["background"] != by[1, 1]["background"]
    assert len(entries(page, "coriolis_matrix")) == 4 and len(entries(page, "gravity")) == 2
    legend = page.locator("#equations-legend").inner_text()
    assert "depends on q2" in legend and "depends on q1 q2" in legend
    # KaTeX's fonts came from the service
    assert any("/static/vendor/katex/fonts/" in u for u in page.log.requests)
    page.screenshot(
        path=str(ARTIFACTS / "equations-planar-arm.png"),
        clip=page.locator("#results").bounding_box(),
    )


def _switch(page, form: str) -> None:
    page.select_option("#equations-form", form)
    page.wait_for_function(
        """() => document.querySelector('#equations-status')
        .textContent.match(/significant digits/)""",
        timeout=90_000,
    )


def test_the_forms_switch_and_the_parametric_one_lists_its_parameters(page, server, api) -> None:
    open_equations(page, server, "planar_arm")
    assert page.locator("#equations-form").input_value() == "readable"
    assert "6 significant digits" in page.locator("#equations-status").inner_text()
    assert page.locator(".eq-parameter").count() == 0
    _switch(page, "parametric")
    answer = api.get("/v1/robots/planar_arm/equations?form=parametric").json()
    rows = page.eval_on_selector_all(
        ".eq-parameter",
        "trs => trs.map(tr => [...tr.querySelectorAll('td')].map(td => td.innerText))",
    )
    assert len(rows) == len(answer["parameters"]) == 6
    for row, parameter in zip(rows, answer["parameters"], strict=True):
        assert row[1] == parameter["expression"]
        assert float(row[2]) == float(f"{parameter['value']:.6g}")
    by = {(e["row"], e["col"]): e for e in entries(page, "mass_matrix")}
    # M22 is one parameter (p4 = elbow.Iyy here), M11 its own constant parameter plus cos q2
    assert re.sub(r"[\s\u200b]", "", by[1, 1]["text"]) == "p4", by[1, 1]["text"]
    assert "p" in by[0, 0]["text"] and "cos" in by[0, 0]["text"]
    _switch(page, "exact")
    assert "every term" in page.locator("#equations-status").inner_text()
    assert page.locator(".eq-parameter").count() == 0
    sent = [u for u in page.log.requests if "/equations" in u]
    assert any("form=parametric" in u for u in sent) and any("digits=17" in u for u in sent)
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_hover_shows_the_value_at_the_sliders(page, server, api) -> None:
    open_equations(page, server, "ur5")
    page.click("#dynamics-view-button")
    set_slider(page, "#q-1", -0.7)
    set_slider(page, "#v-2", 1.3)
    page.wait_for_function("""() => {
        const box = document.querySelector('#heatmap').dataset;
        return JSON.parse(box.q)[1] === -0.7 && JSON.parse(box.v)[2] === 1.3 }""")
    wait_computed(page)
    q, v = shown_state(page)
    page.click("#equations-view-button")
    page.wait_for_selector(".eq-block[data-quantity='coriolis_matrix']")
    M = api.post("/v1/robots/ur5/mass-matrix", json={"q": q}).json()["mass_matrix"]
    C = api.post("/v1/robots/ur5/coriolis", json={"q": q, "v": v}).json()["coriolis_matrix"]
    g = api.post("/v1/robots/ur5/gravity", json={"q": q}).json()["gravity"]
    tip = page.locator("#equations-tooltip")
    for quantity, (i, j), want in [
        ("mass_matrix", (1, 2), M[1][2]),
        ("coriolis_matrix", (0, 1), C[0][1]),
        ("gravity", (1, 0), g[1]),
    ]:
        page.hover(
            f".eq-block[data-quantity='{quantity}'] .eq-entry[data-row='{i}'][data-col='{j}']"
        )
        assert tip.is_visible()
        assert math.isclose(
            float(tip.get_attribute("data-value")), want, rel_tol=1e-12, abs_tol=1e-12
        )
    # and the expressions themselves evaluate to those numbers (the service's own test checks
    # this exactly; here: the text the page typesets is the answer's)
    answer = api.get("/v1/robots/ur5/equations").json()
    shown = entries(page, "gravity")
    assert [e["depends"] for e in shown] == [
        " ".join(s["depends_on"]) for s in answer["structure"]["gravity"]
    ]
    assert np.shape(answer["coriolis_matrix"]["latex"]) == (6, 6)
    # long entries: a list, M's upper triangle (21 entries), all of C (36), g (6)
    assert [len(entries(page, k)) for k in ("mass_matrix", "coriolis_matrix", "gravity")] == [
        21,
        36,
        6,
    ]
    page.mouse.move(1, 1)
    assert tip.is_hidden()
    assert page.log.console_errors == [] and page.log.page_errors == []
    assert page.log.foreign_requests(server) == []


def test_an_unsupported_robot_says_why(page, server) -> None:
    open_equations(page, server, "talos")
    status = page.locator("#equations-status")
    assert "No explicit form for this robot" in status.inner_text()
    assert "free-flyer root joint" in status.inner_text()
    assert page.locator(".eq-block").count() == 0
    # choosing an arm again shows its equations
    page.click("#dynamics-view-button")
    open_equations(page, server, "planar_arm")
    assert page.locator("table.eq-matrix").count() == 3  # short entries: matrices


def test_tabs_follow_the_keyboard(page, server) -> None:
    open_explorer(page, server, "planar_arm")
    page.focus("#dynamics-view-button")
    page.keyboard.press("ArrowLeft")  # wraps around to the last tab: Model check
    assert page.locator("#model-check-view-button").get_attribute("aria-selected") == "true"
    page.keyboard.press("ArrowLeft")  # the one before it: Equations
    assert page.locator("#equations-view-button").get_attribute("aria-selected") == "true"
    assert page.evaluate("document.activeElement.id") == "equations-view-button"
    page.wait_for_selector(".eq-block[data-quantity='mass_matrix']")
    page.keyboard.press("ArrowRight")
    page.keyboard.press("ArrowRight")  # past Model check, wrapping around to Dynamics
    assert page.locator("#mass-matrix-figure").is_visible()
    assert page.locator("#equations-view").is_hidden()


def test_katex_is_served_from_the_package_at_its_pinned_version(api) -> None:
    from service.api.routes.pages import KATEX_FILES, WEB_DIR

    assert "katex@0.19.1" in (WEB_DIR / "vendor/katex/README.md").read_text()
    assert "MIT License" in (WEB_DIR / "vendor/katex/LICENSE").read_text()
    assert len([n for n in KATEX_FILES if n.endswith(".woff2")]) == 20
    for name, media_type in KATEX_FILES.items():
        answer = api.get(f"/static/{name}")
        assert answer.status_code == 200, name
        assert answer.headers["content-type"] == media_type
        assert answer.content == (WEB_DIR / name).read_bytes()
    # the stylesheet names only fonts that are served (woff2 first in each list)
    css = (WEB_DIR / "vendor/katex/katex.min.css").read_text()
    for font in set(re.findall(r"url\((fonts/[^)]+\.woff2)\)", css)):
        assert f"vendor/katex/{font}" in KATEX_FILES, font


def test_an_identified_robot_shows_its_parameters_standard_deviations(page, server, api) -> None:
    """A robot made by identification: the parametric form's table has a "std. dev." column
    with the API's standard deviations (3 significant digits; "—" where null)."""
    from service.registry.catalog import load_catalog
    from tests.service.dynamics.identification_logs import synthetic_log

    model = load_catalog(["planar_arm"])[0]["planar_arm"].model
    log = synthetic_log(model, seed=4, duration=10.0, rate=100.0, noise=0.05)
    body = {"t": log.t.tolist(), "q": log.q.tolist(), "tau": log.tau.tolist()}
    variant = api.post("/v1/robots/planar_arm/identify", json=body, timeout=120).json()["robot"]
    open_equations(page, server, variant["id"])
    _switch(page, "parametric")
    answer = api.get(f"/v1/robots/{variant['id']}/equations?form=parametric").json()
    rows = page.eval_on_selector_all(
        ".eq-parameter",
        "trs => trs.map(tr => [...tr.querySelectorAll('td')].map(td => td.innerText))",
    )
    assert len(rows) == len(answer["parameters"])
    for row, parameter in zip(rows, answer["parameters"], strict=True):
        std = parameter["standard_deviation"]
        assert row[3] == "—" if std is None else float(row[3]) == float(f"{std:.3g}"), row
    assert any(p["standard_deviation"] is not None for p in answer["parameters"])
    assert page.log.console_errors == [] and page.log.page_errors == []
