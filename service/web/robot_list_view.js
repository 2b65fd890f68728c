// The robot picker of the explorer: the robots the service serves, in a <select> grouped by
// source (the catalog, then uploads), kept as the server has them now. Models uploaded through
// the API (or deleted) since the page loaded appear (or go) when the page comes back into view,
// every POLL_MS while it is visible, and when a #robot=<id> link names a robot the list does not
// have yet. The chosen robot stays chosen.
import { allRobots } from "./http.js";

const POLL_MS = 30000;

/** The robot a #robot=<id> link names, or null. */
export function hashRobot() {
  return new URLSearchParams(location.hash.slice(1)).get("robot");
}

export class RobotList {
  /** `select`: the <select> to fill; `choose(id)`: show that robot (a Promise); `onError(err)`:
   * say what went wrong. */
  constructor(select, { choose, onError }) {
    this.select = select;
    this.choose = choose;
    this.onError = onError;
  }

  /** Fill the list and pick a robot: `chosen`, else the #robot= link's, else ur5, else the
   * first; its id ("" for an empty list). */
  async load(chosen) {
    const robots = await allRobots();
    this.fill(robots);
    const ids = robots.map((r) => r.id);
    this.select.value = [chosen, hashRobot(), "ur5", ids[0]]
      .find((x) => x && ids.includes(x)) || "";
    return this.select.value;
  }

  /** The list as the server has it now, the chosen robot kept: every id. */
  async refresh() {
    const current = this.select.value;
    const robots = await allRobots();
    this.fill(robots);
    if (robots.some((r) => r.id === current)) this.select.value = current;
    return robots.map((r) => r.id);
  }

  /** Refresh when the page comes back into view, on focus and every POLL_MS; follow #robot=
   * links. */
  watch() {
    const quietly = () => {
      if (document.visibilityState !== "visible") return;
      this.refresh().catch(() => {}); // a failed refresh keeps the list as it was
    };
    document.addEventListener("visibilitychange", quietly);
    window.addEventListener("focus", quietly);
    window.addEventListener("hashchange", () => { this.followHash().catch(this.onError); });
    setInterval(quietly, POLL_MS);
  }

  async followHash() {
    const id = hashRobot();
    if (!id || id === this.select.value) return;
    const ids = await this.refresh();
    if (!ids.includes(id)) {
      throw new Error(`No robot '${id}' on this server (yet): the list has every robot it serves.`);
    }
    this.select.value = id;
    await this.choose(id);
  }

  fill(robots) {
    this.select.replaceChildren();
    const groups = [["catalog", "Catalog"], ["upload", "Uploaded"]];
    for (const [source, title] of groups) {
      const members = robots.filter((r) => r.source === source)
        .sort((a, b) => a.name.localeCompare(b.name));
      if (!members.length) continue;
      const group = document.createElement("optgroup");
      group.label = title;
      for (const r of members) {
        const label = source === "upload" ? `${r.name} (${r.id.slice(0, 10)}…, nv ${r.nv})`
          : `${r.name} (nv ${r.nv})`;
        group.append(new Option(label, r.id));
      }
      this.select.append(group);
    }
  }
}
