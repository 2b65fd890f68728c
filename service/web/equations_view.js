// robodyn explorer, the "Equations" view: M(q), C(q, v) and g(q) of the chosen robot in closed
// form (GET /v1/robots/{id}/equations), typeset by the vendored KaTeX (loaded on first use).
// A switch chooses the form: readable (the default: 6 significant digits, residues left out),
// exact (every term) or parametric (linear in the base inertial parameters p1 … pr, listed in
// a table with their expressions and values).
// Each entry is tinted by the set of coordinates it depends on (a legend lists the sets);
// hovering an entry shows its value at the sliders' state, from the numbers the page computed.

const el = (id) => document.getElementById(id);
const KATEX = "static/vendor/katex/";

// Light tints (dark text stays readable on each): one per distinct dependency set.
const TINTS = ["#dbeafe", "#fde2cf", "#d9f2d9", "#f3d9f0", "#fff1b8", "#d6f0f5", "#e8e0f8",
               "#f8d7da", "#e2ecc8", "#f0e1d2"];
const CONSTANT = "#eceff3";
const COMPACT_CHARS = 120; // LaTeX length up to which a quantity is shown as a matrix
// The query of each form (the API's defaults are the readable form).
const FORMS = { readable: "", exact: "?digits=17&tolerance=0", parametric: "?form=parametric" };

let katexLoading = null;
function loadKatex() {
  // The stylesheet and script are fetched once, when the view is first shown (the page's CSP
  // admits them: same origin). katex.render builds DOM nodes (no inline style attributes).
  if (!katexLoading) {
    katexLoading = new Promise((resolve, reject) => {
      const css = document.createElement("link");
      css.rel = "stylesheet";
      css.href = KATEX + "katex.min.css";
      document.head.append(css);
      const js = document.createElement("script");
      js.src = KATEX + "katex.min.js";
      js.onload = () => resolve(window.katex);
      js.onerror = () => reject(new Error("KaTeX could not be loaded"));
      document.head.append(js);
    });
  }
  return katexLoading;
}

/** The coordinates (q1, …) and velocities (dq1, …) an expression's text names. */
function namesIn(text) {
  const coords = new Set(), vels = new Set();
  for (const m of text.matchAll(/\b(d?)q(\d+)\b/g)) (m[1] ? vels : coords).add(`q${m[2]}`);
  const order = (s) => [...s].sort((a, b) => Number(a.slice(1)) - Number(b.slice(1)));
  return { coords: order(coords), vels: order(vels).map((n) => "d" + n) };
}

export class EquationsView {
  /** `ctx`: the page's { api, robotPath, fmt }. */
  constructor(ctx) {
    this.ctx = ctx;
    this.info = null;
    this.answer = null; // the equations of the chosen robot, once fetched
    this.rendered = null; // the robot id whose equations are on screen
    this.values = null; // { M, g, C, labels } at the sliders' state
    this.seq = 0;
    const box = el("equations-view");
    el("equations-form").addEventListener("change", () => {
      this.rendered = null;
      this.show();
    });
    box.addEventListener("mousemove", (ev) => this.hover(ev));
    box.addEventListener("mouseleave", () => { el("equations-tooltip").hidden = true; });
  }

  get visible() { return !el("equations-view").hidden; }

  /** A newly chosen robot: its equations are fetched when the view is shown. */
  setRobot(info) {
    this.info = info;
    this.answer = null;
    this.values = null;
    if (this.visible) this.show();
  }

  /** The numbers at the sliders' state (for the hover values). */
  update(values) { this.values = values; }

  async show() {
    const form = el("equations-form").value;
    if (!this.info || this.rendered === `${this.info.id} ${form}`) return;
    const seq = ++this.seq;
    const id = this.info.id;
    const status = el("equations-status");
    status.classList.remove("error");
    status.textContent = `Deriving the equations of ${id}… (the first time can take seconds)`;
    el("equations-body").replaceChildren();
    try {
      const [katex, answer] = await Promise.all([
        loadKatex(), this.ctx.api(this.ctx.robotPath(id, "equations") + FORMS[form])]);
      if (seq !== this.seq) return;
      this.answer = answer;
      this.render(katex, answer);
      this.rendered = `${id} ${form}`;
      const acc = answer.accuracy;
      const bound = this.ctx.fmt(acc.max_abs_error.mass_matrix, 2);
      status.textContent = `${answer.joints.length} coordinates: ` +
        answer.joints.map((j, i) => `q${i + 1} = ${j}`).join(", ") +
        `. Coefficients to ${acc.digits} significant digits` +
        (acc.tolerance ? `, terms below ${acc.tolerance} of their quantity's largest left out`
          : ", every term") +
        `: |printed − exact| ≤ ${bound} on M. ` +
        "Hover an entry for its value at the state set on the left.";
    } catch (err) {
      if (seq !== this.seq) return;
      this.rendered = null;
      status.classList.add("error");
      status.textContent = err.code === "unsupported_model"
        ? `No explicit form for this robot: ${err.detail}` : err.message;
    }
  }

  render(katex, answer) {
    const sets = new Map(); // "q2 q3" → tint
    const tint = (deps, zero) => {
      if (zero) return "";
      if (!deps.length) return CONSTANT;
      const key = deps.join(" ");
      if (!sets.has(key)) sets.set(key, TINTS[sets.size % TINTS.length]);
      return sets.get(key);
    };
    const sm = answer.structure;
    const body = el("equations-body");
    const mDeps = sm.mass_matrix.map((r) => r.map((e) => [e.depends_on, e.zero]));
    const gDeps = sm.gravity.map((e) => [[e.depends_on, e.zero]]);
    // C has no structure member: its coordinates (and velocities) are read from its text.
    const cDeps = answer.coriolis_matrix.expressions.map((r) => r.map((t) => {
      const { coords } = namesIn(t);
      return [coords, t === "0"];
    }));
    body.append(
      this.block(katex, "M", "Mass matrix M(q)", "mass_matrix", answer.mass_matrix.latex,
                 mDeps, tint),
      this.block(katex, "C", "Coriolis matrix C(q, q̇) (Christoffel symbols of the first " +
                 "kind; Ṁ = C + Cᵀ)", "coriolis_matrix", answer.coriolis_matrix.latex,
                 cDeps, tint),
      this.block(katex, "g", "Gravity g(q) = ∂U/∂q", "gravity",
                 answer.gravity.latex.map((x) => [x]), gDeps, tint));
    const legend = document.createElement("div");
    legend.id = "equations-legend";
    const chip = (colour, text) => {
      const s = document.createElement("span");
      s.className = "eq-chip";
      s.style.background = colour;
      s.textContent = text;
      return s;
    };
    legend.append(chip(CONSTANT, "constant"), chip("#ffffff", "zero"));
    for (const [key, colour] of sets) legend.append(chip(colour, `depends on ${key}`));
    body.prepend(legend);
    if (answer.parameters) legend.after(this.parameterTable(katex, answer.parameters));
  }

  /** The base parameters p1 … pr: symbol, expression in the standard ones, value and, on a
   * robot made by identification, the standard deviation of each value ("—" where the log did
   * not determine it). */
  parameterTable(katex, parameters) {
    const identified = parameters.some((p) => p.standard_deviation != null);
    const fig = document.createElement("figure");
    fig.className = "eq-block";
    fig.dataset.quantity = "parameters";
    const cap = document.createElement("figcaption");
    cap.textContent = `Base inertial parameters (${parameters.length}: the regressor's rank), ` +
      "in the standard ones (joint frame, inertia about the joint origin)";
    const table = document.createElement("table");
    table.className = "eq-parameters";
    const head = document.createElement("tr");
    for (const h of ["", "expression", "value", ...(identified ? ["std. dev."] : [])]) {
      const th = document.createElement("th");
      th.textContent = h;
      head.append(th);
    }
    table.append(head);
    for (const p of parameters) {
      const tr = document.createElement("tr");
      tr.className = "eq-parameter";
      tr.dataset.symbol = p.symbol;
      const sym = document.createElement("td");
      katex.render(`${p.symbol[0]}_{${p.symbol.slice(1)}}`, sym,
                   { throwOnError: false, output: "html" });
      const expr = document.createElement("td");
      expr.textContent = p.expression;
      const value = document.createElement("td");
      value.className = "number";
      value.textContent = this.ctx.fmt(p.value, 6);
      tr.append(sym, expr, value);
      if (identified) {
        const std = document.createElement("td");
        std.className = "number eq-std";
        std.textContent = p.standard_deviation == null ? "—" : this.ctx.fmt(p.standard_deviation, 3);
        tr.append(std);
      }
      table.append(tr);
    }
    const scroll = document.createElement("div");
    scroll.className = "eq-scroll";
    scroll.append(table);
    fig.append(cap, scroll);
    return fig;
  }

  block(katex, symbol, caption, quantity, latex, deps, tint) {
    // Short entries (the textbook arms) as a matrix; long ones (a 6-joint arm's) as a list of
    // entries "M₁₂ = …" that wrap, M's upper triangle only (it is symmetric).
    const fig = document.createElement("figure");
    fig.className = "eq-block";
    fig.dataset.quantity = quantity;
    const cap = document.createElement("figcaption");
    cap.textContent = caption;
    const compact = latex.flat().every((t) => t.length <= COMPACT_CHARS);
    const entry = (tag, i, j, tex) => {
      const node = document.createElement(tag);
      const [depends, zero] = deps[i][j];
      node.className = zero ? "eq-entry zero" : "eq-entry";
      node.style.background = tint(depends, zero);
      Object.assign(node.dataset, { quantity, row: String(i), col: String(j),
                                    depends: depends.join(" ") });
      katex.render(tex, node, { throwOnError: false, output: "html" });
      return node;
    };
    const scroll = document.createElement("div");
    scroll.className = "eq-scroll";
    if (compact) {
      const table = document.createElement("table");
      table.className = "eq-matrix";
      latex.forEach((row, i) => {
        const tr = document.createElement("tr");
        row.forEach((tex, j) => tr.append(entry("td", i, j, tex)));
        table.append(tr);
      });
      scroll.append(table);
    } else {
      const list = document.createElement("div");
      list.className = "eq-list";
      const single = latex[0].length === 1;
      latex.forEach((row, i) => row.forEach((tex, j) => {
        if (quantity === "mass_matrix" && j < i) return;
        const name = single ? `${symbol}_{${i + 1}}` : `${symbol}_{${i + 1},${j + 1}}`;
        list.append(entry("div", i, j, `${name} = ${tex}`));
      }));
      if (quantity === "mass_matrix") cap.textContent += " (symmetric: the upper triangle)";
      scroll.append(list);
    }
    fig.append(cap, scroll);
    return fig;
  }

  hover(ev) {
    const tip = el("equations-tooltip");
    const cell = ev.target.closest && ev.target.closest(".eq-entry");
    if (!cell || !this.answer) { tip.hidden = true; return; }
    const { quantity, row, col, depends } = cell.dataset;
    const i = Number(row), j = Number(col);
    const joints = this.answer.joints;
    const v = this.values;
    let name, value;
    if (quantity === "gravity") {
      name = `g[${joints[i]}]`;
      value = v && v.g[i];
    } else {
      const key = quantity === "mass_matrix" ? "M" : "C";
      name = `${key}[${joints[i]}, ${joints[j]}]`;
      value = v && v[key][i][j];
    }
    const at = value === undefined || value === null ? "not computed yet"
      : `${this.ctx.fmt(value, 6)} at the state on the left`;
    tip.textContent = `${name} = ${at}` + (depends ? ` · depends on ${depends}` : "");
    tip.dataset.value = value === undefined || value === null ? "" : String(value);
    const box = el("equations-view").getBoundingClientRect();
    tip.style.left = `${ev.clientX - box.left + 14}px`;
    tip.style.top = `${ev.clientY - box.top + 14}px`;
    tip.hidden = false;
  }
}
