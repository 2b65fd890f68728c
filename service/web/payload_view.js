// robodyn explorer, the payload view: a payload held by a frame (mass, centre-of-mass offset),
// g(q) with and without it, and the payload capacity at the current pose (the heaviest point
// mass the frame can hold there within the effort limits) with the limiting joint highlighted.
// Every number comes from the service: gravity with `payloads`, and payload-capacity. The
// centre of mass is given in the payload frame's axes, which the 3-D view draws at that frame.
import { numberNode } from "./no_value.js";

const el = (id) => document.getElementById(id);

const NO_LIMIT = "No joint limits the mass this frame can hold here: the frame is fixed to " +
  "the world, or no joint that carries it has an effort limit.";
const NEVER_LIMITS = "it has no effort limit, is a floating root's coordinate, or the mass " +
  "does not load it at this state.";

export class PayloadView {
  /** `ctx`: the page's { api, robotPath, currentQ, rows, fmt, renderBars, onError,
   * markFrame(frame, point) (the 3-D view draws that frame's axes and the point in them) }. */
  constructor(ctx) {
    this.ctx = ctx;
    this.info = null;
    this.seq = 0;
    for (const id of ["payload-frame", "payload-mass", "payload-x", "payload-y", "payload-z"]) {
      el(id).addEventListener("input", () => this.compute());
    }
  }

  /** A newly chosen robot: its frames in the frame list, the tool-like one chosen. */
  setRobot(info) {
    this.info = info;
    const select = el("payload-frame");
    select.replaceChildren();
    const names = [...new Set(info.frames.map((f) => f.name))].filter((n) => n !== "universe");
    for (const n of names) select.append(new Option(n, n));
    // an arm's flange if it has one, else the last link (the end of the last chain)
    const links = info.frames.filter((f) => f.type === "body").map((f) => f.name);
    select.value = ["tool0", "panda_hand", "ee_link"].find((n) => names.includes(n)) ||
      links[links.length - 1] || names[0] || "";
    el("payload-summary").replaceChildren();
    el("payload-table").replaceChildren();
    this.describeAxes();
  }

  /** The sentence saying in which axes the centre of mass is given: the chosen frame's. */
  describeAxes() {
    const frame = el("payload-frame").value;
    el("payload-axes").textContent = frame
      ? `The centre of mass x, y, z is given in ${frame}'s axes, drawn at ${frame} in the 3-D ` +
        "view (x red, y green, z blue; the purple ball is the payload's centre of mass)."
      : "";
  }

  /** The payload as the form gives it, or null with a message when a number is invalid. */
  payload() {
    const mass = Number(el("payload-mass").value);
    const c = ["payload-x", "payload-y", "payload-z"].map((id) => Number(el(id).value));
    if (!(mass > 0) || !c.every(Number.isFinite)) return null;
    return { frame: el("payload-frame").value, mass, center_of_mass: c };
  }

  visible() {
    return !el("payload-view").hidden;
  }

  /** Recompute for the sliders' q (called on every move, debounced by the page). */
  async compute() {
    if (!this.info || !this.visible()) return;
    const seq = ++this.seq;
    const { api, robotPath, currentQ, onError, markFrame } = this.ctx;
    const p = this.payload();
    const status = el("payload-status");
    this.describeAxes();
    markFrame(el("payload-frame").value, p ? p.center_of_mass : null);
    if (!p) {
      status.textContent = "The mass must be > 0 kg and the offset three numbers (m).";
      status.classList.add("error");
      return;
    }
    const id = this.info.id;
    const q = currentQ();
    try {
      const [bare, carried, cap] = await Promise.all([
        api(robotPath(id, "gravity"), { q }),
        api(robotPath(id, "gravity"), { q, payloads: [p] }),
        api(robotPath(id, "payload-capacity"),
            { q, frame: p.frame, center_of_mass: p.center_of_mass }),
      ]);
      if (seq !== this.seq) return; // a newer state or payload is being computed
      status.classList.remove("error");
      status.textContent = "Computed by the service for this state and payload.";
      this.render(p, bare.gravity, carried.gravity, cap);
      el("payload-view").dataset.q = JSON.stringify(q); // what the drawing was computed for
    } catch (err) {
      if (seq !== this.seq) return;
      status.textContent = err.message;
      status.classList.add("error");
      if (onError && !(err.status >= 400 && err.status < 500)) onError(err);
    }
  }

  render(p, bare, carried, cap) {
    const { fmt, rows, renderBars } = this.ctx;
    const summary = el("payload-summary");
    summary.replaceChildren();
    const add = (term, parts, id, value) => {
      const dt = document.createElement("dt");
      dt.textContent = term;
      const dd = document.createElement("dd");
      dd.append(...[parts].flat());
      dd.id = id;
      if (value !== undefined && value !== null) dd.dataset.value = String(value);
      summary.append(dt, dd);
    };
    const where = `at ${p.frame}, offset [${p.center_of_mass.join(", ")}] m`;
    if (cap.mass === null) {
      add("Capacity here", [numberNode(null, fmt, NO_LIMIT), ` ${where}: no joint limits a mass`],
          "payload-capacity", null);
    } else {
      add("Capacity here", `${fmt(cap.mass, 5)} kg ${where}, holding still`, "payload-capacity",
          cap.mass);
      add("Limiting joint", cap.limiting_joint, "payload-limiting", undefined);
      const share = p.mass / cap.mass;
      const under = cap.mass_range && p.mass < cap.mass_range[0];
      add("This payload", cap.mass > 0
        ? `${fmt(p.mass, 5)} kg: ${fmt(100 * share, 3)} % of the capacity` +
          (share > 1 ? " (over it: some joint exceeds its effort limit)" : "") +
          (under ? " (under the lightest mass that keeps every joint within its limit)" : "")
        : `${fmt(p.mass, 5)} kg: no mass keeps every joint within its limit here`,
      "payload-share", share);
    }
    // the masses that keep every joint within its limit: from lo > 0 for a counterweight
    const range = cap.mass_range;
    add("Within every limit", range === null
      ? "no mass: a joint is over its limit whatever the payload"
      : `${fmt(range[0], 5)} kg to ${range[1] === null ? "any mass" : `${fmt(range[1], 5)} kg`}`,
    "payload-range", range === null ? "" : JSON.stringify(range));
    el("payload-summary").dataset.limiting = cap.limiting_joint || "";
    renderBars(el("payload-gravity-chart"), carried, "f");
    const owners = this.info.joints.flatMap((j) => Array(j.nv).fill(j.name));
    for (const row of el("payload-gravity-chart").querySelectorAll(".bar-row")) {
      const limiting = owners[Number(row.dataset.index)] === cap.limiting_joint;
      row.classList.toggle("limiting", limiting);
      if (limiting) row.title = "This joint limits the payload";
    }
    this.table(bare, carried, cap, rows(), fmt);
  }

  table(bare, carried, cap, rows, fmt) {
    const limits = this.info.joints.flatMap((j) => j.effort_limit);
    const owners = this.info.joints.flatMap((j) => Array(j.nv).fill(j.name));
    const table = document.createElement("table");
    table.className = "numbers payload";
    const head = document.createElement("tr");
    for (const h of ["Coordinate", "g(q)", "g(q) with the payload", "Effort limit",
                     "Capacity of this joint alone (kg)"]) {
      const th = document.createElement("th");
      th.scope = "col";
      th.textContent = h;
      head.append(th);
    }
    table.append(head);
    rows.forEach((r, i) => {
      const tr = document.createElement("tr");
      tr.dataset.joint = owners[i];
      if (cap.limiting_joint && owners[i] === cap.limiting_joint) {
        tr.className = "limiting";
        tr.title = "This joint limits the payload";
      }
      const th = document.createElement("th");
      th.scope = "row";
      th.textContent = r.label;
      const limit = limits[i] > 0 && limits[i] < 1e300 ? limits[i] : null; // 0: none
      const cells = [fmt(bare[i], 5), fmt(carried[i], 5),
                     numberNode(limit, (x) => fmt(x, 4), `${r.label} has no effort limit.`),
                     numberNode(cap.mass_per_joint[i], (x) => fmt(x, 5),
                                `${r.label} never limits the payload here: ${NEVER_LIMITS}`)];
      tr.append(th, ...cells.map((cell) => {
        const td = document.createElement("td");
        td.append(cell);
        return td;
      }));
      table.append(tr);
    });
    el("payload-table").replaceChildren(table);
  }
}
