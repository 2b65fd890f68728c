// The explorer's requests to this service, every one of them (JSON answers, progress streams,
// mesh files): relative URLs (the page also works behind a path prefix), and the API key the
// user entered, when there is one, on each (`Authorization: Bearer <key>`; a server with
// ROBODYN_API_KEYS_SCOPE=all needs it for reads too). An error answer (problem+json) is thrown
// as a `Problem`.

export class Problem extends Error {
  constructor(status, body) {
    super(`${body.title || "Error"} (${status}${body.code ? ", " + body.code : ""}): ` +
          `${body.detail || "no detail"}`);
    this.status = status;
    this.title = body.title || "Error";
    this.code = body.code || "";
    this.detail = body.detail || "";
  }
}

let apiKey = ""; // the key the user entered ("" for none)

/** The key every later request carries ("" or blanks: none). */
export function setApiKey(key) {
  apiKey = String(key || "").trim();
}

/** `fetch` of this service with the API key added to the headers, when there is one. */
export function request(path, init = {}) {
  const headers = { ...(init.headers || {}) };
  if (apiKey) headers.Authorization = `Bearer ${apiKey}`;
  return fetch(path, { ...init, headers });
}

export async function api(path, body) {
  const init = { headers: { Accept: "application/json" } };
  if (body !== undefined) {
    init.method = "POST";
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  return jsonOf(await request(path, init));
}

// A whole answer's JSON, or its problem thrown as a `Problem`.
async function jsonOf(res) {
  const text = await res.text();
  let json = null;
  try { json = text ? JSON.parse(text) : null; } catch { json = null; }
  if (!res.ok) throw new Problem(res.status, json || { title: res.statusText });
  return json;
}

// Every robot the service serves: the pages of GET v1/robots, following `next_cursor` until
// it is null (the catalog first, then stored models by id).
export async function allRobots() {
  const robots = [];
  let cursor = null;
  do {
    const after = cursor ? `&cursor=${encodeURIComponent(cursor)}` : "";
    const page = await api(`v1/robots?limit=1000${after}`);
    robots.push(...page.robots);
    cursor = page.next_cursor;
  } while (cursor);
  return robots;
}

export const robotPath = (id, quantity) =>
  `v1/robots/${encodeURIComponent(id)}${quantity ? "/" + quantity : ""}`;

// The same request answered as the service's progress stream (Accept: application/x-ndjson):
// `onProgress({done, total, unit, stage})` for each progress line, then the answer line's
// answer is returned; a problem line (a failure once the stream began) is thrown as a Problem.
// An error before the stream (a refused request) is an ordinary problem+json answer.
export async function apiWithProgress(path, body, onProgress) {
  const res = await request(path, {
    method: "POST", body: JSON.stringify(body),
    headers: { Accept: "application/x-ndjson, application/problem+json",
               "Content-Type": "application/json" } });
  if (!res.ok || !(res.headers.get("content-type") || "").startsWith("application/x-ndjson")) {
    return jsonOf(res);
  }
  const reader = res.body.pipeThrough(new TextDecoderStream()).getReader();
  let buffered = "";
  for (;;) {
    const { value, done } = await reader.read();
    if (value) buffered += value;
    let end;
    while ((end = buffered.indexOf("\n")) >= 0) {
      const line = buffered.slice(0, end).trim();
      buffered = buffered.slice(end + 1);
      if (!line) continue;
      const message = JSON.parse(line);
      if (message.progress) onProgress(message.progress);
      else if ("answer" in message) return message.answer;
      else if (message.problem) throw new Problem(message.problem.status, message.problem);
    }
    if (done) throw new Error("the service's answer ended before its result");
  }
}

// "stage 2 of 5 (regressor)" or "120000 of 320001 evaluated points": a progress line in words.
export function progressText({ done, total, unit, stage }) {
  return unit === "stage" ? `stage ${done + 1} of ${total} (${stage})`
    : `${done.toLocaleString("en")} of ${total.toLocaleString("en")} ${unit}s` +
      (stage ? ` (${stage})` : "");
}
