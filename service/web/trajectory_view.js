// robodyn explorer, the trajectory view: paste or upload a CSV (t, then one column per joint,
// or waypoints: one column per joint), check the motion against the robot's limits (with an
// acceleration limit and the spline's end conditions if asked) or retime it, see per-joint
// plots of τ, v (and a of a retimed motion) ÷ limit over time with the violations shaded, the
// joints' sizing figures (joint_sizing.js), and play the motion in a 3-D view. Every number
// shown comes from the service (POST .../trajectory-check and .../retime); plots are drawn by
// the vendored uPlot.
import { apiWithProgress, progressText } from "./http.js";
import { renderSizing } from "./joint_sizing.js";
import { numberNode } from "./no_value.js";
import { yAxis } from "./plot_axes.js";
import { RobotDrawing } from "./robot_drawing.js";
import uPlot from "./vendor/uplot/uPlot.esm.js";

const el = (id) => document.getElementById(id);
const MAX_FRAMES = 400; // configurations placed for the 3-D playback (evenly picked)
const TAU = "rgb(178, 24, 43)";
const VEL = "rgb(33, 102, 172)";
const ACC = "rgb(27, 120, 55)";

/** Split CSV text into rows of cells (comma, semicolon or tab separated; # comments). */
function csvRows(text) {
  return text.split(/\r?\n/).map((line) => line.trim())
    .filter((line) => line && !line.startsWith("#"))
    .map((line) => line.split(/[,;\t]/).map((cell) => cell.trim()));
}

/** The CSV as a motion of robot `info`: {t: [N] | null, q: [N][nq], names}. A first column
 * named t (or time) makes it samples; otherwise every row is a waypoint. Joints without a
 * column keep their value in the robot's default configuration. */
export function parseMotion(text, info) {
  const rows = csvRows(text);
  if (rows.length < 3) throw new Error("The CSV needs a header row and at least two rows of numbers.");
  const header = rows[0];
  const timed = ["t", "time"].includes(header[0].toLowerCase());
  const names = timed ? header.slice(1) : header;
  const byName = new Map(info.joints.map((j) => [j.name, j]));
  const columns = names.map((name) => {
    const joint = byName.get(name);
    if (!joint) {
      const known = info.joints.filter((j) => j.nq === 1).map((j) => j.name);
      throw new Error(`"${name}" is not a joint of ${info.id}; its 1-DoF joints are: ` +
                      known.join(", "));
    }
    if (joint.nq !== 1) throw new Error(`Joint "${name}" has ${joint.nq} numbers in q: only ` +
                                        "1-DoF joints can be columns.");
    return joint.idx_q;
  });
  const t = [], q = [];
  for (const [k, row] of rows.slice(1).entries()) {
    if (row.length !== header.length) {
      throw new Error(`Row ${k + 2} has ${row.length} cells; the header has ${header.length}.`);
    }
    const numbers = row.map(Number);
    const bad = numbers.findIndex((x) => !Number.isFinite(x));
    if (bad >= 0) throw new Error(`Row ${k + 2}, column ${bad + 1} is not a number.`);
    const config = info.default_configuration.slice();
    const values = timed ? numbers.slice(1) : numbers;
    columns.forEach((iq, c) => { config[iq] = values[c]; });
    if (timed) t.push(numbers[0]);
    q.push(config);
  }
  return { t: timed ? t : null, q, names };
}

/** An example CSV for robot `info`: 3 s of a smooth motion of its first (up to 6) 1-DoF
 * joints around the default configuration, or 4 waypoints of the same joints. */
export function exampleCsv(info, waypoints) {
  const joints = info.joints.filter((j) => j.nq === 1).slice(0, 6);
  const q0 = info.default_configuration;
  const lines = [(waypoints ? [] : ["t"]).concat(joints.map((j) => j.name)).join(",")];
  const count = waypoints ? 4 : 61;
  for (let i = 0; i < count; i++) {
    const t = waypoints ? i : (3 * i) / (count - 1);
    const value = (j, k) => {
      const x = q0[j.idx_q] + 0.6 * Math.sin((waypoints ? 1.3 : 1.1) * t + k);
      const lo = j.lower[0], hi = j.upper[0];
      return Number.isFinite(lo) && Number.isFinite(hi) && lo < hi
        ? Math.min(hi - 0.05 * (hi - lo), Math.max(lo + 0.05 * (hi - lo), x)) : x;
    };
    const row = joints.map((j, k) => value(j, k).toFixed(4));
    lines.push((waypoints ? row : [t.toFixed(3), ...row]).join(","));
  }
  return lines.join("\n");
}

export class TrajectoryView {
  /** `ctx`: the page's { api, robotPath, fmt, onError }. */
  constructor(ctx) {
    this.ctx = ctx;
    this.info = null;
    this.plots = [];
    this.motion = null; // {t, q, frames, positions, rotations} for the playback
    this.playing = false;
    this.drawing = null;
    this.drawnRobot = null; // the robot id the 3-D view was built for
    el("trajectory-file").addEventListener("change", async (ev) => {
      const file = ev.target.files[0];
      if (file) el("trajectory-csv").value = await file.text();
    });
    el("trajectory-example").addEventListener("click", () => {
      if (this.info) el("trajectory-csv").value = exampleCsv(this.info, false);
    });
    el("waypoints-example").addEventListener("click", () => {
      if (this.info) el("trajectory-csv").value = exampleCsv(this.info, true);
    });
    el("trajectory-check").addEventListener("click", () => this.run("check"));
    el("trajectory-retime").addEventListener("click", () => this.run("retime"));
    el("trajectory-play").addEventListener("click", () => this.togglePlay());
    el("trajectory-time").addEventListener("input", (ev) => {
      this.pause();
      this.show(Number(ev.target.value));
    });
  }

  /** A newly chosen robot: forget the last answer (its joints are another robot's). */
  setRobot(info) {
    this.info = info;
    el("trajectory-robot").textContent = info.id;
    this.clear();
  }

  /** The tab became visible: the 3-D view can take its size now. */
  shown() {
    if (this.drawing) this.drawing.resize();
    for (const p of this.plots) p.setSize(this.plotSize());
  }

  clear() {
    this.pause();
    for (const p of this.plots) p.destroy();
    this.plots = [];
    this.motion = null;
    el("trajectory-plots").replaceChildren();
    el("trajectory-summary").replaceChildren();
    el("trajectory-sizing").replaceChildren();
    el("trajectory-sizing").hidden = true;
    el("trajectory-player").hidden = true;
  }

  status(text, error = false) {
    const s = el("trajectory-status");
    s.textContent = text;
    s.className = error ? "error" : "";
  }

  /** The limits object of both routes: the scales, and the acceleration limit entered for
   * every 1-DoF joint (null for the other entries of v; none at all when the field is empty). */
  limits() {
    const read = (id) => Number(el(id).value);
    const limits = { effort_scale: read("effort-scale"), velocity_scale: read("velocity-scale") };
    const text = el("acceleration-limit").value.trim();
    if (text !== "") {
      const acceleration = new Array(this.info.nv).fill(null);
      for (const j of this.info.joints) if (j.nv === 1) acceleration[j.idx_v] = Number(text);
      limits.acceleration = acceleration;
    }
    return limits;
  }

  async run(kind) {
    if (!this.info) return;
    const info = this.info;
    let motion;
    try {
      motion = parseMotion(el("trajectory-csv").value, info);
      if (kind === "check" && !motion.t) {
        throw new Error("Checking needs samples: a first column t (s). Waypoints are retimed.");
      }
    } catch (err) {
      this.status(err.message, true);
      return;
    }
    this.clear();
    this.status(kind === "check" ? "Checking…" : "Retiming…");
    const { api, robotPath } = this.ctx;
    try {
      let answer, t, q;
      if (kind === "check") {
        const k = Number(el("samples-per-interval").value);
        answer = await apiWithProgress(robotPath(info.id, "trajectory-check"),
                                       { t: motion.t, q: motion.q, limits: this.limits(),
                                         boundary: el("spline-boundary").value,
                                         samples_per_interval: k },
                                       (p) => this.status(`Checking: ${progressText(p)}…`));
        [t, q] = [motion.t, motion.q];
      } else {
        answer = await api(robotPath(info.id, "retime"),
                           { waypoints: motion.q, limits: this.limits() });
        [t, q] = [answer.t, answer.q];
      }
      if (this.info !== info) return; // another robot was chosen meanwhile
      const check = kind === "check" ? answer : answer.check;
      const v = answer.v; // the check's: given or the spline's; the retimed motion's
      el("trajectory-plots").result = { kind, answer }; // for the tests and the console
      this.summarise(kind, answer, check);
      this.plot(t, answer.tau, v, kind === "retime" ? answer.a : null, check);
      renderSizing(el("trajectory-sizing"), check, info, this.ctx.fmt);
      this.status(kind === "check"
        ? `${t.length} samples checked.`
        : `Retimed: ${this.ctx.fmt(answer.duration, 4)} s, sampled every 0.01 s.`);
      await this.preparePlayback(info, t, q);
    } catch (err) {
      this.status(err.message, true);
    }
  }

  summarise(kind, answer, check) {
    const box = el("trajectory-summary");
    const verdict = document.createElement("p");
    verdict.id = "trajectory-verdict";
    verdict.className = check.feasible ? "ok" : "error";
    const n = check.violations.length;
    verdict.textContent = check.feasible
      ? (kind === "retime" ? "Within every limit, everywhere along the motion."
                           : "Within every limit at every evaluated point.")
      : `${n} violation${n === 1 ? "" : "s"} of the limits (shaded in the plots).`;
    const { fmt } = this.ctx;
    const work = document.createElement("p");
    work.textContent = `Work: positive ${fmt(check.work.positive, 4)} J, negative ` +
      `${fmt(check.work.negative, 4)} J.`;
    box.replaceChildren(verdict, work);
    if (!n) return;
    const table = document.createElement("table");
    table.className = "numbers violations";
    const head = table.createTHead().insertRow();
    for (const h of ["joint", "kind", "from (s)", "to (s)", "worst", "limit"]) {
      const th = document.createElement("th");
      th.scope = "col";
      th.textContent = h;
      head.append(th);
    }
    const body = table.createTBody();
    for (const x of check.violations) {
      const row = body.insertRow();
      for (const cell of [x.joint, x.kind, fmt(x.t_start, 4), fmt(x.t_end, 4),
                          fmt(x.worst, 4), fmt(x.limit, 4)]) {
        row.insertCell().textContent = cell;
      }
    }
    box.append(table);
  }

  plotSize() {
    const width = Math.max(280, Math.min(760, el("trajectory-plots").clientWidth - 8));
    return { width, height: 170 };
  }

  plot(t, tau, v, a, check) {
    const box = el("trajectory-plots");
    const index = new Map(this.info.joints.map((j) => [j.name, j.idx_v]));
    for (const joint of check.joints) {
      const iv = index.get(joint.name);
      const series = [{ label: "t (s)" }];
      const data = [t];
      if (joint.effort_limit) {
        series.push({ label: "τ ÷ effort limit", stroke: TAU, width: 1.5 });
        data.push(tau.map((row) => row[iv] / joint.effort_limit));
      }
      if (joint.velocity_limit && v) {
        series.push({ label: "v ÷ velocity limit", stroke: VEL, width: 1.5 });
        data.push(v.map((row) => row[iv] / joint.velocity_limit));
      }
      if (joint.acceleration_limit && a) {
        series.push({ label: "a ÷ acceleration limit", stroke: ACC, width: 1.5 });
        data.push(a.map((row) => row[iv] / joint.acceleration_limit));
      }
      if (data.length === 1) continue; // no limit to compare with
      const spans = check.violations.filter((x) => x.joint === joint.name &&
                                                   x.kind !== "position");
      const figure = document.createElement("figure");
      figure.className = "joint-plot";
      figure.dataset.joint = joint.name;
      figure.dataset.violations = String(spans.length);
      const caption = document.createElement("figcaption");
      caption.append(`${joint.name}: peak |τ| `, this.ratioNode(joint, "effort"),
                     ", peak |v| ", this.ratioNode(joint, "velocity"));
      if (joint.acceleration_limit) {
        caption.append(", peak |a| ", this.ratioNode(joint, "acceleration"));
      }
      caption.append(" of the limit");
      figure.append(caption);
      box.append(figure);
      const opts = {
        ...this.plotSize(),
        scales: { x: { time: false } },
        series,
        axes: [{ label: "t (s)" }, yAxis("÷ limit")],
        hooks: { draw: [(u) => this.decorate(u, spans)] },
      };
      const plot = new uPlot(opts, data, figure);
      figure.plot = plot;
      this.plots.push(plot);
    }
  }

  /** The joint's peak ÷ limit of `kind` (effort, velocity, acceleration) in %, or n/a where
   * it has none. */
  ratioNode(joint, kind) {
    return numberNode(joint[`${kind}_ratio`], (r) => `${this.ctx.fmt(100 * r, 3)} %`,
                      `${joint.name} has no ${kind} limit (after the scales): its peak is not ` +
                      "compared with one.");
  }

  /** The limits ±1 as dashed lines, and each violation's time span shaded. */
  decorate(u, spans) {
    const { ctx, bbox } = u;
    ctx.save();
    ctx.fillStyle = "rgba(164, 14, 38, 0.18)";
    for (const s of spans) {
      const x0 = u.valToPos(s.t_start, "x", true), x1 = u.valToPos(s.t_end, "x", true);
      ctx.fillRect(Math.min(x0, x1 - 2), bbox.top, Math.max(3, x1 - x0), bbox.height);
    }
    ctx.strokeStyle = "rgb(74, 74, 74)";
    ctx.setLineDash([5, 4]);
    for (const level of [1, -1]) {
      const y = u.valToPos(level, "y", true);
      if (y < bbox.top || y > bbox.top + bbox.height) continue;
      ctx.beginPath();
      ctx.moveTo(bbox.left, y);
      ctx.lineTo(bbox.left + bbox.width, y);
      ctx.stroke();
    }
    ctx.restore();
  }

  // ---- 3-D playback -------------------------------------------------------------------------

  async preparePlayback(info, t, q) {
    const { api, robotPath } = this.ctx;
    if (!this.drawing) {
      try {
        this.drawing = new RobotDrawing(el("trajectory-view3d"));
      } catch (err) { // no WebGL: the plots still work
        el("trajectory-view-note").textContent = `No 3-D view in this browser (${err.message}).`;
        return;
      }
      el("trajectory-view3d").robotDrawing = this.drawing;
    }
    if (this.drawnRobot !== info.id) {
      const [{ visuals }, { bodies }] = await Promise.all([
        api(robotPath(info.id, "visuals")), api(robotPath(info.id, "inertias"))]);
      const assets = robotPath(info.id, "assets");
      this.drawing.setRobot(info, visuals,
                         (a) => `${assets}/${a.split("/").map(encodeURIComponent).join("/")}`,
                         bodies);
      this.drawnRobot = info.id;
    }
    const step = Math.max(1, Math.ceil(t.length / MAX_FRAMES));
    const pick = [...Array(Math.ceil(t.length / step)).keys()].map((i) => i * step);
    if (pick[pick.length - 1] !== t.length - 1) pick.push(t.length - 1);
    const placed = await api(robotPath(info.id, "frame-placements"),
                             { q: pick.map((i) => q[i]) });
    if (this.info !== info) return;
    this.motion = { t: pick.map((i) => t[i]), q: pick.map((i) => q[i]), ...placed };
    const slider = el("trajectory-time");
    slider.min = String(this.motion.t[0]);
    slider.max = String(this.motion.t[this.motion.t.length - 1]);
    slider.step = "any";
    slider.value = slider.min;
    el("trajectory-player").hidden = false;
    this.drawing.resize();
    this.show(this.motion.t[0]);
  }

  /** Place the robot at time `time` (the nearest placed configuration at or before it). */
  show(time) {
    const m = this.motion;
    if (!m || !this.drawing) return;
    let i = 0;
    while (i + 1 < m.t.length && m.t[i + 1] <= time) i++;
    this.drawing.setPlacements(m.frames, m.positions[i], m.rotations[i], m.q[i]);
    el("trajectory-time").value = String(time);
    el("trajectory-clock").textContent = `${this.ctx.fmt(time, 3)} s`;
  }

  togglePlay() {
    if (this.playing) { this.pause(); return; }
    const m = this.motion;
    if (!m) return;
    this.playing = true;
    el("trajectory-play").textContent = "Pause";
    const t0 = m.t[0], t1 = m.t[m.t.length - 1];
    let start = Number(el("trajectory-time").value);
    if (start >= t1) start = t0;
    const wall = performance.now();
    const frame = (now) => {
      if (!this.playing) return;
      const time = Math.min(t1, start + (now - wall) / 1000);
      this.show(time);
      if (time >= t1) { this.pause(); return; }
      requestAnimationFrame(frame);
    };
    requestAnimationFrame(frame);
  }

  pause() {
    this.playing = false;
    el("trajectory-play").textContent = "Play";
  }
}
