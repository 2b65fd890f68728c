"""The explorer's trajectory view sizes the joints in Chromium: after a check, bars per joint
and a table of the service's sizing figures (peak and RMS torque, peak speed and power, the
bearing loads), and a button that copies the table as tab-separated text whose numbers are
the service's."""

from __future__ import annotations

from tests.browser.test_trajectory_view import CSV, _trajectory_tab

COLUMNS = (
    "peak_effort",
    "rms_effort",
    "peak_velocity",
    "peak_power",
    "peak_force",
    "peak_axial_force",
    "peak_moment",
    "peak_bending_moment",
)

RECORD_COPIES = """
Object.defineProperty(navigator, "clipboard", {
  configurable: true,
  value: { writeText: async (text) => { window.copied = text; } },
});
"""


def test_a_check_sizes_every_joint_and_the_table_copies(page, server, api) -> None:
    page.add_init_script(RECORD_COPIES)
    _trajectory_tab(page, server)
    assert page.locator("#trajectory-sizing").is_hidden()
    page.fill("#trajectory-csv", CSV)
    page.click("#trajectory-check")
    page.locator("#trajectory-verdict").wait_for()
    page.locator("#trajectory-sizing-table").wait_for()
    info = api.get("/v1/robots/ur5").json()
    q0 = info["default_configuration"]
    rows = [[float(x) for x in line.split(",")] for line in CSV.strip().splitlines()[1:]]
    expected = api.post(
        "/v1/robots/ur5/trajectory-check",
        json={
            "t": [r[0] for r in rows],
            "q": [[r[1], r[2], r[3], *q0[3:]] for r in rows],
            "velocity_scale": 1,
            "effort_scale": 1,
            "samples_per_interval": 4,
        },
    ).json()["joints"]
    names = [j["name"] for j in expected]
    shown = page.eval_on_selector_all(
        "#trajectory-sizing-table tbody tr", "rs => rs.map(r => r.dataset.joint)"
    )
    assert shown == names
    # a unit in every cell; the shoulder's bending moment as the service computed it
    shoulder = page.locator('#trajectory-sizing-table tr[data-joint="shoulder_lift_joint"] td')
    assert shoulder.nth(7).inner_text().endswith(" N·m")
    assert float(shoulder.nth(7).inner_text().split()[0]) == float(
        f"{expected[1]['peak_bending_moment']:.4g}"
    )
    # the bars: one per joint, each the service's number
    for quantity in ("peak_effort", "peak_power", "peak_axial_force", "peak_bending_moment"):
        values = page.eval_on_selector_all(
            f'figure.sizing-plot[data-quantity="{quantity}"] .bar-row',
            "rs => rs.map(r => Number(r.dataset.value))",
        )
        assert values == [j[quantity] for j in expected]
    # the copy: the page's tab-separated text, numbers in full, the units in the header
    page.click("#trajectory-sizing-copy")
    page.wait_for_function("() => window.copied !== undefined")
    copied = page.evaluate("() => window.copied")
    assert copied == page.evaluate("() => document.querySelector('#trajectory-sizing').tsv")
    lines = copied.rstrip("\n").split("\n")
    header = lines[0].split("\t")
    assert header[0] == "joint" and header[1] == "peak |τ| (N·m)" and "(W)" in header[4]
    assert len(lines) == 1 + len(names)
    for line, joint in zip(lines[1:], expected, strict=True):
        cells = line.split("\t")
        assert cells[0] == joint["name"]
        assert [float(x) for x in cells[1:]] == [joint[k] for k in COLUMNS]
    assert page.locator("#trajectory-sizing-copied").inner_text().strip() == "Copied."
    assert page.log.console_errors == [] and page.log.page_errors == []
