// The y axes of the explorer's uPlot plots: each tick label written with as many digits as the
// tick spacing needs ("0.000025", "2e-14"; uPlot's default of at most three decimals writes every
// tick of a small range as "0"), and the axis as wide as its widest tick label, measured in the
// axis's own font, plus its tick and the gap between them, so that "-0.874" or "12,500" is never
// cut at the plot's edge nor drawn over the axis title.

const measure = document.createElement("canvas").getContext("2d"); // not uPlot's own context
const MAX_DECIMALS = 6; // finer tick spacings are written in exponent form

/** The decimals that write `step` exactly (0.1 → 1, 0.00025 → 5, 2500 → 0), or null when
 * that takes more than MAX_DECIMALS. */
function decimalsOf(step) {
  for (let d = 0; d <= MAX_DECIMALS; d++) {
    const scaled = Math.abs(step) * 10 ** d;
    if (Math.round(scaled) >= 1 && Math.abs(scaled - Math.round(scaled)) < 1e-6 * scaled) return d;
  }
  return null;
}

/** uPlot's axis `values` callback: the ticks `splits`, `incr` apart, as text. */
export function tickLabels(u, splits, axisIdx, space, incr) {
  const d = decimalsOf(incr);
  const style = { minimumFractionDigits: d, maximumFractionDigits: d };
  return splits.map((v) => {
    if (v === null) return "";
    if (d !== null) return (v + 0).toLocaleString("en", style); // (+ 0: no "-0")
    if (Math.abs(v) < 1e-6 * incr) return "0";
    // enough significant digits to tell ticks `incr` apart: 3e-14, 1.00002e-7
    const digits = Math.min(17, Math.max(1, Math.ceil(Math.log10(Math.abs(v) / incr)) + 2));
    return Number(v.toPrecision(digits)).toExponential();
  });
}

/** uPlot's axis `size` callback: the axis width in CSS px for tick labels `values`. */
export function sizeToLabels(u, values, axisIdx, cycleNum) {
  const axis = u.axes[axisIdx];
  const [font, size, cssSize] = axis.font; // the font at the device's pixel ratio, and its px
  measure.font = font;
  const widest = Math.max(0, ...(values || []).map((v) => measure.measureText(String(v)).width));
  const tick = axis.ticks && axis.ticks.show !== false ? axis.ticks.size : 0;
  const width = Math.ceil(tick + axis.gap + (widest * cssSize) / size + 2);
  // uPlot lays the axes out in up to three passes (the ticks depend on the plot's height, which
  // depends on the other axes): from the second on the width only grows, so the layout settles
  // with room for the labels of every pass.
  return cycleNum > 1 ? Math.max(axis._size, width) : width;
}

/** A y axis titled `label`, its ticks written in full and as wide as their labels. */
export const yAxis = (label) => ({ label, values: tickLabels, size: sizeToLabels });
