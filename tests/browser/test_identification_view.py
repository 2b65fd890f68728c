"""The explorer's identification view in a real browser: a log CSV read from a file, identified
by the service, its RMSE table equal to the API's answer and one uPlot plot of measured,
identified and own-model torques per joint, with y tick labels that fit their axes; a log that
leaves a parameter undetermined shows its condition number (null) as n/a, saying why; a CSV of
the wrong width is refused in the page."""

from __future__ import annotations

import math
import re

import numpy as np
import pinocchio as pin

from service.registry.catalog import load_catalog
from tests.browser.conftest import ARTIFACTS
from tests.browser.plot_labels import RECORD_CANVAS_TEXT_JS, clipped_y_tick_labels
from tests.browser.test_explorer import open_explorer
from tests.service.dynamics.identification_logs import synthetic_log

MAX_POINTS = 600  # the page's points per curve (identification_view.js)


def _csv(t: np.ndarray, q: np.ndarray, tau: np.ndarray) -> tuple[str, dict]:
    rows = np.column_stack([t, q, tau])
    header = (
        "t," + ",".join(f"q{j}" for j in range(6)) + "," + ",".join(f"tau{j}" for j in range(6))
    )
    text = header + "\n" + "\n".join(",".join(repr(float(x)) for x in row) for row in rows)
    body = {"t": t.tolist(), "q": q.tolist(), "tau": tau.tolist(), "store": False}
    body["include_series"] = True  # as the page asks
    return text, body


def _log_csv() -> tuple[str, dict]:
    ur5 = load_catalog(["ur5"])[0]["ur5"]
    log = synthetic_log(ur5.model, seed=4, duration=8.0, rate=100.0, noise=0.05)
    return _csv(log.t, log.q, log.tau)


def _still_wrist_log_csv() -> tuple[str, dict]:
    """A log of the ur5 whose last joint never moves: the log cannot determine its friction,
    so the condition number is infinite (null in JSON)."""
    ur5 = load_catalog(["ur5"])[0]["ur5"]
    log = synthetic_log(ur5.model, seed=4, duration=8.0, rate=100.0, noise=0.05)
    q, v, a = log.q.copy(), log.v.copy(), log.a.copy()
    q[:, 5] = 0.3
    v[:, 5] = a[:, 5] = 0.0
    true = ur5.model.copy()
    for j, block in enumerate(log.pi.reshape(-1, 10), start=1):
        true.inertias[j] = pin.Inertia.FromDynamicParameters(block)
    data = true.createData()
    tau = np.array([pin.rnea(true, data, q[i], v[i], a[i]) for i in range(log.t.size)])
    tau += log.offset + log.coulomb * np.sign(v) + log.viscous * v
    tau += np.random.default_rng(3).normal(0.0, log.noise, tau.shape)
    return _csv(log.t, q, tau)


def _identify_in_the_page(page, server: str, csv: str) -> None:
    page.add_init_script(RECORD_CANVAS_TEXT_JS)
    open_explorer(page, server, "ur5")
    page.set_input_files(
        "#ident-file", files=[{"name": "log.csv", "mimeType": "text/csv", "buffer": csv.encode()}]
    )
    page.click("#identify-form button[type=submit]")
    page.wait_for_selector("#ident-rmse", timeout=120_000)


def _assert_plots_show(page, expected: dict) -> None:
    """One plot per joint whose curves are the answer's validation series (thinned evenly to
    at most MAX_POINTS points), with every y tick label within its axis."""
    series = expected["validation_series"]
    n = len(series["t"])
    picks = list(range(0, n, math.ceil(n / MAX_POINTS)))
    names = [b["name"] for b in expected["bodies"]]
    assert page.locator(".ident-plot .uplot").count() == len(names)
    for j, name in enumerate(names):
        data = page.evaluate(
            "(name) => document.querySelector(`.ident-plot[data-joint='${name}']`).plot.data",
            name,
        )
        assert len(data) == 4
        np.testing.assert_allclose(data[0], [series["t"][i] for i in picks], rtol=1e-12)
        for shown, key in zip(data[1:], ("measured", "predicted", "before"), strict=True):
            want = [series[key][i][j] for i in picks]
            np.testing.assert_allclose(shown, want, rtol=1e-6, atol=1e-9 * max(map(abs, want)))
    assert clipped_y_tick_labels(page, "#ident-results .uplot") == []


def test_identify_a_log_in_the_page(page, server, api) -> None:
    csv, body = _log_csv()
    expected = api.post("/v1/robots/ur5/identify", json=body, timeout=120).json()
    _identify_in_the_page(page, server, csv)
    rows = page.eval_on_selector_all(
        "#ident-rmse tr", "rs => rs.slice(1).map(r => [...r.children].map(c => c.textContent))"
    )
    assert [r[0] for r in rows] == [f["joint"] for f in expected["friction"]]
    assert page.locator("#ident-warnings").count() == 0  # every joint moves
    for j, row in enumerate(rows):
        for cell, key in zip(row[1:], ("validation_before", "validation", "train"), strict=True):
            assert float(cell) == float(f"{expected['rmse'][key][j]:.3g}")
    _assert_plots_show(page, expected)
    status = page.locator("#ident-status").inner_text()
    shown = re.fullmatch(
        r"Identified: condition number (\S+), low-pass cut-off (\S+) Hz, .*", status
    )
    assert shown, status
    assert float(shown[1]) == float(f"{expected['condition_number']:.3g}")
    assert float(shown[2]) == float(f"{expected['filter_hz']:.3g}")
    assert page.locator("#ident-status .no-value").count() == 0
    assert page.log.console_errors == [] and page.log.page_errors == []
    page.screenshot(path=str(ARTIFACTS / "identification.png"), full_page=True)


def test_an_undetermined_log_shows_its_condition_number_as_not_available(page, server, api):
    """condition_number is null when the log leaves a base parameter undetermined (a joint
    that never moves): the page says n/a, its title says why, and shows the rest."""
    csv, body = _still_wrist_log_csv()
    expected = api.post("/v1/robots/ur5/identify", json=body, timeout=120).json()
    assert expected["condition_number"] is None  # the documented null, for this log
    _identify_in_the_page(page, server, csv)
    status = page.locator("#ident-status")
    assert status.inner_text().startswith("Identified: condition number n/a, ")
    missing = status.locator(".no-value")
    assert missing.count() == 1 and missing.inner_text() == "n/a"
    assert "undetermined" in missing.get_attribute("title")
    rows = page.eval_on_selector_all(
        "#ident-rmse tr", "rs => rs.slice(1).map(r => [...r.children].map(c => c.textContent))"
    )
    assert [float(r[2]) for r in rows] == [
        float(f"{x:.3g}") for x in expected["rmse"]["validation"]
    ]
    # the still wrist is named: its friction is not determined by the log
    assert expected["friction"][5] is None
    warned = page.locator("#ident-warnings li")
    assert warned.count() == 1 and warned.get_attribute("data-joint") == "wrist_3_joint"
    assert warned.inner_text() == expected["warnings"][0]["detail"]
    _assert_plots_show(page, expected)
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_a_csv_of_the_wrong_width_is_refused_in_the_page(browser, server) -> None:
    page = browser.new_page()
    open_explorer(page, server, "ur5")
    page.set_input_files(
        "#ident-file",
        files=[{"name": "bad.csv", "mimeType": "text/csv", "buffer": b"0,1,2\n1,2,3\n"}],
    )
    page.click("#identify-form button[type=submit]")
    page.wait_for_function(
        "() => document.querySelector('#ident-status').classList.contains('error')"
    )
    assert "needs 13" in page.locator("#ident-status").inner_text()
    page.close()
