// Mirror symmetry set-up: planes across which the morph keeps the mesh symmetric (SPEC.symmetry),
// typed as a point and a normal, or taken from the section plane of the view, each drawn in the
// view as a translucent square through the model. They go into the SPEC Create session sends and
// come back from a session's SPEC when it is reopened.
import * as THREE from "three";
import { $ } from "./dom.js";
import { fmt } from "./panels.js";
import { state } from "./state.js";

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

export class SymmetryPanel {
  constructor(viewer, meshView, regions) {
    this.viewer = viewer;
    this.meshView = meshView;
    this.regions = regions;
    this.group = new THREE.Group();
    viewer.scene.add(this.group);
    this.material = new THREE.MeshBasicMaterial({ color: 0x7b2cbf, transparent: true, opacity: 0.18,
      side: THREE.DoubleSide, depthWrite: false });
    $("sym-add").addEventListener("click", () => this.addTyped());
    $("sym-from-section").addEventListener("click", () => this.addFromSection());
    $("sym-list").addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-k]");
      if (b) this.remove(Number(b.dataset.k));
    });
  }

  /** The SPEC's mirror planes (kept with the regions' SPEC extras). */
  list() { return this.regions.specExtra.symmetry || []; }

  set(list) {
    if (list.length) this.regions.specExtra.symmetry = list; else delete this.regions.specExtra.symmetry;
    this.render();
  }

  add(point, normal) {
    const len = Math.hypot(...normal);
    if (!state.V) return "open a mesh first";
    if (!(len > 0) || point.length !== 3 || ![...point, ...normal].every(Number.isFinite))
      return "a mirror plane needs a point and a normal: three numbers each";
    const names = new Set(this.list().map((s) => s.name));
    let k = this.list().length + 1;
    while (names.has(`mirror${k}`)) k++;
    const entry = { name: `mirror${k}`, plane: { point, normal: normal.map((x) => x / len) } };
    const tol = $("sym-tol").value.trim();
    if (tol !== "" && Number(tol) >= 0) entry.tolerance = Number(tol);
    this.set([...this.list(), entry]);
    return null;
  }

  addTyped() {
    const nums = (id) => $(id).value.trim().split(/[\s,;]+/).map(Number);
    return this.add(nums("sym-point"), nums("sym-normal"));
  }

  /** The section plane of the view (clip on) as a mirror plane: its normal, through the model's centre. */
  addFromSection() {
    if (!this.meshView.options.clip) return this.fail("turn the section plane on (clip) first");
    const pl = this.meshView.clipPlane, n = pl.normal.clone().negate();
    const c = this.meshView.box().getCenter(new THREE.Vector3());
    const p = c.clone().addScaledVector(n, pl.constant - n.dot(c));
    return this.fail(this.add(p.toArray().map((x) => Number(x.toPrecision(12))), n.toArray()));
  }

  fail(msg) { if (msg) $("sym-note").textContent = msg; else $("sym-note").textContent = ""; return msg; }

  remove(k) { this.set(this.list().filter((_, i) => i !== k)); }

  /** The list in the panel and the planes in the view. */
  render() {
    const list = this.list();
    $("sym-list").innerHTML = list.map((s, k) => `<li data-name="${esc(s.name)}"><span class="name">${esc(s.name)}: ` +
      `n (${s.plane.normal.map((x) => fmt(Number(x.toFixed(4)))).join(", ")}) through ` +
      `(${s.plane.point.map((x) => fmt(Number(x.toPrecision(6)))).join(", ")})</span>` +
      `<button data-k="${k}" title="remove the plane">×</button></li>`).join("");
    for (const m of [...this.group.children]) { this.group.remove(m); m.geometry.dispose(); }
    if (!state.V) return;
    const size = 1.2 * state.diag;
    for (const s of list) {
      const m = new THREE.Mesh(new THREE.PlaneGeometry(size, size), this.material);
      m.position.set(...s.plane.point);
      m.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), new THREE.Vector3(...s.plane.normal).normalize());
      m.renderOrder = 4;
      this.group.add(m);
    }
  }
}
