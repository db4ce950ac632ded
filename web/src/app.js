// tetmorph browser editor: open a mesh, select fixed and handle regions, create a session,
// drag the handle and watch the FE mesh (surface and interior) follow over the WebSocket.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { TransformControls } from "three/addons/controls/TransformControls.js";
import { decodeBundle, decodeFrame } from "./binary.js";
import { cutTets, histogram, scaledJacobians, tetFaces } from "./quality.js";

const $ = (id) => document.getElementById(id);
const LOW_QUALITY = 0.2; // scaled Jacobian below which an element is coloured as poor
const COLORS = { none: [0.78, 0.8, 0.83], fixed: [0.16, 0.4, 0.85], handle: [0.95, 0.55, 0.1] };

const state = {
  meshId: null, meshName: "", V0: null, V: null, F: null, T: null, boundary: null, sets: {},
  role: null, sessionId: null, ws: null, seq: 0, lastSeq: 0, moves: [], lastMove: null,
  sjRest: null, sj: null, report: null, centroid: null, diag: 1, frames: 0,
};

// ------------------------------------------------------------------ HTTP helpers
function headers(extra = {}) {
  const key = $("api-key").value.trim();
  return key ? { ...extra, "X-API-Key": key } : extra;
}

async function api(path, opts = {}) {
  const r = await fetch(path, { ...opts, headers: headers(opts.headers || {}) });
  if (!r.ok) {
    let body;
    try { body = await r.json(); } catch { body = { error: { status: r.status, message: r.statusText } }; }
    const e = new Error(body.error ? body.error.message : r.statusText);
    e.body = body;
    throw e;
  }
  return r;
}

function showError(e) {
  const sec = $("errors");
  sec.hidden = false;
  const err = e && e.body && e.body.error ? e.body.error : { message: String(e && e.message || e) };
  let text = `${err.code || "error"}: ${err.message}`;
  const rep = err.details && err.details.report;
  if (rep) {
    text += `\ninverted elements: ${rep.inverted_elements}`;
    if (rep.safe_fraction !== undefined) text += `\nsafe fraction: ${rep.safe_fraction}`;
    if (rep.conflicting_constraints && rep.conflicting_constraints.length)
      text += `\nconflicting constraints: ${JSON.stringify(rep.conflicting_constraints.slice(0, 5))}`;
  } else if (err.details && Object.keys(err.details).length) {
    text += `\n${JSON.stringify(err.details).slice(0, 600)}`;
  }
  $("error-text").textContent = text;
}

function clearError() { $("errors").hidden = true; $("error-text").textContent = ""; }

// ------------------------------------------------------------------ scene
const canvas = $("canvas");
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.localClippingEnabled = true;
const scene = new THREE.Scene();
scene.background = new THREE.Color(0xf4f5f7);
const camera = new THREE.PerspectiveCamera(40, 1, 0.001, 1e6);
scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
scene.add(sun);
const orbit = new OrbitControls(camera, canvas);
const clipPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);

const surfGeom = new THREE.BufferGeometry();
const surfMat = new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.8, metalness: 0.0,
  side: THREE.DoubleSide, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
const surface = new THREE.Mesh(surfGeom, surfMat);
const edgeMat = new THREE.LineBasicMaterial({ color: 0x38424f, transparent: true, opacity: 0.35 });
let edges = null;
const cutGeom = new THREE.BufferGeometry();
const cutMesh = new THREE.Mesh(cutGeom, new THREE.MeshStandardMaterial({ vertexColors: true, side: THREE.DoubleSide,
  flatShading: true }));
const badGeom = new THREE.BufferGeometry();
const badMesh = new THREE.Mesh(badGeom, new THREE.MeshBasicMaterial({ vertexColors: true, transparent: true,
  opacity: 0.85, depthTest: false, side: THREE.DoubleSide }));
badMesh.renderOrder = 10;
scene.add(surface, cutMesh, badMesh);

const pivot = new THREE.Object3D();
scene.add(pivot);
const gizmo = new TransformControls(camera, canvas);
gizmo.addEventListener("dragging-changed", (ev) => {
  orbit.enabled = !ev.value && currentTool() === "orbit";
  if (!ev.value && state.lastMove) pushMove(state.lastMove);
});
gizmo.addEventListener("objectChange", () => sendMove(moveFromPivot()));
const gizmoHelper = gizmo.getHelper();
scene.add(gizmoHelper);
gizmoHelper.visible = false;

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  }
}

function render() {
  resize();
  sun.position.copy(camera.position);
  renderer.render(scene, camera);
  requestAnimationFrame(render);
}
requestAnimationFrame(render);

function fit() {
  if (!state.V) return;
  resize();
  const box = new THREE.Box3().setFromBufferAttribute(surfGeom.getAttribute("position"));
  const c = box.getCenter(new THREE.Vector3());
  const r = box.getSize(new THREE.Vector3()).length() / 2 || 1;
  orbit.target.copy(c);
  // distance at which the bounding sphere fits the narrower of the two fields of view
  const vfov = THREE.MathUtils.degToRad(camera.fov);
  const hfov = 2 * Math.atan(Math.tan(vfov / 2) * camera.aspect);
  const dist = 1.1 * r / Math.sin(Math.min(vfov, hfov) / 2);
  camera.position.copy(c).add(new THREE.Vector3(0.6, -1.2, 0.8).normalize().multiplyScalar(dist));
  camera.near = r / 1000; camera.far = r * 100;
  camera.up.set(0, 0, 1);
  camera.updateProjectionMatrix();
  orbit.update();
}

// ------------------------------------------------------------------ mesh loading
async function openMesh(id) {
  clearError();
  closeSession();
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
  surfGeom.setAttribute("position", new THREE.BufferAttribute(state.V, 3));
  surfGeom.setIndex(new THREE.BufferAttribute(state.F, 1));
  surfGeom.setAttribute("color", new THREE.BufferAttribute(new Float32Array(state.V.length), 3));
  surfGeom.computeVertexNormals();
  surfGeom.computeBoundingSphere();
  if (edges) { scene.remove(edges); edges.geometry.dispose(); }
  edges = new THREE.LineSegments(edgeGeometry(), edgeMat);
  edges.visible = $("edges").checked;
  scene.add(edges);
  state.sjRest = scaledJacobians(state.V0, state.T);
  state.sj = state.sjRest.slice();
  state.report = null;
  recolor();
  refreshDerived();
  fit();
  showReport({ mesh: state.meshName, elements: state.elements, vertices: state.V.length / 3 });
}

/** Unique surface edges as an index into the shared position buffer (no copies per frame). */
function edgeGeometry() {
  const F = state.F, n = state.V.length / 3;
  const seen = new Set(), idx = [];
  for (let f = 0; f < F.length; f += 3) {
    for (let k = 0; k < 3; k++) {
      const a = F[f + k], b = F[f + (k + 1) % 3];
      const key = a < b ? a * n + b : b * n + a;
      if (!seen.has(key)) { seen.add(key); idx.push(a, b); }
    }
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute("position", surfGeom.getAttribute("position"));
  g.setIndex(new THREE.BufferAttribute(new Uint32Array(idx), 1));
  return g;
}

async function listMeshes() {
  try {
    const list = await (await api("/v1/meshes")).json();
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

// ------------------------------------------------------------------ selection
function currentTool() { return document.querySelector("input[name=tool]:checked").value; }
function currentRole() { return Number(document.querySelector("input[name=role]:checked").value); }

function recolor() {
  const col = surfGeom.getAttribute("color");
  const n = state.role.length;
  for (let i = 0; i < n; i++) {
    const c = state.role[i] === 1 ? COLORS.fixed : state.role[i] === 2 ? COLORS.handle : COLORS.none;
    col.array[3 * i] = c[0]; col.array[3 * i + 1] = c[1]; col.array[3 * i + 2] = c[2];
  }
  col.needsUpdate = true;
  let f = 0, h = 0;
  for (let i = 0; i < n; i++) { if (state.role[i] === 1) f++; else if (state.role[i] === 2) h++; }
  $("sel-count").textContent = `fixed ${f} · handle ${h}`;
}

function assign(ids) {
  if (state.sessionId) { showError("close the session (Reset → reopen the mesh) to change the selection"); return; }
  const r = currentRole();
  for (const i of ids) state.role[i] = r;
  recolor();
}

function screenOf(i, out) {
  out.set(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]).project(camera);
  return out;
}

function boxSelect(x0, y0, x1, y1) {
  const rect = canvas.getBoundingClientRect();
  const ax = Math.min(x0, x1), bx = Math.max(x0, x1), ay = Math.min(y0, y1), by = Math.max(y0, y1);
  const v = new THREE.Vector3();
  const ids = [];
  for (let i = 0; i < state.boundary.length; i++) {
    if (!state.boundary[i]) continue;
    screenOf(i, v);
    if (v.z > 1) continue;
    const sx = (v.x + 1) / 2 * rect.width, sy = (1 - v.y) / 2 * rect.height;
    if (sx >= ax && sx <= bx && sy >= ay && sy <= by) ids.push(i);
  }
  assign(ids);
}

const raycaster = new THREE.Raycaster();
function brushAt(clientX, clientY) {
  const rect = canvas.getBoundingClientRect();
  const p = new THREE.Vector2((clientX - rect.left) / rect.width * 2 - 1, -(clientY - rect.top) / rect.height * 2 + 1);
  raycaster.setFromCamera(p, camera);
  const hit = raycaster.intersectObject(surface, false)[0];
  if (!hit) return;
  const r = Number($("brush").value) / 100 * state.diag;
  const ids = [];
  for (let i = 0; i < state.boundary.length; i++) {
    if (!state.boundary[i]) continue;
    const dx = state.V[3 * i] - hit.point.x, dy = state.V[3 * i + 1] - hit.point.y, dz = state.V[3 * i + 2] - hit.point.z;
    if (dx * dx + dy * dy + dz * dz <= r * r) ids.push(i);
  }
  assign(ids);
}

let drag = null;
canvas.addEventListener("pointerdown", (ev) => {
  const tool = currentTool();
  if (tool === "orbit" || ev.button !== 0 || !state.V || gizmo.dragging) return;
  drag = { x: ev.offsetX, y: ev.offsetY };
  canvas.setPointerCapture(ev.pointerId);
  if (tool === "brush") brushAt(ev.clientX, ev.clientY);
});
canvas.addEventListener("pointermove", (ev) => {
  if (!drag) return;
  if (currentTool() === "box") {
    const b = $("boxsel");
    b.style.display = "block";
    b.style.left = `${Math.min(drag.x, ev.offsetX)}px`; b.style.top = `${Math.min(drag.y, ev.offsetY)}px`;
    b.style.width = `${Math.abs(ev.offsetX - drag.x)}px`; b.style.height = `${Math.abs(ev.offsetY - drag.y)}px`;
  } else {
    brushAt(ev.clientX, ev.clientY);
  }
});
canvas.addEventListener("pointerup", (ev) => {
  if (!drag) return;
  if (currentTool() === "box") boxSelect(drag.x, drag.y, ev.offsetX, ev.offsetY);
  $("boxsel").style.display = "none";
  drag = null;
});
for (const r of document.querySelectorAll("input[name=tool]")) {
  r.addEventListener("change", () => { orbit.enabled = currentTool() === "orbit"; });
}

// ------------------------------------------------------------------ session
function idsOfRole(r) {
  const out = [];
  for (let i = 0; i < state.role.length; i++) if (state.role[i] === r) out.push(i);
  return out;
}

async function createSession() {
  clearError();
  if (!state.meshId) { showError("open a mesh first"); return; }
  const fixed = idsOfRole(1), handle = idsOfRole(2);
  if (!fixed.length || !handle.length) { showError("select a fixed region and a handle region first"); return; }
  const spec = {
    selections: { fixed: { ids: fixed }, handle: { ids: handle } },
    fixed: ["fixed"], handles: { handle: "handle" }, inversion: $("policy").value, repair: $("repair").checked,
  };
  $("session-status").textContent = "building…";
  try {
    let s = await (await api("/v1/sessions", { method: "POST", headers: { "Content-Type": "application/json" },
      body: JSON.stringify({ mesh_id: state.meshId, spec }) })).json();
    while (s.status === "building") {
      $("progress").value = s.progress || 0;
      $("session-status").textContent = `building: ${s.stage} ${Math.round(100 * (s.progress || 0))}%`;
      await new Promise((r) => setTimeout(r, 250));
      s = await (await api(`/v1/sessions/${s.id}`)).json();
    }
    if (s.status !== "ready") throw Object.assign(new Error(`session ${s.status}`), { body: { error: s.error } });
    $("progress").value = 1;
    state.sessionId = s.id;
    state.moves = [];
    const setup = s.setup_timings ? ` · set-up ${Math.round(s.setup_timings.total_ms)} ms` : "";
    $("session-status").textContent = `session ${s.id} ready${setup}`;
    let c = [0, 0, 0];
    for (const i of handle) for (let k = 0; k < 3; k++) c[k] += state.V0[3 * i + k] / handle.length;
    state.centroid = c;
    pivot.position.set(...c);
    pivot.quaternion.identity();
    gizmo.attach(pivot);
    gizmoHelper.visible = true;
    gizmo.setSize(0.9);
    openStream();
  } catch (e) {
    $("session-status").textContent = "no session";
    showError(e);
  }
}

function closeSession() {
  if (state.ws) { state.ws.onclose = null; state.ws.close(); }
  state.ws = null; state.sessionId = null; state.moves = []; state.lastMove = null;
  gizmo.detach();
  gizmoHelper.visible = false;
  $("session-status").textContent = "no session";
  $("progress").value = 0;
}

function openStream() {
  const proto = location.protocol === "https:" ? "wss" : "ws";
  const key = $("api-key").value.trim();
  const q = `kind=positions&dtype=float32${key ? `&api_key=${encodeURIComponent(key)}` : ""}`;
  const ws = new WebSocket(`${proto}://${location.host}/v1/sessions/${state.sessionId}/stream?${q}`);
  ws.binaryType = "arraybuffer";
  ws.onmessage = (ev) => {
    if (typeof ev.data === "string") {
      const msg = JSON.parse(ev.data);
      if (msg.error) showError({ body: msg });
      return;
    }
    const { header, data } = decodeFrame(ev.data);
    const rtt = header.seq === state.seq ? performance.now() - state.sentAt : undefined;
    applyPositions(data);
    state.lastSeq = header.seq;
    state.roundTripMs = rtt;
    showReport({ seq: header.seq, dropped: header.dropped, ...header.report, round_trip_ms: rtt,
      apply_ms: state.applyMs });
    const rep = header.report || {};
    if (rep.inverted_elements > 0 && $("policy").value === "warn") {
      showError({ body: { error: { code: "inverted_elements", message: `${rep.inverted_elements} elements inverted`,
        details: { report: rep } } } });
    } else if (!rep.conflicting_constraints || !rep.conflicting_constraints.length) {
      clearError();
    }
  };
  ws.onclose = () => { if (state.sessionId) $("session-status").textContent += " · stream closed"; };
  state.ws = ws;
}

function moveFromPivot() {
  const c = state.centroid;
  const t = [pivot.position.x - c[0], pivot.position.y - c[1], pivot.position.z - c[2]];
  const q = pivot.quaternion;
  return { handles: { handle: { translation: t, rotation: { quaternion: [q.w, q.x, q.y, q.z] }, pivot: c } } };
}

function sendMove(move) {
  if (!state.ws || state.ws.readyState !== WebSocket.OPEN) return;
  state.lastMove = move;
  state.seq += 1;
  state.sentAt = performance.now();
  state.ws.send(JSON.stringify({ seq: state.seq, move, inversion: $("policy").value, repair: $("repair").checked }));
}

function pushMove(move) { state.moves.push(move); }

function setPivotFromMove(move) {
  const c = state.centroid;
  const h = move.handles.handle;
  pivot.position.set(c[0] + h.translation[0], c[1] + h.translation[1], c[2] + h.translation[2]);
  const q = h.rotation.quaternion;
  pivot.quaternion.set(q[1], q[2], q[3], q[0]);
}

function applyNumeric() {
  if (!state.sessionId) { showError("create a session first"); return; }
  const axis = new THREE.Vector3(Number($("ax").value), Number($("ay").value), Number($("az").value));
  const q = new THREE.Quaternion();
  if (axis.lengthSq() > 0) q.setFromAxisAngle(axis.normalize(), THREE.MathUtils.degToRad(Number($("angle").value)));
  const move = { handles: { handle: { translation: [Number($("tx").value), Number($("ty").value), Number($("tz").value)],
    rotation: { quaternion: [q.w, q.x, q.y, q.z] }, pivot: state.centroid } } };
  setPivotFromMove(move);
  sendMove(move);
  pushMove(move);
}

async function undo() {
  if (!state.sessionId) return;
  state.moves.pop();
  const prev = state.moves[state.moves.length - 1];
  if (prev) { setPivotFromMove(prev); sendMove(prev); } else { await reset(); }
}

async function reset() {
  if (!state.sessionId) return;
  try {
    await api(`/v1/sessions/${state.sessionId}/reset`, { method: "POST" });
    state.moves = []; state.lastMove = null;
    pivot.position.set(...state.centroid); pivot.quaternion.identity();
    applyPositions(state.V0);
    showReport({ reset: true });
  } catch (e) { showError(e); }
}

async function download() {
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

// ------------------------------------------------------------------ derived views
function applyPositions(P) {
  const t0 = performance.now();
  state.V.set(P);
  surfGeom.getAttribute("position").needsUpdate = true;  // the edges share this buffer
  surfGeom.computeVertexNormals();
  surfGeom.computeBoundingSphere();
  state.sj = scaledJacobians(state.V, state.T, state.sj);
  state.frames += 1;
  refreshDerived();
  state.applyMs = performance.now() - t0;
}

function colorOf(sj) {
  if (sj <= 1e-12) return [0.85, 0.1, 0.1];
  if (sj < LOW_QUALITY) return [0.98, 0.6, 0.1];
  return [0.72, 0.8, 0.9];
}

function trianglesOf(tets, geom) {
  const F = tetFaces(state.T, tets);
  const pos = new Float32Array(F.length * 3), col = new Float32Array(F.length * 3);
  for (let i = 0; i < F.length; i++) {
    const v = F[i];
    pos[3 * i] = state.V[3 * v]; pos[3 * i + 1] = state.V[3 * v + 1]; pos[3 * i + 2] = state.V[3 * v + 2];
    const c = colorOf(state.sj[tets[Math.floor(i / 12)]]);
    col[3 * i] = c[0]; col[3 * i + 1] = c[1]; col[3 * i + 2] = c[2];
  }
  geom.setAttribute("position", new THREE.BufferAttribute(pos, 3));
  geom.setAttribute("color", new THREE.BufferAttribute(col, 3));
  geom.computeVertexNormals();
  geom.computeBoundingSphere();
}

function refreshDerived() {
  if (!state.V) return;
  // cross-section: the surface is clipped, the tets cut by the plane are drawn coloured by quality
  const clip = $("clip").checked;
  if (clip) {
    const axis = Number($("clip-axis").value);
    let lo = Infinity, hi = -Infinity;
    for (let i = axis; i < state.V.length; i += 3) { lo = Math.min(lo, state.V[i]); hi = Math.max(hi, state.V[i]); }
    const c = lo + Number($("clip-pos").value) * (hi - lo);
    clipPlane.normal.set(0, 0, 0).setComponent(axis, -1);
    clipPlane.constant = c;
    surfMat.clippingPlanes = [clipPlane];
    edgeMat.clippingPlanes = [clipPlane];
    const tets = cutTets(state.V, state.T, axis, c);
    state.cut = tets.length;
    trianglesOf(tets, cutGeom);
    $("cut-count").textContent = `${tets.length} tets in the section`;
  } else {
    surfMat.clippingPlanes = [];
    edgeMat.clippingPlanes = [];
    cutGeom.deleteAttribute("position");
    state.cut = 0;
    $("cut-count").textContent = "";
  }
  cutMesh.visible = clip;
  surfMat.needsUpdate = true;
  edgeMat.needsUpdate = true;
  // inverted and poor elements, drawn through the surface
  const bad = [];
  if ($("bad").checked) for (let t = 0; t < state.sj.length; t++) if (state.sj[t] < LOW_QUALITY) bad.push(t);
  state.badCount = bad.length;
  if (bad.length) trianglesOf(bad, badGeom); else badGeom.deleteAttribute("position");
  badMesh.visible = bad.length > 0;
  drawHistogram();
}

function drawHistogram() {
  const cv = $("hist"), g = cv.getContext("2d");
  const bins = 40, hr = histogram(state.sjRest, bins), hn = histogram(state.sj, bins);
  const top = Math.log10(Math.max(...hr, ...hn, 1) + 1);
  g.clearRect(0, 0, cv.width, cv.height);
  const w = cv.width / bins, H = cv.height - 14;
  for (let b = 0; b < bins; b++) {
    const a = Math.log10(hr[b] + 1) / top * H, c = Math.log10(hn[b] + 1) / top * H;
    g.fillStyle = "#aab2bd"; g.fillRect(b * w, H - a, w * 0.5, a);
    g.fillStyle = "#2e86de"; g.fillRect(b * w + w * 0.5, H - c, w * 0.5, c);
  }
  g.fillStyle = "#56616e"; g.font = "10px sans-serif";
  g.fillText("-1", 0, cv.height - 2); g.fillText("0", cv.width / 2 - 3, cv.height - 2);
  g.fillText("1", cv.width - 8, cv.height - 2);
  g.fillStyle = "#d62828"; g.fillRect(cv.width / 2, 0, 1, H);
}

function showReport(rep) {
  state.report = rep;
  const keys = ["mesh", "elements", "vertices", "seq", "dropped", "inverted_elements", "degenerate_elements",
    "min_scaled_jacobian", "safe_fraction", "clamped", "applied_fraction", "inverted_elements_unclamped",
    "constraint_residual_max", "max_displacement", "solve_ms", "round_trip_ms", "apply_ms", "reset"];
  const rows = [];
  for (const k of keys) {
    if (rep[k] === undefined || rep[k] === null) continue;
    const v = typeof rep[k] === "number" ? Number(rep[k].toPrecision(5)) : rep[k];
    const bad = (k === "inverted_elements" && rep[k] > 0) || (k === "clamped" && rep[k]);
    rows.push(`<tr class="${bad ? "bad" : ""}"><td>${k}</td><td>${v}</td></tr>`);
  }
  if (rep.conflicting_constraints && rep.conflicting_constraints.length)
    rows.push(`<tr class="bad"><td>conflicting</td><td>${rep.conflicting_constraints.length}</td></tr>`);
  if (rep.repair) rows.push(`<tr><td>repair</td><td>${rep.repair.inverted_before} → ${rep.repair.inverted_after}</td></tr>`);
  if (state.sj) rows.push(`<tr><td>elements below ${LOW_QUALITY}</td><td>${state.badCount || 0}</td></tr>`);
  $("report").innerHTML = rows.join("");
}

// ------------------------------------------------------------------ wiring
$("upload").addEventListener("change", (ev) => { if (ev.target.files[0]) upload(ev.target.files[0]); });
$("open-mesh").addEventListener("click", () => { if ($("meshes").value) openMesh($("meshes").value).catch(showError); });
$("demo").addEventListener("click", () => openMesh("m_demo_beam").catch(showError));
$("set-apply").addEventListener("click", () => {
  const s = state.sets[$("sets").value];
  if (s) assign(s);
});
$("clear-sel").addEventListener("click", () => { if (state.role && !state.sessionId) { state.role.fill(0); recolor(); } });
$("create").addEventListener("click", createSession);
$("apply-move").addEventListener("click", applyNumeric);
$("undo").addEventListener("click", undo);
$("reset").addEventListener("click", reset);
$("download").addEventListener("click", download);
$("fit").addEventListener("click", fit);
$("edges").addEventListener("change", () => { if (edges) edges.visible = $("edges").checked; });
for (const id of ["clip", "clip-axis", "clip-pos", "bad"]) $(id).addEventListener("input", refreshDerived);
for (const r of document.querySelectorAll("input[name=gizmo]")) {
  r.addEventListener("change", () => gizmo.setMode(document.querySelector("input[name=gizmo]:checked").value));
}
$("api-key").value = localStorage.getItem("tetmorph-api-key") || "";
$("api-key").addEventListener("change", () => { localStorage.setItem("tetmorph-api-key", $("api-key").value); listMeshes(); });
listMeshes();

/** Page coordinates of a point in normalized device coordinates. */
function toPage(v) {
  const rect = canvas.getBoundingClientRect();
  return { x: rect.left + (v.x + 1) / 2 * rect.width, y: rect.top + (1 - v.y) / 2 * rect.height };
}

// Automation hooks for the browser tests (read-only views of the state, plus where the
// gizmo is on screen so a test can drag it with the real mouse).
window.tetmorph = {
  state,
  pivotScreen: () => toPage(pivot.position.clone().project(camera)),
  screenOf: (i) => toPage(screenOf(i, new THREE.Vector3())),
  positions: () => Array.from(state.V),
};
