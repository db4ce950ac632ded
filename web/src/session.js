// The session's life: create it from the selection (polling a long build), stream MOVEs and
// show each frame, reset, download, close.
import { api, apiKey, getJson, postJson } from "./api.js";
import { $ } from "./dom.js";
import { appendStatus, clearError, setProgress, setStatus, showError, showReport } from "./panels.js";
import { state } from "./state.js";
import { Stream } from "./stream.js";

export class SessionControl {
  constructor(meshView, selection) {
    this.meshView = meshView;
    this.selection = selection;
    this.moves = null;  // set by the wiring (gizmo.js Moves)
  }

  policy() { return $("policy").value; }
  repair() { return $("repair").checked; }

  async create() {
    clearError();
    if (!state.meshId) { showError("open a mesh first"); return; }
    const fixed = this.selection.idsOfRole(1), handle = this.selection.idsOfRole(2);
    if (!fixed.length || !handle.length) { showError("select a fixed region and a handle region first"); return; }
    const spec = {
      selections: { fixed: { ids: fixed }, handle: { ids: handle } },
      fixed: ["fixed"], handles: { handle: "handle" }, inversion: this.policy(), repair: this.repair(),
    };
    setStatus("building…");
    try {
      let s = await postJson("/v1/sessions", { mesh_id: state.meshId, spec });
      while (s.status === "building") {
        setProgress(s.progress || 0);
        setStatus(`building: ${s.stage} ${Math.round(100 * (s.progress || 0))}%`);
        await new Promise((r) => setTimeout(r, 250));
        s = await getJson(`/v1/sessions/${s.id}`);
      }
      if (s.status !== "ready") throw Object.assign(new Error(`session ${s.status}`), { body: { error: s.error } });
      setProgress(1);
      state.sessionId = s.id;
      const setup = s.setup_timings ? ` · set-up ${Math.round(s.setup_timings.total_ms)} ms` : "";
      setStatus(`session ${s.id} ready${setup}`);
      const c = [0, 0, 0];
      for (const i of handle) for (let k = 0; k < 3; k++) c[k] += state.V0[3 * i + k] / handle.length;
      this.moves.attach(c);
      this.openStream();
    } catch (e) {
      setStatus("no session");
      showError(e);
    }
  }

  close() {
    if (state.ws) state.ws.close();
    state.ws = null; state.sessionId = null;
    this.moves.detach();
    setStatus("no session");
    setProgress(0);
  }

  openStream() {
    state.ws = new Stream(state.sessionId, apiKey(), {
      onFrame: (f) => this.frame(f),
      onMessage: (msg) => { if (msg.error) showError({ body: msg }); },
      onClose: () => { if (state.sessionId) appendStatus(" · stream closed"); },
    });
  }

  frame({ header, data }) {
    const rtt = header.seq === state.seq ? performance.now() - state.sentAt : undefined;
    this.meshView.applyPositions(data);
    state.lastSeq = header.seq;
    state.roundTripMs = rtt;
    showReport({ seq: header.seq, dropped: header.dropped, ...header.report, round_trip_ms: rtt,
      apply_ms: state.applyMs });
    const rep = header.report || {};
    if (rep.inverted_elements > 0 && this.policy() === "warn") {
      showError({ body: { error: { code: "inverted_elements", message: `${rep.inverted_elements} elements inverted`,
        details: { report: rep } } } });
    } else if (!rep.conflicting_constraints || !rep.conflicting_constraints.length) {
      clearError();
    }
  }

  send(move) {
    if (!state.ws || !state.ws.open) return;
    state.lastMove = move;
    state.seq += 1;
    state.sentAt = performance.now();
    state.ws.send({ seq: state.seq, move, inversion: this.policy(), repair: this.repair() });
  }

  async reset() {
    if (!state.sessionId) return;
    try {
      await api(`/v1/sessions/${state.sessionId}/reset`, { method: "POST" });
      this.moves.rest();
      this.meshView.applyPositions(state.V0);
      showReport({ reset: true });
    } catch (e) { showError(e); }
  }

  async download() {
    if (!state.sessionId) { showError("create a session first"); return; }
    const fmt = $("format").value;
    try {
      const r = await api(`/v1/sessions/${state.sessionId}/mesh${fmt ? `?format=${fmt}` : ""}`);
      const blob = await r.blob();
      const cd = r.headers.get("Content-Disposition") || "";
      const m = /filename="([^"]+)"/.exec(cd);
      const a = document.createElement("a");
      a.href = URL.createObjectURL(blob);
      a.download = m ? m[1] : `deformed.${fmt || "vtu"}`;
      document.body.appendChild(a);
      a.click();
      a.remove();
    } catch (e) { showError(e); }
  }
}
