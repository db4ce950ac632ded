// tetmorph browser editor: open a mesh, mark fixed and handle regions, create a session,
// move the handles and watch the FE mesh (surface and interior) follow over the WebSocket.
// This module wires the parts together: viewer.js (renderer, camera, navigation, triad),
// meshview.js (what is drawn), selection.js (regions), gizmo.js (moves, history, presets),
// session.js (the session's life), panels.js (read-outs), lists.js (the panels' lists),
// messages.js (errors in words), api.js (REST) and stream.js (WebSocket), around the shared
// state of state.js.
import * as THREE from "three";
import { api, getJson, setApiKey } from "./api.js";
import { decodeBundle } from "./binary.js";
import { $ } from "./dom.js";
import { Moves } from "./gizmo.js";
import { renderFeatures, renderHandleSelect, renderHistory, renderMeshSessions, renderPresets, renderRegions,
  renderSessionsTable, wireRegions } from "./lists.js";
import { MeshView, QUALITY_COLORS } from "./meshview.js";
import { clearError, drawHistogram, drawLegend, fmt, refreshReport, setBusy, showError, showModel, showReport,
  thresholdPageX, wireThreshold } from "./panels.js";
import { Regions } from "./selection.js";
import { saveBlob, SessionControl } from "./session.js";
import { on, state } from "./state.js";
import { Viewer } from "./viewer.js";

const viewer = new Viewer($("canvas"));
const meshView = new MeshView(viewer);
const regions = new Regions(viewer, meshView);
const session = new SessionControl(meshView, regions);
const moves = new Moves(viewer, regions, {
  send: (m) => session.send(m), reset: (record) => session.reset(record), refuse: showError,
  updatePresets: (change) => session.updatePresets(change),
});
session.moves = moves;
session.openMesh = (id) => openMesh(id);
regions.busy = () => moves.dragging;

// ------------------------------------------------------------------ signals -> panels
const legend = () => drawLegend(meshView, state.regions);
on("regions", () => { renderRegions(regions); legend(); });
on("legend", legend);
on("history", () => { renderHistory(moves); session.note(); });
on("presets", () => renderPresets(moves));
on("active-handle", () => renderHandleSelect(moves));
on("open-sessions", () => openSessionsDialog());
on("sessions-changed", () => offerMeshSessions());
wireRegions(regions);

function fit() { if (state.V) viewer.fit(meshView.box()); }
function view(name) { if (state.V) viewer.view(name, meshView.box()); }

// ------------------------------------------------------------------ meshes
async function openMesh(id) {
  clearError();
  await session.leave();
  setBusy("loading");
  try {
    const r = await api(`/v1/meshes/${id}/geometry`);
    const { header, arrays } = decodeBundle(await r.arrayBuffer());
    state.meshId = id;
    state.meshName = header.name || id;
    state.V0 = Float32Array.from(arrays.V);
    state.V = Float32Array.from(arrays.V);
    state.F = arrays.F;
    state.T = arrays.T;
    state.boundary = arrays.boundary;
    const n = state.V.length / 3;
    // vertices that belong to an element: the mid-side nodes of quadratic elements do not
    state.used = new Uint8Array(n);
    const src = state.T.length ? state.T : state.F;
    for (let k = 0; k < src.length; k++) state.used[src[k]] = 1;
    state.sets = {};
    for (const name of header.sets) state.sets[name] = arrays[`set:${name}`];
    const lo = header.bbox[0], hi = header.bbox[1];
    state.bbox = header.bbox;
    state.diag = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
    // mixed meshes: T also carries the corner tets of hexahedra, wedges and pyramids
    state.elements = header.elements ?? state.T.length / 4;
    state.units = localStorage.getItem(`tetmorph-units:${state.meshName}`) ?? "mm";
    $("units").value = state.units;
    $("mesh-name").textContent = `${state.meshName} · ${fmt(n)} vertices · ${fmt(state.elements)} elements`;
    $("mesh-name").title = $("mesh-name").textContent;
    $("sets").innerHTML = '<option value="">— named sets —</option>' +
      header.sets.map((s) => `<option>${s}</option>`).join("");
    meshView.load();
    regions.reset();
    regions.changed();
    state.report = null;
    meshView.refresh();
    viewer.fit(meshView.box(), new THREE.Vector3(1, -1, 1));
    $("welcome").hidden = true;
    renderFeatures(null);
    showModel(header);
    showReport({ mesh: state.meshName, elements: state.elements, vertices: n });
    offerMeshSessions();
  } finally {
    setBusy(null);
  }
}

async function listMeshes() {
  try {
    const list = await getJson("/v1/meshes");
    $("meshes").innerHTML = '<option value="">— stored meshes —</option>' +
      list.map((m) => `<option value="${m.id}">${m.name || m.id} (${m.id})</option>`).join("");
    return list;
  } catch (e) { showError(e); return []; }
}

/** Upload the chosen files: the mesh, with TetGen's .ele (and .face, .edge) as companions. */
async function upload(files) {
  clearError();
  files = [...files];
  if (!files.length) return;
  const lower = (f) => f.name.toLowerCase();
  const node = files.find((f) => lower(f).endsWith(".node"));
  const main = node || files.find((f) => !/\.(ele|face|edge|neigh)$/.test(lower(f))) || files[0];
  if (node && !files.some((f) => lower(f) === lower(node).replace(/\.node$/, ".ele"))) {
    showError({ body: { error: { code: "missing_companion", message: "no .ele chosen",
      details: { missing: node.name.replace(/\.node$/i, ".ele") } } } });
    return;
  }
  const fd = new FormData();
  fd.append("file", main, main.name);
  for (const f of files) if (f !== main) fd.append("companions", f, f.name);
  setBusy("uploading");
  try {
    const meta = await (await api("/v1/meshes", { method: "POST", body: fd })).json();
    await listMeshes();
    $("meshes").value = meta.id;
    await openMesh(meta.id);
  } catch (e) { showError(e); } finally { setBusy(null); }
}

async function demo() {
  clearError();
  try {
    await getJson("/v1/sessions/s_demo");
  } catch (e) {
    if (e.status !== 404) { showError(e); return; }
    try { await openMesh("m_demo_beam"); } catch (e2) {
      if (e2.status === 404) showError("The demo is not loaded on this service: start it with `tetmorph serve --demo` (make run does).");
      else showError(e2);
      return;
    }
    showError("The demo session s_demo is gone from this service; the demo beam is open: mark regions and create a session.");
    return;
  }
  await session.open("s_demo");
}

async function offerMeshSessions() {
  if (!state.meshId) { renderMeshSessions([], {}); return; }
  try {
    renderMeshSessions(await session.list(), sessionHandlers());
  } catch { renderMeshSessions([], {}); }
}

// ------------------------------------------------------------------ sessions dialog
function sessionHandlers(after = () => {}) {
  return {
    open: async (id) => { $("sessions-dialog").close(); await session.open(id); },
    close: async () => { session.close(); await after(); offerMeshSessions(); },
    delete: async (id) => { await session.remove(id); await after(); },
  };
}

async function openSessionsDialog() {
  const dlg = $("sessions-dialog");
  const refresh = async () => {
    try {
      const [sessions, meshes] = await Promise.all([session.list(), getJson("/v1/meshes")]);
      renderSessionsTable(sessions, new Map(meshes.map((m) => [m.id, m.name || m.id])), sessionHandlers(refresh));
      dlg.dataset.count = String(sessions.length);
    } catch (e) { showError(e); }
  };
  await refresh();
  if (!dlg.open) dlg.showModal();
  $("sessions-delete-others").onclick = async () => {
    for (const s of await session.list()) if (s.id !== state.sessionId) await session.remove(s.id, true);
    await refresh();
  };
}

// ------------------------------------------------------------------ SPEC dialog
function openSpecDialog() {
  $("spec-text").value = JSON.stringify(session.spec(), null, 1);
  $("spec-dialog").showModal();
}

function useSpec(spec) {
  if (!state.V) { showError("open a mesh first"); return; }
  if (!spec || typeof spec !== "object" || !spec.selections) { showError("this is not a SPEC (it has no selections)"); return; }
  regions.loadSpec(spec);
  if (spec.inversion) $("policy").value = spec.inversion;
  if (spec.repair !== undefined) $("repair").checked = !!spec.repair;
  $("spec-text").value = JSON.stringify(session.spec(), null, 1);
}

async function readJsonFile(input) {
  const f = input.files[0];
  input.value = "";
  if (!f) return null;
  try { return JSON.parse(await f.text()); } catch (e) { showError(`${f.name} is not JSON: ${e.message}`); return null; }
}

// ------------------------------------------------------------------ view options
function syncViewOptions() {
  Object.assign(meshView.options, { clip: $("clip").checked, clipAxis: Number($("clip-axis").value),
    clipPos: Number($("clip-pos").value), bad: $("bad").checked });
  state.clip = $("clip").checked;
  meshView.refresh();
  legend();
  refreshReport();
}

function setThreshold(t) {
  state.threshold = t;
  $("threshold").value = String(t);
  meshView.refresh();
  legend();
  refreshReport();
}

function togglePanel(side) {
  const el = $(side), btn = $(`toggle-${side}`);
  el.classList.toggle("collapsed");
  btn.setAttribute("aria-pressed", String(!el.classList.contains("collapsed")));
}

// ------------------------------------------------------------------ wiring
$("upload-btn").addEventListener("click", () => $("upload").click());
$("welcome-upload").addEventListener("click", () => $("upload").click());
$("upload").addEventListener("change", (ev) => { upload(ev.target.files); ev.target.value = ""; });
$("open-mesh").addEventListener("click", () => { if ($("meshes").value) openMesh($("meshes").value).catch(showError); });
$("demo").addEventListener("click", demo);
$("welcome-demo").addEventListener("click", demo);
$("set-apply").addEventListener("click", () => regions.assignSet($("sets").value));
$("add-fixed").addEventListener("click", () => { if (state.V) regions.add("fixed"); });
$("add-handle").addEventListener("click", () => { if (state.V) regions.add("handle"); });
$("clear-sel").addEventListener("click", () => { if (state.V) regions.clear(); });
$("find-features").addEventListener("click", async () => {
  if (!state.meshId) { showError("open a mesh first"); return; }
  setBusy("finding features");
  try {
    const list = await getJson(`/v1/meshes/${state.meshId}/features?ids=true`);
    state.features = list;
    renderFeatures(list, (f, kind) => regions.fromIds(f.name, kind, regions.resolve(f.selection), null));
  } catch (e) { showError(e); } finally { setBusy(null); }
});
$("spec-view").addEventListener("click", openSpecDialog);
$("spec-close").addEventListener("click", () => $("spec-dialog").close());
$("spec-export").addEventListener("click", () => {
  const stem = (state.meshName || "mesh").replace(/\.[^.]+$/, "");
  saveBlob(new Blob([JSON.stringify(session.spec(), null, 1)], { type: "application/json" }), `${stem}.spec.json`);
});
$("spec-import-btn").addEventListener("click", () => $("spec-import").click());
$("spec-import").addEventListener("change", async (ev) => { const doc = await readJsonFile(ev.target); if (doc) useSpec(doc); });
$("spec-apply").addEventListener("click", () => {
  try { useSpec(JSON.parse($("spec-text").value)); } catch (e) { showError(`the SPEC text is not JSON: ${e.message}`); }
});
$("create").addEventListener("click", () => session.create());
$("save-session").addEventListener("click", () => session.save());
$("load-session-btn").addEventListener("click", () => $("load-session").click());
$("load-session").addEventListener("change", async (ev) => { const doc = await readJsonFile(ev.target); if (doc) session.restore(doc); });
$("sessions-btn").addEventListener("click", openSessionsDialog);
$("sessions-close").addEventListener("click", () => $("sessions-dialog").close());
$("apply-move").addEventListener("click", () => moves.applyFields());
$("move-by").addEventListener("click", () => moves.moveBy());
$("undo").addEventListener("click", () => moves.undo());
$("redo").addEventListener("click", () => moves.redo());
$("reset").addEventListener("click", () => session.reset());
$("download").addEventListener("click", () => session.download());
$("handle-select").addEventListener("change", () => moves.setActive($("handle-select").value));
$("preset-save").addEventListener("click", () => { if (state.sessionId) moves.savePreset($("preset-name").value); });
$("fit").addEventListener("click", fit);
for (const b of document.querySelectorAll("[data-view]")) b.addEventListener("click", () => view(b.dataset.view));
$("edges").addEventListener("change", () => meshView.setEdges($("edges").checked));
$("ghost").addEventListener("change", () => { meshView.setGhost($("ghost").checked); legend(); });
$("color-by").addEventListener("change", () => meshView.setColorBy($("color-by").value));
for (const id of ["clip", "clip-axis", "clip-pos", "bad"]) $(id).addEventListener("input", syncViewOptions);
$("units").addEventListener("change", () => {
  state.units = $("units").value;
  if (state.meshName) localStorage.setItem(`tetmorph-units:${state.meshName}`, state.units);
  if (state.bbox) showModel({ bbox: state.bbox });
  legend(); refreshReport(); moves.updateLabel();
});
$("toggle-left").addEventListener("click", () => togglePanel("left"));
$("toggle-right").addEventListener("click", () => togglePanel("right"));
wireThreshold(setThreshold);
for (const id of ["tx", "ty", "tz", "ax", "ay", "az", "angle", "scale"]) {
  $(id).addEventListener("keydown", (ev) => { if (ev.key === "Enter") { ev.preventDefault(); moves.applyFields(); } });
}
for (const id of ["dx", "dy", "dz", "dangle"]) {
  $(id).addEventListener("keydown", (ev) => { if (ev.key === "Enter") { ev.preventDefault(); moves.moveBy(); } });
}
$("threshold").addEventListener("keydown", (ev) => {
  if (ev.key === "Enter") { const t = Number($("threshold").value); if (t > -1 && t < 1) setThreshold(t); }
});
$("preset-name").addEventListener("keydown", (ev) => { if (ev.key === "Enter" && state.sessionId) moves.savePreset($("preset-name").value); });

// keyboard: Ctrl+Z / Ctrl+Shift+Z (or Ctrl+Y), F fit, W / E translate / rotate, 1 3 7 0 views, Esc cancel
const VIEW_KEYS = { 1: "front", 3: "side", 7: "top", 0: "iso" };
document.addEventListener("keydown", (ev) => {
  const t = ev.target;
  const typing = t && (t.tagName === "INPUT" && !["checkbox", "radio", "range", "button"].includes(t.type) ||
    t.tagName === "TEXTAREA" || t.tagName === "SELECT");
  if (ev.key === "Escape") { if (!typing && regions.cancel()) ev.preventDefault(); return; }
  if (typing || document.querySelector("dialog[open]")) return;
  const ctrl = ev.ctrlKey || ev.metaKey, key = ev.key.toLowerCase();
  if (ctrl && key === "z") { ev.preventDefault(); if (ev.shiftKey) moves.redo(); else moves.undo(); return; }
  if (ctrl && key === "y") { ev.preventDefault(); moves.redo(); return; }
  if (ctrl || ev.altKey) return;
  if (key === "f") fit();
  else if (key === "w") moves.setMode("translate");
  else if (key === "e") moves.setMode("rotate");
  else if (VIEW_KEYS[ev.key]) view(VIEW_KEYS[ev.key]);
  else return;
  ev.preventDefault();
});

$("api-key").value = localStorage.getItem("tetmorph-api-key") || "";
setApiKey($("api-key").value);
$("api-key").addEventListener("change", () => {
  localStorage.setItem("tetmorph-api-key", $("api-key").value);
  setApiKey($("api-key").value);
  clearError();
  listMeshes();
});
listMeshes();
drawHistogram();
renderHistory(moves);

// Automation hooks for the browser tests (read-only views of the state, plus where things are
// on screen so a test can use the real mouse).
window.tetmorph = {
  state,
  pivotScreen: () => viewer.toPage(moves.pivot.position),
  pivot: () => ({ position: moves.pivot.position.toArray(), quaternion: moves.pivot.quaternion.toArray(),
    centroid: state.centroid, handle: moves.active }),
  building: () => session.building,
  screenOf: (i) => viewer.ndcToPage(regions.screenOf(i, new THREE.Vector3())),
  worldToPage: (p) => viewer.toPage(new THREE.Vector3(...p)),
  positions: () => Array.from(state.V),
  camera: () => ({ position: viewer.camera.position.toArray(), target: viewer.orbit.target.toArray(),
    up: viewer.camera.up.toArray(), quaternion: viewer.camera.quaternion.toArray() }),
  triadAxes: () => viewer.triadAxes(),
  surfaceColor: (i) => Array.from(meshView.surfGeom.getAttribute("color").array.slice(3 * i, 3 * i + 3)),
  qualityColors: QUALITY_COLORS,
  regions: () => state.regions.map((r) => ({ id: r.id, name: r.name, kind: r.kind, count: r.count, visible: r.visible,
    color: r.color, source: r.source })),
  spec: () => session.spec(),
  ring: () => ({ visible: regions.ring.visible, position: regions.ring.position.toArray(), radius: regions.ring.scale.x }),
  ghostVisible: () => meshView.ghost.visible,
  dispMax: () => meshView.dispMax,
  measureFrames: (n) => viewer.measureFrames(n),
  viewOptions: () => ({ ...meshView.options }),
  histogramTicks: () => state.histogramTicks,
  histogramX: (t) => thresholdPageX(t),
};
