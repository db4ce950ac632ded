// tetmorph browser editor: open a mesh, select fixed and handle regions, create a session,
// drag the handle and watch the FE mesh (surface and interior) follow over the WebSocket.
// This module wires the parts together: viewer.js (renderer, camera, navigation),
// meshview.js (what is drawn), selection.js, gizmo.js (moves), session.js, panels.js,
// api.js (REST) and stream.js (WebSocket), around the shared state of state.js.
import * as THREE from "three";
import { getJson, api, setApiKey } from "./api.js";
import { decodeBundle } from "./binary.js";
import { $ } from "./dom.js";
import { Moves } from "./gizmo.js";
import { MeshView } from "./meshview.js";
import { clearError, showError, showReport, showSelectionCounts } from "./panels.js";
import { Selection } from "./selection.js";
import { SessionControl } from "./session.js";
import { on, state } from "./state.js";
import { Viewer } from "./viewer.js";

const viewer = new Viewer($("canvas"));
const meshView = new MeshView(viewer);
const selection = new Selection(viewer, meshView, { onRefused: showError });
const session = new SessionControl(meshView, selection);
const moves = new Moves(viewer, { send: (m) => session.send(m), reset: () => session.reset(), refuse: showError });
session.moves = moves;
selection.busy = () => moves.dragging;

on("selection", () => { const c = selection.counts(); showSelectionCounts(c.fixed, c.handle); });

function fit() { if (state.V) viewer.fit(meshView.box()); }

// ------------------------------------------------------------------ meshes
async function openMesh(id) {
  clearError();
  session.close();
  const r = await api(`/v1/meshes/${id}/geometry`);
  const { header, arrays } = decodeBundle(await r.arrayBuffer());
  state.meshId = id;
  state.meshName = header.name || id;
  state.V0 = Float32Array.from(arrays.V);
  state.V = Float32Array.from(arrays.V);
  state.F = arrays.F;
  state.T = arrays.T;
  state.boundary = arrays.boundary;
  state.sets = {};
  for (const name of header.sets) state.sets[name] = arrays[`set:${name}`];
  state.role = new Uint8Array(state.V.length / 3);
  const lo = header.bbox[0], hi = header.bbox[1];
  state.diag = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
  // mixed meshes: T also carries the corner tets of hexahedra, wedges and pyramids
  state.elements = header.elements ?? state.T.length / 4;
  $("mesh-name").textContent = `${state.meshName} · ${state.V.length / 3} vertices · ${state.elements} elements`;
  $("sets").innerHTML = '<option value="">— named sets —</option>' +
    header.sets.map((s) => `<option>${s}</option>`).join("");
  meshView.load();
  state.report = null;
  selection.changed();
  meshView.refresh();
  fit();
  showReport({ mesh: state.meshName, elements: state.elements, vertices: state.V.length / 3 });
}

async function listMeshes() {
  try {
    const list = await getJson("/v1/meshes");
    $("meshes").innerHTML = '<option value="">— stored meshes —</option>' +
      list.map((m) => `<option value="${m.id}">${m.name || m.id} (${m.id})</option>`).join("");
  } catch (e) { showError(e); }
}

async function upload(file) {
  clearError();
  const fd = new FormData();
  fd.append("file", file, file.name);
  try {
    const meta = await (await api("/v1/meshes", { method: "POST", body: fd })).json();
    await listMeshes();
    $("meshes").value = meta.id;
    await openMesh(meta.id);
  } catch (e) { showError(e); }
}

// ------------------------------------------------------------------ wiring
function syncViewOptions() {
  Object.assign(meshView.options, { clip: $("clip").checked, clipAxis: Number($("clip-axis").value),
    clipPos: Number($("clip-pos").value), bad: $("bad").checked });
  meshView.refresh();
}

$("upload").addEventListener("change", (ev) => { if (ev.target.files[0]) upload(ev.target.files[0]); });
$("open-mesh").addEventListener("click", () => { if ($("meshes").value) openMesh($("meshes").value).catch(showError); });
$("demo").addEventListener("click", () => openMesh("m_demo_beam").catch(showError));
$("set-apply").addEventListener("click", () => {
  const s = state.sets[$("sets").value];
  if (s) selection.assign(s);
});
$("clear-sel").addEventListener("click", () => selection.clear());
$("create").addEventListener("click", () => session.create());
$("apply-move").addEventListener("click", () => moves.applyNumeric());
$("undo").addEventListener("click", () => moves.undo());
$("reset").addEventListener("click", () => session.reset());
$("download").addEventListener("click", () => session.download());
$("fit").addEventListener("click", fit);
$("edges").addEventListener("change", () => meshView.setEdges($("edges").checked));
for (const id of ["clip", "clip-axis", "clip-pos", "bad"]) $(id).addEventListener("input", syncViewOptions);
$("api-key").value = localStorage.getItem("tetmorph-api-key") || "";
setApiKey($("api-key").value);
$("api-key").addEventListener("change", () => {
  localStorage.setItem("tetmorph-api-key", $("api-key").value);
  setApiKey($("api-key").value);
  listMeshes();
});
listMeshes();

// Automation hooks for the browser tests (read-only views of the state, plus where the
// gizmo is on screen so a test can drag it with the real mouse).
window.tetmorph = {
  state,
  pivotScreen: () => viewer.toPage(moves.pivot.position),
  screenOf: (i) => viewer.ndcToPage(selection.screenOf(i, new THREE.Vector3())),
  positions: () => Array.from(state.V),
};
