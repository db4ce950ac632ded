// Regions: any number of named fixed and handle regions, each a set of vertices (a vertex is
// in one region at most), with a colour, a visibility and a count. They are filled with a box
// (through the mesh, or the front surface only), a brush on the surface, a named set of the
// file, or a feature candidate; Shift adds, Ctrl subtracts. The same tools paint the morph
// domain (SPEC.domain): the part of the mesh the morph may move, every node outside it held at
// rest; a vertex may be in the domain and in a region. The domain is a volume: a box through the
// mesh or the brush's ball takes the inner nodes in it as well. The SPEC the session is created from is
// written from them, and a SPEC can be read back into them.
import * as THREE from "three";
import { $, radio } from "./dom.js";
import { claim, emit, state } from "./state.js";

// the owner of the state's "selection" group: the regions and each vertex's role
const own = claim("selection");

/**
 * Region colours by kind: for fixed regions blue, dark red, violet and navy, told apart at a glance (at
 * least 34 CIELAB units from each other, 49 from every handle colour); for handles green, olive, teal and
 * pink. All are 33 units or more from the poor-tet magenta, and the fixed ones 45 from the preview orange.
 */
export const PALETTE = {
  fixed: [[0.16, 0.4, 0.85], [0.6, 0.1, 0.1], [0.5, 0.22, 0.78], [0.08, 0.18, 0.42]],
  handle: [[0.12, 0.6, 0.28], [0.45, 0.5, 0.1], [0.0, 0.58, 0.58], [0.84, 0.24, 0.55]],
};
/** The morph domain's tint, on the vertices of it that are in no region. */
export const DOMAIN_COLOR = [0.93, 0.8, 0.5];
const KINDS = { 1: "fixed", 2: "handle", 3: "domain" };
const DOMAIN_ROLE = 3;
const NAME_OK = /^[A-Za-z0-9_.:=-]{1,64}$/;

export class Regions {
  constructor(viewer, meshView) {
    this.viewer = viewer;
    this.meshView = meshView;
    this.nextId = 1;
    this.raycaster = new THREE.Raycaster();
    this.drag = null;
    this.reset();
    meshView.regionColor = (i) => {
      const r = this.owner ? this.byId.get(this.owner[i]) : null;
      if (r && r.visible) return r.color;
      return this.domain && this.domain[i] ? DOMAIN_COLOR : null;
    };
    // brush cursor preview: a ring on the surface under the pointer
    this.ring = new THREE.Mesh(new THREE.RingGeometry(0.93, 1, 64),
      new THREE.MeshBasicMaterial({ color: 0xd35400, transparent: true, opacity: 0.9, depthTest: false,
        side: THREE.DoubleSide }));
    this.ring.renderOrder = 20;
    this.ring.visible = false;
    viewer.scene.add(this.ring);
    const canvas = viewer.canvas;
    canvas.addEventListener("pointerdown", (ev) => this.down(ev));
    canvas.addEventListener("pointermove", (ev) => this.move(ev));
    canvas.addEventListener("pointerup", (ev) => this.up(ev));
    canvas.addEventListener("pointerleave", () => { this.ring.visible = false; });
    for (const r of document.querySelectorAll("input[name=tool]")) r.addEventListener("change", () => this.toolChanged());
    for (const r of document.querySelectorAll("input[name=role]")) r.addEventListener("change", () => this.roleChanged());
  }

  /** Forget every region (a new mesh). */
  reset() {
    own.regions = [];
    this.byId = new Map();
    this.owner = state.V ? new Int32Array(state.V.length / 3) : null;
    own.role = state.V ? new Uint8Array(state.V.length / 3) : null;
    own.activeRegion = null;
    this.domain = state.V ? new Uint8Array(state.V.length / 3) : null;  // 1: in the morph domain
    this.domainSource = null;  // {set} while the domain is exactly a named set
    this.specExtra = {};
    this.extraSelections = {};
    if (this.history) this.history.clear();  // regions.js: a new mesh starts a new region history
    emit("selection");
  }

  /** The regions as they are (membership, names, colours, the domain): what region undo restores. */
  snapshot() {
    return { owner: this.owner ? this.owner.slice() : null, domain: this.domain ? this.domain.slice() : null,
      regions: state.regions.map((r) => ({ ...r })), active: state.activeRegion, nextId: this.nextId,
      domainSource: this.domainSource };
  }

  /** Put back a snapshot() of this mesh. */
  restore(snap) {
    if (!this.owner || !snap.owner || snap.owner.length !== this.owner.length) return;
    this.owner.set(snap.owner);
    if (this.domain && snap.domain) this.domain.set(snap.domain);
    own.regions = snap.regions.map((r) => ({ ...r }));
    this.byId = new Map(own.regions.map((r) => [r.id, r]));
    for (let i = 0; i < this.owner.length; i++) {
      const r = this.byId.get(this.owner[i]);
      own.role[i] = r ? (r.kind === "fixed" ? 1 : 2) : 0;
    }
    own.activeRegion = snap.active;
    this.nextId = snap.nextId;
    this.domainSource = snap.domainSource;
    this.changed();
  }

  // ---------------------------------------------------------------- the regions
  tool() { return radio("tool"); }
  role() { return Number(radio("role")); }

  /** A name the SPEC can use: letters, digits and _ . : = - only. */
  static clean(base) { return String(base).replace(/[^A-Za-z0-9_.:=-]/g, "_").slice(0, 60) || "region"; }

  uniqueName(base) {
    const names = new Set(state.regions.map((r) => r.name));
    const name = Regions.clean(base);
    if (!names.has(name)) return name;
    for (let k = 2; ; k++) if (!names.has(`${name}_${k}`)) return `${name}_${k}`;
  }

  add(kind, name) {
    const same = state.regions.filter((r) => r.kind === kind).length;
    const used = new Set(state.regions.map((r) => r.color));
    const pal = PALETTE[kind];
    const color = pal.find((c) => !used.has(c)) || pal[same % pal.length];
    const r = { id: this.nextId++, name: this.uniqueName(name || `${kind}${same + 1}`), kind, color, visible: true,
      count: 0, source: null };
    own.regions.push(r);
    this.byId.set(r.id, r);
    this.activate(r.id);
    return r;
  }

  get active() { return this.byId.get(state.activeRegion) || null; }

  activate(id) {
    const r = this.byId.get(id);
    if (!r) return;
    own.activeRegion = id;
    const radioEl = document.querySelector(`input[name=role][value='${r.kind === "fixed" ? 1 : 2}']`);
    if (radioEl) radioEl.checked = true;
    emit("regions");
  }

  /** The region new selections of this kind go into: the active one if of that kind, else the last one, else a new one. */
  target(kind) {
    const a = this.active;
    if (a && a.kind === kind) return a;
    const last = [...state.regions].reverse().find((r) => r.kind === kind);
    if (last) { this.activate(last.id); return last; }
    return this.add(kind);
  }

  remove(id) {
    const r = this.byId.get(id);
    if (!r) return;
    for (let i = 0; i < this.owner.length; i++) if (this.owner[i] === id) { this.owner[i] = 0; own.role[i] = 0; }
    own.regions = own.regions.filter((x) => x.id !== id);
    this.byId.delete(id);
    if (own.activeRegion === id) own.activeRegion = own.regions.length ? own.regions[own.regions.length - 1].id : null;
    this.changed();
  }

  rename(id, name) {
    const r = this.byId.get(id);
    if (!r || !NAME_OK.test(name) || state.regions.some((x) => x !== r && x.name === name)) return false;
    r.name = name;
    this.changed();
    return true;
  }

  setVisible(id, visible) {
    const r = this.byId.get(id);
    if (r) { r.visible = visible; this.changed(); }
  }

  /**
   * Change region membership. mode "add" (the ids join `region`, leaving any other region),
   * "subtract" (they leave `region`), "replace" (`region` becomes exactly these ids), or
   * "erase" (they leave every region; `region` unused).
   */
  apply(ids, mode, region) {
    const owner = this.owner, role = own.role, touched = new Set();
    if (mode === "replace") {
      for (let i = 0; i < owner.length; i++) if (owner[i] === region.id) { owner[i] = 0; role[i] = 0; }
      touched.add(region.id);
      mode = "add";
    }
    for (const i of ids) {
      const cur = owner[i];
      if (mode === "add") {
        if (cur === region.id) continue;
        if (cur) touched.add(cur);
        owner[i] = region.id; role[i] = region.kind === "fixed" ? 1 : 2;
        touched.add(region.id);
      } else if (mode === "subtract") {
        if (cur !== region.id) continue;
        owner[i] = 0; role[i] = 0; touched.add(region.id);
      } else if (cur) {
        touched.add(cur); owner[i] = 0; role[i] = 0;
      }
    }
    for (const id of touched) { const r = this.byId.get(id); if (r) r.source = null; }
    this.changed();
  }

  /** A selection made with the tools: into the region of the current role, with the modifier's mode. */
  select(ids, ev, plain = "replace") {
    if (!state.V) return;
    const role = this.role();
    if (role === 0) { this.apply(ids, "erase"); return; }
    const mode = ev && (ev.ctrlKey || ev.metaKey) ? "subtract" : ev && ev.shiftKey ? "add" : plain;
    if (role === DOMAIN_ROLE) { this.applyDomain(ids, mode); return; }
    this.apply(ids, mode, this.target(KINDS[role]));
  }

  /** A region holding exactly these vertices (a named set, a feature candidate, an imported selection). */
  fromIds(name, kind, ids, source) {
    let r = state.regions.find((x) => x.name === Regions.clean(name) && x.kind === kind);
    if (!r) r = this.add(kind, name);
    this.apply(ids, "replace", r);
    r.source = source || null;
    this.activate(r.id);
    return r;
  }

  /** Assign a named set of the file with the current role (erase: take its vertices out of every region). */
  assignSet(name) {
    const ids = state.sets[name];
    if (!ids) return;
    const role = this.role();
    if (role === 0) { this.apply(ids, "erase"); return; }
    if (role === DOMAIN_ROLE) { this.applyDomain(ids, "replace"); this.domainSource = { set: name }; return; }
    this.fromIds(name, KINDS[role], ids, { set: name });
  }

  // ---------------------------------------------------------------- the morph domain
  /** Change the domain: "replace" (exactly these ids), "add" or "subtract" them; [] with replace: no domain. */
  applyDomain(ids, mode) {
    if (!this.domain) return;
    if (mode === "replace") this.domain.fill(0);
    const v = mode === "subtract" ? 0 : 1;
    for (const i of ids) this.domain[i] = v;
    this.domainSource = null;
    this.changed();
  }

  /** Vertices in the domain (0: none, the whole mesh may move). */
  domainCount() {
    let n = 0;
    if (this.domain) for (let i = 0; i < this.domain.length; i++) n += this.domain[i];
    return n;
  }

  /** The domain's vertex ids (of elements only, with usedOnly). */
  domainIds(usedOnly = false) {
    const out = [];
    if (this.domain) for (let i = 0; i < this.domain.length; i++) if (this.domain[i] && (!usedOnly || state.used[i])) out.push(i);
    return out;
  }

  clear() {
    for (const r of [...state.regions]) this.remove(r.id);
    if (this.domain && this.domainCount()) this.applyDomain([], "replace");
  }

  changed() {
    for (const r of state.regions) r.count = 0;
    for (let i = 0; i < this.owner.length; i++) {
      const r = this.byId.get(this.owner[i]);
      if (r) r.count++;
    }
    this.meshView.recolor();
    emit("regions");
    emit("selection");
  }

  counts() {
    let f = 0, h = 0;
    for (let i = 0; i < state.role.length; i++) { if (state.role[i] === 1) f++; else if (state.role[i] === 2) h++; }
    return { fixed: f, handle: h };
  }

  idsOf(region, usedOnly = false) {
    const out = [];
    for (let i = 0; i < this.owner.length; i++) {
      if (this.owner[i] === region.id && (!usedOnly || state.used[i])) out.push(i);
    }
    return out;
  }

  handles() { return state.regions.filter((r) => r.kind === "handle" && r.count > 0); }

  /** Rest-shape centroid of a region's element vertices. */
  centroid(region) {
    const ids = this.idsOf(region, true), c = [0, 0, 0];
    for (const i of ids) for (let k = 0; k < 3; k++) c[k] += state.V0[3 * i + k] / ids.length;
    return c;
  }

  // ---------------------------------------------------------------- SPEC
  /**
   * The SPEC for the current regions. A region that is still exactly a named set of the file
   * is sent as {"set": NAME}; otherwise as ids, keeping only vertices that belong to an element
   * (the mid-side nodes of quadratic elements follow their corners and cannot be selected).
   */
  spec(options = {}) {
    // selections other parts of the SPEC name (cyclic faces, features, ...), then the regions'
    const selections = { ...this.extraSelections }, fixed = [], handles = {};
    for (const r of state.regions) {
      if (!r.count) continue;
      selections[r.name] = r.source && r.source.set ? { set: r.source.set } : { ids: this.idsOf(r, true) };
      if (r.kind === "fixed") fixed.push(r.name); else handles[r.handleName || r.name] = r.name;
    }
    const out = { ...this.specExtra, selections, fixed, handles, ...options };
    if (this.domainCount()) {
      const names = new Set(Object.keys(selections));
      let name = "domain";
      for (let k = 2; names.has(name); k++) name = `domain_${k}`;
      selections[name] = this.domainSource ? { ...this.domainSource } : { ids: this.domainIds(true) };
      out.domain = name;
    }
    return out;
  }

  /** Regions from a SPEC's selections (ids, set, box, sphere, plane; boundary_only). Unknown keys are kept. */
  loadSpec(spec) {
    const { selections = {}, fixed = [], handles = {}, ...extra } = spec;
    delete extra.inversion; delete extra.repair;
    this.clear();
    this.specExtra = extra;
    this.extraSelections = {};
    const kindOf = new Map(), handleOf = new Map();
    for (const n of fixed) kindOf.set(n, "fixed");
    for (const [h, sel] of Object.entries(handles)) {
      const selName = typeof sel === "string" ? sel : h;
      kindOf.set(selName, "handle");
      handleOf.set(selName, h);
    }
    const domainName = extra.domain;
    delete this.specExtra.domain;
    for (const [name, sel] of Object.entries(selections)) {
      const kind = kindOf.get(name);
      if (name === domainName && !kind) {  // the domain, painted again
        this.applyDomain(this.resolve(sel), "replace");
        if (sel.set && !sel.boundary_only) this.domainSource = { set: sel.set };
        continue;
      }
      if (!kind) { this.extraSelections[name] = sel; continue; }  // kept as it is for the SPEC
      const ids = this.resolve(sel);
      const source = sel.set && !sel.boundary_only ? { set: sel.set } : null;
      const r = this.fromIds(name, kind, ids, source);
      if (handleOf.has(name) && handleOf.get(name) !== r.name) r.handleName = handleOf.get(name);
    }
    const first = state.regions[0];
    if (first) this.activate(first.id);
  }

  /**
   * Vertex ids of a SPEC selection, as the service resolves it: a named set whole (its mid-side nodes
   * follow the set), geometric selections on element vertices only.
   */
  resolve(sel) {
    const V = state.V0, n = V.length / 3, out = [];
    const kind = Object.keys(sel).find((k) => k !== "boundary_only");
    const val = sel[kind];
    if (kind === "ids") {
      for (const i of val) if (i >= 0 && i < n && state.used[i]) out.push(i);
    } else if (kind === "set") {  // the whole set, mid-side nodes included, as Assign set makes it
      for (const i of state.sets[val] || []) out.push(i);
    } else {
      const test = kind === "box" ? (x, y, z) => x >= val.min[0] && x <= val.max[0] && y >= val.min[1] &&
          y <= val.max[1] && z >= val.min[2] && z <= val.max[2]
        : kind === "sphere" ? (x, y, z) => Math.hypot(x - val.center[0], y - val.center[1], z - val.center[2]) <= val.radius
        : kind === "plane" ? (() => {
          const nn = Math.hypot(...val.normal), nx = val.normal[0] / nn, ny = val.normal[1] / nn, nz = val.normal[2] / nn;
          const tol = val.tolerance || 0;
          return (x, y, z) => Math.abs((x - val.point[0]) * nx + (y - val.point[1]) * ny + (z - val.point[2]) * nz) <= tol;
        })() : null;
      if (test) for (let i = 0; i < n; i++) if (state.used[i] && test(V[3 * i], V[3 * i + 1], V[3 * i + 2])) out.push(i);
    }
    return sel.boundary_only ? out.filter((i) => state.boundary[i]) : out;
  }

  // ---------------------------------------------------------------- tools
  toolChanged() {
    this.viewer.orbit.enabled = this.tool() === "orbit";
    this.ring.visible = false;
    this.viewer.canvas.style.cursor = this.tool() === "orbit" ? "" : "crosshair";
  }

  roleChanged() {
    const role = this.role();
    if (!role) return;
    const a = this.active;
    if (!a || a.kind !== KINDS[role]) {
      const last = [...state.regions].reverse().find((r) => r.kind === KINDS[role]);
      own.activeRegion = last ? last.id : null;
      emit("regions");
    }
  }

  /** Esc: drop a box being drawn, else go back to navigating. */
  cancel() {
    if (this.drag) {
      this.drag = null;
      $("boxsel").style.display = "none";
      return true;
    }
    if (this.tool() !== "orbit") {
      document.querySelector("input[name=tool][value=orbit]").checked = true;
      this.toolChanged();
      return true;
    }
    return false;
  }

  screenOf(i, out) {
    out.set(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]).project(this.viewer.camera);
    return out;
  }

  boxSelect(x0, y0, x1, y1, ev) {
    const rect = this.viewer.canvas.getBoundingClientRect();
    const ax = Math.min(x0, x1), bx = Math.max(x0, x1), ay = Math.min(y0, y1), by = Math.max(y0, y1);
    const v = new THREE.Vector3();
    let ids = [];
    const clip = this.meshView.options.clip ? this.meshView.clipPlane : null;
    // the domain is a volume: a box through the mesh takes the nodes inside it too
    const inner = this.role() === DOMAIN_ROLE && $("box-mode").value !== "front";
    for (let i = 0; i < state.boundary.length; i++) {
      if (!state.boundary[i] && !(inner && state.used[i])) continue;
      if (clip && clip.distanceToPoint(v.set(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2])) < 0) continue;
      this.screenOf(i, v);
      if (v.z > 1) continue;
      const sx = (v.x + 1) / 2 * rect.width, sy = (1 - v.y) / 2 * rect.height;
      if (sx >= ax && sx <= bx && sy >= ay && sy <= by) ids.push(i);
    }
    if ($("box-mode").value === "front") ids = this.visibleOnly(ids);
    this.select(ids, ev, "replace");
  }

  /** The vertices among `ids` not hidden behind the surface (a depth render of the surface as drawn). */
  visibleOnly(ids) {
    const { renderer, camera, canvas } = this.viewer;
    const w = canvas.width, h = canvas.height;
    if (!this.depthTarget || this.depthTarget.width !== w || this.depthTarget.height !== h) {
      if (this.depthTarget) this.depthTarget.dispose();
      this.depthTarget = new THREE.WebGLRenderTarget(w, h);
      this.depthMat = new THREE.MeshDepthMaterial({ depthPacking: THREE.RGBADepthPacking, side: THREE.DoubleSide });
      this.depthScene = new THREE.Scene();
      this.depthScene.add(new THREE.Mesh(this.meshView.surfGeom, this.depthMat));
    }
    this.depthMat.clippingPlanes = this.meshView.surfMat.clippingPlanes;
    this.depthMat.needsUpdate = true;
    const prevColor = renderer.getClearColor(new THREE.Color()), prevAlpha = renderer.getClearAlpha();
    renderer.setRenderTarget(this.depthTarget);
    renderer.setClearColor(0xffffff, 1);
    renderer.clear();
    renderer.render(this.depthScene, camera);
    const px = new Uint8Array(w * h * 4);
    renderer.readRenderTargetPixels(this.depthTarget, 0, 0, w, h, px);
    renderer.setRenderTarget(null);
    renderer.setClearColor(prevColor, prevAlpha);
    const f = [255 / 256 / 255, 255 / 256 / 256 / 255, 255 / 256 / 65536 / 255, 1 / 16777216 / 255];
    const depthAt = (x, y) => {
      const o = 4 * (y * w + x);
      return px[o] * f[0] + px[o + 1] * f[1] + px[o + 2] * f[2] + px[o + 3] * f[3];
    };
    const near = camera.near, far = camera.far;
    const viewZ = (d) => (near * far) / ((far - near) * d - far); // perspective depth -> view-space z (< 0)
    const tol = 0.004 * state.diag;
    const v = new THREE.Vector3(), m = camera.matrixWorldInverse;
    const out = [];
    for (const i of ids) {
      v.set(state.V[3 * i], state.V[3 * i + 1], state.V[3 * i + 2]);
      const zView = v.clone().applyMatrix4(m).z;
      v.project(camera);
      const sx = Math.round((v.x + 1) / 2 * w), sy = Math.round((v.y + 1) / 2 * h);
      // visible when the surface drawn at one of the 3x3 pixels around it is not in front of it
      // (background pixels do not count: a hidden wall seen edge-on stays hidden)
      let visible = false;
      for (let dy = -1; dy <= 1 && !visible; dy++) for (let dx = -1; dx <= 1; dx++) {
        const x = Math.min(w - 1, Math.max(0, sx + dx)), y = Math.min(h - 1, Math.max(0, sy + dy));
        const d = depthAt(x, y);
        if (d < 0.999999 && -zView <= -viewZ(d) + tol) { visible = true; break; }
      }
      if (visible) out.push(i);
    }
    return out;
  }

  /** Surface point under the pointer, with the face normal. */
  pick(clientX, clientY) {
    const rect = this.viewer.canvas.getBoundingClientRect();
    const p = new THREE.Vector2((clientX - rect.left) / rect.width * 2 - 1, -(clientY - rect.top) / rect.height * 2 + 1);
    this.raycaster.setFromCamera(p, this.viewer.camera);
    return this.raycaster.intersectObject(this.meshView.surface, false)[0] || null;
  }

  brushRadius() { return Number($("brush").value) / 100 * state.diag; }

  brushAt(clientX, clientY, ev) {
    const hit = this.pick(clientX, clientY);
    this.showRing(hit);
    if (!hit) return;
    const r = this.brushRadius();
    const ids = [], inner = this.role() === DOMAIN_ROLE;  // the domain: the nodes inside the ball too
    for (let i = 0; i < state.boundary.length; i++) {
      if (!state.boundary[i] && !(inner && state.used[i])) continue;
      const dx = state.V[3 * i] - hit.point.x, dy = state.V[3 * i + 1] - hit.point.y, dz = state.V[3 * i + 2] - hit.point.z;
      if (dx * dx + dy * dy + dz * dz <= r * r) ids.push(i);
    }
    this.select(ids, ev, "add");
  }

  showRing(hit) {
    const ring = this.ring;
    if (!hit || !hit.face) { ring.visible = false; return; }
    const r = this.brushRadius();
    ring.position.copy(hit.point);
    const nrm = hit.face.normal.clone().transformDirection(this.meshView.surface.matrixWorld);
    ring.quaternion.setFromUnitVectors(new THREE.Vector3(0, 0, 1), nrm);
    ring.scale.setScalar(r);
    const role = this.role();
    ring.material.color.setRGB(...(role === 0 ? [0.4, 0.4, 0.4] : role === DOMAIN_ROLE ? DOMAIN_COLOR : this.activeColor(role)));
    ring.visible = true;
  }

  activeColor(role) {
    const a = this.active;
    if (a && a.kind === KINDS[role]) return a.color;
    return PALETTE[KINDS[role]][0];
  }

  down(ev) {
    const tool = this.tool();
    if ((tool !== "box" && tool !== "brush") || ev.button !== 0 || !state.V || this.busy(ev)) return;
    this.drag = { x: ev.offsetX, y: ev.offsetY };
    this.viewer.canvas.setPointerCapture(ev.pointerId);
    if (tool === "brush") this.brushAt(ev.clientX, ev.clientY, ev);
  }

  move(ev) {
    const tool = this.tool();
    if (!this.drag) {
      if (tool === "brush" && state.V && !this.busy()) this.showRing(this.pick(ev.clientX, ev.clientY));
      return;
    }
    if (tool === "box") {
      const b = $("boxsel"), d = this.drag;
      b.style.display = "block";
      b.style.left = `${Math.min(d.x, ev.offsetX)}px`; b.style.top = `${Math.min(d.y, ev.offsetY)}px`;
      b.style.width = `${Math.abs(ev.offsetX - d.x)}px`; b.style.height = `${Math.abs(ev.offsetY - d.y)}px`;
    } else {
      this.brushAt(ev.clientX, ev.clientY, ev);
    }
  }

  up(ev) {
    if (!this.drag) return;
    if (this.tool() === "box") this.boxSelect(this.drag.x, this.drag.y, ev.offsetX, ev.offsetY, ev);
    $("boxsel").style.display = "none";
    this.drag = null;
  }

  /** Set by the wiring: true while the gizmo is being dragged, or when the event `ev` is over the gizmo. */
  busy(_ev) { return false; }
}
