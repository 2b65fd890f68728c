// The Dynamics view of the explorer (the first view of the results): the generalized gravity
// g(q) and the Coriolis and centrifugal forces C(q, v) v as bars, one per velocity coordinate,
// and the total mass and the kinetic energy T = ½ vᵀ M(q) v. M(q) itself is drawn by
// mass_matrix_view.js; the Payload view draws its g(q) with the same bars.
import { UNITS } from "./joint_coordinates.js";
import { fmt } from "./mass_matrix_view.js";

function baseRows(info) {
  // The velocity rows of a multi-dof root joint (a free-flyer or planar base), else 0.
  const first = info.joints[0];
  return first && first.nv > 1 && ["free_flyer", "planar"].includes(first.type) ? first.nv : 0;
}

/** Horizontal bars of `values` (nv, N·m or N) in `box`, one per velocity coordinate, labelled
 * by `rows` (the page's {label, kind} per coordinate) of robot `info`; `unitKey` picks the unit
 * from UNITS. */
export function renderBars(box, values, unitKey, rows, info) {
  // Bars about a centre line. A floating base's rows (a free-flyer carries the whole weight:
  // 885 N on talos) get their own scale, so that they do not flatten every joint's bar.
  const nBase = baseRows(info);
  if (!nBase || nBase >= values.length) {
    box.replaceChildren(...barRows(values, 0, unitKey, rows));
    return;
  }
  const heading = (text) => {
    const p = document.createElement("p");
    p.className = "bar-group";
    p.textContent = text;
    return p;
  };
  box.replaceChildren(
    heading(`Base (${info.joints[0].name}, ${info.joints[0].type}), own scale`),
    ...barRows(values.slice(0, nBase), 0, unitKey, rows),
    heading("Joints"),
    ...barRows(values.slice(nBase), nBase, unitKey, rows));
}

function barRows(values, offset, unitKey, rows) {
  const maxAbs = Math.max(...values.map(Math.abs)) || 1;
  return values.map((x, k) => {
    const i = offset + k;
    const r = rows[i];
    const row = document.createElement("div");
    row.className = "bar-row";
    row.dataset.index = String(i);
    row.dataset.value = String(x);
    const label = document.createElement("span");
    label.className = "bar-label";
    label.textContent = r.label;
    const track = document.createElement("span");
    track.className = "bar-track";
    const bar = document.createElement("span");
    bar.className = x < 0 ? "bar negative" : "bar positive";
    const width = (Math.abs(x) / maxAbs) * 50;
    bar.style.width = `${width}%`;
    bar.style.left = x < 0 ? `${50 - width}%` : "50%";
    track.append(bar);
    const value = document.createElement("span");
    value.className = "bar-value";
    value.textContent = `${fmt(x)} ${UNITS[r.kind][unitKey]}`;
    row.append(label, track, value);
    return row;
  });
}

/** The total mass of robot `info` (kg) and the kinetic energy T = ½ vᵀ M v (J) of M (nv × nv)
 * and v (nv), as the terms of the list `dl`. */
export function renderEnergy(dl, M, v, info) {
  // The service's `energy` endpoint is not used here (it may not be deployed yet): the kinetic
  // energy follows from the mass matrix the page already has, T = ½ vᵀ M(q) v.
  const Mv = M.map((r) => r.reduce((s, x, k) => s + x * v[k], 0));
  const T = 0.5 * v.reduce((s, x, k) => s + x * Mv[k], 0);
  dl.replaceChildren();
  const add = (term, text, value) => {
    const dt = document.createElement("dt");
    dt.textContent = term;
    const dd = document.createElement("dd");
    dd.textContent = text;
    if (value !== undefined) dd.dataset.value = String(value);
    dl.append(dt, dd);
    return dd;
  };
  add("Total mass", `${fmt(info.total_mass, 6)} kg`, info.total_mass).id = "total-mass";
  add("Kinetic energy T = ½ vᵀ M(q) v", `${fmt(T, 6)} J`, T).id = "kinetic-energy";
}
