// A morph volume in the view: the box of a SPEC `lattice` entry, its l×m×n control points where the
// session's MOVE puts them (rest place plus displacement), the chosen one larger, and a translate gizmo
// on the chosen one. Dragging the gizmo sets that control point's displacement: `moved(d, done)` is
// called with it at every step of the drag (done false) and once when the drag ends (done true).
import * as THREE from "three";
import { TransformControls } from "three/addons/controls/TransformControls.js";
import { radio } from "./dom.js";

/** Rest place of control point (i, j, k) of a lattice {box: {min, max}, counts}. */
export function controlPoint(entry, i, j, k) {
  const { min, max } = entry.box, idx = [i, j, k];
  return [0, 1, 2].map((a) => {
    const n = entry.counts[a];
    const u = n > 1 ? idx[a] / (n - 1) : 0.5;
    return min[a] + u * (max[a] - min[a]);
  });
}

/** Every control point's key "i,j,k", x fastest. */
export function controlKeys(entry) {
  const [l, m, n] = entry.counts, out = [];
  for (let k = 0; k < n; k++) for (let j = 0; j < m; j++) for (let i = 0; i < l; i++) out.push(`${i},${j},${k}`);
  return out;
}

export class LatticeView {
  /**
   * @param {Viewer} viewer
   * @param {(d: number[], done: boolean) => void} moved the chosen control point's new displacement
   */
  constructor(viewer, moved) {
    this.viewer = viewer;
    this.moved = moved;
    this.entry = null;   // the lattice drawn (a SPEC entry)
    this.key = null;     // the chosen control point, "i,j,k"
    this.group = new THREE.Group();
    viewer.scene.add(this.group);
    this.target = new THREE.Object3D();
    viewer.scene.add(this.target);
    this.gizmo = new TransformControls(viewer.camera, viewer.canvas);
    this.gizmo.setSize(0.7);
    this.helper = this.gizmo.getHelper();
    this.helper.visible = false;
    viewer.scene.add(this.helper);
    this.gizmo.addEventListener("dragging-changed", (ev) => {
      viewer.orbit.enabled = !ev.value && radio("tool") === "orbit";
      if (!ev.value && this.dragged) { this.dragged = false; this.moved(this.displacement(), true); }
    });
    this.gizmo.addEventListener("objectChange", () => {
      if (!this.entry || !this.key) return;
      this.dragged = true;
      this.moved(this.displacement(), false);
    });
  }

  get dragging() { return this.gizmo.dragging; }

  /** True when a pointer event is over the gizmo (a press there drags the control point). */
  under(ev) {
    if (!this.helper.visible || !this.gizmo.object) return false;
    const rect = this.viewer.canvas.getBoundingClientRect();
    this.gizmo.pointerHover({ x: (ev.clientX - rect.left) / rect.width * 2 - 1,
      y: -(ev.clientY - rect.top) / rect.height * 2 + 1, button: ev.button });
    return this.gizmo.axis !== null;
  }

  /** The chosen control point's displacement: where the gizmo is less its rest place. */
  displacement() {
    const rest = controlPoint(this.entry, ...this.key.split(",").map(Number));
    return this.target.position.toArray().map((x, a) => x - rest[a]);
  }

  /**
   * Draw `entry` (null: nothing) with its displacements {key: [dx, dy, dz]}; the gizmo on control point
   * `key` when `movable` (the open session has the lattice), else none.
   */
  show(entry, displacements, key, movable) {
    for (const o of [...this.group.children]) { this.group.remove(o); o.geometry.dispose(); o.material.dispose(); }
    this.entry = entry;
    this.key = entry ? key : null;
    if (!entry) { this.gizmo.detach(); this.helper.visible = false; return; }
    const d = displacements || {};
    const keys = controlKeys(entry), at = new Float32Array(3 * keys.length);
    keys.forEach((kk, p) => {
      const r = controlPoint(entry, ...kk.split(",").map(Number)), dd = d[kk] || [0, 0, 0];
      for (let a = 0; a < 3; a++) at[3 * p + a] = r[a] + dd[a];
    });
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", new THREE.BufferAttribute(at, 3));
    const points = new THREE.Points(g, new THREE.PointsMaterial({ color: 0x6a3d9a, size: 7, sizeAttenuation: false,
      depthTest: false }));
    const { min, max } = entry.box;
    const box = new THREE.Box3(new THREE.Vector3(...min), new THREE.Vector3(...max));
    const edges = new THREE.Box3Helper(box, 0x6a3d9a);
    for (const o of [points, edges]) { o.renderOrder = 25; o.frustumCulled = false; this.group.add(o); }
    if (!this.key) { this.gizmo.detach(); this.helper.visible = false; return; }
    const r = controlPoint(entry, ...this.key.split(",").map(Number)), dd = d[this.key] || [0, 0, 0];
    if (!this.dragging) this.target.position.set(r[0] + dd[0], r[1] + dd[1], r[2] + dd[2]);
    const cg = new THREE.BufferGeometry();
    cg.setAttribute("position", new THREE.BufferAttribute(new Float32Array(this.target.position.toArray()), 3));
    const chosen = new THREE.Points(cg, new THREE.PointsMaterial({ color: 0xe8590c, size: 12, sizeAttenuation: false,
      depthTest: false }));
    chosen.renderOrder = 26;
    chosen.frustumCulled = false;
    this.group.add(chosen);
    if (movable) {
      if (this.gizmo.object !== this.target) this.gizmo.attach(this.target);
      this.helper.visible = true;
    } else {
      this.gizmo.detach();
      this.helper.visible = false;
    }
  }
}
