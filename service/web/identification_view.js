// The identification view of the explorer: upload a log (CSV: t, q per coordinate, τ per
// velocity coordinate), identify the chosen robot's inertial parameters and friction on the
// service (POST v1/robots/{id}/identify), and compare measured and predicted joint torques on
// the held-out end of the log, before (the model's own parameters) and after. Every number it
// shows comes from the service's answer.

import { apiWithProgress, progressText } from "./http.js";

const SVG = "http://www.w3.org/2000/svg";
const COLOURS = { measured: "#1b1b1b", predicted: "#0b5cad", before: "#a40e26" };
const PLOT = { width: 520, height: 150, left: 52, right: 8, top: 8, bottom: 22 };
const MAX_POINTS = 600; // points drawn per curve (the series is thinned evenly)

function node(tag, attrs = {}, text = "") {
  const out = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) out.setAttribute(k, v);
  if (text) out.textContent = text;
  return out;
}

function svg(tag, attrs) {
  const out = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) out.setAttribute(k, v);
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

function plotJoint(series, j, label, unit) {
  const { t, measured, predicted, before } = series;
  const picks = thin(t.length);
  const curves = { measured, predicted, before };
  let lo = Infinity, hi = -Infinity;
  for (const values of Object.values(curves)) {
    for (const i of picks) { lo = Math.min(lo, values[i][j]); hi = Math.max(hi, values[i][j]); }
  }
  if (!(hi > lo)) { hi = lo + 1; }
  const w = PLOT.width - PLOT.left - PLOT.right, h = PLOT.height - PLOT.top - PLOT.bottom;
  const x = (s) => PLOT.left + (w * (s - t[0])) / Math.max(t[t.length - 1] - t[0], 1e-12);
  const y = (v) => PLOT.top + h * (1 - (v - lo) / (hi - lo));
  const box = svg("svg", { viewBox: `0 0 ${PLOT.width} ${PLOT.height}`, role: "img",
                           "aria-label": `${label}: measured, identified and own-model torques` });
  box.append(svg("rect", { x: PLOT.left, y: PLOT.top, width: w, height: h, fill: "#ffffff",
                           stroke: "#c8ced6" }));
  for (const [name, values] of Object.entries(curves)) {
    const points = picks.map((i) => `${x(t[i]).toFixed(1)},${y(values[i][j]).toFixed(1)}`);
    box.append(svg("polyline", { points: points.join(" "), fill: "none",
                                 stroke: COLOURS[name], "stroke-width": name === "measured" ? 2 : 1.3,
                                 "data-series": name }));
  }
  for (const [v, anchor] of [[hi, PLOT.top + 10], [lo, PLOT.top + h]]) {
    const tick = svg("text", { x: PLOT.left - 4, y: anchor, "text-anchor": "end",
                               "font-size": 11, fill: "#4a4a4a" });
    tick.textContent = `${v.toPrecision(3)} ${unit}`;
    box.append(tick);
  }
  const axis = svg("text", { x: PLOT.left + w / 2, y: PLOT.height - 5, "text-anchor": "middle",
                             "font-size": 11, fill: "#4a4a4a" });
  axis.textContent = `t from ${t[0].toFixed(2)} to ${t[t.length - 1].toFixed(2)} s`;
  box.append(axis);
  const figure = node("figure", { class: "ident-plot" });
  figure.append(node("figcaption", {}, label), box);
  return figure;
}

export class IdentificationView {
  // root: the element to fill; api(path, body) → answer (throws a Problem); robotPath(id, q).
  constructor(root, { api, robotPath }) {
    this.root = root;
    this.api = api;
    this.robotPath = robotPath;
    this.info = null;
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
    this.results.replaceChildren();
    this.say("");
  }

  say(text, kind = "") {
    this.status.className = kind;
    this.status.textContent = text;
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
    this.results.replaceChildren();
    try {
      // identify is a write where the server has API keys: the upload form's key is sent
      const key = (document.querySelector("#api-key")?.value || "").trim();
      const headers = key ? { Authorization: `Bearer ${key}` } : {};
      const answer = await apiWithProgress(
        this.robotPath(info.id, "identify"), body, (p) => {
          if (this.info === info) this.say(`Identifying ${info.name}: ${progressText(p)}…`);
        }, headers);
      if (this.info !== info) return;
      this.say(`Identified: condition number ${answer.condition_number.toPrecision(3)}, ` +
               (answer.physically_consistent ? "every body physically consistent."
                 : "some bodies are not physically consistent (least squares)."), "ok");
      this.show(answer);
    } catch (err) {
      this.say(err.message || String(err), "error");
    }
  }

  show(answer) {
    const names = answer.friction.map((f) => f.joint);
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
    const legend = node("p", { class: "ident-legend" });
    for (const [name, text] of [["measured", "━ measured"], ["predicted", "━ identified model"],
                                ["before", "━ the robot's own model"]]) {
      legend.append(node("span", { class: `ident-${name}` }, text));
    }
    const plots = node("div", { class: "ident-plots" });
    const units = this.info.joints.map((jt) => (jt.type === "prismatic" ? "N" : "N·m"));
    if (answer.validation_series) {
      names.forEach((name, j) => {
        plots.append(plotJoint(answer.validation_series, j, name, units[j] || ""));
      });
    }
    this.results.replaceChildren(table, legend, plots);
  }
}
