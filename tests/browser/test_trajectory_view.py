"""The explorer's Trajectory tab in Chromium: a pasted CSV is checked (the plots show τ and v
over their limits as the service computed them, the violations shaded), waypoints are retimed
and the motion plays in the 3-D view; nothing is loaded from elsewhere."""

from __future__ import annotations

import numpy as np

from tests.browser.plot_labels import RECORD_CANVAS_TEXT_JS, clipped_y_tick_labels
from tests.browser.test_explorer import open_explorer

CSV = """t,shoulder_pan_joint,shoulder_lift_joint,elbow_joint
0,0,-1.57,1.57
0.5,0.4,-1.4,1.3
1,1.2,-1.2,1.0
1.5,1.6,-1.0,0.8
"""


def _trajectory_tab(page, server: str) -> None:
    open_explorer(page, server, "ur5")
    page.click("#tab-trajectory-button")
    page.locator("#tab-trajectory").wait_for(state="visible")
    assert page.locator("#tab-state").is_hidden()


def test_a_pasted_motion_is_checked_and_plotted(page, server, api) -> None:
    _trajectory_tab(page, server)
    page.fill("#trajectory-csv", CSV)
    page.fill("#velocity-scale", "0.5")
    page.click("#trajectory-check")
    page.locator("#trajectory-verdict").wait_for()
    assert "1 violation" in page.locator("#trajectory-verdict").inner_text()
    # the same request straight to the service: the page shows its numbers
    info = api.get("/v1/robots/ur5").json()
    q0 = info["default_configuration"]
    rows = [[float(x) for x in line.split(",")] for line in CSV.strip().splitlines()[1:]]
    q = [[r[1], r[2], r[3], *q0[3:]] for r in rows]
    expected = api.post(
        "/v1/robots/ur5/trajectory-check",
        json={
            "t": [r[0] for r in rows],
            "q": q,
            "velocity_scale": 0.5,
            "effort_scale": 1,
            "samples_per_interval": 4,
        },
    ).json()
    shown = page.evaluate("() => document.querySelector('#trajectory-plots').result.answer")
    assert shown["violations"] == expected["violations"]
    np.testing.assert_allclose(shown["tau"], expected["tau"], rtol=1e-12)
    # one plot per joint with limits; the base joint's marks its violation
    plots = page.locator("#trajectory-plots figure.joint-plot")
    assert plots.count() == 6
    base = page.locator('figure.joint-plot[data-joint="shoulder_pan_joint"]')
    assert base.get_attribute("data-violations") == "1"
    data = page.evaluate("""() => document.querySelector(
        'figure.joint-plot[data-joint="shoulder_pan_joint"]').plot.data""")
    limit = 0.5 * info["joints"][0]["velocity_limit"][0]
    np.testing.assert_allclose(data[0], [r[0] for r in rows])
    np.testing.assert_allclose(data[2], np.array(expected["v"])[:, 0] / limit, rtol=1e-12)
    assert page.locator("#trajectory-summary table.violations tbody tr").count() == 1
    assert page.log.foreign_requests(server) == []
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_waypoints_are_retimed_and_played(page, server, api) -> None:
    _trajectory_tab(page, server)
    page.click("#waypoints-example")
    page.click("#trajectory-retime")
    page.locator("#trajectory-verdict").wait_for()
    assert "Within every limit" in page.locator("#trajectory-verdict").inner_text()
    answer = page.evaluate("() => document.querySelector('#trajectory-plots').result.answer")
    assert answer["check"]["feasible"] and answer["duration"] > 0
    page.locator("#trajectory-player").wait_for(state="visible")
    page.wait_for_function("() => document.querySelector('#trajectory-view3d').dataset.q")
    start = page.evaluate("() => document.querySelector('#trajectory-view3d').dataset.q")
    page.click("#trajectory-play")
    page.wait_for_function(
        "(s) => document.querySelector('#trajectory-view3d').dataset.q !== s", arg=start
    )
    page.wait_for_function(
        "() => document.querySelector('#trajectory-play').textContent === 'Play'", timeout=30_000
    )  # played to the end
    end = page.evaluate("() => JSON.parse(document.querySelector('#trajectory-view3d').dataset.q)")
    np.testing.assert_allclose(end, answer["q"][-1], atol=1e-12)
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_a_long_check_shows_the_services_progress(page, server) -> None:
    """20,000 samples × 16 points per interval: the service streams its progress, and the
    status line counts the evaluated points before the verdict."""
    _trajectory_tab(page, server)
    t = np.linspace(0.0, 20.0, 20_000)
    lines = ["t,shoulder_pan_joint,shoulder_lift_joint"] + [
        f"{x:.17g},{0.4 * np.sin(0.3 * x):.17g},{-1.2 + 0.3 * np.sin(0.6 * x):.17g}" for x in t
    ]
    page.evaluate(
        "text => { const area = document.querySelector('#trajectory-csv'); "
        "area.value = text; area.dispatchEvent(new Event('input')); }",
        "\n".join(lines),
    )
    page.fill("#samples-per-interval", "16")
    page.evaluate("""() => {
        window.statuses = [];
        new MutationObserver(() => window.statuses.push(
            document.querySelector('#trajectory-status').textContent)).observe(
            document.querySelector('#trajectory-status'),
            {childList: true, characterData: true, subtree: true});
    }""")
    page.click("#trajectory-check")
    page.locator("#trajectory-verdict").wait_for(timeout=60_000)
    statuses = page.evaluate("() => window.statuses")
    counted = [s for s in statuses if "evaluated points" in s]
    assert counted and counted[0].startswith("Checking: "), statuses[:5]
    assert "of 319,985 evaluated points (inverse dynamics)" in counted[0]
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_the_plots_y_axes_are_as_wide_as_their_tick_labels(page, server) -> None:
    """A motion of a tenth of a milliradian per second: its ratios to the limits vary little and
    their ticks need many decimals ("0.000025"); each tick label says its own value, and none is
    cut at the plot's edge or drawn over the axis title."""
    page.add_init_script(RECORD_CANVAS_TEXT_JS)
    _trajectory_tab(page, server)
    rows = [f"{t},{1e-4 * t},{-1.57 + 2e-4 * t},{1.57 - 1e-4 * t}" for t in (0, 0.5, 1, 1.5, 2)]
    page.fill("#trajectory-csv", "\n".join([CSV.splitlines()[0], *rows]))
    page.click("#trajectory-check")
    page.locator("#trajectory-verdict").wait_for()
    assert page.locator("#trajectory-plots .uplot").count() == 6
    labels = page.evaluate(
        "() => [...document.querySelectorAll('#trajectory-plots canvas')].flatMap("
        "c => (c.drawnTexts || []).map(t => t.text))"
    )
    assert max(len(text) for text in labels) >= 7, labels  # wider than uPlot's default axis
    for plot in page.locator("#trajectory-plots .uplot").all():
        ticks = plot.evaluate(
            "p => p.querySelector('canvas').drawnTexts"
            ".filter(t => !t.rotated && t.align === 'right').map(t => t.text)"
        )
        assert len(set(ticks)) == len(ticks) >= 2, ticks  # each tick says its own value
    assert clipped_y_tick_labels(page, "#trajectory-plots .uplot") == []
    assert page.log.console_errors == [] and page.log.page_errors == []


def test_acceleration_limits_and_spline_ends_are_sent(page, server, api) -> None:
    """An acceleration limit for every joint and the clamped spline: the check's answer is
    the service's for the same limits object and boundary; retimed, the motion reaches that
    limit and the plots show a ÷ its limit."""
    _trajectory_tab(page, server)
    page.fill("#trajectory-csv", CSV)
    page.fill("#acceleration-limit", "2")
    page.select_option("#spline-boundary", "clamped")
    page.click("#trajectory-check")
    page.locator("#trajectory-verdict").wait_for()
    info = api.get("/v1/robots/ur5").json()
    q0 = info["default_configuration"]
    rows = [[float(x) for x in line.split(",")] for line in CSV.strip().splitlines()[1:]]
    limits = {"effort_scale": 1, "velocity_scale": 1, "acceleration": [2.0] * 6}
    expected = api.post(
        "/v1/robots/ur5/trajectory-check",
        json={
            "t": [r[0] for r in rows],
            "q": [[r[1], r[2], r[3], *q0[3:]] for r in rows],
            "limits": limits,
            "boundary": "clamped",
            "samples_per_interval": 4,
        },
    ).json()
    shown = page.evaluate("() => document.querySelector('#trajectory-plots').result.answer")
    assert shown["joints"] == expected["joints"]
    assert shown["violations"] == expected["violations"]
    assert any(x["kind"] == "acceleration" for x in shown["violations"])
    page.click("#waypoints-example")
    page.click("#trajectory-retime")
    page.wait_for_function(
        "() => document.querySelector('#trajectory-plots').result?.kind === 'retime'"
    )
    page.locator("#trajectory-verdict").wait_for()
    answer = page.evaluate("() => document.querySelector('#trajectory-plots').result.answer")
    joints = answer["check"]["joints"]
    assert all(j["acceleration_limit"] == 2.0 for j in joints)
    assert 0.99 < max(j["acceleration_ratio"] for j in joints) <= 1 + 1e-6
    figure = page.locator("figure.joint-plot").first
    assert "peak |a|" in figure.locator("figcaption").inner_text()
    series = page.evaluate(
        "() => document.querySelector('figure.joint-plot').plot.series.map(s => s.label)"
    )
    assert "a ÷ acceleration limit" in series
    assert page.log.console_errors == [] and page.log.page_errors == []
