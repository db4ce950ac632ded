// Quality checks: the criteria a solver applies, with thresholds, answered by the service
// (GET /v1/meshes/{id}/check at rest, GET /v1/sessions/{id}/check at the session's current shape;
// solver/validity/criteria.py computes both, as `tetmorph check` does). The panel shows, per
// criterion, pass or fail, how many elements fail, the worst value and its element, and the failing
// elements' ids as the deck numbers them; "Isolate" shows only the failing elements in the view, and
// the CSV and element-set downloads are the service's result=csv and result=elset answers.
import * as THREE from "three";
import { api, getJson } from "./api.js";
import { $ } from "./dom.js";
import { clearError, fmt, setBusy, showError } from "./panels.js";
import { tetFaces } from "./quality.js";
import { saveBlob } from "./session.js";
import { on, state } from "./state.js";

/** The criteria, in the service's order: what each reads, and which side of the threshold passes. */
export const CRITERIA = [
  ["min_scaled_jacobian", "scaled Jacobian, corners", "≥"],
  ["min_scaled_jacobian_ip", "scaled Jacobian, integration points (tet10)", "≥"],
  ["max_aspect_ratio", "aspect ratio", "≤"],
  ["min_dihedral", "smallest dihedral angle °", "≥"],
  ["max_dihedral", "largest dihedral angle °", "≤"],
  ["min_volume_ratio", "volume / rest volume", "≥"],
  ["max_volume_ratio", "volume / rest volume", "≤"],
];

/** Failing elements drawn while isolated. */
const ISOLATE_COLOR = [0.93, 0.33, 0.1];
/** Ids listed per criterion in the panel (the downloads have all of them). */
const LISTED = 200;

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

export class ChecksPanel {
  /** `meshView`: the view whose surface isolate hides (MeshView). */
  constructor(viewer, meshView) {
    this.viewer = viewer;
    this.meshView = meshView;
    this.result = null;      // the last answer (JSON), with `on` ("mesh" | "session") and `ids` of all failing
    this.isolated = null;    // element indices shown while isolated (null: not isolated)
    this.thresholds = {};    // the chosen preset's thresholds, as the service answered them
    this.geom = new THREE.BufferGeometry();
    this.group = new THREE.Mesh(this.geom, new THREE.MeshStandardMaterial({ vertexColors: true, side: THREE.DoubleSide,
      flatShading: true, roughness: 0.8 }));
    this.group.visible = false;
    viewer.scene.add(this.group);
    this.render();
    $("sec-check").addEventListener("toggle", () => { if ($("sec-check").open) this.loadPreset(); });
    $("check-preset").addEventListener("change", () => this.loadPreset(true));
    $("check-run").addEventListener("click", () => this.run());
    $("check-csv").addEventListener("click", () => this.download("csv"));
    $("check-elset").addEventListener("click", () => this.download("elset"));
    $("check-isolate").addEventListener("click", () => this.isolate(null));
    $("check-ids").addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-isolate]");
      if (b) this.isolate(b.dataset.isolate);
    });
    $("show-all").addEventListener("click", () => this.unisolate());
    on("mesh", () => {  // a new mesh: nothing of the last one's check stays (its surface is drawn anew)
      this.result = null; this.thresholds = {}; this.isolated = null; this.group.visible = false;
      this.render(); this.showResult();
      if ($("sec-check").open) this.loadPreset(); });
    on("session", () => this.offerTargets());
    on("positions", () => { if (this.isolated) this.place(); });
  }

  // ---------------------------------------------------------------- criteria and thresholds
  /** The criteria table: a checkbox and a threshold per criterion, the result cells empty. */
  render() {
    $("check-table").innerHTML = "<tr><th></th><th>criterion</th><th>limit</th><th>result</th><th>worst</th></tr>" +
      CRITERIA.map(([name, label, sense]) => `<tr data-criterion="${name}">
        <td><input type="checkbox" data-on="${name}" checked aria-label="check ${esc(label)}"></td>
        <td class="name" title="${name}">${esc(label)} ${sense}</td>
        <td><input type="number" step="any" data-threshold="${name}" aria-label="threshold of ${esc(label)}"></td>
        <td data-cell="result"></td><td data-cell="worst"></td></tr>`).join("");
    this.offerTargets();
  }

  /** "the session's current shape" only while a session is open. */
  offerTargets() {
    const sel = $("check-on"), opt = sel.querySelector("option[value=session]");
    opt.disabled = !state.sessionId;
    if (!state.sessionId) sel.value = "mesh";
    else if (!this.result) sel.value = "session";
  }

  /**
   * Fill the thresholds with the chosen preset's (the service answers them: the library's presets,
   * docs/guide/validity.md). `force`: replace what was typed.
   */
  async loadPreset(force = false) {
    if (!state.meshId || state.surface) return;
    const preset = $("check-preset").value;
    if (!force && this.thresholds.preset === preset) return;
    try {
      const doc = await getJson(`/v1/meshes/${state.meshId}/check?preset=${encodeURIComponent(preset)}&ids=0`);
      this.thresholds = { preset };
      for (const c of doc.criteria) this.thresholds[c.name] = c.threshold;
      for (const [name] of CRITERIA) {
        const t = this.thresholds[name], field = this.field(name), box = this.box(name);
        field.value = t === null || t === undefined ? "" : String(t);
        box.checked = t !== null && t !== undefined;
      }
    } catch (e) { showError(e); }
  }

  field(name) { return $("check-table").querySelector(`[data-threshold="${name}"]`); }
  box(name) { return $("check-table").querySelector(`[data-on="${name}"]`); }

  /** The query of the check: the preset, each checked criterion's typed threshold, off= for the others. */
  query(extra = {}) {
    const q = new URLSearchParams({ preset: $("check-preset").value });
    for (const [name, label] of CRITERIA) {
      if (!this.box(name).checked) { q.append("off", name); continue; }
      const text = this.field(name).value.trim();
      if (text === "") continue;  // the preset's
      const v = Number(text);
      if (!Number.isFinite(v)) throw new Error(`the threshold of ${label} is not a number: ${text}`);
      q.set(name, String(v));
    }
    for (const [k, v] of Object.entries(extra)) q.set(k, String(v));
    return q;
  }

  /** The check's URL on what is chosen: the mesh at rest, or the open session now. */
  url(extra) {
    const onSession = $("check-on").value === "session" && state.sessionId;
    const base = onSession ? `/v1/sessions/${state.sessionId}/check` : `/v1/meshes/${state.meshId}/check`;
    return { url: `${base}?${this.query(extra)}`, on: onSession ? "session" : "mesh" };
  }

  // ---------------------------------------------------------------- run
  /** Run the check on the service and show its answer. */
  async run() {
    if (!state.meshId) { showError("open a mesh first"); return; }
    if (state.surface) { showError("the quality check measures volume elements; tetrahedralize the surface first"); return; }
    clearError();
    setBusy("checking quality");
    try {
      const { url, on: target } = this.url({ ids: Math.max(1, state.elements) });
      const doc = await getJson(url);
      this.result = { ...doc, on: target };
      this.unisolate();
      this.showResult();
    } catch (e) { showError(e); } finally { setBusy(null); }
  }

  /** The answer in the table and the failing ids below it. */
  showResult() {
    const r = this.result;
    for (const tr of $("check-table").querySelectorAll("tr[data-criterion]")) {
      const c = r && r.criteria.find((x) => x.name === tr.dataset.criterion);
      const res = tr.querySelector("[data-cell=result]"), worst = tr.querySelector("[data-cell=worst]");
      tr.className = !c || !c.checked ? "" : c.passed ? "pass" : "fail";
      res.textContent = !c ? "" : !c.checked ? "off" : !c.applicable ? "n/a" : c.passed ? "pass" : `fail ${fmt(c.failing)}`;
      res.dataset.failing = c ? String(c.failing) : "";
      worst.textContent = c && c.worst !== null ? fmt(c.worst) : "";
      worst.dataset.value = c && c.worst !== null ? String(c.worst) : "";
      worst.dataset.element = c && c.worst_element !== null ? String(c.worst_element) : "";
      worst.title = c && c.worst_element !== null ? `element ${c.worst_element}` : "";
    }
    const what = r ? (r.on === "session" ? `session ${state.sessionId}, current shape` : "the mesh at rest") : "";
    $("check-status").textContent = r ? `${r.passed ? "passed" : `${fmt(r.failing_elements)} of ${fmt(r.elements)} ` +
      "elements fail"} · ${what}` : "";
    $("check-status").className = r ? (r.passed ? "pass" : "fail") : "muted";
    const failing = r ? r.criteria.filter((c) => c.failing) : [];
    $("check-ids").innerHTML = failing.map((c) => {
      const shown = c.ids.slice(0, LISTED).join(", ");
      const more = c.failing > LISTED ? ` … and ${fmt(c.failing - LISTED)} more (in the CSV)` : "";
      return `<li data-criterion="${c.name}"><div class="row"><b>${esc(c.name)}</b>
        <span class="muted">${fmt(c.failing)} element${c.failing === 1 ? "" : "s"}</span>
        <button data-isolate="${c.name}" title="show only these elements">isolate</button></div>
        <div class="ids" data-ids="${c.name}">${shown}${more}</div></li>`;
    }).join("");
    for (const id of ["check-isolate", "check-csv", "check-elset"]) $(id).disabled = !r || r.passed;
  }

  // ---------------------------------------------------------------- isolate
  /** Element index of each deck id (the geometry bundle's element_ids; 1, 2, ... where it has none). */
  elementIndex() {
    if (this.index && this.index.mesh === state.meshId) return this.index.map;
    const map = new Map(), ids = state.elementIds;
    for (let k = 0; k < state.elements; k++) map.set(ids ? ids[k] : k + 1, k);
    this.index = { mesh: state.meshId, map };
    return map;
  }

  /**
   * Show only the failing elements (of one criterion, or of any): the surface is hidden as Isolate
   * hides it, and the elements are drawn whole, in the current shape. "Show all" brings the rest back.
   */
  isolate(criterion) {
    const r = this.result;
    if (!r) return;
    const list = r.criteria.filter((c) => c.failing && (!criterion || c.name === criterion));
    const map = this.elementIndex(), elements = new Set();
    for (const c of list) for (const id of c.ids) { const k = map.get(id); if (k !== undefined) elements.add(k); }
    if (!elements.size) return;
    const owner = state.tetElement, rows = [];
    const m = state.T.length / 4;
    for (let t = 0; t < m; t++) if (elements.has(owner ? owner[t] : t)) rows.push(t);
    this.isolated = { criterion: criterion || null, elements: [...elements].sort((a, b) => a - b), tets: rows };
    this.meshView.setFaceFilter(() => false);
    this.place();
    this.group.visible = true;
    $("check-isolate").setAttribute("aria-pressed", "true");
  }

  /** The isolated elements' faces where the mesh is now. */
  place() {
    const F = tetFaces(state.T, this.isolated.tets), V = state.V;
    const pos = new Float32Array(F.length * 3), col = new Float32Array(F.length * 3);
    for (let i = 0; i < F.length; i++) {
      const v = 3 * F[i];
      pos[3 * i] = V[v]; pos[3 * i + 1] = V[v + 1]; pos[3 * i + 2] = V[v + 2];
      col[3 * i] = ISOLATE_COLOR[0]; col[3 * i + 1] = ISOLATE_COLOR[1]; col[3 * i + 2] = ISOLATE_COLOR[2];
    }
    this.geom.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    this.geom.setAttribute("color", new THREE.BufferAttribute(col, 3));
    this.geom.computeVertexNormals();
    this.geom.computeBoundingSphere();
  }

  unisolate() {
    if (!this.isolated) return;
    this.isolated = null;
    this.group.visible = false;
    $("check-isolate").setAttribute("aria-pressed", "false");
    if (state.V) this.meshView.setFaceFilter(null);
  }

  // ---------------------------------------------------------------- downloads
  /** The failing elements as the service writes them: CSV, or an element set in the deck's syntax. */
  async download(kind) {
    if (!this.result) return;
    clearError();
    try {
      const { url } = this.url({ result: kind });
      const r = await api(url);
      const m = /filename="([^"]+)"/.exec(r.headers.get("Content-Disposition") || "");
      saveBlob(await r.blob(), m ? m[1] : `failed.${kind === "csv" ? "csv" : "inc"}`);
    } catch (e) { showError(e); }
  }

  /** What the panel shows, for the test hook. */
  values() {
    return { result: this.result ? structuredClone(this.result) : null,
      isolated: this.isolated ? structuredClone(this.isolated) : null };
  }
}
