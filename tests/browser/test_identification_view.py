"""The explorer's identification view in a real browser: a log CSV read from a file, identified
by the service, its RMSE table equal to the API's answer and one plot of measured, identified
and own-model torques per joint; a CSV of the wrong width is refused in the page."""

from __future__ import annotations

import numpy as np

from service.registry.catalog import load_catalog
from tests.browser.conftest import ARTIFACTS
from tests.browser.test_explorer import open_explorer
from tests.service.dynamics.identification_logs import synthetic_log


def _log_csv() -> tuple[str, dict]:
    ur5 = load_catalog(["ur5"])[0]["ur5"]
    log = synthetic_log(ur5.model, seed=4, duration=8.0, rate=100.0, noise=0.05)
    rows = np.column_stack([log.t, log.q, log.tau])
    header = (
        "t," + ",".join(f"q{j}" for j in range(6)) + "," + ",".join(f"tau{j}" for j in range(6))
    )
    text = header + "\n" + "\n".join(",".join(repr(float(x)) for x in row) for row in rows)
    body = {"t": log.t.tolist(), "q": log.q.tolist(), "tau": log.tau.tolist(), "store": False}
    return text, body


def test_identify_a_log_in_the_page(browser, server, api) -> None:
    csv, body = _log_csv()
    expected = api.post("/v1/robots/ur5/identify", json=body, timeout=120).json()
    page = browser.new_page()
    open_explorer(page, server, "ur5")
    page.set_input_files(
        "#ident-file", files=[{"name": "log.csv", "mimeType": "text/csv", "buffer": csv.encode()}]
    )
    page.click("#identify-form button[type=submit]")
    page.wait_for_selector("#ident-rmse", timeout=120_000)
    rows = page.eval_on_selector_all(
        "#ident-rmse tr", "rs => rs.slice(1).map(r => [...r.children].map(c => c.textContent))"
    )
    assert [r[0] for r in rows] == [f["joint"] for f in expected["friction"]]
    for j, row in enumerate(rows):
        for cell, key in zip(row[1:], ("validation_before", "validation", "train"), strict=True):
            assert float(cell) == float(f"{expected['rmse'][key][j]:.3g}")
    assert page.locator(".ident-plot").count() == 6
    assert page.locator(".ident-plot polyline").count() == 18
    assert page.locator("#ident-status").inner_text().startswith("Identified")
    page.screenshot(path=str(ARTIFACTS / "identification.png"), full_page=True)
    page.close()


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
