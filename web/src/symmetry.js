// Mirror symmetry set-up: planes across which the morph keeps the mesh symmetric (SPEC.symmetry),
// typed as a point and a normal, taken from the section plane of the view, or picked from the
// planes the service finds in the open mesh (GET /v1/meshes/{id}/symmetry, as `tetmorph info`
// lists them), each drawn in the view as a translucent square through the model. The cyclic panel
// offers the deck's own sector definitions the same way. They go into the SPEC Create session
// sends and come back from a session's SPEC when it is reopened.
import * as THREE from "three";
import { api, getAll, getJson } from "./api.js";
import { decodeBundle } from "./binary.js";
import { $ } from "./dom.js";
import { fmt } from "./panels.js";
import { on, state } from "./state.js";

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
const vec = (a, digits) => a.map((x) => fmt(Number(digits ? x.toPrecision(digits) : x.toFixed(4)))).join(", ");
const close = (a, b) => a.length === b.length && a.every((x, i) => Math.abs(x - b[i]) <= 1e-9 * Math.max(1, Math.abs(x)));

const NONE = Object.freeze({ planes: [], cyclic: [] });
let found = { id: null, doc: Promise.resolve(NONE) };

/** What the service finds in the open mesh: {planes, cyclic} (read once per mesh; none for a surface). */
function symmetryOf() {
  const id = state.meshId;
  if (!id || state.surface) return Promise.resolve(NONE);
  if (found.id !== id) found = { id, doc: getJson(`/v1/meshes/${id}/symmetry`).catch(() => NONE) };
  return found.doc;
}

/**
 * A list of offers under a panel: each item drawn in the view while the pointer (or the keyboard
 * focus) is on it (`draw` makes its three.js object), added by its button (`pick`), and shown as
 * added once `taken` says so. Its hint (`LISTID-hint`) shows only when there is something to offer.
 */
class Offers {
  constructor(viewer, listId, key, { label, draw, pick, taken }) {
    Object.assign(this, { viewer, listId, key, label, draw, pick, taken });
    this.items = [];
    this.preview = new THREE.Group();
    viewer.scene.add(this.preview);
    const el = $(listId);
    el.addEventListener("pointerover", (ev) => this.show(ev.target.closest("li[data-k]")));
    el.addEventListener("pointerleave", () => this.show(null));
    el.addEventListener("focusin", (ev) => this.show(ev.target.closest("li[data-k]")));  // Tab onto its button
    el.addEventListener("focusout", () => this.show(null));
    el.addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-k]");
      if (b && !b.disabled) this.pick(this.items[Number(b.dataset.k)]);
    });
    on("mesh", () => this.load());
  }

  async load() {
    const id = state.meshId;
    this.items = [];
    this.render();
    const doc = await symmetryOf();
    if (id !== state.meshId) return;  // another mesh was opened meanwhile
    this.items = doc[this.key] || [];
    this.render();
  }

  show(li) {
    const k = li ? Number(li.dataset.k) : null;
    if (k === this.shown) return;
    this.shown = k;
    for (const m of [...this.preview.children]) { this.preview.remove(m); m.geometry.dispose(); }
    if (k !== null && this.items[k] && state.V) this.preview.add(this.draw(this.items[k]));
  }

  render() {
    this.show(null);
    $(`${this.listId}-hint`).hidden = !this.items.length;
    $(this.listId).innerHTML = this.items.map((o, k) => {
      const done = this.taken(o);
      return `<li data-k="${k}"><span class="name" title="drawn in the view while the pointer is here">${esc(this.label(o))}</span>` +
        `<button data-k="${k}"${done ? " disabled" : ""}>${done ? "added" : "Add"}</button></li>`;
    }).join("");
  }
}

/** A mirror plane as a translucent square through the model. */
function planeMesh(plane, material) {
  const size = 1.2 * state.diag, m = new THREE.Mesh(new THREE.PlaneGeometry(size, size), material);
  m.position.set(...plane.point);
  m.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), new THREE.Vector3(...plane.normal).normalize());
  m.renderOrder = 4;
  return m;
}

/** An axis as a line through the model. */
function axisLine(axis, material) {
  const p = new THREE.Vector3(...axis.point), d = new THREE.Vector3(...axis.direction).normalize();
  const h = 0.75 * state.diag, g = new THREE.BufferGeometry().setFromPoints([p.clone().addScaledVector(d, -h), p.clone().addScaledVector(d, h)]);
  const line = new THREE.Line(g, material);
  line.renderOrder = 25;
  return line;
}

/**
 * Cyclic symmetry set-up (SPEC.cyclic): face B of the sector is face A turned by the angle about
 * the axis. The faces are named sets of the file, sent as selections of their own; the axis is
 * drawn through the model.
 */
export class CyclicPanel {
  constructor(viewer, regions) {
    this.viewer = viewer;
    this.regions = regions;
    this.group = new THREE.Group();
    viewer.scene.add(this.group);
    this.material = new THREE.LineBasicMaterial({ color: 0x7b2cbf, depthTest: false });
    this.added = new Set();  // face selections this panel put into the SPEC
    $("cyc-add").addEventListener("click", () => this.add());
    const hover = new THREE.LineBasicMaterial({ color: 0xe07a10, depthTest: false });
    this.offers = new Offers(viewer, "cyc-offers", "cyclic", {
      label: (c) => `${c.name}: ${c.faces[0]} → ${c.faces[1]} by ${fmt(c.angle_deg)}° about (${vec(c.axis.direction)})`,
      draw: (c) => axisLine(c.axis, hover),
      pick: (c) => this.fill(c),
      taken: (c) => this.list().some((x) => x.faces[0] === c.faces[0] && x.faces[1] === c.faces[1] &&
        Math.abs(x.angle_deg - c.angle_deg) < 1e-9 && close(x.axis.point, c.axis.point) && close(x.axis.direction, c.axis.direction)),
    });
    $("cyc-list").addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-k]");
      if (b) this.remove(Number(b.dataset.k));
    });
  }

  list() { return this.regions.specExtra.cyclic || []; }

  /** The named sets offered as faces A and B. */
  offerSets() {
    const opts = '<option value="">— set —</option>' + Object.keys(state.sets || {}).map((n) => `<option>${esc(n)}</option>`).join("");
    for (const id of ["cyc-a", "cyc-b"]) { const el = $(id), cur = el.value; el.innerHTML = opts; el.value = cur; }
  }

  /** An offered definition in the panel's fields, then added (under the deck's name when it is free). */
  fill(c) {
    this.offerSets();
    $("cyc-point").value = c.axis.point.join(" ");
    $("cyc-dir").value = c.axis.direction.join(" ");
    $("cyc-angle").value = String(c.angle_deg);
    $("cyc-a").value = c.faces[0];
    $("cyc-b").value = c.faces[1];
    $("cyc-tol").value = c.tolerance === undefined || c.tolerance === null ? "" : String(c.tolerance);
    this.add(c.name);
  }

  add(wanted = null) {
    const nums = (id) => $(id).value.trim().split(/[\s,;]+/).map(Number);
    const point = nums("cyc-point"), dir = nums("cyc-dir"), angle = Number($("cyc-angle").value);
    const a = $("cyc-a").value, b = $("cyc-b").value, note = $("cyc-note");
    const len = Math.hypot(...dir);
    if (!state.V) { note.textContent = "open a mesh first"; return; }
    if (point.length !== 3 || dir.length !== 3 || ![...point, ...dir].every(Number.isFinite) || !(len > 0)) {
      note.textContent = "the axis needs a point and a direction: three numbers each"; return;
    }
    if (!(Math.abs(angle) > 0 && Math.abs(angle) < 360)) { note.textContent = "the sector angle is between 0 and 360°"; return; }
    if (!a || !b || a === b) { note.textContent = "choose two different named sets, face A and face B"; return; }
    note.textContent = "";
    const names = new Set(this.list().map((c) => c.name));
    let k = this.list().length + 1;
    while (names.has(`cyclic${k}`)) k++;
    const name = wanted && !names.has(wanted) ? wanted : `cyclic${k}`;
    const entry = { name, axis: { point, direction: dir.map((x) => x / len) }, angle_deg: angle, faces: [a, b] };
    const tol = $("cyc-tol").value.trim();
    if (tol !== "" && Number(tol) >= 0) entry.tolerance = Number(tol);
    for (const f of [a, b]) {
      if (state.regions.some((r) => r.name === f) || this.regions.extraSelections[f]) continue;
      this.regions.extraSelections[f] = { set: f };
      this.added.add(f);
    }
    this.regions.specExtra.cyclic = [...this.list(), entry];
    this.render();
  }

  remove(k) {
    const list = this.list().filter((_, i) => i !== k);
    if (list.length) this.regions.specExtra.cyclic = list; else delete this.regions.specExtra.cyclic;
    const used = new Set(list.flatMap((c) => c.faces));
    for (const n of [...this.added]) if (!used.has(n)) { delete this.regions.extraSelections[n]; this.added.delete(n); }
    this.render();
  }

  render() {
    this.offerSets();
    $("cyc-list").innerHTML = this.list().map((c, k) => `<li data-name="${esc(c.name)}"><span class="name">${esc(c.name)}: ` +
      `${esc(c.faces[0])} → ${esc(c.faces[1])} by ${fmt(c.angle_deg)}° about (${vec(c.axis.direction)})` +
      `</span><button data-k="${k}" title="remove">×</button></li>`).join("");
    this.offers.render();
    for (const m of [...this.group.children]) { this.group.remove(m); m.geometry.dispose(); }
    if (!state.V) return;
    for (const c of this.list()) this.group.add(axisLine(c.axis, this.material));
  }
}

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
    const hover = new THREE.MeshBasicMaterial({ color: 0xe07a10, transparent: true, opacity: 0.3,
      side: THREE.DoubleSide, depthWrite: false });
    this.offers = new Offers(viewer, "sym-offers", "planes", {
      label: (o) => `n (${vec(o.plane.normal)}) through (${vec(o.plane.point, 6)}) · ${fmt(Number((100 * o.matched).toFixed(1)))}% of the boundary`,
      draw: (o) => planeMesh(o.plane, hover),
      pick: (o) => this.fail(this.add(o.plane.point, o.plane.normal, String(o.tolerance))),
      taken: (o) => this.list().some((s) => close(s.plane.point, o.plane.point) && close(s.plane.normal, o.plane.normal)),
    });
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

  add(point, normal, tol = $("sym-tol").value.trim()) {
    const len = Math.hypot(...normal);
    if (!state.V) return "open a mesh first";
    if (!(len > 0) || point.length !== 3 || ![...point, ...normal].every(Number.isFinite))
      return "a mirror plane needs a point and a normal: three numbers each";
    const names = new Set(this.list().map((s) => s.name));
    let k = this.list().length + 1;
    while (names.has(`mirror${k}`)) k++;
    const entry = { name: `mirror${k}`, plane: { point, normal: normal.map((x) => x / len) } };
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
      `n (${vec(s.plane.normal)}) through (${vec(s.plane.point, 6)})</span>` +
      `<button data-k="${k}" title="remove the plane">×</button></li>`).join("");
    this.offers.render();
    for (const m of [...this.group.children]) { this.group.remove(m); m.geometry.dispose(); }
    if (!state.V) return;
    for (const s of list) this.group.add(planeMesh(s.plane, this.material));
  }
}

/**
 * Target surfaces (SPEC.targets): the boundary nodes of a named set land on a triangle surface
 * stored on the service (uploaded as a mesh of no elements), named by its id. Each surface is
 * drawn in the view, read from the service's geometry of that mesh.
 */
export class TargetPanel {
  constructor(viewer, regions) {
    this.viewer = viewer;
    this.regions = regions;
    this.group = new THREE.Group();
    viewer.scene.add(this.group);
    this.material = new THREE.MeshBasicMaterial({ color: 0xe07a10, transparent: true, opacity: 0.35,
      side: THREE.DoubleSide, depthWrite: false });
    this.geometries = new Map();  // mesh id -> THREE.BufferGeometry (or a Promise of it)
    this.added = new Set();       // selections this panel put into the SPEC
    this.surfaces = [];           // the stored surfaces: [{id, name}]
    $("tgt-add").addEventListener("click", () => this.add());
    $("sec-symmetry").addEventListener("toggle", () => { if ($("sec-symmetry").open) this.offerSurfaces(); });
    $("tgt-list").addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-k]");
      if (b) this.remove(Number(b.dataset.k));
    });
  }

  list() { return this.regions.specExtra.targets || []; }

  /** The stored meshes that are surfaces (no volume elements), offered as targets. */
  async offerSurfaces() {
    try {
      const meshes = await getAll("/v1/meshes");
      this.surfaces = meshes.filter((m) => m.info && m.info.elements === 0).map((m) => ({ id: m.id, name: m.name || m.id }));
    } catch { this.surfaces = []; }
    const el = $("tgt-surface"), cur = el.value;
    el.innerHTML = '<option value="">— stored surface —</option>' +
      this.surfaces.map((m) => `<option value="${esc(m.id)}">${esc(m.name)} (${esc(m.id)})</option>`).join("");
    if ([...el.options].some((o) => o.value === cur)) el.value = cur;
  }

  offerSets() {
    const el = $("tgt-set"), cur = el.value;
    el.innerHTML = '<option value="">— set —</option>' + Object.keys(state.sets || {}).map((n) => `<option>${esc(n)}</option>`).join("");
    el.value = cur;
  }

  add() {
    const set = $("tgt-set").value, mesh = $("tgt-surface").value, note = $("tgt-note");
    if (!state.V) { note.textContent = "open a mesh first"; return; }
    if (!set || !mesh) { note.textContent = "choose a named set and a stored surface (upload one first)"; return; }
    note.textContent = "";
    const names = new Set(this.list().map((t) => t.name));
    let k = this.list().length + 1;
    while (names.has(`target${k}`)) k++;
    if (!state.regions.some((r) => r.name === set) && !this.regions.extraSelections[set]) {
      this.regions.extraSelections[set] = { set };
      this.added.add(set);
    }
    const entry = { name: `target${k}`, selection: set, surface: { mesh_id: mesh }, method: $("tgt-method").value };
    this.regions.specExtra.targets = [...this.list(), entry];
    this.render();
  }

  remove(k) {
    const list = this.list().filter((_, i) => i !== k);
    if (list.length) this.regions.specExtra.targets = list; else delete this.regions.specExtra.targets;
    const used = new Set(list.map((t) => t.selection));
    for (const n of [...this.added]) if (!used.has(n)) { delete this.regions.extraSelections[n]; this.added.delete(n); }
    this.render();
  }

  /** The geometry of a stored surface, read once. */
  geometry(id) {
    if (!this.geometries.has(id)) {
      this.geometries.set(id, (async () => {
        const r = await api(`/v1/meshes/${id}/geometry`);
        const { arrays } = decodeBundle(await r.arrayBuffer());
        const g = new THREE.BufferGeometry();
        g.setAttribute("position", new THREE.BufferAttribute(Float32Array.from(arrays.V), 3));
        g.setIndex(new THREE.BufferAttribute(Uint32Array.from(arrays.F), 1));
        return g;
      })().catch(() => { this.geometries.delete(id); return null; }));
    }
    return this.geometries.get(id);
  }

  /** The list in the panel and the surfaces in the view. */
  async render() {
    this.offerSets();
    const list = this.list();
    $("tgt-list").innerHTML = list.map((t, k) => `<li data-name="${esc(t.name)}"><span class="name">${esc(t.name)}: ` +
      `${esc(t.selection)} → ${esc(t.surface && t.surface.mesh_id ? t.surface.mesh_id : "inline surface")} (${esc(t.method || "closest")})` +
      `</span><button data-k="${k}" title="remove the target">×</button></li>`).join("");
    const ids = [...new Set(list.map((t) => t.surface && t.surface.mesh_id).filter(Boolean))];
    const token = (this.renders = (this.renders || 0) + 1);
    const geoms = await Promise.all(ids.map((id) => this.geometry(id)));
    if (token !== this.renders) return;  // rendered again meanwhile: the later render draws
    this.group.clear();  // the geometries are kept (read once per surface)
    for (const g of geoms) {
      if (!g) continue;
      const m = new THREE.Mesh(g, this.material);
      m.renderOrder = 5;
      this.group.add(m);
    }
    this.viewer.draw();
  }
}
