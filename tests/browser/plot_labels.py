"""The tick labels a uPlot plot of the explorer draws, read from its canvas: every `fillText`
of the page is recorded with its position, alignment, transform and the width the canvas itself
measures for it (since the canvas's last full clear), so a test can check that each y tick label
lies within its axis (not cut at the plot's edge, not over the axis title)."""

from __future__ import annotations

# Installed with `page.add_init_script` before the page loads.
RECORD_CANVAS_TEXT_JS = """(() => {
  const proto = CanvasRenderingContext2D.prototype;
  const fillText = proto.fillText, clearRect = proto.clearRect;
  proto.fillText = function (text, x, y, ...rest) {
    const m = this.getTransform();
    (this.canvas.drawnTexts ||= []).push({
      text: String(text), x, y, align: this.textAlign, width: this.measureText(text).width,
      rotated: m.b !== 0 || m.c !== 0, e: m.e, a: m.a });
    return fillText.call(this, text, x, y, ...rest);
  };
  proto.clearRect = function (x, y, w, h) {
    if (x <= 0 && y <= 0 && w >= this.canvas.width && h >= this.canvas.height) {
      this.canvas.drawnTexts = [];
    }
    return clearRect.call(this, x, y, w, h);
  };
})();"""

# For each plot (a uPlot root under `selector`, axes [x, y] with y on the left): its y axis's
# extent and every unrotated, right-aligned text drawn on its canvas (the y tick labels), in CSS
# px from the canvas's left.
_Y_TICK_LABELS_JS = """(selector) => [...document.querySelectorAll(selector)].map((plot) => {
  const canvas = plot.querySelector('canvas');
  const box = canvas.getBoundingClientRect();
  const scale = canvas.width / box.width;
  const y = plot.querySelectorAll('.u-axis')[1]; // uPlot's axis boxes in order: x, then y
  const axis = y && y.getBoundingClientRect();
  const labels = (canvas.drawnTexts || [])
    .filter((t) => !t.rotated && t.align === 'right')
    .map((t) => { const right = (t.a * t.x + t.e) / scale;
                  return { text: t.text, left: right - t.width / scale, right }; });
  return { axis: axis && { left: axis.left - box.left, right: axis.right - box.left },
           labels };
})"""


def clipped_y_tick_labels(page, selector: str) -> list[str]:
    """Every y tick label of the plots under `selector` that reaches beyond its axis (cut at the
    canvas's edge or drawn over the axis title), as "text: why"; a plot without a y axis or
    tick labels is reported too. Empty when every label fits."""
    plots = page.evaluate(_Y_TICK_LABELS_JS, selector)
    assert plots, f"no plot under {selector}"
    problems = []
    for k, plot in enumerate(plots):
        if not plot["axis"] or not plot["labels"]:
            problems.append(f"plot {k}: no y axis or no tick labels drawn")
            continue
        left, right = plot["axis"]["left"], plot["axis"]["right"]
        for label in plot["labels"]:
            if label["left"] < left - 0.5 or label["right"] > right + 0.5:
                problems.append(
                    f"plot {k}: {label['text']!r} spans {label['left']:.1f}..{label['right']:.1f}"
                    f" px, its axis {left:.1f}..{right:.1f} px"
                )
    return problems
