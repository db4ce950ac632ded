// Shapes: the session's presets as shape variables, a slider each, combined into one MOVE as the
// DOE combines them (solver/workflows/shapes.py): translations add weighted by the values,
// rotations add as quaternion logarithms, scales multiply as s ** value. "Run DOE" submits a PLAN
// (CSV, a header of shape names, a row per variant) with the shapes as a batch of the session
// (POST /v1/sessions/{id}/batch), waits for it and lists the decks of its zip.
import * as THREE from "three";
import { api, getJson, postJson } from "./api.js";
import { $ } from "./dom.js";
import { combineEdits } from "./editshapes.js";
import { parseHandleMove } from "./gizmo.js";
import { clearError, fmt, setBusy, showError } from "./panels.js";
import { saveBlob } from "./session.js";
import { claim, emit, state } from "./state.js";

// the owner of the state's "shapes" group: the last batch run
const own = claim("shapes");

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

/** log of a unit quaternion: (angle / 2) axis, the shortest way round. */
function qlog(q) {
  const s = q.w < 0 ? -1 : 1, w = Math.min(1, Math.abs(q.w));
  const v = new THREE.Vector3(s * q.x, s * q.y, s * q.z), n = v.length();
  return n > 1e-15 ? v.multiplyScalar(Math.acos(w) / n) : new THREE.Vector3();
}

function qexp(r) {
  const a = r.length();
  if (a < 1e-15) return new THREE.Quaternion();
  const k = Math.sin(a) / a;
  return new THREE.Quaternion(r.x * k, r.y * k, r.z * k, Math.cos(a));
}

/**
 * The MOVE of shape values {name: theta}: the DOE's combination of the shapes (MOVEs at value 1),
 * handles and edits (`rest(kind, name)`: an edit's rest value, editshapes.js).
 */
export function combine(shapes, values, rest = () => null) {
  const handles = {};
  for (const [name, h] of Object.entries(state.transforms)) {
    const t = new THREE.Vector3(), r = new THREE.Vector3();
    let s = 1;
    for (const [shape, move] of Object.entries(shapes)) {
      const th = values[shape] || 0;
      if (!th) continue;
      const p = parseHandleMove(move.handles && move.handles[name], h.centroid);
      t.addScaledVector(new THREE.Vector3(...p.t), th);
      r.addScaledVector(qlog(p.q), th);
      s *= p.s ** th;
    }
    const q = qexp(r);
    const doc = { translation: t.toArray(), rotation: { quaternion: [q.w, q.x, q.y, q.z] }, pivot: h.centroid };
    if (s !== 1) doc.scale = s;
    handles[name] = doc;
  }
  return { ...combineEdits(shapes, values, rest), handles };
}

/** Names and sizes of the files of a zip (its central directory). */
export function zipEntries(buf) {
  const dv = new DataView(buf), out = [];
  let eocd = -1;
  for (let i = buf.byteLength - 22; i >= Math.max(0, buf.byteLength - 65557); i--) {
    if (dv.getUint32(i, true) === 0x06054b50) { eocd = i; break; }
  }
  if (eocd < 0) return out;
  const count = dv.getUint16(eocd + 10, true);
  let p = dv.getUint32(eocd + 16, true);
  for (let k = 0; k < count && dv.getUint32(p, true) === 0x02014b50; k++) {
    const size = dv.getUint32(p + 24, true), nlen = dv.getUint16(p + 28, true);
    const elen = dv.getUint16(p + 30, true), clen = dv.getUint16(p + 32, true);
    out.push({ name: new TextDecoder().decode(new Uint8Array(buf, p + 46, nlen)), size });
    p += 46 + nlen + elen + clen;
  }
  return out;
}

export class ShapesPanel {
  constructor(moves, session) {
    this.moves = moves;
    this.session = session;
    this.values = {};
    this.editRest = () => null;  // an edit's rest value (the Edits panel's), set by the wiring
    const el = $("shapes");
    el.addEventListener("input", (ev) => { if (ev.target.dataset.shape) this.slide(ev.target, false); });
    el.addEventListener("change", (ev) => { if (ev.target.dataset.shape) this.slide(ev.target, true); });
    $("doe-run").addEventListener("click", () => this.runDoe());
    $("doe-spec-file").addEventListener("click", () => this.saveFile("spec"));
    $("doe-shapes-file").addEventListener("click", () => this.saveFile("shapes"));
    $("doe-plan-file").addEventListener("click", () => this.saveFile("plan"));
  }

  /**
   * The DOE as the files `tetmorph doe` reads, so it runs unchanged from the command line: the
   * SPEC the session was created from, SHAPES.json ({"shapes": {name: MOVE}}) and the PLAN.
   */
  saveFile(what) {
    if (what !== "plan" && !state.sessionId) { showError("create a session first"); return; }
    if (what === "shapes" && !state.presets.length) { showError("save a preset first: the presets are the shapes"); return; }
    const stem = (state.meshName || "mesh").replace(/\.[^.]+$/, "");
    const json = (doc) => new Blob([`${JSON.stringify(doc, null, 1)}\n`], { type: "application/json" });
    if (what === "spec") saveBlob(json(state.specSent), `${stem}.spec.json`);
    else if (what === "shapes") saveBlob(json({ shapes: this.shapes() }), `${stem}.shapes.json`);
    else {
      const plan = $("doe-plan").value.trim();
      if (!plan) { showError("the PLAN is empty: a header of shape names, then a row of values per variant"); return; }
      saveBlob(new Blob([`${plan}\n`], { type: "text/csv" }), `${stem}.plan.csv`);
    }
  }

  /** The presets as shapes: {name: MOVE}. */
  shapes() { return Object.fromEntries(state.presets.map((p) => [p.name, p.move])); }

  render() {
    const names = state.presets.map((p) => p.name);
    for (const k of Object.keys(this.values)) if (!names.includes(k)) delete this.values[k];
    $("shapes").innerHTML = names.length ? names.map((n) => `<li><span class="name" title="${esc(n)}">${esc(n)}</span>
      <input type="range" min="-1" max="2" step="0.05" value="${this.values[n] || 0}" data-shape="${esc(n)}"
        aria-label="value of shape ${esc(n)}">
      <span class="val" data-val="${esc(n)}">${fmt(this.values[n] || 0)}</span></li>`).join("")
      : '<li class="muted">saved presets are the shapes: save one to get a slider</li>';
    this.renderPlan();
  }

  /** Until it is edited, the PLAN is the shapes' names and the sliders' values. */
  renderPlan() {
    const plan = $("doe-plan"), names = state.presets.map((p) => p.name);
    if (!plan.dataset.edited) plan.value = names.length ? `${names.join(",")}\n${names.map((n) => this.values[n] || 0).join(",")}\n` : "";
  }

  /** A slider moved: the combined MOVE is sent (live), and kept in the history when let go. */
  slide(input, done) {
    const name = input.dataset.shape;
    this.values[name] = Number(input.value);
    const span = [...$("shapes").querySelectorAll("[data-val]")].find((s) => s.dataset.val === name);
    if (span) span.textContent = fmt(this.values[name]);
    if (!state.sessionId) return;
    const move = combine(this.shapes(), this.values, this.editRest);
    this.moves.setFromMove(move);
    if (done) {
      const label = Object.entries(this.values).filter(([, v]) => v).map(([k, v]) => `${k} ${fmt(v)}`).join(" + ");
      this.moves.sendAndCommit(`shapes ${label || "0"}`);
    } else {
      this.moves.io.send(move);
    }
    this.renderPlan();
  }

  /** Submit the PLAN with the shapes as a batch of the session; list the decks when it is done. */
  async runDoe() {
    const id = state.sessionId, list = $("doe-decks");
    if (!id) { showError("create a session first"); return; }
    if (!state.presets.length) { showError("save a preset first: the presets are the shapes"); return; }
    clearError();
    list.innerHTML = "";
    setBusy("running the DOE");
    try {
      const body = { shapes: this.shapes(), plan: $("doe-plan").value };
      const fmtName = this.session.downloadFormat();
      if (fmtName) body.format = fmtName;
      let job = await postJson(`/v1/sessions/${id}/batch`, body);
      while (job.status === "queued" || job.status === "running") {
        setBusy(`running the DOE: ${job.done ?? Math.round((job.progress || 0) * 100)}`);
        $("doe-status").textContent = `batch ${job.id}: ${Math.round(100 * (job.progress || 0))} % of the rows`;
        await new Promise((r) => setTimeout(r, 500));
        job = await getJson(`/v1/sessions/${id}/batch/${job.id}`);
      }
      own.doeJob = job.id;
      emit("doe-job");
      if (job.status !== "done") throw Object.assign(new Error(`batch ${job.status}`), { body: { error: job.error } });
      const buf = await (await api(`/v1/sessions/${id}/batch/${job.id}/result`)).arrayBuffer();
      const files = zipEntries(buf);
      $("doe-status").textContent = `batch ${job.id} done: ${files.length - 1} deck${files.length === 2 ? "" : "s"} and summary.csv`;
      list.innerHTML = files.map((f) => `<li data-name="${esc(f.name)}"><span class="name">${esc(f.name)}</span>
        <span class="muted">${fmt(f.size)} B</span></li>`).join("") +
        '<li><button id="doe-zip">Download the zip</button></li>';
      const stem = (state.meshName || "mesh").replace(/\.[^.]+$/, "");
      $("doe-zip").addEventListener("click", () => saveBlob(new Blob([buf], { type: "application/zip" }), `${stem}_doe.zip`));
    } catch (e) { showError(e); } finally { setBusy(null); }
  }
}
