// The session's life: create it from the regions (polling a long build), open an existing one,
// stream MOVEs and show each frame, reset, download, save and reload, close and delete, and the
// session's named presets, which the service keeps with it (PATCH /v1/sessions/{id}).
// A session this tab created is deleted when the tab replaces it with a new one, when the tab
// leaves it for another mesh before it was moved, and when the tab closes while it is still
// building; otherwise it stays on the service (its address reopens it, Sessions lists it) until
// deleted or removed by the service's idle sweep. A reload keeps it: the address names it.
import { api, apiKey, getAll, getJson, headers, postJson } from "./api.js";
import { decodeFrame } from "./binary.js";
import { EDIT_KINDS } from "./edits.js";
import { $ } from "./dom.js";
import { ask, clearError, meshReport, setBusy, setProgress, setStatus, showError, showReport } from "./panels.js";
import { claim, emit, state } from "./state.js";
import { Stream } from "./stream.js";

// the owner of the state's "session" group: the open session, its presets and its stream
const own = claim("session");

// where editors before the service kept presets kept them in this browser (moved to the service on open)
const legacyPresetKey = (id) => `tetmorph-presets:${id}`;
// where editors before the service kept a session's undo history in this browser (no longer read)
const legacyHistoryKey = (id) => `tetmorph-history:${id}`;
// most MOVEs each list of a history the service keeps (service/models/history.py)
const HISTORY_MAX = 500;

export class SessionControl {
  constructor(meshView, regions) {
    this.meshView = meshView;
    this.regions = regions;
    this.moves = null;       // set by the wiring (gizmo.js Moves)
    this.openMesh = null;    // set by the wiring: (id) => Promise, loads a mesh into the view
    this.own = new Set();    // sessions this tab created
    this.building = null;    // id of a session being built for this tab
    this.presetQueue = Promise.resolve(); // preset changes, one after another
    this.pendingBoundary = null; // a boundary frame waiting for the next paint
    this.historyOf = null;   // the session whose history the editor holds (read from the service, or new)
    this.historyTimer = null; // the debounced PUT of the history
    this.historyQueue = Promise.resolve(); // history PUTs, one after another
    this.displacementTimer = null; // the debounced read of the REPORT's handle and free displacements
    this.workspace = null;   // set by the wiring (workspace.js Workspace): the history's labels come from it
    this.openQueue = Promise.resolve(); // opens, one after another (the address's and the user's)
    this.unmeasured = 0;     // MOVEs up to this seq went out across a reconnect: no round trip of theirs is real
    meshView.viewer.beforeRender.push(() => this.drawPendingBoundary());
    window.addEventListener("pagehide", () => this.leaving());
  }

  policy() { return $("policy").value; }
  repair() { return $("repair").checked; }

  /** The SPEC Create session sends. */
  spec() { return this.regions.spec({ inversion: this.policy(), repair: this.repair() }); }

  // ---------------------------------------------------------------- create
  async create(after) {
    clearError();
    if (!state.meshId) { showError("open a mesh first"); return false; }
    if (state.surface) { showError("this mesh is a surface: tetrahedralize it first (Session section)"); return false; }
    const handles = this.regions.handles();
    const fixed = state.regions.filter((r) => r.kind === "fixed" && r.count > 0);
    const spec = this.spec();
    const edits = EDIT_KINDS.some((k) => (spec[k] || []).length);  // a SPEC may hold edits alone
    if (!edits && (!fixed.length || !handles.length)) {
      showError("select a fixed region and a handle region first, or add an edit (Edits)");
      return false;
    }
    // this tab's session on the old regions is replaced, not left behind; one that was moved is
    // replaced only when the user agrees (Cancel keeps it open, with its moves)
    const old = state.sessionId;
    const moves = state.history.length - 1;
    if (old && this.own.has(old) && moves > 0 && !await ask(`Create a new session? The open session ${old} has ` +
      `${moves} move${moves === 1 ? "" : "s"} in its history: it is deleted on the service, with its moves and ` +
      "presets, and this cannot be undone. Cancel keeps it open as it is.", "Replace it")) return false;
    if (state.sessionId !== old) return false;  // closed or replaced while the question was open
    if (old && this.own.has(old)) await this.remove(old, true);
    else this.close();
    setStatus("building…");
    setBusy("building");
    let sid = null;
    try {
      let s = await postJson("/v1/sessions", { mesh_id: state.meshId, spec });
      sid = s.id;
      this.own.add(s.id);
      this.building = s.id;
      for (let polls = 0; s.status === "building"; polls++) {
        setProgress(s.progress || 0);
        setStatus(`building: ${s.stage} ${Math.round(100 * (s.progress || 0))}%`);
        await new Promise((r) => setTimeout(r, Math.min(1000, 150 + 50 * polls)));
        s = await getJson(`/v1/sessions/${s.id}`);
      }
      this.building = null;
      if (s.status !== "ready") throw Object.assign(new Error(`session ${s.status}`), { body: { error: s.error } });
      setProgress(1);
      this.start(s.id, handles);
      this.historyOf = s.id;  // a new session: its history is the rest shape only
      own.presets = s.presets || [];
      if (after) after();
      emit("presets");
      const setup = s.setup_timings ? ` · set-up ${Math.round(s.setup_timings.total_ms)} ms` : "";
      setStatus(`session ${s.id} ready${setup}`);
      this.note();
      emit("sessions-changed");
      return true;
    } catch (e) {
      this.building = null;
      if (sid && state.sessionId !== sid) this.remove(sid, true);  // a build that failed leaves nothing behind
      setStatus("no session");
      showError(e);
      return false;
    } finally {
      setBusy(null);
    }
  }

  /** Attach the gizmo and the stream to a ready session, which starts from the rest shape. */
  start(id, handleRegions) {
    this.dropBoundary();
    own.sessionId = id;
    own.specSent = this.spec();
    own.presets = [];
    // the MOVE counter and the round trips are the session's: a new one starts from 0
    own.seq = 0; own.lastSeq = 0; own.roundTripMs = undefined; own.boundaryRoundTripMs = undefined;
    this.unmeasured = 0;
    emit("session");
    this.moves.attach(handleRegions);
    this.meshView.applyPositions(state.V0);
    showReport(meshReport());
    this.openStream();
    $("session-note").hidden = true;
  }

  /** Say what happens to the session when the tab closes. */
  note() {
    const el = $("session-note");
    if (!state.sessionId) { el.hidden = true; return; }
    const mine = this.own.has(state.sessionId);
    el.textContent = !mine
      ? "Opened from the service: closing this tab leaves it there (Sessions lists it)."
      : "Kept on the service when this tab closes: a reload or this page's address reopens it, and Sessions " +
        "lists it; the service removes it after it has been idle for its time-to-live (24 h by default).";
    el.hidden = false;
  }

  /** pagehide: delete this tab's unfinished session (still building); a ready one stays for the address. */
  leaving() {
    this.flushHistory(true);
    const id = this.building;
    if (!id) return;
    try { fetch(`/v1/sessions/${id}`, { method: "DELETE", keepalive: true, headers: headers() }); } catch { /* closing */ }
  }

  // ---------------------------------------------------------------- open, close, delete
  /** Open an existing session: its mesh, regions from its SPEC, its current positions and last MOVE. */
  open(id) {
    const run = () => this.openNow(id);
    this.openQueue = this.openQueue.then(run, run);
    return this.openQueue;
  }

  async openNow(id) {
    if (state.sessionId === id && state.ws && state.ws.usable) return true;  // open here already
    clearError();
    setBusy("loading");
    try {
      const doc = await getJson(`/v1/sessions/${id}`);
      if (doc.status === "failed") throw Object.assign(new Error("failed"), { body: { error: doc.error } });
      if (state.meshId !== doc.mesh_id || !state.V) await this.openMesh(doc.mesh_id);
      else await this.leave();
      this.regions.loadSpec(doc.spec);
      if (doc.spec.inversion) $("policy").value = doc.spec.inversion;
      $("repair").checked = !!doc.spec.repair;
      setBusy(doc.status === "ready" ? "loading" : "building");
      const r = await api(`/v1/sessions/${id}/positions?result=binary&dtype=float32`);
      const { data } = decodeFrame(await r.arrayBuffer());
      // the history is read before the stream opens: a session that is open and streaming has its history
      const kept = await this.serviceHistory(id);
      this.start(id, this.regions.handles());
      own.specSent = doc.spec;
      emit("session");
      this.dropBoundary();
      this.meshView.applyPositions(data);
      // the history kept with the session (its current entry is what the session holds), then
      // the service's last MOVE when it was moved without it since
      this.historyOf = id;
      this.moves.resume(kept, doc.last_move);
      own.presets = doc.presets || [];
      emit("presets");
      showReport({ ...(doc.last_report || {}), mesh: state.meshName });
      setStatus(`session ${id} (${doc.updates} update${doc.updates === 1 ? "" : "s"} on the service)`);
      this.note();
      await this.migratePresets(id);
      return true;
    } catch (e) {
      showError(e);
      return false;
    } finally {
      setBusy(null);
    }
  }

  /** Leave the open session: this tab's session is deleted when it was never moved, else kept. */
  async leave() {
    const id = state.sessionId;
    if (id && this.own.has(id) && state.history.length <= 1) await this.remove(id, true);
    else this.close();
  }

  /** Leave the session in this tab (it stays on the service). */
  close() {
    this.flushHistory();
    this.historyOf = null;
    this.dropBoundary();  // a boundary frame of the stream being closed is never drawn
    if (own.ws) own.ws.close();
    own.ws = null; own.sessionId = null; own.specSent = null; own.presets = [];
    this.reconnect = null;
    streamBadge(null);
    emit("session");
    emit("presets");  // the closed session's presets leave the screen with it
    this.moves.detach();
    setStatus("no session");
    setProgress(0);
    $("session-note").hidden = true;
    setBusy(null);
  }

  /** Delete a session on the service (the open one is closed first). */
  async remove(id, quiet = false) {
    if (id === state.sessionId) this.close();
    try {
      await api(`/v1/sessions/${id}`, { method: "DELETE" });
    } catch (e) {
      if (!(e.status === 404)) { if (!quiet) showError(e); return false; }
    }
    this.own.delete(id);
    localStorage.removeItem(legacyPresetKey(id));
    localStorage.removeItem(legacyHistoryKey(id));
    emit("sessions-changed");
    return true;
  }

  async list() { return getAll("/v1/sessions"); }

  // ---------------------------------------------------------------- history kept with the session
  /**
   * Keep the open session's undo history with the session on the service (PUT .../history), a
   * moment after it last changed: reopening the session, from this browser or another, or
   * reloading the page brings back Undo and Redo.
   */
  saveHistory() {
    const id = state.sessionId;
    if (!id || this.historyOf !== id) return;  // not read yet: saving now would replace it with nothing
    clearTimeout(this.historyTimer);
    this.historyTimer = setTimeout(() => this.flushHistory(), 300);
  }

  /** PUT the history now when a save is waiting (keepalive: the page is going away). */
  flushHistory(keepalive = false) {
    if (this.historyTimer === null) return this.historyQueue;
    clearTimeout(this.historyTimer);
    this.historyTimer = null;
    const id = state.sessionId;
    if (!id || this.historyOf !== id) return this.historyQueue;
    const body = JSON.stringify(historyDoc(state.history, state.historyIndex));
    const put = () => api(`/v1/sessions/${id}/history`, { method: "PUT", keepalive,
      headers: { "Content-Type": "application/json" }, body }).catch((e) => {
      // a session gone or a history refused: the editor's history stays as it is, unsaved
      if (state.sessionId === id && e.status !== 404 && e.status !== 410) {
        setStatus(`session ${id} · the undo history was not saved on the service: ${e.message}`);
      }
    });
    this.historyQueue = keepalive ? put() : this.historyQueue.then(put);
    return this.historyQueue;
  }

  /** The history kept with a session on the service as editor entries and the index shown, or null. */
  async serviceHistory(id) {
    try {
      const [doc, ws] = await Promise.all([getJson(`/v1/sessions/${id}/history`),
        this.workspace ? this.workspace.fetchSession(id) : null]);
      const applied = doc.applied || [], undone = doc.undone || [];
      if (!applied.length && !undone.length) return null;
      // the labels kept with the session's workspace, when they are of this history (one per MOVE)
      const labels = ws && Array.isArray(ws.labels) && ws.labels.length === applied.length + undone.length
        ? ws.labels : null;
      const entry = (label, at) => (m, k) => ({ label: labels ? labels[at + k] : isRest(m) ? "rest" : label,
        move: isRest(m) ? null : m });
      const history = [{ label: "rest", move: null }, ...applied.map(entry("move", 0)),
        ...undone.map(entry("undone move", applied.length))];
      return { history, index: applied.length };
    } catch { return null; }
  }

  // ---------------------------------------------------------------- stream
  /** Before each paint: the boundary frame that came since the last one, if its full frame did not. */
  drawPendingBoundary() {
    const p = this.pendingBoundary;
    if (!p) return;
    if (p.session !== state.sessionId || p.seq <= state.lastSeq) {  // another session's, or overtaken
      this.dropBoundary();
      return;
    }
    this.pendingBoundary = null;
    this.meshView.applyBoundary(p.data);
    if (p.seq === own.seq && p.seq > this.unmeasured) {
      own.boundaryRoundTripMs = performance.now() - own.sentAt;
      emit("stream");
    }
  }

  /** Forget the pending boundary frame (counted as skipped) when its MOVE is at most ``upTo``. */
  dropBoundary(upTo = Infinity) {
    if (!this.pendingBoundary || this.pendingBoundary.seq > upTo) return;
    this.pendingBoundary = null;
    own.boundarySkipped += 1;
    emit("stream");
  }

  openStream() {
    const id = state.sessionId;
    const ws = new Stream(id, apiKey(), {
      onFrame: (f) => this.frame(f),
      onMessage: (msg) => this.message(msg),
      onClose: (ev) => {
        if (state.ws !== ws) return;
        // a MOVE still out is never answered: the handles go back to what the session showed last
        if (own.lastSeq < own.seq) { this.moves.rejected(own.seq); own.lastSeq = own.seq; emit("stream"); }
        const code = { 4404: "session_not_found", 4410: "session_not_found", 4401: "unauthorized" }[ev.code];
        if (code) showError({ body: { error: { code, message: ev.reason || "" } } });
        setStatus(`session ${id} · stream closed${ev.reason ? ` (${ev.reason})` : ""}: moves cannot be sent; ` +
          "reopen the session from Sessions, or create one");
        streamBadge("stream closed: moves cannot be sent", $("session-status").textContent, true);
        setBusy(null);
      },
      onState: (what, info) => {
        if (state.ws !== ws) return;
        if (what === "reconnecting") {
          this.unmeasured = Infinity;  // until it is back: whatever is sent now waits for it
          this.reconnect = info;
          this.reconnectStatus();
        } else {
          this.unmeasured = state.seq;  // the MOVEs sent before the reconnect waited for it
          this.reconnect = null;
          setStatus(`session ${id} · stream reconnected`);
          streamBadge(null);
          if (state.error && state.error.code === "network") clearError();
        }
      },
    });
    own.ws = ws;
    emit("stream");
  }

  /** The status while the stream is down: when it tries again, and whether a move waits for it. */
  reconnectStatus() {
    const r = this.reconnect;
    if (!r) return;
    const queued = state.lastSeq < state.seq ? "; the latest move is queued and goes out when it is back" : "";
    setStatus(`session ${state.sessionId} · stream lost, reconnecting (try ${r.attempt}, ` +
      `next in ${(r.delayMs / 1000).toFixed(1)} s)${queued}`);
    streamBadge(`stream lost · reconnecting, try ${r.attempt}${queued ? " · move queued" : ""}`,
      $("session-status").textContent);
  }

  frame({ header, data }) {
    if (header.frame === "boundary") {
      // The surface at the next paint (nothing can show it sooner); quality and the REPORT come
      // with the full frame. When the full frame of the same MOVE is in before that paint, the
      // boundary is never applied: applying it would only delay the full frame.
      own.boundaryReceived += 1;
      emit("stream");
      this.dropBoundary();  // an older one not painted yet
      this.pendingBoundary = { seq: header.seq, data, session: state.sessionId };
      return;
    }
    this.dropBoundary(header.seq);
    // a round trip is measured only for a MOVE that went out and came back over one connection
    const rtt = header.seq === state.seq && header.seq > this.unmeasured ? performance.now() - state.sentAt : undefined;
    this.meshView.applyPositions(data);
    own.lastSeq = header.seq;
    own.roundTripMs = rtt;
    emit("stream");
    const rep = header.report || {};
    this.moves.solved(header.seq, rep);
    showReport({ mesh: state.meshName, seq: header.seq, dropped: header.dropped, ...rep, round_trip_ms: rtt, apply_ms: state.applyMs });
    if (rep.max_free_displacement === undefined) this.fetchDisplacements(header.seq);
    setBusy(null);
    if (header.seq !== state.seq) setBusy("solving", 250); // newer MOVEs are still out
    if (rep.inverted_elements > 0 && this.policy() === "warn") {
      showError({ body: { error: { code: "inverted_elements", message: `${rep.inverted_elements} elements inverted`,
        details: { report: rep, applied: true } } } });
    } else if (!rep.conflicting_constraints || !rep.conflicting_constraints.length) {
      clearError();
    }
    this.note();
  }

  /**
   * The REPORT's largest handle and free displacements, which the stream's frames do not carry:
   * from the session's last REPORT, once the MOVEs sent have come back (a moment after the last
   * frame, so a drag asks once), and shown when the REPORT shown is still of that MOVE.
   */
  fetchDisplacements(seq) {
    clearTimeout(this.displacementTimer);
    if (seq !== state.seq) return;
    const id = state.sessionId;
    this.displacementTimer = setTimeout(async () => {
      let doc;
      try { doc = await getJson(`/v1/sessions/${id}`); } catch { return; }
      const rep = state.report, last = doc.last_report || {};
      if (state.sessionId !== id || !rep || rep.seq !== seq || state.seq !== seq || rep.rejected) return;
      if (last.max_free_displacement === undefined || last.max_free_displacement === null) return;
      showReport({ ...rep, max_handle_displacement: last.max_handle_displacement,
        max_free_displacement: last.max_free_displacement });
    }, 150);
  }

  /** A text frame: a MOVE the service refused (the session stays where it was). */
  message(msg) {
    if (!msg.error) return;
    if (msg.seq !== null && msg.seq !== undefined) {
      own.lastSeq = msg.seq;
      emit("stream");
      this.dropBoundary(msg.seq);  // its MOVE was refused
    }
    if (msg.seq === state.seq) setBusy(null);
    showError({ body: msg });
    this.moves.rejected(msg.seq);
    const rep = (msg.error.details && msg.error.details.report) || {};
    const small = {};
    for (const k of ["inverted_elements", "degenerate_elements", "min_scaled_jacobian", "safe_fraction",
      "conflicting_constraints"]) if (rep[k] !== undefined) small[k] = rep[k];
    showReport({ mesh: state.meshName, rejected: true, seq: msg.seq, ...small });
  }

  /** Stream a MOVE; answers its seq, or null when there is no open stream. */
  send(move) {
    if (!state.ws || !state.ws.usable) return null;
    this.moves.sent(move);
    own.seq += 1;
    own.sentAt = performance.now();
    emit("stream");
    state.ws.send({ seq: state.seq, move, inversion: this.policy(), repair: this.repair() });
    if (state.ws.reconnecting) this.reconnectStatus(); else setBusy("solving", 250);
    return state.seq;
  }

  /** Wait (bounded) until every MOVE sent has come back. */
  async settled(ms = 3000) {
    const t0 = performance.now();
    while (state.lastSeq < state.seq && performance.now() - t0 < ms) await new Promise((r) => setTimeout(r, 20));
  }

  async reset(record = true) {
    if (!state.sessionId) return;
    clearError();
    try {
      await this.settled();
      await api(`/v1/sessions/${state.sessionId}/reset`, { method: "POST" });
      this.moves.rested(record);
      this.dropBoundary();
      this.meshView.applyPositions(state.V0);
      showReport({ ...meshReport(), max_displacement: 0, reset: true });
    } catch (e) { showError(e); }
  }

  /** The format a download writes: the one chosen, else the mesh's own (VTU for a mesh sent as arrays). */
  downloadFormat() {
    return $("format").value || (state.meshFormat && state.meshFormat !== "arrays" ? state.meshFormat : "vtu");
  }

  /**
   * Download the session's mesh. In its own format the file is the upload with only the coordinates
   * changed; a format that cannot hold everything the mesh has (sets, element types) is written only
   * after the user saw what it drops and agreed.
   */
  async download() {
    if (!state.sessionId) { showError("create a session first"); return; }
    const id = state.sessionId, fmt = this.downloadFormat();
    const url = (lossy) => `/v1/sessions/${id}/mesh?format=${encodeURIComponent(fmt)}${lossy ? "&lossy=true" : ""}`;
    try {
      let r;
      try {
        r = await api(url(false));
      } catch (e) {
        const err = e.body && e.body.error;
        if (!err || err.code !== "lossy_write") throw e;
        if (!await ask(lossText(fmt, (err.details && err.details.losses) || []), "Download without them")) return;
        r = await api(url(true));
      }
      const blob = await r.blob();
      const cd = r.headers.get("Content-Disposition") || "";
      const m = /filename="([^"]+)"/.exec(cd);
      saveBlob(blob, m ? m[1] : `deformed.${fmt}`);
    } catch (e) { showError(e); }
  }

  // ---------------------------------------------------------------- presets and saved sessions
  /**
   * Change the open session's presets on the service: change(list) answers the new list (null: nothing
   * to change). Changes run one after another, each on the list the service answered last, and the list
   * shown is the service's: a change the service refuses shows its error and changes nothing.
   * Answers true when stored (or nothing to store), else the error.
   */
  updatePresets(change) {
    const id = state.sessionId;
    const run = async () => {
      if (!id || state.sessionId !== id) return new Error("the session was closed");
      const next = change(state.presets);
      if (!next) return true;
      clearError();
      try {
        const r = await api(`/v1/sessions/${id}`, { method: "PATCH", headers: { "Content-Type": "application/json" },
          body: JSON.stringify({ presets: next }) });
        const doc = await r.json();
        if (state.sessionId === id) { own.presets = doc.presets || []; emit("presets"); }
        return true;
      } catch (e) {
        if (state.sessionId === id) showError(e);
        return e;
      }
    };
    this.presetQueue = this.presetQueue.then(run);
    return this.presetQueue;
  }

  /** Presets an editor of before kept in this browser for the session: added to the service's once. */
  async migratePresets(id) {
    const key = legacyPresetKey(id);
    const raw = localStorage.getItem(key);
    if (raw === null) return;
    let local = [];
    try { local = JSON.parse(raw); } catch { /* unreadable: nothing to move */ }
    const done = await this.updatePresets((list) => {
      const names = new Set(list.map((p) => p.name));  // the service's names win; local repeats go
      const fits = (p) => p && typeof p.name === "string" && p.name.trim() && p.name.length <= 64 &&
        p.move && typeof p.move === "object" && !names.has(p.name);
      const add = (Array.isArray(local) ? local : []).filter((p) => fits(p) && names.add(p.name));
      return add.length ? [...list, ...add].slice(0, Math.max(list.length, 100)) : null;
    });
    // stored, or refused for what they are (422): never again; else (offline, busy) on the next open
    if (done === true || done.status === 422) localStorage.removeItem(key);
  }

  /** The session as a file: mesh, SPEC, history, presets, view settings. */
  document() {
    return {
      format: "tetmorph-session", version: 1, saved: new Date().toISOString(),
      mesh: { id: state.meshId, name: state.meshName }, session_id: state.sessionId,
      spec: state.specSent || this.spec(),
      history: state.history.map((e) => ({ label: e.label, move: e.move })), history_index: state.historyIndex,
      presets: state.presets, units: state.units, threshold: state.threshold,
    };
  }

  save() {
    if (!state.meshId) { showError("open a mesh first"); return; }
    const doc = this.document();
    const stem = (state.meshName || "mesh").replace(/\.[^.]+$/, "");
    saveBlob(new Blob([JSON.stringify(doc, null, 1)], { type: "application/json" }), `${stem}.session.json`);
  }

  /** Reload a saved session: its mesh (by id, else by name), regions, a new session, its history and presets. */
  async restore(doc) {
    clearError();
    if (!doc || doc.format !== "tetmorph-session") { showError("this file is not a saved tetmorph session"); return false; }
    const meshes = await getAll("/v1/meshes");
    const m = meshes.find((x) => x.id === doc.mesh.id) || meshes.find((x) => x.name === doc.mesh.name);
    if (!m) { showError(`the mesh ${doc.mesh.name} (${doc.mesh.id}) is not on this service: upload it first`); return false; }
    if (state.meshId !== m.id) await this.openMesh(m.id);
    this.regions.loadSpec(doc.spec);
    if (doc.spec.inversion) $("policy").value = doc.spec.inversion;
    $("repair").checked = !!doc.spec.repair;
    const ok = await this.create(() => this.moves.loadHistory(doc.history, doc.history_index));
    if (!ok) return false;
    emit("history");
    if (Array.isArray(doc.presets) && doc.presets.length) await this.updatePresets(() => doc.presets);
    const cur = state.history[state.historyIndex];
    if (cur && cur.move) {
      await this.streamReady();
      this.moves.setFromMove(cur.move);
      this.moves.pending.set(this.send(cur.move), cur);
    }
    return true;
  }

  /** Wait (bounded) for the stream to open. */
  async streamReady(ms = 5000) {
    const t0 = performance.now();
    while (state.ws && !state.ws.open && performance.now() - t0 < ms) await new Promise((r) => setTimeout(r, 20));
  }
}

/**
 * The stream's state in the top bar, where it is in sight whatever the panels show: `text` while it
 * is down (`title` the whole status; `lost`: for good), hidden (null) while it works.
 */
function streamBadge(text, title = "", lost = false) {
  const el = $("stream-status");
  el.hidden = !text;
  el.textContent = text || "";
  el.title = title;
  el.classList.toggle("lost", lost);
}

/** A MOVE that leaves every handle at rest (how the history on the service holds a reset). */
const REST_MOVE = Object.freeze({ handles: {} });

function isRest(m) {
  return !m || Object.keys(m).every((k) => !m[k] || Object.keys(m[k]).length === 0);
}

/**
 * The editor's history as the service keeps it: the MOVEs of the entries up to the one shown
 * (applied, the last the session's), then those after it (undone, the next to redo first); the
 * rest entry 0 is implied, and a reset is a MOVE of no handles. Each list keeps its 500 MOVEs
 * nearest the entry shown.
 */
export function historyDoc(history, index) {
  const move = (e) => e.move || REST_MOVE;
  return { applied: history.slice(1, index + 1).map(move).slice(-HISTORY_MAX),
    undone: history.slice(index + 1).map(move).slice(0, HISTORY_MAX) };
}

const LOSS_KINDS = { node_set: "node sets", element_set: "element sets", element_type: "element types" };

/** What a lossy write drops, in words, one line per kind (the service lists some twice). */
export function lossText(fmt, losses) {
  const groups = new Map(), seen = new Set();
  for (const l of losses) {
    const key = `${l.kind}:${l.name}`;
    if (seen.has(key)) continue;
    seen.add(key);
    if (!groups.has(l.kind)) groups.set(l.kind, []);
    groups.get(l.kind).push(`${l.name} (${l.count.toLocaleString("en-US")})`);
  }
  const lines = [...groups].map(([k, names]) => `${LOSS_KINDS[k] || k.replace(/_/g, " ")}: ${names.join(", ")}`);
  return `A ${fmt} file cannot hold everything this mesh has. Written as ${fmt}, it leaves out\n${lines.join("\n")}`;
}

export function saveBlob(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name;
  document.body.appendChild(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}
