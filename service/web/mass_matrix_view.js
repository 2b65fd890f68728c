// The mass matrix view of the explorer: M(q) as a heat map (linear or logarithmic colour
// scale, optionally normalised by √(Mii Mjj), lines between limbs, a tooltip per entry), its
// legend, and the same numbers as a table.

const el = (id) => document.getElementById(id);

export const fmt = (x, digits = 4) => (x === 0 ? "0" : Number(x).toPrecision(digits));

const LOG_DECADES = 4;

function scaled(x, maxAbs) {
  // The position of x on the colour scale, in [−1, 1]: linear, or logarithmic over
  // LOG_DECADES decades below max |M| (smaller magnitudes are drawn as 0).
  if (!el("log-scale").checked) return x / maxAbs;
  const decades = Math.log10(Math.abs(x) / maxAbs) + LOG_DECADES;
  return x === 0 || decades <= 0 ? 0 : Math.sign(x) * Math.min(1, decades / LOG_DECADES);
}

function colour(t) {
  // Diverging scale for t in [−1, 1]: blue (negative) – light grey (0) – red (positive).
  const mid = [247, 247, 247], neg = [33, 102, 172], pos = [178, 24, 43];
  const end = t < 0 ? neg : pos;
  const a = Math.min(1, Math.abs(t));
  const c = mid.map((m, k) => Math.round(m + (end[k] - m) * a));
  return `rgb(${c[0]}, ${c[1]}, ${c[2]})`;
}

const SVG = "http://www.w3.org/2000/svg";
function svgEl(name, attrs) {
  const e = document.createElementNS(SVG, name);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, String(v));
  return e;
}

function limbStarts(joints) {
  // Velocity rows where a limb begins: a multi-dof root (a free-flyer base) is its own block,
  // and a new limb starts at each joint whose parent has several children (a branch point)
  // or is such a root. Talos: base | left leg | right leg | torso | left arm | right arm | head.
  const children = new Map();
  for (const j of joints) children.set(j.parent, (children.get(j.parent) || 0) + 1);
  const root = new Set(joints.filter((j) => j.nv > 1 && !joints.some((p) => p.name === j.parent))
    .map((j) => j.name));
  const starts = new Set();
  for (const j of joints) {
    if (j.idx_v > 0 && (children.get(j.parent) > 1 || root.has(j.parent) || root.has(j.name))) {
      starts.add(j.idx_v);
    }
  }
  return starts;
}

export function renderHeatmap(M, labels, stamp, joints) {
  const box = el("heatmap");
  const n = M.length;
  const normalised = el("normalised").checked;
  // Mij / sqrt(Mii Mjj): unitless in [-1, 1] (M is positive definite), 1 on the diagonal.
  const shown = normalised
    ? M.map((r, i) => r.map((x, j) => x / Math.sqrt(Math.abs(M[i][i] * M[j][j])) || 0)) : M;
  const maxAbs = Math.max(...shown.flat().map(Math.abs)) || 1;
  // Cells of at least 14 px and labels of at least 11 px: a large robot (talos, nv 38) scrolls
  // sideways rather than shrinking its labels out of reach.
  const cell = Math.max(14, Math.min(48, Math.floor(440 / Math.max(n, 1))));
  const font = Math.max(11, Math.min(13, cell * 0.75));
  const pad = Math.ceil(Math.max(0, ...labels.map((l) => l.length)) * font * 0.6) + 8;
  const size = pad + n * cell;
  const svg = svgEl("svg", { width: size, height: size, viewBox: `0 0 ${size} ${size}`,
                             role: "img", "aria-label": `Heat map of the ${n}×${n} mass ` +
                             "matrix; the table below lists the numbers" });
  labels.forEach((label, i) => {
    const row = svgEl("text", { x: pad - 4, y: pad + (i + 0.5) * cell, "font-size": font,
                                "text-anchor": "end", "dominant-baseline": "middle" });
    row.textContent = label;
    const col = svgEl("text", { x: 0, y: 0, "font-size": font, "text-anchor": "start",
                                "dominant-baseline": "middle",
                                transform: `translate(${pad + (i + 0.5) * cell} ${pad - 4}) ` +
                                           "rotate(-90)" });
    col.textContent = label;
    svg.append(row, col);
  });
  M.forEach((r, i) => r.forEach((value, j) => {
    svg.append(svgEl("rect", { x: pad + j * cell, y: pad + i * cell, width: cell, height: cell,
                               fill: colour(scaled(shown[i][j], maxAbs)), class: "cell",
                               "data-row": i, "data-col": j, "data-value": String(value),
                               "data-normalised": String(shown[i][j]) }));
  }));
  for (const k of limbStarts(joints)) { // a line between limbs, across and down
    const at = pad + k * cell;
    svg.append(svgEl("line", { x1: pad, x2: pad + n * cell, y1: at, y2: at, class: "limb" }),
               svgEl("line", { x1: at, x2: at, y1: pad, y2: pad + n * cell, class: "limb" }));
  }
  svg.addEventListener("mousemove", (ev) => showTooltip(ev, labels));
  svg.addEventListener("mouseleave", () => { el("tooltip").hidden = true; });
  box.replaceChildren(svg);
  box.dataset.robot = stamp.robot;
  box.dataset.q = JSON.stringify(stamp.q);
  box.dataset.v = JSON.stringify(stamp.v);
  renderLegend(maxAbs, normalised);
}

function showTooltip(ev, labels) {
  const tip = el("tooltip");
  const t = ev.target;
  if (!t.classList || !t.classList.contains("cell")) { tip.hidden = true; return; }
  const i = Number(t.dataset.row), j = Number(t.dataset.col);
  tip.textContent = `M[${labels[i]}, ${labels[j]}] = ${fmt(Number(t.dataset.value), 6)}` +
    (el("normalised").checked ? ` (÷ √(Mii Mjj): ${fmt(Number(t.dataset.normalised), 3)})` : "");
  const fig = el("mass-matrix-figure").getBoundingClientRect();
  tip.style.left = `${ev.clientX - fig.left + 14}px`;
  tip.style.top = `${ev.clientY - fig.top + 14}px`;
  tip.hidden = false;
}

function renderLegend(maxAbs, normalised) {
  const legend = el("legend");
  const bar = document.createElement("div");
  bar.className = "legend-bar";
  const ticks = document.createElement("div");
  ticks.className = "legend-ticks";
  // Ticks at −1, −½, 0, ½, 1 of the scale: on the log scale ½ is 10^(−decades/2) of the max.
  const log = el("log-scale").checked;
  const half = log ? maxAbs * 10 ** (-LOG_DECADES / 2) : maxAbs / 2;
  const floor = `${normalised ? "" : "|M| "}< ${fmt(maxAbs * 10 ** -LOG_DECADES, 2)}`;
  for (const x of [-maxAbs, -half, 0, half, maxAbs]) {
    const s = document.createElement("span");
    s.textContent = x === 0 && log ? floor : fmt(x, 3);
    ticks.append(s);
  }
  legend.replaceChildren(bar, ticks);
}

export function renderNumbers(M, labels) {
  const table = document.createElement("table");
  table.className = "numbers";
  const head = document.createElement("tr");
  head.append(document.createElement("td"));
  for (const l of labels) {
    const th = document.createElement("th");
    th.scope = "col";
    th.textContent = l;
    head.append(th);
  }
  table.append(head);
  M.forEach((r, i) => {
    const tr = document.createElement("tr");
    const th = document.createElement("th");
    th.scope = "row";
    th.textContent = labels[i];
    tr.append(th);
    for (const x of r) {
      const td = document.createElement("td");
      td.textContent = fmt(x, 6);
      tr.append(td);
    }
    table.append(tr);
  });
  el("mass-matrix-numbers").replaceChildren(table);
}
