// The REST client: every HTTP call of the editor goes through api(), which adds the API key
// and turns an error answer into an exception carrying the service's error envelope.

let key = "";

/** The API key sent with every request (empty: none). */
export function setApiKey(k) { key = (k || "").trim(); }
export function apiKey() { return key; }

export function headers(extra = {}) {
  return key ? { ...extra, "X-API-Key": key } : extra;
}

/** fetch() that throws on a non-2xx answer; the error's `body` is the service's envelope. */
export async function api(path, opts = {}) {
  const r = await fetch(path, { ...opts, headers: headers(opts.headers || {}) });
  if (!r.ok) {
    let body;
    try { body = await r.json(); } catch { body = { error: { status: r.status, message: r.statusText } }; }
    const e = new Error(body.error ? body.error.message : r.statusText);
    e.body = body;
    e.status = r.status;
    throw e;
  }
  return r;
}

export async function getJson(path) { return (await api(path)).json(); }

export async function postJson(path, doc) {
  return (await api(path, { method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(doc) })).json();
}
