// tetmorph browser editor: open a mesh, mark fixed and handle regions, create a session,
// move the handles and watch the FE mesh (surface and interior) follow over the WebSocket.
// This module wires the parts together: viewer.js (renderer, camera, navigation, triad),
// meshview.js (what is drawn), selection.js (regions), gizmo.js (moves, history, presets),
// session.js (the session's life), panels.js (read-outs), lists.js (the panels' lists),
// messages.js (errors in words), api.js (REST) and stream.js (WebSocket), around the shared
// state of state.js.
import * as THREE from "three";
import { api, getAll, getJson, setApiKey } from "./api.js";
import { decodeBundle } from "./binary.js";
import { $ } from "./dom.js";
import { Moves } from "./gizmo.js";
import { renderFeatures, renderHandleSelect, renderHistory, renderMeshSessions, renderPresets, renderRegions,
  renderSessionsTable, wireRegions } from "./lists.js";
import { loadMesh, setUnits } from "./mesh.js";
import { MeshView, PREVIEW_COLOR, QUALITY_COLORS } from "./meshview.js";
import { ask, clearError, drawHistogram, drawLegend, fmt, legendModel, meshReport, paintLegend, refreshReport, setBusy,
  setReport, showError, showModel, showReport, unitText,
  thresholdPageX, wireThreshold } from "./panels.js";
import { Measure } from "./measure.js";
import { Regions } from "./selection.js";
import { RegionTools, UndoKeys } from "./regions.js";
import { FloodFill } from "./floodfill.js";
import { CyclicPairs, Diagnostics } from "./diagnostics.js";
import { ShapesPanel } from "./shapes.js";
import { CsysPanel } from "./csys.js";
import { EditsPanel } from "./edits.js";
import { scaleEdits } from "./editshapes.js";
import { ChecksPanel } from "./checks.js";
import { DoePlanPanel } from "./doeplan.js";
import { CyclicPanel, SymmetryPanel, TargetPanel } from "./symmetry.js";
import { saveBlob, SessionControl } from "./session.js";
import { on, state } from "./state.js";
import { TetraDialog } from "./tetradialog.js";
import { stateAccessors } from "./testhook.js";
import { Viewer } from "./viewer.js";
import { Workspace } from "./workspace.js";

const viewer = new Viewer($("canvas"));
const meshView = new MeshView(viewer);
const regions = new Regions(viewer, meshView);
const session = new SessionControl(meshView, regions);
const moves = new Moves(viewer, regions, {
  send: (m) => session.send(m), reset: (record) => session.reset(record), refuse: showError,
  updatePresets: (change) => session.updatePresets(change),
});
session.moves = moves;
const measure = new Measure(viewer, regions);
const symmetry = new SymmetryPanel(viewer, meshView, regions);
const cyclic = new CyclicPanel(viewer, regions);
const targets = new TargetPanel(viewer, regions);
const shapes = new ShapesPanel(moves, session);
const checks = new ChecksPanel(viewer, meshView);
new DoePlanPanel(shapes);
moves.picked = () => measure.values().vertices.map((i) => measure.point(i).toArray());
measure.changed = () => moves.loadPivot();  // the rings follow a picked pivot
viewer.beforeRender.push(placeLegend);  // after the gizmo's read-out is placed (Moves placed it first)
const csys = new CsysPanel(moves, { picked: () => moves.picked(), pickedIds: () => measure.values().vertices,
  refuse: showError });
const edits = new EditsPanel(viewer, meshView, regions, moves, { pickedIds: () => measure.values().vertices,
  refuse: showError, create: () => session.create() });
moves.extra = { move: () => edits.move(), set: (m) => edits.fromMove(m),
  scaled: (m, f) => scaleEdits(m, f, (kind, name) => edits.rest(kind, name)) };
shapes.editRest = (kind, name) => edits.rest(kind, name);
$("doe-plan").addEventListener("input", () => { $("doe-plan").dataset.edited = "1"; });
session.openMesh = (id) => openMesh(id);
// the mesh's and the session's workspace, on the service and in the page's address (#m=…&s=…)
const workspace = new Workspace({ session, regions, shapes, openMesh: (id) => openMesh(id) });
session.workspace = workspace;
regions.busy = (ev) => moves.dragging || (ev !== undefined && moves.under(ev)) || edits.busy(ev);
const regionTools = new RegionTools(regions, showError);
const undoKeys = new UndoKeys(regionTools.history, moves);
new FloodFill(viewer, regions, regionTools.history);
new Diagnostics(viewer, meshView, regions);
const cyclicPairs = new CyclicPairs(viewer, regions);
const tetraDialog = new TetraDialog({ opened: async (id) => { await listMeshes(); await openMesh(id); } });

// ------------------------------------------------------------------ signals -> panels
const legend = () => { drawLegend(meshView, state.regions); placeLegend(); };

/**
 * The legend in a corner of the view where it covers neither the gizmo's read-out nor the gizmo:
 * lower right, else upper right, else upper left (the triad has the lower left); where every corner
 * covers the gizmo, the first that leaves the read-out free.
 */
function placeLegend() {
  const el = $("legend");
  if (el.hidden) return;
  const W = viewer.canvas.clientWidth, H = viewer.canvas.clientHeight, w = el.offsetWidth, h = el.offsetHeight, m = 8;
  const boxes = [];
  const label = $("gizmo-label");
  if (!label.hidden) boxes.push({ x: label.offsetLeft, y: label.offsetTop, w: label.offsetWidth, h: label.offsetHeight });
  if (moves.helper.visible) {
    const p = moves.screen(moves.pivot.position), r = moves.gizmoReach(p);
    boxes.push({ x: p.x - r, y: p.y - r, w: 2 * r, h: 2 * r });
  }
  const corners = [{ x: W - m - w, y: H - m - h, at: "lower-right" }, { x: W - m - w, y: m, at: "upper-right" },
    { x: m, y: m, at: "upper-left" }];
  const clear = (c, list) => list.every((b) => c.x + w <= b.x || b.x + b.w <= c.x || c.y + h <= b.y || b.y + b.h <= c.y);
  const c = corners.find((k) => clear(k, boxes)) || corners.find((k) => clear(k, boxes.slice(0, label.hidden ? 0 : 1))) ||
    corners[0];
  if (el.dataset.at === c.at) return;
  el.dataset.at = c.at;
  el.style.left = c.at === "upper-left" ? `${m}px` : "auto";
  el.style.right = c.at === "upper-left" ? "auto" : `${m}px`;
  el.style.top = c.at === "lower-right" ? "auto" : `${m}px`;
  el.style.bottom = c.at === "lower-right" ? `${m}px` : "auto";
}
on("regions", () => { renderRegions(regions); legend(); showChoices(); symmetry.render(); cyclic.render(); targets.render(); });
on("legend", legend);
on("history", () => { renderHistory(moves); session.note(); session.saveHistory(); });
on("presets", () => { renderPresets(moves); shapes.render(); });
on("active-handle", () => renderHandleSelect(moves));
on("open-sessions", () => openSessionsDialog());
on("sessions-changed", () => offerMeshSessions());
on("derived", () => { if (measure.picks.length) measure.show(); });
wireRegions(regions);

function fit() { if (state.V) viewer.fit(meshView.box()); }
function view(name) { if (state.V) viewer.view(name, meshView.box()); }

// ------------------------------------------------------------------ meshes
async function openMesh(id) {
  clearError();
  await session.leave();
  setBusy("loading");
  try {
    const [r, meta] = await Promise.all([api(`/v1/meshes/${id}/geometry`), getJson(`/v1/meshes/${id}`)]);
    const { header, arrays } = decodeBundle(await r.arrayBuffer());
    loadMesh(id, header, meta, arrays);
    const n = state.V.length / 3;
    $("units").value = state.units;
    $("mesh-name").textContent = `${state.meshName} · ${fmt(n)} vertices · ` +
      (state.surface ? `surface, ${fmt(state.F.length / 3)} triangles` : `${fmt(state.elements)} elements`);
    $("mesh-name").title = $("mesh-name").textContent;
    if (![...$("meshes").options].some((o) => o.value === id)) await listMeshes();
    $("meshes").value = id;
    $("sets").innerHTML = '<option value="">— named sets —</option>' +
      header.sets.map((s) => `<option>${s}</option>`).join("");
    // nothing of the mesh before stays: colouring, move fields, snap step, download choice
    $("color-by").value = "regions";
    $("quality-metric").hidden = true;
    meshView.options.colorBy = "regions";
    csys.reset();
    moves.resetFields();
    moves.snapDefaults(state.diag);
    $("format").value = "";
    meshView.load();
    showChoices();
    regions.reset();
    regions.changed();
    setReport(null);
    meshView.refresh();
    viewer.fit(meshView.box(), new THREE.Vector3(1, -1, 1));
    $("welcome").hidden = true;
    renderFeatures(null, null, () => meshView.setPreview(null));
    measure.reset();
    showModel(header);
    showReport(meshReport());
    showSurface();
    formatNote();
    brushSize();
    offerMeshSessions();
    await workspace.meshOpened();
  } finally {
    setBusy(null);
  }
}

// ------------------------------------------------------------------ hide, isolate, opacity
/** The regions and named sets the view can hide or isolate. */
function showChoices() {
  const el = $("show-what"), cur = el.value;
  el.innerHTML = '<option value="">— region or set —</option>' +
    state.regions.filter((r) => r.count).map((r) => `<option value="region:${r.id}">region ${r.name}</option>`).join("") +
    Object.keys(state.sets || {}).map((n) => `<option value="set:${n}">set ${n}</option>`).join("");
  if ([...el.options].some((o) => o.value === cur)) el.value = cur;
}

/** Vertex mask of the choice: 1 for its vertices. */
function choiceMask() {
  const v = $("show-what").value, n = state.V ? state.V.length / 3 : 0, mask = new Uint8Array(n);
  if (v.startsWith("set:")) for (const i of state.sets[v.slice(4)] || []) mask[i] = 1;
  else if (v.startsWith("region:")) {
    const r = state.regions.find((x) => x.id === Number(v.slice(7)));
    if (r) for (const i of regions.idsOf(r)) mask[i] = 1;
  }
  return v ? mask : null;
}

function hideOrIsolate(isolate) {
  const m = choiceMask();
  if (!state.V || !m) { showError("choose a region or a named set to hide or isolate"); return; }
  // hide: the triangles with all three corners in it go; isolate: only those stay
  meshView.setFaceFilter(isolate ? (a, b, c) => m[a] && m[b] && m[c] : (a, b, c) => !(m[a] && m[b] && m[c]));
}

/** The brush's size beside its slider: percent of the model diagonal, and the radius in model units. */
function brushSize() {
  const pct = Number($("brush").value);
  $("brush-size").textContent = state.V
    ? `${pct} % · r ${Number((pct / 100 * state.diag).toPrecision(3))}${unitText()}` : `${pct} %`;
}

// ------------------------------------------------------------------ download formats
let formats = [];  // GET /v1/formats: what each format keeps

async function loadFormats() {
  try { formats = await getJson("/v1/formats"); } catch { formats = []; }
  formatNote();
}

/** The extension a format is written with (the mesh's own when `name` is empty). */
function extOf(name) {
  const row = formats.find((f) => f.name === name || f.extension === `.${name}`);
  if (row) return row.name === "tetgen" ? ".node + .ele" : row.extension;
  return name ? `.${name}` : "";
}

/** Below the format choice: the mesh's own format, or what a conversion to the chosen one leaves out. */
function formatNote() {
  const el = $("format-note"), own = $("format").options[0];
  const mine = state.meshFormat && state.meshFormat !== "arrays" ? state.meshFormat : "vtu";
  // the uploaded file itself, its coordinates changed: same encoding (ASCII VTK stays ASCII), same lines
  own.textContent = state.meshFormat ? `original format (${extOf(mine)} as uploaded)` : "original format";
  const chosen = $("format").value;
  if (!state.meshId || !chosen) { el.hidden = true; return; }
  const row = formats.find((f) => f.extension === `.${chosen}` || f.name === chosen);
  const info = state.meshInfo || {}, lost = [];
  const sets = Object.keys(info.sets || {});
  const types = Object.keys(info.cell_types || {});
  if (row && !row.sets && sets.length) lost.push(`the named sets (${sets.join(", ")})`);
  if (row && !row.quadratic && info.element_order === 2) lost.push("the mid-side nodes of its quadratic elements");
  if (row && !row.mixed && types.some((t) => /^(hexahedron|wedge|pyramid)/.test(t))) lost.push("its hexahedra, wedges and pyramids");
  el.textContent = lost.length
    ? `A ${extOf(chosen)} file does not keep ${lost.join(", ")}: the download says what it leaves out before writing.`
    : `Converted to ${extOf(chosen)}; the mesh's own format (${extOf(mine)}) keeps the file as uploaded.`;
  el.hidden = false;
}

// ------------------------------------------------------------------ surfaces
/** A surface mesh has no volume to morph: say so, and offer to fill it with tetrahedra. */
function showSurface() {
  const el = $("surface-note");
  $("create").disabled = !!state.surface;
  if (!state.surface) { el.hidden = true; return; }
  $("surface-text").textContent = `${state.meshName} is a surface: ${fmt(state.F.length / 3)} triangles and no ` +
    "volume elements. Morphing moves the nodes of a volume mesh; tetrahedralize the surface to get one.";
  el.hidden = false;
}

async function listMeshes() {
  try {
    // the newest first: the one just uploaded heads the list, however many are stored
    const list = (await getAll("/v1/meshes")).reverse();
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
    if (state.surface) tetraDialog.open();  // a surface has nothing to morph: offer to fill it
  } catch (e) { showError(e); } finally { setBusy(null); }
}

async function demo() {
  clearError();
  try {
    const doc = await getJson("/v1/sessions/s_demo");
    // the demo starts at rest: whatever moved it before is not the next visitor's starting point
    if (doc.last_move) await api("/v1/sessions/s_demo/reset", { method: "POST" });
    // nor is its undo history
    await api("/v1/sessions/s_demo/history", { method: "PUT", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ applied: [], undone: [] }) });
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
    delete: async (id) => {
      const open = id === state.sessionId ? " It is open here: it closes." : "";
      if (!await ask(`Delete session ${id} on the service? Its factorization, last move and presets go with it, ` +
        `and this cannot be undone.${open}`, "Delete")) return;
      await session.remove(id);
      await after();
    },
  };
}

async function openSessionsDialog() {
  const dlg = $("sessions-dialog");
  const refresh = async () => {
    try {
      const [sessions, meshes] = await Promise.all([session.list(), getAll("/v1/meshes")]);
      renderSessionsTable(sessions, new Map(meshes.map((m) => [m.id, m.name || m.id])), sessionHandlers(refresh));
      dlg.dataset.count = String(sessions.length);
      // "all but the open one" with none open would be all of them: offered only beside an open session
      const others = $("sessions-delete-others");
      others.disabled = !state.sessionId || !sessions.some((s) => s.id !== state.sessionId);
      others.title = state.sessionId ? `delete every session but ${state.sessionId}` : "no session is open here";
    } catch (e) { showError(e); }
  };
  await refresh();
  if (!dlg.open) dlg.showModal();
  $("sessions-delete-others").onclick = async () => {
    const keep = state.sessionId;
    if (!keep) return;
    const others = (await session.list()).filter((s) => s.id !== keep);
    if (!others.length) return;
    const n = others.length;
    if (!await ask(`Delete ${n} session${n === 1 ? "" : "s"} on the service, every one but the open ${keep}? ` +
      "This cannot be undone.", `Delete ${n}`)) return;
    for (const s of others) if (s.id !== state.sessionId) await session.remove(s.id, true);
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
  const axis = $("clip-axis").value;
  $("clip-normal").hidden = axis !== "n";
  let normal = [0, 0, 0];
  if (axis === "n") {
    const v = $("clip-normal").value.trim().split(/[\s,;]+/).map(Number);
    const len = v.length === 3 && v.every(Number.isFinite) ? Math.hypot(...v) : 0;
    normal = len > 0 ? v.map((x) => x / len) : meshView.options.clipNormal;
  } else {
    normal[Number(axis)] = 1;
  }
  Object.assign(meshView.options, { clip: $("clip").checked, clipAxis: axis, clipNormal: normal,
    clipPos: Number($("clip-pos").value), bad: $("bad").checked });
  meshView.setClip($("clip").checked);
  meshView.refresh();
  legend();
  refreshReport();
}

/** Keep the other side of the section plane (the button, or N). */
function flipClip() {
  const flip = !meshView.options.clipFlip;
  meshView.options.clipFlip = flip;
  $("clip-flip").setAttribute("aria-pressed", String(flip));
  syncViewOptions();
}

function setThreshold(t) {
  meshView.setThreshold(t);
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
$("open-mesh").addEventListener("click", () => { if ($("meshes").value) workspace.openMeshWorkspace($("meshes").value); });
$("demo").addEventListener("click", demo);
$("welcome-demo").addEventListener("click", demo);
$("set-apply").addEventListener("click", () => regions.assignSet($("sets").value));
$("add-fixed").addEventListener("click", () => { if (state.V) regions.add("fixed"); });
$("add-handle").addEventListener("click", () => { if (state.V) regions.add("handle"); });
$("clear-sel").addEventListener("click", () => { if (state.V) regions.clear(); });
$("domain-clear").addEventListener("click", () => { if (state.V) regions.applyDomain([], "replace"); });
$("find-features").addEventListener("click", async () => {
  if (!state.meshId) { showError("open a mesh first"); return; }
  setBusy("finding features");
  try {
    const list = await getJson(`/v1/meshes/${state.meshId}/features?ids=true`);
    renderFeatures(list, (f, kind) => (kind === "axes" ? csys.fromFeature(f)
      : regions.fromIds(f.name, kind, regions.resolve(f.selection), null)),
      (f) => meshView.setPreview(f ? regions.resolve(f.selection) : null));
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
$("reset").addEventListener("click", async () => {
  const cur = state.history[state.historyIndex];
  if (state.sessionId && cur && cur.move && !await ask("Reset the session to the rest shape? The history keeps the " +
    "current pose: Undo brings it back.", "Reset")) return;
  session.reset();
});
$("download").addEventListener("click", () => session.download());
$("format").addEventListener("change", formatNote);
$("tetrahedralize").addEventListener("click", () => tetraDialog.open());
$("handle-select").addEventListener("change", () => moves.setActive($("handle-select").value));
$("preset-save").addEventListener("click", () => { if (state.sessionId) moves.savePreset($("preset-name").value); });
$("fit").addEventListener("click", fit);
for (const b of document.querySelectorAll("[data-view]")) b.addEventListener("click", () => view(b.dataset.view));
$("edges").addEventListener("change", () => meshView.setEdges($("edges").checked));
$("ghost").addEventListener("change", () => { meshView.setGhost($("ghost").checked); legend(); });
$("color-by").addEventListener("change", () => {
  $("quality-metric").hidden = $("color-by").value !== "quality";
  meshView.setColorBy($("color-by").value);
});
$("quality-metric").addEventListener("change", () => meshView.setQualityMetric($("quality-metric").value));
for (const id of ["clip", "clip-axis", "clip-pos", "bad"]) $(id).addEventListener("input", syncViewOptions);
$("clip-normal").addEventListener("change", syncViewOptions);
$("clip-flip").addEventListener("click", flipClip);
$("clip-from-view").addEventListener("click", () => {
  // a section facing the camera: the part between the camera and the plane is cut away
  const d = viewer.camera.position.clone().sub(viewer.orbit.target).normalize();
  $("clip-normal").value = d.toArray().map((x) => Number(x.toFixed(4))).join(" ");
  $("clip-axis").value = "n";
  $("clip").checked = true;
  syncViewOptions();
});
$("hide-sel").addEventListener("click", () => hideOrIsolate(false));
$("isolate-sel").addEventListener("click", () => hideOrIsolate(true));
$("show-all").addEventListener("click", () => { if (state.V) meshView.setFaceFilter(null); });
$("opacity").addEventListener("input", () => meshView.setOpacity(Number($("opacity").value)));
let pngLegend = null;  // what the last PNG's legend said, and where (the test hook reads it)
$("png").addEventListener("click", () => {
  if (!state.V) { showError("open a mesh first"); return; }
  // the model without the tools drawn over it (gizmo, brush ring), then the legend painted on a copy
  const shown = [moves.helper, regions.ring].map((o) => [o, o.visible]);
  for (const [o] of shown) o.visible = false;
  viewer.draw();  // the drawing buffer is kept (preserveDrawingBuffer): the frame just drawn
  const src = viewer.canvas, out = document.createElement("canvas");
  out.width = src.width;
  out.height = src.height;
  const g = out.getContext("2d");
  g.drawImage(src, 0, 0);
  for (const [o, v] of shown) o.visible = v;
  viewer.draw();
  pngLegend = paintLegend(g, legendModel(meshView, state.regions), out.width, out.height,
    src.width / Math.max(1, src.clientWidth));
  const stem = (state.meshName || "view").replace(/\.[^.]+$/, "");
  out.toBlob((blob) => saveBlob(blob, `${stem}.png`), "image/png");
});
$("units").addEventListener("change", () => {
  setUnits($("units").value);
  if (state.bbox) showModel({ bbox: state.bbox });
  legend(); refreshReport(); moves.updateLabel(); brushSize();
});
$("brush").addEventListener("input", brushSize);
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

// keyboard: Ctrl+Z / Ctrl+Shift+Z (or Ctrl+Y), F fit, W / E translate / rotate, N flip the section,
// 1 3 7 0 views, Esc cancel
const VIEW_KEYS = { 1: "front", 3: "side", 7: "top", 0: "iso" };
document.addEventListener("keydown", (ev) => {
  const t = ev.target;
  const typing = t && (t.tagName === "INPUT" && !["checkbox", "radio", "range", "button"].includes(t.type) ||
    t.tagName === "TEXTAREA" || t.tagName === "SELECT");
  const dialog = document.querySelector("dialog[open]");
  const ctrl = ev.ctrlKey || ev.metaKey, key = ev.key.toLowerCase();
  if (ev.key === "Escape") {
    if (typing && !dialog) { t.blur(); ev.preventDefault(); return; }  // Esc leaves the field
    if (!typing && regions.cancel()) ev.preventDefault();
    return;
  }
  // in a move field that shows what was applied (nothing typed since), Ctrl+Z undoes the morph;
  // with text typed into it, it undoes the typing
  if (typing && !dialog && ctrl && (key === "z" || key === "y") && moves.unedited(t)) {
    ev.preventDefault();
    if (key === "y" || ev.shiftKey) moves.redo(); else moves.undo();
    return;
  }
  if (typing || dialog) return;
  // the last kind of edit: a move, or a region edit (regions.js UndoKeys; the Regions panel says which)
  if (ctrl && key === "z") { ev.preventDefault(); if (ev.shiftKey) undoKeys.redo(); else undoKeys.undo(); return; }
  if (ctrl && key === "y") { ev.preventDefault(); undoKeys.redo(); return; }
  if (ctrl || ev.altKey) return;
  if (key === "f") fit();
  else if (key === "w") moves.setMode("translate");
  else if (key === "e") moves.setMode("rotate");
  else if (key === "n") flipClip();
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
workspace.restore();  // what the address names: a reload, a bookmark or a second tab opens the same workspace
loadFormats();
drawHistogram();
renderHistory(moves);
brushSize();

// The test hook, for automation only (the browser tests): read-only accessors of the state (listed
// in testhook.js), plus where things are on screen so a test can use the real mouse, and a few
// views of the parts (the gizmo, the camera, the colours drawn).
window.tetmorph = Object.freeze({
  ...stateAccessors(),
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
  previewColor: () => Array.from(PREVIEW_COLOR),  // what a hovered candidate is drawn in
  faceColors: () => meshView.faceColors(),  // per surface triangle, the quality contour's colour (null: not drawn)
  sectionColors: () => meshView.sectionColors(),  // {tets, colors}: the section's tets and their colours
  qualityColors: QUALITY_COLORS,
  showGizmo: (visible) => { moves.helper.visible = visible; viewer.draw(); },
  pngLegend: () => (pngLegend ? structuredClone(pngLegend) : null),  // {box, title, ticks, items} of the last PNG
  regions: () => state.regions.map((r) => ({ id: r.id, name: r.name, kind: r.kind, count: r.count, visible: r.visible,
    color: r.color, source: r.source })),
  spec: () => session.spec(),
  edits: () => edits.snapshot(),  // {spec: the SPEC's edit entries, values: the MOVE's, lattice: the one drawn}
  measure: () => measure.values(),
  doeJob: () => state.doeJob,
  checks: () => checks.values(),  // {result, isolated}: the quality check shown, the elements isolated
  csys: () => (moves.csys ? moves.csys.axes.map((a) => a.toArray()) : null),
  csysOrigin: () => (moves.csys ? moves.csys.origin.slice() : null),
  gizmoAxis: () => moves.gizmo.axis,
  cyclicPairs: () => structuredClone(cyclicPairs.result),  // [{name, pairs, max, a, b, tolerance}] drawn
  targetSurfaces: () => targets.group.children.length,  // the target surfaces drawn  // the gizmo handle under the pointer ("X", "XY", ...), or null
  ring: () => ({ visible: regions.ring.visible, position: regions.ring.position.toArray(), radius: regions.ring.scale.x }),
  ghostVisible: () => meshView.ghost.visible,
  dispMax: () => meshView.dispMax,
  measureFrames: (n) => viewer.measureFrames(n),
  viewOptions: () => ({ ...meshView.options }),
  histogramTicks: () => state.histogramTicks,
  histogramX: (t) => thresholdPageX(t),
});
