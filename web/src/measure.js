// Picking and measuring nodes: with the "pick" tool, hovering the model shows the node under the
// pointer (its vertex index, the deck's own node number when the file has them, and its coordinates
// in the current shape) and a click picks it. One picked node reads out its coordinates, two their
// distance and its components, three also the angle at the middle one; a fourth click starts
// again, Shift+click replaces the last one, Esc clears.
// Picked nodes are marked in the view and joined by a line, and follow the mesh as it moves.
import * as THREE from "three";
import { $, radio } from "./dom.js";
import { fmt, unitText } from "./panels.js";
import { state } from "./state.js";

export class Measure {
  constructor(viewer, regions) {
    this.viewer = viewer;
    this.regions = regions;
    this.picks = [];
    this.changed = () => {};  // set by the wiring: the picked nodes changed
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(9), 3));
    this.markers = new THREE.Points(g, new THREE.PointsMaterial({ color: 0xe8590c, size: 9, sizeAttenuation: false,
      depthTest: false }));
    this.line = new THREE.Line(g, new THREE.LineBasicMaterial({ color: 0xe8590c, depthTest: false }));
    for (const o of [this.markers, this.line]) { o.renderOrder = 30; o.visible = false; o.frustumCulled = false; }
    viewer.scene.add(this.markers, this.line);
    viewer.beforeRender.push(() => this.follow());
    const canvas = viewer.canvas;
    canvas.addEventListener("pointerdown", (ev) => {
      if (radio("tool") !== "pick" || ev.button !== 0 || !state.V) return;
      const i = this.nodeAt(ev.clientX, ev.clientY);
      if (i !== null) this.pick(i, ev.shiftKey);
    });
    canvas.addEventListener("pointermove", (ev) => this.hover(ev));
    canvas.addEventListener("pointerleave", () => { $("pick-tip").hidden = true; });
    $("measure-clear").addEventListener("click", () => this.clear());
  }

  /**
   * The vertex under the pointer: the corner of the surface triangle hit that is nearest the hit
   * point; when the ray passes between triangles (exactly through a node), the surface node drawn
   * nearest the pointer within 8 px, the one nearest the camera on the same pixel.
   */
  nodeAt(clientX, clientY) {
    const hit = this.regions.pick(clientX, clientY);
    if (!hit || !hit.face) return this.nodeNear(clientX, clientY, 8);
    let best = null, bestD = Infinity;
    for (const i of [hit.face.a, hit.face.b, hit.face.c]) {
      const d = Math.hypot(state.V[3 * i] - hit.point.x, state.V[3 * i + 1] - hit.point.y, state.V[3 * i + 2] - hit.point.z);
      if (d < bestD) { bestD = d; best = i; }
    }
    return best;
  }

  nodeNear(clientX, clientY, px) {
    const rect = this.viewer.canvas.getBoundingClientRect(), cam = this.viewer.camera, v = new THREE.Vector3();
    const x = clientX - rect.left, y = clientY - rect.top, near = [];
    for (let i = 0; i < state.boundary.length; i++) {
      if (!state.boundary[i]) continue;
      v.set(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]).project(cam);
      if (v.z < -1 || v.z > 1) continue;
      const d = Math.hypot((v.x + 1) / 2 * rect.width - x, (1 - v.y) / 2 * rect.height - y);
      if (d < px) near.push([d, v.z, i]);
    }
    if (!near.length) return null;
    const dmin = Math.min(...near.map((n) => n[0]));
    return near.filter((n) => n[0] <= dmin + 1).sort((a, b) => a[1] - b[1])[0][2];
  }

  hover(ev) {
    const tip = $("pick-tip");
    if (radio("tool") !== "pick" || !state.V) { tip.hidden = true; return; }
    const i = this.nodeAt(ev.clientX, ev.clientY);
    if (i === null) { tip.hidden = true; return; }
    tip.textContent = `${this.name(i)} · ${this.coords(i)}`;
    tip.dataset.vertex = String(i);
    const rect = this.viewer.canvas.getBoundingClientRect();
    tip.style.left = `${ev.clientX - rect.left + 14}px`;
    tip.style.top = `${ev.clientY - rect.top + 14}px`;
    tip.hidden = false;
  }

  /** The vertex's 0-based id, and the deck's own node number when the file has them. */
  name(i) { return state.labels ? `vertex ${i} (node ${state.labels[i]})` : `vertex ${i}`; }

  coords(i) {
    return `(${[0, 1, 2].map((k) => fmt(Number(state.V[3 * i + k].toPrecision(6)))).join(", ")})${unitText()}`;
  }

  pick(i, replaceLast = false) {
    if (replaceLast && this.picks.length) this.picks[this.picks.length - 1] = i;
    else if (this.picks.length >= 3) this.picks = [i];
    else this.picks.push(i);
    this.show();
    this.changed();
  }

  clear() { this.picks = []; this.show(); this.changed(); }

  /** A new mesh: nothing picked. */
  reset() { this.clear(); }

  point(i) { return new THREE.Vector3(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]); }

  /** Distance, components and angle of the picked nodes in the current shape. */
  values() {
    const p = this.picks.map((i) => this.point(i)), out = { vertices: this.picks.slice() };
    if (p.length >= 2) {
      const d = p[1].clone().sub(p[0]);
      out.distance = d.length();
      out.delta = d.toArray();
    }
    if (p.length === 3) {
      const a = p[0].clone().sub(p[1]), b = p[2].clone().sub(p[1]);
      out.angle = a.lengthSq() && b.lengthSq() ? THREE.MathUtils.radToDeg(a.angleTo(b)) : null;
      out.distance2 = b.length();
    }
    return out;
  }

  show() {
    const el = $("measure"), v = this.values(), u = unitText(), rows = [];
    this.picks.forEach((i, k) => rows.push(`<div data-key="node${k}">${"ABC"[k]} · ${this.name(i)} ${this.coords(i)}</div>`));
    if (v.distance !== undefined) {
      rows.push(`<div data-key="distance"><b>|AB| ${fmt(Number(v.distance.toPrecision(6)))}${u}</b></div>`,
        `<div class="muted" data-key="delta">Δ ${v.delta.map((x) => fmt(Number(x.toPrecision(6)))).join(", ")}${u}</div>`);
    }
    if (v.distance2 !== undefined) rows.push(`<div data-key="distance2">|BC| ${fmt(Number(v.distance2.toPrecision(6)))}${u}</div>`);
    if (v.angle !== undefined && v.angle !== null) rows.push(`<div data-key="angle"><b>angle ABC ${v.angle.toFixed(3)}°</b></div>`);
    el.innerHTML = rows.length ? rows.join("") : '<span class="muted">pick nodes with the pick tool: one for its ' +
      "coordinates, two for a distance, three for an angle</span>";
    this.markers.visible = this.line.visible = this.picks.length > 0;
    this.line.visible = this.picks.length > 1;
    this.follow();
  }

  /** Keep the marks on their nodes as the mesh moves. */
  follow() {
    if (!this.picks.length || !state.V) return;
    const g = this.markers.geometry, pos = g.getAttribute("position");
    this.picks.forEach((i, k) => pos.setXYZ(k, state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]));
    pos.needsUpdate = true;
    g.setDrawRange(0, this.picks.length);
  }
}
