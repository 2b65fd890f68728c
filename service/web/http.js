// The explorer's requests to this service: JSON in, JSON out, relative URLs (the page also
// works behind a path prefix); an error answer (problem+json) is thrown as a `Problem`.

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

export async function api(path, body, headers = {}) {
  const init = { headers: { Accept: "application/json", ...headers } };
  if (body !== undefined) {
    init.method = "POST";
    init.headers["Content-Type"] = "application/json";
    init.body = JSON.stringify(body);
  }
  const res = await fetch(path, init);
  const text = await res.text();
  let json = null;
  try { json = text ? JSON.parse(text) : null; } catch { json = null; }
  if (!res.ok) throw new Problem(res.status, json || { title: res.statusText });
  return json;
}

export const robotPath = (id, quantity) =>
  `v1/robots/${encodeURIComponent(id)}${quantity ? "/" + quantity : ""}`;
