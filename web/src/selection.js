// Selecting the fixed and handle regions: a box through the mesh, a brush on the surface, or a
// named set of the file. The result is state.role (0 none, 1 fixed, 2 handle per vertex).
import * as THREE from "three";
import { $, radio } from "./dom.js";
import { emit, state } from "./state.js";

export class Selection {
  constructor(viewer, meshView, { onRefused }) {
    this.viewer = viewer;
    this.meshView = meshView;
    this.onRefused = onRefused;
    this.raycaster = new THREE.Raycaster();
    this.drag = null;
    const canvas = viewer.canvas;
    canvas.addEventListener("pointerdown", (ev) => this.down(ev));
    canvas.addEventListener("pointermove", (ev) => this.move(ev));
    canvas.addEventListener("pointerup", (ev) => this.up(ev));
    for (const r of document.querySelectorAll("input[name=tool]")) {
      r.addEventListener("change", () => { viewer.orbit.enabled = this.tool() === "orbit"; });
    }
  }

  tool() { return radio("tool"); }
  role() { return Number(radio("role")); }

  /** Give the current role to these vertices. */
  assign(ids) {
    if (state.sessionId) { this.onRefused("close the session (Reset → reopen the mesh) to change the selection"); return; }
    const r = this.role();
    for (const i of ids) state.role[i] = r;
    this.changed();
  }

  clear() {
    if (state.role && !state.sessionId) { state.role.fill(0); this.changed(); }
  }

  changed() {
    this.meshView.recolor();
    emit("selection");
  }

  counts() {
    let f = 0, h = 0;
    for (let i = 0; i < state.role.length; i++) { if (state.role[i] === 1) f++; else if (state.role[i] === 2) h++; }
    return { fixed: f, handle: h };
  }

  idsOfRole(r) {
    const out = [];
    for (let i = 0; i < state.role.length; i++) if (state.role[i] === r) out.push(i);
    return out;
  }

  screenOf(i, out) {
    out.set(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]).project(this.viewer.camera);
    return out;
  }

  boxSelect(x0, y0, x1, y1) {
    const rect = this.viewer.canvas.getBoundingClientRect();
    const ax = Math.min(x0, x1), bx = Math.max(x0, x1), ay = Math.min(y0, y1), by = Math.max(y0, y1);
    const v = new THREE.Vector3();
    const ids = [];
    for (let i = 0; i < state.boundary.length; i++) {
      if (!state.boundary[i]) continue;
      this.screenOf(i, v);
      if (v.z > 1) continue;
      const sx = (v.x + 1) / 2 * rect.width, sy = (1 - v.y) / 2 * rect.height;
      if (sx >= ax && sx <= bx && sy >= ay && sy <= by) ids.push(i);
    }
    this.assign(ids);
  }

  brushAt(clientX, clientY) {
    const rect = this.viewer.canvas.getBoundingClientRect();
    const p = new THREE.Vector2((clientX - rect.left) / rect.width * 2 - 1, -(clientY - rect.top) / rect.height * 2 + 1);
    this.raycaster.setFromCamera(p, this.viewer.camera);
    const hit = this.raycaster.intersectObject(this.meshView.surface, false)[0];
    if (!hit) return;
    const r = Number($("brush").value) / 100 * state.diag;
    const ids = [];
    for (let i = 0; i < state.boundary.length; i++) {
      if (!state.boundary[i]) continue;
      const dx = state.V[3 * i] - hit.point.x, dy = state.V[3 * i + 1] - hit.point.y, dz = state.V[3 * i + 2] - hit.point.z;
      if (dx * dx + dy * dy + dz * dz <= r * r) ids.push(i);
    }
    this.assign(ids);
  }

  down(ev) {
    const tool = this.tool();
    if (tool === "orbit" || ev.button !== 0 || !state.V || this.busy()) return;
    this.drag = { x: ev.offsetX, y: ev.offsetY };
    this.viewer.canvas.setPointerCapture(ev.pointerId);
    if (tool === "brush") this.brushAt(ev.clientX, ev.clientY);
  }

  move(ev) {
    if (!this.drag) return;
    if (this.tool() === "box") {
      const b = $("boxsel"), d = this.drag;
      b.style.display = "block";
      b.style.left = `${Math.min(d.x, ev.offsetX)}px`; b.style.top = `${Math.min(d.y, ev.offsetY)}px`;
      b.style.width = `${Math.abs(ev.offsetX - d.x)}px`; b.style.height = `${Math.abs(ev.offsetY - d.y)}px`;
    } else {
      this.brushAt(ev.clientX, ev.clientY);
    }
  }

  up(ev) {
    if (!this.drag) return;
    if (this.tool() === "box") this.boxSelect(this.drag.x, this.drag.y, ev.offsetX, ev.offsetY);
    $("boxsel").style.display = "none";
    this.drag = null;
  }

  /** Set by the wiring: true while the gizmo is being dragged. */
  busy() { return false; }
}
