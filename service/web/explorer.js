// robodyn explorer: plain JavaScript modules, no build step; the 3-D drawing (robot_drawing.js)
// uses the vendored three.js. Every request goes to this service through a relative URL (so the
// page also works behind a path prefix); the page's Content-Security-Policy forbids any other
// origin.
import { renderBars, renderEnergy } from "./dynamics_view.js";
import { EquationsView } from "./equations_view.js";
import { api, Problem, robotPath, setApiKey } from "./http.js";
import { IdentificationView } from "./identification_view.js";
import { finite, jointCoordinates, UNITS } from "./joint_coordinates.js";
import { fmt, renderHeatmap, renderNumbers } from "./mass_matrix_view.js";
import { ModelCheckView } from "./model_check_view.js";
import { PayloadView } from "./payload_view.js";
import { RobotList } from "./robot_list_view.js";
import { RobotView } from "./robot_view.js";
import { arrowKeys } from "./tabs.js";
import { TrajectoryView } from "./trajectory_view.js";

const DEFAULT_VELOCITY = 0.5; // rad/s or m/s in every coordinate when a robot is chosen

const el = (id) => document.getElementById(id);
const state = {
  info: null, // RobotInfo of the chosen robot (GET /v1/robots/{id})
  joints: [], // per joint: {joint, coords, toQ(positions) → its nq entries of q}
  rows: [], // one per velocity coordinate: {label, kind, pos input | null, vel input}
  seq: 0, // stamp of the newest computation: older answers are dropped
  robotSeq: 0,
  timer: 0,
  last: null, // the last drawn M(q), to redraw it when the colour scale changes
  chooseScale: false,
  view: null, // the 3-D view (robot_view.js)
  trajectory: null, // the trajectory tab (trajectory_view.js)
  payload: null, // the payload view (payload_view.js)
  equations: null, // the equations view (equations_view.js)
  modelCheck: null, // the model check view (model_check_view.js)
  identification: null, // the identification view (identification_view.js)
  robots: null, // the robot picker (robot_list_view.js)
};

// ---- Controls -----------------------------------------------------------------------------

function slider(id, label, min, max, value, unit) {
  // A native range input (keyboard: arrows move 1 % of the range, Page Up/Down 10 %).
  const wrap = document.createElement("div");
  wrap.className = "slider";
  const lab = document.createElement("label");
  lab.htmlFor = id;
  lab.className = "visually-hidden";
  lab.textContent = label;
  const input = document.createElement("input");
  Object.assign(input, { type: "range", id, min: String(min), max: String(max), step: "any" });
  input.value = String(value);
  const out = document.createElement("output");
  out.htmlFor = id;
  const show = () => {
    const x = Number(input.value);
    out.textContent = `${(Math.abs(x) < 5e-4 ? 0 : x).toFixed(3)} ${unit}`; // no "-0.000"
  };
  show();
  input.addEventListener("input", () => { show(); schedule(); });
  wrap.append(lab, input, out);
  return { wrap, input };
}

function breakable(node, text) {
  // Long joint names (shoulder_lift_joint) may wrap after an underscore, not mid-word.
  text.split(/(?<=_)/).forEach((part, k) => {
    if (k) node.append(document.createElement("wbr"));
    node.append(part);
  });
}

function buildControls(q0, v0) {
  const tbody = el("joints").querySelector("tbody");
  tbody.replaceChildren();
  state.joints = [];
  state.rows = [];
  for (const j of state.info.joints) {
    const spec = jointCoordinates(j, q0, state.info.neutral_configuration);
    const entry = { joint: j, toQ: spec.toQ, inputs: [] };
    spec.coords.forEach((c, k) => {
      const row = document.createElement("tr");
      const name = j.nv === 1 ? j.name : `${j.name} ${c.suffix}`;
      const vName = j.nv === 1 ? j.name : `${j.name} ${c.vSuffix}`;
      const th = document.createElement("th");
      th.scope = "row";
      breakable(th, name);
      const n = state.rows.length;
      const posCell = document.createElement("td");
      let pos = null;
      if (c.held) {
        posCell.textContent = "held at the chosen configuration";
      } else {
        pos = slider(`q-${n}`, `${name} position (${UNITS[c.kind].q || "q units"})`,
                     c.min, c.max, c.value, UNITS[c.kind].q).input;
        posCell.append(pos.parentElement);
        entry.inputs.push(pos);
      }
      const lim = j.velocity_limit[k];
      const vmax = finite(lim) && lim > 0 ? lim : c.kind === "angle" ? 2 * Math.PI : 2;
      const vValue = v0 ? v0[j.idx_v + k] : Math.min(DEFAULT_VELOCITY, vmax);
      const vel = slider(`v-${n}`, `${vName} velocity (${UNITS[c.kind].v || "v units"})`,
                         Math.min(-vmax, vValue), Math.max(vmax, vValue), vValue,
                         UNITS[c.kind].v).input;
      const velCell = document.createElement("td");
      velCell.append(vel.parentElement);
      row.append(th, posCell, velCell);
      tbody.append(row);
      state.rows.push({ label: vName, kind: c.kind, pos, vel });
    });
    state.joints.push(entry);
  }
}

function currentQ() {
  const q = state.info.neutral_configuration.slice();
  for (const { joint, toQ, inputs } of state.joints) {
    const part = toQ(inputs.map((i) => Number(i.value)));
    part.forEach((x, k) => { q[joint.idx_q + k] = x; });
  }
  return q;
}

const currentV = () => state.rows.map((r) => Number(r.vel.value));

function schedule() {
  clearTimeout(state.timer);
  state.timer = setTimeout(compute, 40);
  state.view.place(); // the 3-D view follows the sliders at once, without the debounce
}

// ---- Computation and rendering ------------------------------------------------------------

function setStatus(text, isError = false) {
  // A polite live region: changed only when its text changes, so that moving a slider does
  // not make a screen reader repeat it.
  const s = el("status");
  if (s.textContent !== text) s.textContent = text;
  s.classList.toggle("error", isError);
}

async function compute() {
  const seq = ++state.seq;
  const id = state.info.id;
  const q = currentQ();
  const v = currentV();
  el("results").setAttribute("aria-busy", "true");
  try {
    const [mm, g, c] = await Promise.all([
      api(robotPath(id, "mass-matrix"), { q }),
      api(robotPath(id, "gravity"), { q }),
      api(robotPath(id, "coriolis"), { q, v }),
    ]);
    if (seq !== state.seq) return; // a newer state is being computed
    const labels = state.rows.map((r) => r.label);
    if (state.chooseScale) { // once per robot: log scale if the diagonal spans > 2 decades
      const diag = mm.mass_matrix.map((r, i) => Math.abs(r[i])).filter((x) => x > 0);
      el("log-scale").checked = diag.length > 0 &&
        Math.max(...diag) > 100 * Math.min(...diag);
      state.chooseScale = false;
    }
    state.last = { M: mm.mass_matrix, labels, stamp: { robot: id, q, v } };
    renderHeatmap(mm.mass_matrix, labels, { robot: id, q, v }, state.info.joints);
    renderNumbers(mm.mass_matrix, labels);
    renderBars(el("gravity-chart"), g.gravity, "f", state.rows, state.info);
    renderBars(el("coriolis-chart"), c.coriolis_forces, "f", state.rows, state.info);
    state.view.colour(g.gravity, c.coriolis_forces);
    state.equations.update({ M: mm.mass_matrix, g: g.gravity, C: c.coriolis_matrix });
    renderEnergy(el("energy"), mm.mass_matrix, v, state.info);
    setStatus("Computed by the service for the state set on the left.");
    state.payload.compute();
  } catch (err) {
    if (seq === state.seq) setStatus(err.message, true);
  } finally {
    if (seq === state.seq) el("results").setAttribute("aria-busy", "false");
  }
}

// ---- Robots -------------------------------------------------------------------------------

async function selectRobot(id) {
  if (!id) { setStatus("No robot is loaded yet.", true); return; }
  const mine = ++state.robotSeq;
  setStatus(`Loading ${id}…`);
  const info = await api(robotPath(id));
  if (mine !== state.robotSeq) return;
  state.info = info;
  state.identification.setRobot(info);
  history.replaceState(null, "", `#robot=${encodeURIComponent(id)}`);
  const posture = el("posture");
  posture.replaceChildren(new Option("default", "default"), new Option("neutral", "neutral"));
  for (const name of Object.keys(info.reference_configurations)) {
    if (name !== "default" && name !== "neutral") posture.append(new Option(name, name));
  }
  posture.value = "default";
  renderFacts(info);
  state.trajectory.setRobot(info);
  state.payload.setRobot(info);
  state.equations.setRobot(info);
  state.modelCheck.setRobot(info);
  buildControls(info.default_configuration, null);
  state.chooseScale = true;
  if (!(await state.view.setRobot(info, () => mine === state.robotSeq))) return;
  await compute();
}

function postureQ(name) {
  const info = state.info;
  if (name === "neutral") return info.neutral_configuration;
  return info.reference_configurations[name] || info.default_configuration;
}

function renderFacts(info) {
  const dl = el("facts");
  dl.replaceChildren();
  const facts = [["id", info.id], ["source", info.source], ["root joint", info.root_joint],
                 ["nq, nv", `${info.nq}, ${info.nv}`],
                 ["gravity", `[${info.gravity.join(", ")}] m/s²`]];
  for (const [k, v] of facts) {
    const dt = document.createElement("dt");
    dt.textContent = k;
    const dd = document.createElement("dd");
    dd.textContent = v;
    dl.append(dt, dd);
  }
  const box = el("warnings");
  box.replaceChildren();
  if (info.warnings.length) {
    const details = document.createElement("details");
    const summary = document.createElement("summary");
    summary.textContent = warningsSummary(info.warnings);
    const ul = document.createElement("ul");
    for (const w of info.warnings) {
      const li = document.createElement("li");
      li.textContent = w.message || JSON.stringify(w);
      ul.append(li);
    }
    details.append(summary, ul);
    box.append(details);
  }
}

/** "2 missing mesh file(s), 1 finding(s) in the description": what `warnings` holds. */
function warningsSummary(warnings) {
  const missing = warnings.filter((w) => w.code === "missing_mesh").length;
  const unreferenced = warnings.filter((w) => w.code === "unreferenced_asset").length;
  const findings = warnings.length - missing - unreferenced;
  const parts = [];
  if (missing) parts.push(`${missing} missing mesh file(s)`);
  if (unreferenced) parts.push(`${unreferenced} unused asset(s)`);
  if (findings) parts.push(`${findings} finding(s) in the description`);
  return parts.join(", ");
}

// ---- Upload -------------------------------------------------------------------------------

async function upload(ev) {
  ev.preventDefault();
  const out = el("upload-status");
  const file = el("urdf-file").files[0];
  if (!file) return;
  const body = { urdf: await file.text(), root_joint: el("root-joint").value,
                 inertia_check: el("inertia-check").value };
  const name = el("upload-name").value.trim();
  if (name) body.name = name;
  out.className = "";
  out.textContent = "Uploading…";
  try {
    const info = await api("v1/robots", body);
    out.className = "ok";
    out.textContent = `Stored as ${info.id}` +
      (info.warnings.length ? ` with ${warningsSummary(info.warnings)}.` : ".");
    await selectRobot(await state.robots.load(info.id));
  } catch (err) {
    out.className = "error";
    const p = document.createElement("p");
    const strong = document.createElement("strong");
    strong.textContent = err instanceof Problem
      ? `Upload refused: ${err.title} (${err.status}${err.code ? ", " + err.code : ""})`
      : "Upload failed";
    const detail = document.createElement("span");
    detail.className = "detail";
    detail.textContent = err instanceof Problem ? err.detail : String(err.message || err);
    p.append(strong, document.createTextNode(": "), detail);
    out.replaceChildren(p);
  }
}

// ---- Tabs (the page's views: robot and dynamics, trajectory) ----------------------------

function selectTab(button) {
  for (const tab of document.querySelectorAll('#tabs [role="tab"]')) {
    const mine = tab === button;
    tab.setAttribute("aria-selected", String(mine));
    tab.tabIndex = mine ? 0 : -1;
    el(tab.getAttribute("aria-controls")).hidden = !mine;
  }
  if (button.id === "tab-trajectory-button") {
    state.trajectory.shown();
    return;
  }
  if (state.view.drawing) state.view.drawing.resize();
  state.identification.shown();
}

function setUpTabs() {
  arrowKeys([...document.querySelectorAll('#tabs [role="tab"]')], selectTab);
}

// ---- Views of the results (dynamics, payload, equations, model check) -----------------------------------------------

function showView(button) {
  const tabs = [...document.querySelectorAll('#result-views [role="tab"]')];
  for (const tab of tabs) {
    tab.setAttribute("aria-selected", String(tab === button));
    tab.tabIndex = tab === button ? 0 : -1;
  }
  const payload = button.id === "payload-view-button";
  const equations = button.id === "equations-view-button";
  const modelCheck = button.id === "model-check-view-button";
  el("payload-view").hidden = !payload;
  el("equations-view").hidden = !equations;
  el("model-check-view").hidden = !modelCheck;
  el("results").classList.toggle("payload-shown", payload);
  el("results").classList.toggle("equations-shown", equations);
  el("results").classList.toggle("model-check-shown", modelCheck);
  if (payload) state.payload.compute();
  else if (modelCheck) state.modelCheck.show(); // marks the chosen link
  else state.view.markFrame(null); // a frame's axes: only with the Payload or Model check view
  if (equations) state.equations.show();
}

function setUpViews() {
  arrowKeys([...document.querySelectorAll('#result-views [role="tab"]')], showView);
}

// ---- Start --------------------------------------------------------------------------------

// The robot list, then the robot `chosen` (else the one a link names, else ur5); while the
// service is still loading its catalog (503 not_ready), again every second. A server that
// needs an API key for reads (401) is said to need the key: entering one loads them again.
async function loadAndShow(chosen) {
  for (;;) {
    try {
      await selectRobot(await state.robots.load(chosen));
      return;
    } catch (err) {
      if (err instanceof Problem && err.status === 401) {
        setStatus(`This server needs an API key for every request: enter it in the field ` +
                  `"API key" above the robot list. (${err.message})`, true);
        return;
      }
      if (!(err instanceof Problem && err.code === "not_ready")) throw err;
      setStatus("The service is still loading its robots…");
      await new Promise((resolve) => setTimeout(resolve, 1000));
    }
  }
}

function start() {
  const onError = (err) => setStatus(err.message, true);
  state.view = new RobotView({ api, robotPath, currentQ, fmt, finite, onError });
  state.payload = new PayloadView({
    api, robotPath, currentQ, fmt, onError, rows: () => state.rows,
    renderBars: (box, values, unitKey) => renderBars(box, values, unitKey, state.rows,
                                                     state.info),
    markFrame: (frame, point) => state.view.markFrame(frame, point),
  });
  state.equations = new EquationsView({ api, robotPath, fmt });
  state.modelCheck = new ModelCheckView({
    api, robotPath, fmt,
    markFrame: (frame, point, ellipsoids) => state.view.markFrame(frame, point, ellipsoids),
    openRobot: async (id) => selectRobot(await state.robots.load(id)),
  });
  setUpViews();
  state.trajectory = new TrajectoryView({ api, robotPath, fmt });
  setUpTabs();
  state.identification = new IdentificationView(el("identification"), { api, robotPath });
  state.robots = new RobotList(el("robot"), { choose: selectRobot, onError });
  el("robot").addEventListener("change", (ev) => selectRobot(ev.target.value).catch(onError));
  el("api-key").addEventListener("change", (ev) => {
    setApiKey(ev.target.value);
    if (state.info) schedule(); // the state shown, computed again with this key
    else loadAndShow(el("robot").value).catch(onError); // nothing loaded yet: now, with it
  });
  el("posture").addEventListener("change", (ev) => {
    buildControls(postureQ(ev.target.value), currentV());
    schedule();
  });
  el("zero-velocity").addEventListener("click", () => {
    for (const r of state.rows) {
      r.vel.value = "0";
      r.vel.dispatchEvent(new Event("input"));
    }
  });
  el("upload").addEventListener("submit", upload);
  for (const id of ["normalised", "log-scale"]) {
    el(id).addEventListener("change", () => {
      if (state.last) {
        renderHeatmap(state.last.M, state.last.labels, state.last.stamp, state.info.joints);
      }
    });
  }
  state.robots.watch();
  setApiKey(el("api-key").value); // a key the browser kept in the field across a reload
  loadAndShow().catch(onError);
}

start();
