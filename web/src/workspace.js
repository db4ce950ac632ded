// The workspace of the open mesh and session: what the editor shows beside them that is not the
// morph state (the regions drawn, the undo history's labels, the DOE plan, the shape sliders), kept
// on the service with the mesh and with the session (GET/PUT /v1/meshes/{id}/workspace and
// /v1/sessions/{id}/workspace) and named in the page's address, #m=<mesh>&s=<session>. A reload, a
// bookmark or a second tab on that address opens the same workspace; opening another mesh shows
// that mesh's workspace (its regions, and the session last opened on it), never the last one's.
// Regions changed after Create session are marked as not in the session, with Rebuild session.
import { api, getJson } from "./api.js";
import { $ } from "./dom.js";
import { setStatus, showError } from "./panels.js";
import { on, state } from "./state.js";

// a change is saved this long after the last one (a brush stroke saves once)
const SAVE_MS = 250;
// most MOVEs each list of a history the service keeps (service/models/history.py)
const HISTORY_MAX = 500;
// keepalive requests (the page is going away) carry at most 64 KiB
const KEEPALIVE_MAX = 60000;

/** The mesh and session an address names ({mesh, session}, null where it names none). */
export function addressed(hash = location.hash) {
  const p = new URLSearchParams(hash.replace(/^#/, ""));
  return { mesh: p.get("m"), session: p.get("s") };
}

/** The address fragment of a mesh and session ("" for none). */
export function addressOf(mesh, session) {
  const p = new URLSearchParams();
  if (mesh) p.set("m", mesh);
  if (session) p.set("s", session);
  const h = p.toString();
  return h ? `#${h}` : "";
}

/** The regions of a SPEC in one spelling (keys sorted), to tell whether two of them differ. */
export function regionsKey(spec) {
  const { selections = {}, fixed = [], handles = {}, domain = null } = spec || {};
  const sorted = (x) => (Array.isArray(x) ? x.map(sorted) : x && typeof x === "object"
    ? Object.fromEntries(Object.keys(x).sort().map((k) => [k, sorted(x[k])])) : x);
  return JSON.stringify(sorted({ selections, fixed: [...fixed].sort(), handles, domain }));
}

/** The labels of a history, one per MOVE the service keeps of it (historyDoc in session.js): applied, then undone. */
export function historyLabels(history, index) {
  return [...history.slice(1, index + 1).slice(-HISTORY_MAX), ...history.slice(index + 1).slice(0, HISTORY_MAX)]
    .map((e) => String(e.label).slice(0, 200));
}

export class Workspace {
  /**
   * @param {{session: object, regions: object, shapes: object, openMesh: Function}} parts the session
   *   control, the regions, the shapes panel, and openMesh(id), which loads a mesh into the view
   */
  constructor({ session, regions, shapes, openMesh }) {
    Object.assign(this, { session, regions, shapes, openMesh });
    this.meshRead = null;     // the mesh whose workspace was read: saving before would replace it with nothing
    this.sessionRead = null;  // the same of the session
    this.sessionShown = null; // the session whose workspace is on screen
    this.meshSession = null;  // the session last opened on the open mesh (its workspace's)
    this.baseline = null;     // regionsKey of the regions the open session was created from
    this.fetching = null;     // {id, promise} of the session workspace being read
    this.applying = false;    // while a stored workspace is put on screen: nothing is saved
    this.timers = { mesh: null, session: null };
    this.queue = Promise.resolve();
    this.staleTimer = null;
    on("mesh", () => this.meshChanged());
    on("session", () => this.sessionChanged());
    on("regions", () => this.regionsChanged());
    on("selection", () => this.regionsChanged());
    on("history", () => this.save("session"));
    $("doe-plan").addEventListener("input", () => this.save("session"));
    $("shapes").addEventListener("change", () => this.save("session"));
    $("rebuild-session").addEventListener("click", () => this.rebuild());
    window.addEventListener("hashchange", () => this.restore());
    window.addEventListener("pagehide", () => { this.flush("mesh", true); this.flush("session", true); });
  }

  // ---------------------------------------------------------------- the address
  /** The address names the open mesh and session (replaced, so Back leaves the editor as before). */
  address() {
    const h = addressOf(state.meshId, state.sessionId);
    if (location.hash === h) return;
    window.history.replaceState(null, "", h || `${location.pathname}${location.search}`);
  }

  /** Open what the address names: its session (with its mesh), else its mesh with the mesh's workspace. */
  async restore() {
    const { mesh, session } = addressed();
    if (session && session !== state.sessionId) {
      if (await this.session.open(session)) return;
      if (!mesh) return;
      await this.openMeshWorkspace(mesh, false);
      if (state.meshId === mesh) {
        showError(`Session ${session} is no longer on the service (deleted, or removed after its idle time): ` +
          `the mesh is open with its regions; Create session makes a new session from them.`);
      }
      return;
    }
    if (mesh && mesh !== state.meshId) await this.openMeshWorkspace(mesh);
  }

  /** Open a mesh with its workspace: its regions, and (`reattach`) the session last opened on it when it still exists. */
  async openMeshWorkspace(id, reattach = true) {
    try { await this.openMesh(id); } catch (e) { showError(e); return; }
    const last = this.meshSession;
    if (!reattach || !last || state.sessionId || state.meshId !== id) return;
    let doc = null;
    try { doc = await getJson(`/v1/sessions/${last}`); } catch { return; }  // gone: the mesh's regions stay
    if (doc.mesh_id === id && doc.status !== "failed" && state.meshId === id && !state.sessionId) {
      await this.session.open(last);
    }
  }

  // ---------------------------------------------------------------- reading
  /** A mesh was opened (a new one on screen): nothing of the last one's workspace stays. */
  meshChanged() {
    this.meshRead = null;
    this.meshSession = null;
    clearTimeout(this.timers.mesh);
    this.timers.mesh = null;
    this.clearDoe();
    this.address();
  }

  /** Called by openMesh once the mesh is on screen: its regions as its workspace keeps them. */
  async meshOpened() {
    const id = state.meshId;
    let doc = null;
    try { doc = await getJson(`/v1/meshes/${id}/workspace`); } catch { doc = null; }
    if (state.meshId !== id) return;
    this.meshRead = id;
    this.meshSession = doc && doc.session;
    if (doc && doc.regions && !state.sessionId) this.put(() => this.regions.loadSpec(doc.regions));
    this.address();
  }

  /** The session's workspace, read once per opening (the history's labels and the rest come from it). */
  fetchSession(id) {
    if (!this.fetching || this.fetching.id !== id) {
      this.fetching = { id, promise: getJson(`/v1/sessions/${id}/workspace`).catch(() => null) };
    }
    return this.fetching.promise;
  }

  /** A session was opened, created or closed. */
  sessionChanged() {
    const id = state.sessionId;
    this.address();
    if (id !== this.sessionShown) {
      this.sessionShown = id;
      this.sessionRead = null;
      clearTimeout(this.timers.session);
      this.timers.session = null;
      this.clearDoe();
      if (id) {
        this.baseline = regionsKey(this.regions.spec());  // what it was created from (or opened with)
        this.loadSession(id);
      } else {
        this.baseline = null;
        this.fetching = null;
      }
    }
    this.markStale();
  }

  async loadSession(id) {
    const doc = await this.fetchSession(id);
    if (state.sessionId !== id) return;
    this.sessionRead = id;
    this.meshSession = id;
    if (doc) {
      this.put(() => {
        // regions drawn after the session was created, not in it yet: on screen again, marked
        if (doc.regions && regionsKey(doc.regions) !== this.baseline) this.regions.loadSpec(doc.regions);
        if (doc.doe_plan) { $("doe-plan").value = doc.doe_plan; $("doe-plan").dataset.edited = "1"; }
        this.shapes.values = { ...(doc.shape_values || {}) };
        this.shapes.render();
      });
    }
    this.markStale();
    this.save("mesh");  // the mesh's workspace names this session now
  }

  /** Put a stored workspace on screen without saving it back. */
  put(fn) {
    this.applying = true;
    try { fn(); } finally { this.applying = false; }
  }

  /** The DOE panel and the shape sliders as for a new session: empty. */
  clearDoe() {
    this.shapes.values = {};
    const plan = $("doe-plan");
    plan.value = "";
    delete plan.dataset.edited;
    $("doe-status").textContent = "";
    $("doe-decks").innerHTML = "";
    this.shapes.render();
  }

  // ---------------------------------------------------------------- regions not in the session
  regionsChanged() {
    clearTimeout(this.staleTimer);
    this.staleTimer = setTimeout(() => this.markStale(), 60);
    if (this.applying) return;
    this.save("mesh");
    this.save("session");
  }

  /** Regions that differ from those the open session was created from are marked, with Rebuild session. */
  stale() {
    return !!state.sessionId && this.baseline !== null && !!state.V && regionsKey(this.regions.spec()) !== this.baseline;
  }

  markStale() {
    const stale = this.stale();
    $("regions-stale").hidden = !stale;
    if (stale) {
      $("regions-stale-text").textContent = `The regions changed after Create session: they are not in session ` +
        `${state.sessionId} yet, which still morphs with the regions it was created from. Rebuild session makes ` +
        "a session of the regions on screen (its presets and DOE plan carry over).";
    }
  }

  /** One action: a new session from the regions on screen, with the presets, DOE plan and shape values carried over. */
  async rebuild() {
    const presets = state.presets.map((p) => ({ name: p.name, move: p.move }));
    const plan = $("doe-plan").dataset.edited ? $("doe-plan").value : "";
    const values = { ...this.shapes.values };
    if (!await this.session.create()) return;
    if (presets.length) await this.session.updatePresets(() => presets);
    await this.fetchSession(state.sessionId);
    this.put(() => {
      if (plan) { $("doe-plan").value = plan; $("doe-plan").dataset.edited = "1"; }
      this.shapes.values = values;
      this.shapes.render();
    });
    this.save("session");
  }

  // ---------------------------------------------------------------- saving
  /** Save the mesh's or the session's workspace a moment after its last change. */
  save(which) {
    if (this.applying) return;
    const id = which === "mesh" ? state.meshId : state.sessionId;
    if (!id || (which === "mesh" ? this.meshRead : this.sessionRead) !== id) return;  // not read yet
    clearTimeout(this.timers[which]);
    this.timers[which] = setTimeout(() => this.flush(which), SAVE_MS);
  }

  /** The workspace document of the open mesh or session. */
  document(which) {
    const spec = state.V ? this.regions.spec() : null;
    const drawn = spec && Object.keys(spec.selections || {}).length ? spec : null;
    if (which === "mesh") return { regions: drawn, session: state.sessionId || this.meshSession || null };
    const shapeValues = Object.fromEntries(Object.entries(this.shapes.values).filter(([, v]) => v));
    const plan = $("doe-plan");
    return {
      regions: drawn && regionsKey(drawn) !== this.baseline ? drawn : null,
      labels: historyLabels(state.history, state.historyIndex),
      doe_plan: plan.dataset.edited ? plan.value : "",
      shape_values: shapeValues,
    };
  }

  /** PUT a waiting save now (keepalive: the page is going away). */
  flush(which, keepalive = false) {
    if (this.timers[which] === null) return this.queue;
    clearTimeout(this.timers[which]);
    this.timers[which] = null;
    const id = which === "mesh" ? state.meshId : state.sessionId;
    if (!id) return this.queue;
    const body = JSON.stringify(this.document(which));
    const path = `/v1/${which === "mesh" ? "meshes" : "sessions"}/${id}/workspace`;
    const put = () => api(path, { method: "PUT", keepalive: keepalive && body.length < KEEPALIVE_MAX,
      headers: { "Content-Type": "application/json" }, body }).catch((e) => {
      // gone (deleted meanwhile) says nothing; a refusal says the workspace was not saved
      if (e.status !== 404 && e.status !== 410 && !keepalive) {
        setStatus(`the ${which}'s workspace was not saved on the service: ${e.message}`);
      }
    });
    this.queue = keepalive ? put() : this.queue.then(put);
    return this.queue;
  }
}
