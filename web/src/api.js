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

// a listing is read this many items a page (the service's most), at most this many pages
const PAGE_LIMIT = 1000;
const PAGES_MAX = 100;

/**
 * Every item of a paged listing (/v1/meshes, /v1/sessions): the pages in order, each after the
 * X-Next-Cursor of the one before, so that a store with more items than one page lists them all.
 */
export async function getAll(path) {
  const items = [];
  let cursor = null;
  for (let k = 0; k < PAGES_MAX; k++) {
    const q = new URLSearchParams({ limit: String(PAGE_LIMIT) });
    if (cursor) q.set("cursor", cursor);
    const r = await api(`${path}${path.includes("?") ? "&" : "?"}${q}`);
    items.push(...await r.json());
    cursor = r.headers.get("X-Next-Cursor");
    if (!cursor) break;
  }
  return items;
}

export async function postJson(path, doc) {
  return (await api(path, { method: "POST", headers: { "Content-Type": "application/json" },
    body: JSON.stringify(doc) })).json();
}

let setupRead = { id: null, promise: null };

/**
 * A session's document, read once per session: what its set-up measured (`constraints_at_rest`,
 * `edits_at_rest`) does not change while the session lives, so the panels that show it share one
 * request. Only the last session asked for is kept.
 */
export function sessionSetup(id) {
  if (setupRead.id !== id) {
    const promise = getJson(`/v1/sessions/${id}`);
    setupRead = { id, promise };
    // kept only once the set-up has ended: a building session's document is asked again next time
    const forget = () => { if (setupRead.promise === promise) setupRead = { id: null, promise: null }; };
    promise.then((doc) => { if (doc.status !== "ready") forget(); }, forget);
  }
  return setupRead.promise;
}
