// robodyn explorer, the model check view: the findings of GET model-check for the chosen robot
// (errors no rigid body has, warnings for what is rarely meant), and for a chosen link its
// declared mass properties beside its geometry's, with both inertia ellipsoids drawn at the
// link in the 3-D view; a button stores the repaired variant and opens it. Every number comes
// from the service.
import { numberNode } from "./no_value.js";

const el = (id) => document.getElementById(id);

const DECLARED = "#c2185b"; // the declared inertia's ellipsoid
const GEOMETRY = "#00838f"; // the geometry's

/** Eigen-decomposition of a symmetric 3×3 matrix by Jacobi rotations: {values [3], vectors
 * 3×3 (columns)}. */
export function symmetricEigen(matrix) {
  const a = matrix.map((row) => [...row]);
  const v = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  for (let sweep = 0; sweep < 50; sweep++) {
    const off = Math.abs(a[0][1]) + Math.abs(a[0][2]) + Math.abs(a[1][2]);
    if (off <= 1e-300) break;
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
      if (a[p][q] === 0) continue;
      const theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
      const t = Math.sign(theta || 1) / (Math.abs(theta) + Math.sqrt(theta * theta + 1));
      const c = 1 / Math.sqrt(t * t + 1), s = t * c;
      for (let k = 0; k < 3; k++) { // A ← A J
        const akp = a[k][p], akq = a[k][q];
        a[k][p] = c * akp - s * akq;
        a[k][q] = s * akp + c * akq;
      }
      for (let k = 0; k < 3; k++) { // A ← Jᵀ A
        const apk = a[p][k], aqk = a[q][k];
        a[p][k] = c * apk - s * aqk;
        a[q][k] = s * apk + c * aqk;
      }
      for (let k = 0; k < 3; k++) { // V ← V J
        const vkp = v[k][p], vkq = v[k][q];
        v[k][p] = c * vkp - s * vkq;
        v[k][q] = s * vkp + c * vkq;
      }
    }
  }
  return { values: [a[0][0], a[1][1], a[2][2]], vectors: v };
}

/** The uniform solid ellipsoid of mass m with inertia I about its centre (the equivalent
 * inertia ellipsoid): semi-axes aᵢ² = 5/(2m) (λⱼ + λₖ − λᵢ) along the principal axes; a
 * negative square (the triangle inequality broken) is drawn flat. Null without mass. */
export function inertiaEllipsoid(mass, inertia, center, colour) {
  if (!(mass > 0) || !inertia) return null;
  const { values, vectors } = symmetricEigen(inertia);
  const sum = values[0] + values[1] + values[2];
  const radii = values.map((l) => Math.sqrt(Math.max(0, 5 / (2 * mass) * (sum - 2 * l))));
  // a right-handed rotation (det +1) for the drawing's placement matrix
  const det = vectors[0][0] * (vectors[1][1] * vectors[2][2] - vectors[1][2] * vectors[2][1]) -
    vectors[0][1] * (vectors[1][0] * vectors[2][2] - vectors[1][2] * vectors[2][0]) +
    vectors[0][2] * (vectors[1][0] * vectors[2][1] - vectors[1][1] * vectors[2][0]);
  const axes = vectors.map((row) => [row[0], row[1], det < 0 ? -row[2] : row[2]]);
  return { center, axes, radii, colour };
}

export class ModelCheckView {
  /** `ctx`: the page's { api, robotPath, fmt, markFrame(frame, point, ellipsoids),
   * openRobot(id) (choose a robot in the page) }. */
  constructor(ctx) {
    this.ctx = ctx;
    this.info = null;
    this.answer = null; // the model check of `info.id`
    this.chosen = null; // the link shown, kept across robots that have it
    this.seq = 0;
    el("model-check-link").addEventListener("change", () => this.showLink());
    el("model-check-repair").addEventListener("click", () => this.repair());
  }

  get visible() { return !el("model-check-view").hidden; }

  /** A newly chosen robot: its check is fetched when the view is shown. */
  setRobot(info) {
    this.info = info;
    this.answer = null;
    el("model-check-findings").replaceChildren();
    el("model-check-link").replaceChildren();
    el("model-check-facts").replaceChildren();
    el("model-check-repair-status").textContent = "";
    delete el("model-check-view").dataset.robot;
    if (this.visible) this.show();
  }

  async show() {
    if (!this.info) return;
    if (this.answer) { this.showLink(); return; }
    const seq = ++this.seq;
    const id = this.info.id;
    const status = el("model-check-status");
    status.classList.remove("error");
    status.textContent = `Checking ${id}'s inertias against physics and its geometry…`;
    try {
      const answer = await this.ctx.api(this.ctx.robotPath(id, "model-check"));
      if (seq !== this.seq || !this.info || this.info.id !== id) return;
      this.answer = answer;
      this.render();
      el("model-check-view").dataset.robot = id;
    } catch (err) {
      if (seq !== this.seq) return;
      status.textContent = err.message;
      status.classList.add("error");
    }
  }

  render() {
    const { findings, links } = this.answer;
    const errors = findings.filter((f) => f.severity === "error").length;
    const warnings = findings.length - errors;
    el("model-check-status").textContent = findings.length
      ? `${errors} error(s) and ${warnings} warning(s) in ${this.info.id}'s description.`
      : `No finding: every link's inertia is physical and fits its geometry.`;
    el("model-check-repair").disabled = errors === 0;
    const table = document.createElement("table");
    table.className = "numbers findings";
    const head = document.createElement("tr");
    for (const h of ["Severity", "Link", "Finding", "What", "Suggestion"]) {
      const th = document.createElement("th");
      th.scope = "col";
      th.textContent = h;
      head.append(th);
    }
    table.append(head);
    for (const f of findings) {
      const tr = document.createElement("tr");
      tr.className = f.severity;
      tr.dataset.code = f.code;
      tr.dataset.link = f.link;
      const s = f.suggestion;
      const cells = [f.severity, f.link, f.code, f.message,
                     s ? `${s.attribute} = ${s.value}` : "—"];
      for (const text of cells) {
        const td = document.createElement("td");
        td.textContent = text;
        tr.append(td);
      }
      tr.addEventListener("click", () => {
        el("model-check-link").value = f.link;
        this.showLink();
      });
      table.append(tr);
    }
    el("model-check-findings").replaceChildren(...(findings.length ? [table] : []));
    const select = el("model-check-link");
    select.replaceChildren(...links.map((l) => new Option(l.name, l.name)));
    // the link chosen before (e.g. on the robot this one repairs), else the first one found
    const first = findings.find((f) => links.some((l) => l.name === f.link));
    if (links.some((l) => l.name === this.chosen)) select.value = this.chosen;
    else if (first) select.value = first.link;
    this.showLink();
  }

  /** The chosen link: its numbers beside its geometry's, and both ellipsoids at the link. */
  showLink() {
    if (!this.answer) return;
    const { fmt, markFrame } = this.ctx;
    const link = this.answer.links.find((l) => l.name === el("model-check-link").value);
    this.chosen = link ? link.name : this.chosen;
    const facts = el("model-check-facts");
    facts.replaceChildren();
    if (!link) { markFrame(null); return; }
    const g = link.geometry;
    const vec = (v) => `[${v.map((x) => fmt(x, 4)).join(", ")}]`;
    const moments = (m) => vec(symmetricEigen(m).values.sort((a, b) => a - b));
    const add = (term, value, id) => {
      const dt = document.createElement("dt");
      dt.textContent = term;
      const dd = document.createElement("dd");
      dd.append(value);
      if (id) dd.id = id;
      facts.append(dt, dd);
    };
    const none = (why) => numberNode(null, fmt, why);
    add("Mass", `${fmt(link.mass, 5)} kg`, "model-check-mass");
    add("Declared centre of mass", `${vec(link.center_of_mass)} m`);
    add("Declared principal moments", `${vec(link.principal_moments)} kg·m²`,
        "model-check-declared");
    add("Geometry", g ? `${g.source}, ${fmt(g.volume, 4)} m³, ${fmt(g.density, 4)} kg/m³`
      : none("The link has no collision or visual shape whose volume is known."),
        "model-check-geometry");
    if (g) {
      add("Geometry's centre of mass", `${vec(g.center_of_mass)} m`);
      add("Geometry's principal moments (declared mass)",
          g.inertia ? `${moments(g.inertia)} kg·m²` : none("A massless link has no inertia."),
          "model-check-shaped");
    }
    const ellipsoids = [
      inertiaEllipsoid(link.mass, link.inertia, link.center_of_mass, DECLARED),
      g ? inertiaEllipsoid(link.mass, g.inertia, g.center_of_mass, GEOMETRY) : null,
    ].filter((e) => e);
    markFrame(link.name, null, ellipsoids);
    facts.dataset.link = link.name;
    facts.dataset.ellipsoids = String(ellipsoids.length);
  }

  /** Store the variant with every error repaired, and open it. */
  async repair() {
    if (!this.info) return;
    const out = el("model-check-repair-status");
    const from = el("model-check-from").value;
    out.classList.remove("error");
    out.textContent = "Storing the repaired variant…";
    try {
      const variant = await this.ctx.api(this.ctx.robotPath(this.info.id, "variants"),
                                         { inertias: { links: "errors", from } });
      out.textContent = `Stored as ${variant.id}; opening it.`;
      out.dataset.variant = variant.id;
      await this.ctx.openRobot(variant.id);
    } catch (err) {
      out.textContent = err.message;
      out.classList.add("error");
    }
  }
}
