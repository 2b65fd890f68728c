// robodyn explorer, the 3-D view of the robot at the sliders' state: asks the service for what
// it draws (visuals, frame placements, centre of mass), reports mesh loading, and colours the
// links by a joint quantity with a legend. The drawing itself is robot_drawing.js.
import { RobotDrawing } from "./robot_drawing.js";

const el = (id) => document.getElementById(id);

// Sequential colour scale for link values in [0, 1]: pale yellow → orange → dark red (sRGB).
const HEAT = [[255, 255, 204], [253, 141, 60], [189, 0, 38]];
function heat(t) {
  const x = Math.max(0, Math.min(1, t)) * (HEAT.length - 1);
  const k = Math.min(HEAT.length - 2, Math.floor(x)), f = x - k;
  return HEAT[k].map((a, i) => (a + (HEAT[k + 1][i] - a) * f) / 255);
}

export class RobotView {
  /** `ctx`: the page's { api, robotPath, currentQ, fmt, finite, onError }. */
  constructor(ctx) {
    this.ctx = ctx;
    this.info = null;
    this.drawing = null; // the RobotDrawing (null where WebGL is unavailable)
    this.placing = false; // a frame-placements request is in flight
    this.placeAgain = false; // ... and the sliders moved since it was sent
    this.dynamics = null; // the last g(q) and C(q, v) v, to colour the links
    this.mark = null; // the frame whose axes are drawn: {name, point}, or null
    this.markPlacement = null; // its last world placement {position, rotation}
    try {
      this.drawing = new RobotDrawing(el("view3d"),
                                      { onProgress: (d, t, f) => this.progress(d, t, f) });
    } catch (err) { // no WebGL: the numbers still work
      el("view-progress").textContent = `No 3-D view in this browser (${err.message}).`;
      return;
    }
    el("view3d").robotDrawing = this.drawing; // for the browser tests and the devtools console
    el("show-com").addEventListener("change", (ev) => this.drawing.setShowCom(ev.target.checked));
    el("show-triads").addEventListener("change", (ev) => this.drawing.setTriads(ev.target.checked));
    el("link-colour").addEventListener("change", () => this.colourLinks());
  }

  /** Show a newly chosen robot; false when `current()` says another was chosen meanwhile. */
  async setRobot(info, current) {
    this.info = info;
    this.dynamics = null;
    this.mark = null; // the last robot's frame: a view marks one of this robot's again
    if (!this.drawing) return true;
    this.drawing.setFrameMark(null);
    const { api, robotPath } = this.ctx;
    const { visuals } = await api(robotPath(info.id, "visuals"));
    // a stick figure (no visuals, or no mesh to be had) also shows each body's centre of
    // mass, in its joint's frame
    const { bodies } = await api(robotPath(info.id, "inertias"));
    if (!current()) return false;
    const assets = robotPath(info.id, "assets");
    this.drawing.setRobot(info, visuals,
                       (a) => `${assets}/${a.split("/").map(encodeURIComponent).join("/")}`,
                       bodies);
    this.place();
    return true;
  }

  /** Place the robot at the sliders' q. One frame-placements request at a time; while it is
   * out, moves only mark the view stale, and the newest q is sent when it answers (so a drag
   * never queues requests). */
  async place() {
    if (!this.drawing || !this.info) return;
    if (this.placing) { this.placeAgain = true; return; }
    const { api, robotPath, currentQ } = this.ctx;
    this.placing = true;
    try {
      do {
        this.placeAgain = false;
        const id = this.info.id, q = currentQ(), mark = this.mark;
        const placements = (body) => api(robotPath(id, "frame-placements"), body);
        const [p, com, marked] = await Promise.all([
          placements({ q }), api(robotPath(id, "center-of-mass"), { q }),
          mark ? placements({ q, frames: [mark.name] }) : null]);
        if (this.info.id === id) {
          this.drawing.setPlacements(p.frames, p.positions, p.rotations, q);
          this.drawing.setCenterOfMass(com.position);
          if (this.mark !== mark) {
            this.placeAgain = true; // another frame was marked meanwhile
          } else if (mark) {
            this.markPlacement = { position: marked.positions[0], rotation: marked.rotations[0] };
            this.drawing.setFrameMark({ name: mark.name, point: mark.point,
                                        ellipsoids: mark.ellipsoids, ...this.markPlacement });
          }
        }
      } while (this.placeAgain);
    } catch (err) {
      this.ctx.onError(err);
    } finally {
      this.placing = false;
    }
  }

  /** Draw frame `name`'s axes at the sliders' state, following them, with `point` (3 numbers
   * in the frame's coordinates, m, or null) as a ball and `ellipsoids` (robot_drawing.js's
   * setEllipsoids, or null) in the frame; null: no frame. */
  markFrame(name, point = null, ellipsoids = null) {
    const previous = this.mark;
    this.mark = name ? { name, point, ellipsoids } : null;
    if (!this.drawing) return;
    if (!name) {
      this.markPlacement = null;
      this.drawing.setFrameMark(null);
    } else if (previous && previous.name === name && this.markPlacement) {
      this.drawing.setFrameMark({ name, point, ellipsoids, ...this.markPlacement }); // placed
    } else {
      this.markPlacement = null;
      this.place();
    }
  }

  /** Mesh loading: `done` of `total` mesh visuals settled, `failed` the file of each one not
   * drawn (404, unreadable, or named missing by the upload's warnings). */
  progress(done, total, failed = []) {
    const p = el("view-progress");
    p.dataset.done = String(done);
    p.dataset.total = String(total);
    p.dataset.failed = String(failed.length);
    const files = [...new Set(failed)];
    const listed = files.slice(0, 5).join(", ") + (files.length > 5 ? ", …" : "");
    const notDrawn = files.length
      ? `${files.length} mesh file(s) could not be loaded (${listed}); see the warnings.` : "";
    let text;
    if (total === 0) {
      text = this.drawing && this.drawing.stick
        ? (failed.length ? `No mesh could be drawn: ${notDrawn} ` : "Nothing to draw from " +
           "this description's visuals: ") + "drawn as a stick figure (joints blue, each " +
          "body's centre of mass orange)." : "";
    } else if (done < total) {
      text = `Loading meshes: ${done} of ${total}…`;
    } else {
      text = failed.length ? `${total - failed.length} of ${total} meshes loaded; ${notDrawn}`
        : `${total} meshes loaded.`;
    }
    if (p.textContent !== text) p.textContent = text;
  }

  /** New dynamics for the state shown: recolour the links if colouring by them. */
  colour(gravity, coriolisForces) {
    this.dynamics = { g: gravity, cv: coriolisForces };
    this.colourLinks();
  }

  jointValues(mode) {
    // One number per joint for the chosen quantity (null where it has none): the largest
    // |value| ÷ effort limit over the joint's coordinates, or the norm of its |g| entries.
    if (!this.dynamics) return null;
    const { g, cv } = this.dynamics;
    const values = new Map();
    for (const j of this.info.joints) {
      const rows = [...Array(j.nv).keys()].map((k) => j.idx_v + k);
      if (mode === "gravity") {
        values.set(j.name, Math.hypot(...rows.map((r) => g[r])));
        continue;
      }
      const ratios = rows.map((r, k) => {
        const limit = j.effort_limit[k];
        const tau = mode === "torque-effort" ? g[r] + cv[r] : g[r];
        return this.ctx.finite(limit) && limit > 0 ? Math.abs(tau) / limit : null;
      }).filter((x) => x !== null);
      values.set(j.name, ratios.length ? Math.max(...ratios) : null);
    }
    return values;
  }

  colourLinks() {
    if (!this.drawing || !this.info) return;
    const mode = el("link-colour").value;
    const values = mode === "own" ? null : this.jointValues(mode);
    const legend = el("link-legend");
    if (!values) {
      this.drawing.setLinkColours(null);
      legend.replaceChildren();
      return;
    }
    const ratio = mode !== "gravity";
    const top = ratio ? 1 : Math.max(1e-12, ...[...values.values()].filter((x) => x !== null));
    const parentJoint = new Map(this.info.frames.map((f) => [f.name, f.parent_joint]));
    this.drawing.setLinkColours((frame) => {
      const x = values.get(parentJoint.get(frame));
      return x === undefined || x === null ? null : heat(x / top);
    });
    const bar = document.createElement("div");
    bar.className = "legend-bar heat";
    const ticks = document.createElement("div");
    ticks.className = "legend-ticks";
    const labels = ratio ? ["0", "25 %", "50 %", "75 %", "≥ 100 % of the limit"]
      : [0, 0.25, 0.5, 0.75, 1].map((f) => `${this.ctx.fmt(f * top, 3)}` +
                                          (f === 1 ? " N·m or N" : ""));
    for (const t of labels) {
      const span = document.createElement("span");
      span.textContent = t;
      ticks.append(span);
    }
    const note = document.createElement("p");
    note.className = "legend-note";
    note.textContent = "Grey: a link whose joint has no value (the fixed base" +
      (ratio ? ", or no effort limit)." : ").");
    legend.replaceChildren(bar, ticks, note);
  }
}
