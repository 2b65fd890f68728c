// The identification view of the explorer: upload a log (CSV: t, q per coordinate, τ per
// velocity coordinate), identify the chosen robot's inertial parameters and friction on the
// service (POST v1/robots/{id}/identify), and compare measured and predicted joint torques on
// the held-out end of the log, before (the model's own parameters) and after. Every number it
// shows comes from the service's answer.

import { apiWithProgress, progressText } from "./http.js";
import { numberNode } from "./no_value.js";
import { yAxis } from "./plot_axes.js";
import uPlot from "./vendor/uplot/uPlot.esm.js";

const SERIES = [ // the answer's curves: key in validation_series, legend label, colour, width
  ["measured", "measured", "#1b1b1b", 2],
  ["predicted", "identified model", "#0b5cad", 1.3],
  ["before", "the robot's own model", "#a40e26", 1.3],
];
const PLOT_HEIGHT = 170; // px
const MAX_POINTS = 600; // points drawn per curve (the series is thinned evenly)
const CONDITION_WHY = "The log leaves some base parameter undetermined (a joint that never " +
  "moves, a motion that cannot tell two parameters apart): the condition number is infinite, " +
  "and the fit keeps the model's own values there.";
const FILTER_WHY = "The log was used as given: no low-pass filter.";

function node(tag, attrs = {}, text = "") {
  const out = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) out.setAttribute(k, v);
  if (text) out.textContent = text;
  return out;
}

// CSV → {t, q, tau}: one row per sample, numbers separated by commas (or semicolons, tabs);
// a first row that is not all numbers is a header and skipped. Columns: t, then nq entries of
// q, then nv entries of τ.
export function parseLog(text, nq, nv) {
  const rows = text.split(/\r?\n/).map((line) => line.trim()).filter((line) => line.length);
  const cells = rows.map((line) => line.split(/[,;\t]/).map((c) => c.trim()));
  if (cells.length && cells[0].some((c) => c === "" || !Number.isFinite(Number(c)))) {
    cells.shift();
  }
  const width = 1 + nq + nv;
  const t = [], q = [], tau = [];
  cells.forEach((row, i) => {
    if (row.length !== width) {
      throw new Error(`row ${i + 1} has ${row.length} columns; this robot's log needs ` +
                      `${width} (t, ${nq} of q, ${nv} of τ)`);
    }
    const x = row.map(Number);
    if (!x.every(Number.isFinite)) throw new Error(`row ${i + 1} holds a value that is not a number`);
    t.push(x[0]);
    q.push(x.slice(1, 1 + nq));
    tau.push(x.slice(1 + nq));
  });
  return { t, q, tau };
}

function thin(count) {
  const step = Math.max(1, Math.ceil(count / MAX_POINTS));
  const out = [];
  for (let i = 0; i < count; i += step) out.push(i);
  return out;
}

/** The width a plot takes in `figure` (its grid cell), px. */
const plotWidth = (figure) => Math.max(280, Math.min(760, (figure.clientWidth || 384) - 4));

/** uPlot's data of joint j: [t, measured, identified, own model], at most MAX_POINTS each. */
function jointData(series, j) {
  const picks = thin(series.t.length);
  return [picks.map((i) => series.t[i]),
          ...SERIES.map(([key]) => picks.map((i) => series[key][i][j]))];
}
export class IdentificationView {
  // root: the element to fill; api(path, body) → answer (throws a Problem); robotPath(id, q).
  constructor(root, { api, robotPath }) {
    this.root = root;
    this.api = api;
    this.robotPath = robotPath;
    this.info = null;
    this.plots = [];
    this.build();
  }

  build() {
    const form = node("form", { id: "identify-form" });
    form.innerHTML = `
      <p>Fit the chosen robot's inertial parameters and friction to a logged motion. The log is
        a CSV file with one row per sample: <code>t</code> (s), then every entry of q, then
        every joint torque τ (N·m or N); a header row is allowed. The last part of the log is
        held out and predicted.</p>
      <div class="field"><label for="ident-file">Log (CSV)</label>
        <input id="ident-file" type="file" accept=".csv,.txt,text/csv" required></div>
      <div class="field"><label for="ident-friction">Friction model</label>
        <select id="ident-friction">
          <option value="coulomb-viscous">Coulomb + viscous + offset</option>
          <option value="viscous">viscous + offset</option>
          <option value="none">offset only</option></select></div>
      <div class="field"><label for="ident-method">Fit</label>
        <select id="ident-method">
          <option value="physically-consistent">physically consistent (every body possible)</option>
          <option value="least-squares">weighted least squares</option></select></div>
      <div class="field"><label for="ident-filter">Low-pass cut-off, Hz (empty: the default)</label>
        <input id="ident-filter" type="text" inputmode="decimal"></div>
      <div class="field"><label for="ident-fraction">Held-out fraction of the log</label>
        <input id="ident-fraction" type="text" inputmode="decimal" value="0.2"></div>
      <button type="submit">Identify</button>`;
    this.status = node("p", { id: "ident-status", role: "status", "aria-live": "polite" });
    this.results = node("div", { id: "ident-results" });
    this.root.replaceChildren(form, this.status, this.results);
    form.addEventListener("submit", (ev) => { ev.preventDefault(); this.run(); });
  }

  setRobot(info) {
    this.info = info;
    this.clear();
    this.say("");
  }

  clear() {
    for (const p of this.plots) p.destroy();
    this.plots = [];
    this.results.replaceChildren();
  }

  /** The panel is in view again (its tab was chosen): the plots take their cells' width. */
  shown() {
    for (const p of this.plots) {
      p.setSize({ width: plotWidth(p.root.parentElement), height: PLOT_HEIGHT });
    }
  }

  /** The status line: `parts` are text or nodes. */
  say(parts, kind = "") {
    this.status.className = kind;
    this.status.replaceChildren(...[parts].flat());
  }

  async run() {
    const info = this.info;
    const file = this.root.querySelector("#ident-file").files[0];
    if (!info || !file) { this.say("Choose a robot and a log file first.", "error"); return; }
    let log;
    try {
      log = parseLog(await file.text(), info.nq, info.nv);
    } catch (err) {
      this.say(`The log cannot be read: ${err.message}`, "error");
      return;
    }
    const body = { ...log, friction: this.root.querySelector("#ident-friction").value,
                   method: this.root.querySelector("#ident-method").value,
                   store: false, include_series: true };
    const cutoff = this.root.querySelector("#ident-filter").value.trim();
    if (cutoff) body.filter_hz = Number(cutoff);
    const fraction = this.root.querySelector("#ident-fraction").value.trim();
    if (fraction) body.validation_fraction = Number(fraction);
    this.say(`Identifying ${info.name} from ${log.t.length} samples…`);
    this.clear();
    try {
      const answer = await apiWithProgress(
        this.robotPath(info.id, "identify"), body, (p) => {
          if (this.info === info) this.say(`Identifying ${info.name}: ${progressText(p)}…`);
        });
      if (this.info !== info) return;
      const digits = (x) => x.toPrecision(3);
      this.say(["Identified: condition number ",
                numberNode(answer.condition_number, digits, CONDITION_WHY),
                ", low-pass cut-off ",
                numberNode(answer.filter_hz, (x) => `${Number(digits(x))} Hz`, FILTER_WHY), ", ",
                answer.physically_consistent ? "every body physically consistent."
                  : "some bodies are not physically consistent (least squares)."], "ok");
      this.show(answer);
    } catch (err) {
      this.say(err.message || String(err), "error");
    }
  }

  show(answer) {
    const names = answer.bodies.map((b) => b.name); // a body per joint, in joint order
    const table = node("table", { id: "ident-rmse" });
    table.append(node("caption", {}, "Joint torque RMSE on the held-out part (N·m or N)"));
    const head = node("tr");
    for (const h of ["joint", "own model", "identified", "identified, training part"]) {
      head.append(node("th", { scope: "col" }, h));
    }
    table.append(head);
    names.forEach((name, j) => {
      const row = node("tr");
      row.append(node("th", { scope: "row" }, name));
      for (const key of ["validation_before", "validation", "train"]) {
        row.append(node("td", {}, answer.rmse[key][j].toPrecision(3)));
      }
      table.append(row);
    });
    const plots = node("div", { class: "ident-plots" });
    // the joints whose motion does not determine their friction (left out of the variant)
    const warnings = node("ul", { id: "ident-warnings", class: "warnings" });
    for (const w of answer.warnings || []) {
      const item = node("li", { "data-joint": w.joint }, w.detail);
      warnings.append(item);
    }
    this.results.replaceChildren(...(warnings.children.length ? [warnings] : []), table, plots);
    const series = answer.validation_series;
    if (!series || !series.t.length) return;
    const units = names.map((name) => {
      const joint = this.info.joints.find((jt) => jt.name === name);
      return joint && joint.type === "prismatic" ? "N" : "N·m";
    });
    names.forEach((name, j) => {
      const figure = node("figure", { class: "ident-plot", "data-joint": name });
      figure.append(node("figcaption", {}, `${name}: measured, identified and own-model torques`));
      plots.append(figure);
      const opts = {
        width: plotWidth(figure), height: PLOT_HEIGHT,
        scales: { x: { time: false } },
        series: [{ label: "t (s)" },
                 ...SERIES.map(([, label, stroke, width]) => ({ label, stroke, width }))],
        axes: [{ label: "t (s)" }, yAxis(`τ (${units[j]})`)],
      };
      const plot = new uPlot(opts, jointData(series, j), figure);
      figure.plot = plot; // for the browser tests and the devtools console
      this.plots.push(plot);
    });
  }
}
