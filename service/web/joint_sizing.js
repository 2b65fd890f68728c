// robodyn explorer, the trajectory view's sizing of the joints: from a trajectory check's
// per-joint figures (POST .../trajectory-check: peak and RMS effort, peak speed and power, and
// the loads each joint's bearings carry), bars per joint and a table a person can copy as
// plain text (tab-separated, one row per joint, the units in the header). Every number is the
// service's.

/** The columns of the sizing table: [answer key, header, unit of a revolute joint, unit of a
 * prismatic one]. */
export const SIZING_COLUMNS = [
  ["peak_effort", "peak |τ|", "N·m", "N"],
  ["rms_effort", "RMS τ", "N·m", "N"],
  ["peak_velocity", "peak |v|", "rad/s", "m/s"],
  ["peak_power", "peak |τ v|", "W", "W"],
  ["peak_force", "peak ‖f‖", "N", "N"],
  ["peak_axial_force", "peak axial force", "N", "N"],
  ["peak_moment", "peak ‖n‖", "N·m", "N·m"],
  ["peak_bending_moment", "peak bending moment", "N·m", "N·m"],
];

/** What the bars show: [title, answer key of the bar, answer key drawn inside it (or null)];
 * each bar is a joint's, scaled to the largest of its group. */
const BAR_GROUPS = [
  ["Peak |τ| (light) and RMS τ (dark)", "peak_effort", "rms_effort"],
  ["Peak mechanical power |τ v|", "peak_power", null],
  ["Peak axial force |f · s| on the bearings", "peak_axial_force", null],
  ["Peak bending moment ‖n − (n · s) s‖ on the bearings", "peak_bending_moment", null],
];

function prismatic(info, name) {
  const joint = info.joints.find((j) => j.name === name);
  return Boolean(joint && joint.type === "prismatic");
}

function unitOf(info, name, key) {
  const column = SIZING_COLUMNS.find(([k]) => k === key);
  return column[prismatic(info, name) ? 3 : 2];
}

/** The sizing table as tab-separated text: a header row (the units of each column in
 * brackets, "N·m|N" where revolute and prismatic joints differ), then one row per joint with
 * the service's numbers in full. */
export function sizingTsv(check, info) {
  const kinds = new Set(check.joints.map((j) => prismatic(info, j.name)));
  const units = (c) => (kinds.size > 1 && c[2] !== c[3] ? `${c[2]}|${c[3]}`
                                                         : c[kinds.has(true) ? 3 : 2]);
  const header = ["joint", ...SIZING_COLUMNS.map((c) => `${c[1]} (${units(c)})`)];
  const rows = check.joints.map((j) => [j.name, ...SIZING_COLUMNS.map(([k]) => String(j[k]))]);
  return [header, ...rows].map((cells) => cells.join("\t")).join("\n") + "\n";
}

/** Put `text` on the clipboard: the Clipboard API where the page may use it, else a selected
 * text area and the copy command. Resolves to true when copied. */
async function copyText(text) {
  if (navigator.clipboard && window.isSecureContext) {
    try {
      await navigator.clipboard.writeText(text);
      return true;
    } catch (err) { /* refused: try the older way */ }
  }
  const area = document.createElement("textarea");
  area.value = text;
  area.setAttribute("readonly", "");
  area.style.position = "fixed";
  area.style.opacity = "0";
  document.body.append(area);
  area.select();
  const done = document.execCommand("copy");
  area.remove();
  return done;
}

function barGroup(check, info, fmt, [title, key, inner]) {
  const figure = document.createElement("figure");
  figure.className = "sizing-plot";
  figure.dataset.quantity = key;
  const caption = document.createElement("figcaption");
  caption.textContent = title;
  const bars = document.createElement("div");
  bars.className = "bars";
  const top = Math.max(...check.joints.map((j) => j[key])) || 1;
  for (const joint of check.joints) {
    const row = document.createElement("div");
    row.className = "bar-row";
    row.dataset.joint = joint.name;
    row.dataset.value = String(joint[key]);
    const label = document.createElement("span");
    label.className = "bar-label";
    label.textContent = joint.name;
    const track = document.createElement("span");
    track.className = "bar-track sizing";
    const bar = document.createElement("span");
    bar.className = inner ? "bar positive outer" : "bar positive";
    bar.style.left = "0";
    bar.style.width = `${(100 * joint[key]) / top}%`;
    track.append(bar);
    if (inner) {
      const second = document.createElement("span");
      second.className = "bar inner";
      second.style.left = "0";
      second.style.width = `${(100 * joint[inner]) / top}%`;
      track.append(second);
    }
    const value = document.createElement("span");
    value.className = "bar-value";
    const unit = unitOf(info, joint.name, key);
    value.textContent = inner ? `${fmt(joint[key], 4)} / ${fmt(joint[inner], 4)} ${unit}`
                              : `${fmt(joint[key], 4)} ${unit}`;
    row.append(label, track, value);
    bars.append(row);
  }
  figure.append(caption, bars);
  return figure;
}

/** The sizing of `check`'s joints (robot `info`) into `box`: the bars, the table and its copy
 * button. `fmt(x, digits)` formats a number for the page. */
export function renderSizing(box, check, info, fmt) {
  const title = document.createElement("h3");
  title.id = "trajectory-sizing-title";
  title.textContent = "Sizing the joints";
  const hint = document.createElement("p");
  hint.className = "hint";
  hint.textContent = "Over every evaluated point: the torque that heats the motor (RMS), the " +
    "peaks a motor and gearbox must give, and the loads each joint's bearings carry (the " +
    "wrench it transmits, in its frame, s its axis).";
  const table = document.createElement("table");
  table.id = "trajectory-sizing-table";
  table.className = "numbers sizing";
  const head = table.createTHead().insertRow();
  for (const text of ["joint", ...SIZING_COLUMNS.map((c) => c[1])]) {
    const th = document.createElement("th");
    th.scope = "col";
    th.textContent = text;
    head.append(th);
  }
  const body = table.createTBody();
  for (const joint of check.joints) {
    const row = body.insertRow();
    row.dataset.joint = joint.name;
    const name = document.createElement("th");
    name.scope = "row";
    name.textContent = joint.name;
    row.append(name);
    for (const [key] of SIZING_COLUMNS) {
      row.insertCell().textContent = `${fmt(joint[key], 4)} ${unitOf(info, joint.name, key)}`;
    }
  }
  const tsv = sizingTsv(check, info);
  const copy = document.createElement("button");
  copy.id = "trajectory-sizing-copy";
  copy.type = "button";
  copy.className = "secondary";
  copy.textContent = "Copy the table (tab-separated text)";
  const said = document.createElement("span");
  said.id = "trajectory-sizing-copied";
  said.setAttribute("role", "status");
  copy.addEventListener("click", async () => {
    said.textContent = (await copyText(tsv)) ? " Copied." : " The browser refused to copy.";
  });
  const buttons = document.createElement("div");
  buttons.className = "buttons";
  buttons.append(copy, said);
  const plots = document.createElement("div");
  plots.className = "sizing-plots";
  plots.append(...BAR_GROUPS.map((group) => barGroup(check, info, fmt, group)));
  box.replaceChildren(title, hint, plots, table, buttons);
  box.tsv = tsv; // for the tests and the devtools console
  box.hidden = false;
}
