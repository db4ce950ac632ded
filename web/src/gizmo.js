// Moving the handles: one transform per handle region (translation, rotation and scale about
// its rest centroid), the translate/rotate gizmo on the active handle with snapping and a live
// distance/angle read-out, numeric fields that always show the active handle's transform,
// relative moves, the history behind Undo/Redo, and named presets. With local axes on, the
// numeric fields and the gizmo's arrows and rings are in the local x, y, z. Turns (the gizmo's
// rings, Move by) are about the handle's centre, a node picked on the model or the local origin;
// a handle turned about a point sends that point as its MOVE's pivot.
import * as THREE from "three";
import { TransformControls } from "three/addons/controls/TransformControls.js";
import { $, radio } from "./dom.js";
import { fmt, unitText } from "./panels.js";
import { claim, emit, state } from "./state.js";

// the owner of the state's "moves" group: the handles' transforms, the history and the MOVE the session holds
const own = claim("moves");

/**
 * {t, q: THREE.Quaternion, s, pivot} of one handle's entry of a MOVE (quaternion or axis + angle_deg),
 * t about the handle's centroid; pivot is the MOVE's own pivot when it is another point (else null).
 */
export function parseHandleMove(h, centroid) {
  const t = h && h.translation ? h.translation.slice() : [0, 0, 0];
  const q = new THREE.Quaternion();
  const rot = h && h.rotation;
  if (rot && rot.quaternion) q.set(rot.quaternion[1], rot.quaternion[2], rot.quaternion[3], rot.quaternion[0]).normalize();
  else if (rot && rot.axis && rot.angle_deg) {
    const a = new THREE.Vector3(...rot.axis);
    if (a.lengthSq() > 0) q.setFromAxisAngle(a.normalize(), THREE.MathUtils.degToRad(rot.angle_deg));
  }
  const pivot = h && h.pivot ? h.pivot : centroid;
  // the editor's pivot is the centroid: express a move about another pivot about the centroid
  if (pivot !== centroid && pivot) {
    const c = new THREE.Vector3(...centroid), p = new THREE.Vector3(...pivot), s = h.scale ?? 1;
    // u(x) = p + t + s R (x - p)  =>  u(c) = p + t + s R (c - p) = c + t'
    const uc = c.clone().sub(p).applyQuaternion(q).multiplyScalar(s).add(p).add(new THREE.Vector3(...t));
    return { t: uc.sub(c).toArray(), q, s, pivot: pivot.slice() };
  }
  return { t, q, s: h && h.scale !== undefined ? h.scale : 1, pivot: null };
}

/** Angle (degrees, 0..180) and unit axis of a quaternion. */
export function axisAngle(q) {
  const w = Math.min(1, Math.abs(q.w)), sgn = q.w < 0 ? -1 : 1;
  const angle = 2 * Math.acos(w);
  const s = Math.sqrt(Math.max(0, 1 - w * w));
  const axis = s > 1e-9 ? [sgn * q.x / s, sgn * q.y / s, sgn * q.z / s] : null;
  return { angle: THREE.MathUtils.radToDeg(angle), axis };
}

export class Moves {
  /**
   * @param {Viewer} viewer
   * @param {Regions} regions
   * @param {{send: Function, reset: Function, refuse: Function, updatePresets: Function}} io
   *   send(move) streams a MOVE and answers its seq (null when not sent), reset() returns the
   *   session to rest, refuse(text) says why an action is not possible, updatePresets(change)
   *   stores change(presets) with the session on the service (and shows what it answered).
   */
  constructor(viewer, regions, io) {
    this.viewer = viewer;
    this.regions = regions;
    this.io = io;
    this.pending = new Map(); // seq -> history entry it commits
    this.dragSeq = null;
    this.shown = {};          // field id -> [text shown, exact value]
    // the MOVE's other entries (edits.js), set by the wiring: read, set, and scaled as a clamp scales them
    this.extra = { move: () => ({}), set: () => {}, scaled: () => ({}) };
    this.pivot = new THREE.Object3D();
    viewer.scene.add(this.pivot);
    this.gizmo = new TransformControls(viewer.camera, viewer.canvas);
    this.gizmo.addEventListener("dragging-changed", (ev) => {
      viewer.orbit.enabled = !ev.value && radio("tool") === "orbit";
      if (ev.value) {
        this.refusedDrag = false;
        // the handle and the gizmo when the drag begins: a turn is the gizmo's turn since then (in
        // local axes the gizmo wears the axes, not the handle), about the point the gizmo is on
        const h = state.transforms[this.active];
        this.dragStart = h ? { q: this.pivot.quaternion.clone(), hq: h.q.clone(), t: h.t.slice(),
          at: this.pivot.position.toArray() } : null;
        // snap targets: the nodes where they are drawn when the drag begins (free ones move with it)
        this.snapV = $("snap-node").checked && state.V ? Float32Array.from(state.V) : null;
      }
      if (!ev.value && this.dragged) { this.dragged = false; this.commit("drag", this.dragSeq); }
      if (!ev.value) this.loadPivot();  // the gizmo back on its point and axes for the next drag
    });
    this.gizmo.addEventListener("objectChange", () => {
      if (!this.active) return;
      const before = this.snapshot();
      this.snapToNode();
      this.storePivot();
      const seq = this.io.send(this.move());
      if (seq === null) {  // no stream: the handle stays where the session is
        this.restore(before);
        if (!this.refusedDrag) this.io.refuse("the session's stream is closed: this move was not sent");
        this.refusedDrag = true;
        return;
      }
      this.dragged = true;
      this.dragSeq = seq;
      this.syncFields();
    });
    this.helper = this.gizmo.getHelper();
    viewer.scene.add(this.helper);
    this.helper.visible = false;
    this.clear();
    for (const r of document.querySelectorAll("input[name=gizmo]")) r.addEventListener("change", () => this.setMode(radio("gizmo")));
    for (const id of ["snap", "snap-t", "snap-r"]) $(id).addEventListener("change", () => this.applySnap());
    $("dpivot").addEventListener("change", () => this.loadPivot());
    viewer.beforeRender.push(() => this.placeLabel());
  }

  get dragging() { return this.gizmo.dragging; }

  /**
   * True when a pointer event is over one of the gizmo's arrows, planes or rings: a press there
   * starts a gizmo drag, which no region tool may take as its own.
   */
  under(ev) {
    if (!this.helper.visible || !this.gizmo.object || !this.gizmo.enabled) return false;
    const rect = this.viewer.canvas.getBoundingClientRect();
    this.gizmo.pointerHover({ x: (ev.clientX - rect.left) / rect.width * 2 - 1,
      y: -(ev.clientY - rect.top) / rect.height * 2 + 1, button: ev.button });
    return this.gizmo.axis !== null;
  }

  clear() {
    own.transforms = {};
    own.history = [{ label: "rest", move: null }];
    own.historyIndex = 0;
    own.moves = [];
    own.lastMove = null;
    this.active = null;
    this.pending.clear();
  }

  /** A new session on these handle regions: every handle at rest, the gizmo on the first. */
  attach(handleRegions) {
    this.clear();
    for (const r of handleRegions) {
      own.transforms[r.handleName || r.name] = { centroid: this.regions.centroid(r), t: [0, 0, 0],
        q: new THREE.Quaternion(), s: 1, pivot: null };
    }
    const first = handleRegions[0] ? handleRegions[0].handleName || handleRegions[0].name : null;
    own.centroid = first ? own.transforms[first].centroid : null;
    if (first) this.gizmo.attach(this.pivot); else this.gizmo.detach();  // a session of edits alone has no handle
    this.helper.visible = !!first;
    this.gizmo.setSize(0.9);
    this.setActive(first);
    this.applySnap();
    emit("history");
  }

  detach() {
    this.clear();
    this.gizmo.detach();
    this.helper.visible = false;
    $("gizmo-label").hidden = true;
    emit("history");
    emit("active-handle", null);
  }

  /** Every move field back to its value at rest (a new mesh: nothing of the last one's moves stays). */
  resetFields() {
    const rest = { tx: 0, ty: 0, tz: 0, ax: 0, ay: 0, az: 1, angle: 0, scale: 1, dx: 0, dy: 0, dz: 0, dangle: 0 };
    for (const [id, v] of Object.entries(rest)) $(id).value = String(v);
    this.shown = {};
  }

  /** Snap steps for a model of this diagonal: a round length near 1 % of it, and 5°. */
  snapDefaults(diag) {
    const target = diag / 100, p = 10 ** Math.floor(Math.log10(target));
    const step = [5, 2, 1].map((m) => m * p).find((x) => x <= target * 1.0000001) || p;
    $("snap-t").value = String(Number(step.toPrecision(3)));
    $("snap-r").value = "5";
    this.applySnap();
  }

  /** The handles' transforms, to go back to when a move cannot be sent. */
  snapshot() {
    const out = {};
    for (const [name, h] of Object.entries(state.transforms)) {
      out[name] = { t: h.t.slice(), q: h.q.clone(), s: h.s, pivot: h.pivot || null };
    }
    return out;
  }

  restore(snap) {
    for (const [name, v] of Object.entries(snap)) {
      const h = state.transforms[name];
      if (h) { h.t = v.t; h.q = v.q; h.s = v.s; h.pivot = v.pivot; }
    }
    this.loadPivot();
    this.syncFields(true);
  }

  setActive(name) {
    if (!state.transforms[name]) return;
    this.active = name;
    own.centroid = own.transforms[name].centroid;
    this.loadPivot();
    this.syncFields();
    emit("active-handle", name);
  }

  setMode(mode) {
    this.gizmo.setMode(mode);
    this.loadPivot();  // the rings on the turning point, the arrows on the handle
    const r = document.querySelector(`input[name=gizmo][value=${mode}]`);
    if (r) r.checked = true;
  }

  applySnap() {
    const on = $("snap").checked;
    const t = Number($("snap-t").value), r = Number($("snap-r").value);
    this.gizmo.setTranslationSnap(on && t > 0 ? t : null);
    this.gizmo.setRotationSnap(on && r > 0 ? THREE.MathUtils.degToRad(r) : null);
  }

  // ---------------------------------------------------------------- transforms
  /**
   * The point turns are made about (the "turn about" choice): the picked node A, the local origin,
   * or null for the handle's centre (also when the choice has no point yet).
   */
  turnPoint() {
    const about = $("dpivot").value;
    if (about === "A") { const p = this.picked(); return p.length ? p[0].slice() : null; }
    if (about === "origin") return this.csys ? this.csys.origin.slice() : null;
    return null;
  }

  /**
   * The gizmo where the active handle is; its rings on the turning point when turns are about a
   * picked point. In local axes the gizmo's arrows and rings are the local x, y, z (the pivot
   * wears the axes' orientation, the gizmo in its local space); else the world's.
   */
  loadPivot() {
    const h = state.transforms[this.active];
    const qc = this.frameQuaternion();
    this.gizmo.setSpace(qc ? "local" : "world");
    if (!h) return;
    const at = this.gizmo.mode === "rotate" ? this.turnPoint() : null;
    if (at) this.pivot.position.set(...at);
    else this.pivot.position.set(h.centroid[0] + h.t[0], h.centroid[1] + h.t[1], h.centroid[2] + h.t[2]);
    this.pivot.quaternion.copy(qc || h.q);
  }

  /**
   * The handle's transform from the gizmo. Translating: the handle's centre is where the gizmo is.
   * Turning: the gizmo turned by dq = Q Q0⁻¹ since the drag began (in world terms, whether it
   * wears the local axes or the handle's turn); the handle turns by dq about the point the gizmo is
   * on, which, when it is not the handle's centre, becomes the handle's MOVE pivot.
   */
  storePivot() {
    const h = state.transforms[this.active], p = this.pivot.position, d = this.dragStart;
    if (this.gizmo.mode !== "rotate" || !d) {
      h.t = [p.x - h.centroid[0], p.y - h.centroid[1], p.z - h.centroid[2]];
      return;
    }
    const dq = this.pivot.quaternion.clone().multiply(d.q.clone().invert());
    h.q = dq.clone().multiply(d.hq);
    const c = new THREE.Vector3(...h.centroid), at = new THREE.Vector3(...d.at);
    const uc = c.clone().add(new THREE.Vector3(...d.t)).sub(at).applyQuaternion(dq).add(at);
    h.t = uc.sub(c).toArray();
    if (this.turnPoint() !== null) h.pivot = d.at.slice();
  }

  /** The orientation of the local axes in use (null: the global ones). */
  frameQuaternion() {
    const e = this.frame();
    if (!e) return null;
    return new THREE.Quaternion().setFromRotationMatrix(new THREE.Matrix4().makeBasis(e[0], e[1], e[2]));
  }

  /**
   * The MOVE of every handle's current transform: about the handle's centroid c, or about its
   * pivot p when it was turned about one, with the translation that makes it the same map:
   * u(x) = c + t + s R (x - c) = p + t' + s R (x - p) for t' = c + t - p + s R (p - c).
   */
  move() {
    const handles = {};
    for (const [name, h] of Object.entries(state.transforms)) {
      const q = h.q.w < 0 ? new THREE.Quaternion(-h.q.x, -h.q.y, -h.q.z, -h.q.w) : h.q;
      let t = h.t.slice(), pivot = h.centroid;
      if (h.pivot) {
        const c = new THREE.Vector3(...h.centroid), p = new THREE.Vector3(...h.pivot);
        t = p.clone().sub(c).applyQuaternion(h.q).multiplyScalar(h.s).add(c).add(new THREE.Vector3(...h.t)).sub(p).toArray();
        pivot = h.pivot.slice();
      }
      const doc = { translation: t, rotation: { quaternion: [q.w, q.x, q.y, q.z] }, pivot };
      if (h.s !== 1) doc.scale = h.s;
      handles[name] = doc;
    }
    return { ...this.extra.move(), handles };
  }

  /** Set every handle from a MOVE (null: rest). */
  setFromMove(move) {
    for (const [name, h] of Object.entries(state.transforms)) {
      const m = move && move.handles && move.handles[name];
      const p = parseHandleMove(m, h.centroid);
      h.t = p.t; h.q = p.q; h.s = p.s; h.pivot = p.pivot;
    }
    this.loadPivot();
    this.syncFields(true);
    this.extra.set(move);
  }

  /** True when two MOVEs put every handle at the same transform (null: rest). */
  sameMove(a, b) {
    for (const [name, h] of Object.entries(state.transforms)) {
      const p = parseHandleMove(a && a.handles && a.handles[name], h.centroid);
      const q = parseHandleMove(b && b.handles && b.handles[name], h.centroid);
      const dt = Math.hypot(p.t[0] - q.t[0], p.t[1] - q.t[1], p.t[2] - q.t[2]);
      if (dt > 1e-7 * Math.max(1, state.diag) || Math.abs(Math.abs(p.q.dot(q.q)) - 1) > 1e-9 ||
        Math.abs(p.s - q.s) > 1e-9) return false;
    }
    return true;
  }

  /** The MOVE scaled by f, as the service's clamp applies it: f t, f θ, s^f. */
  static scaled(move, f) {
    const handles = {};
    for (const [name, h] of Object.entries(move.handles)) {
      const q = new THREE.Quaternion(h.rotation.quaternion[1], h.rotation.quaternion[2], h.rotation.quaternion[3],
        h.rotation.quaternion[0]);
      const qs = new THREE.Quaternion().slerp(q, f);
      handles[name] = { ...h, translation: h.translation.map((x) => x * f),
        rotation: { quaternion: [qs.w, qs.x, qs.y, qs.z] } };
      if (h.scale !== undefined) handles[name].scale = h.scale ** f;
    }
    return { ...move, handles };
  }

  // ---------------------------------------------------------------- history
  /** An entry after the one shown (the ones after it go), and shown; the caller emits "history". */
  append(entry) {
    own.history.splice(own.historyIndex + 1);
    own.history.push(entry);
    own.historyIndex = own.history.length - 1;
    own.moves = own.history.slice(1).map((e) => e.move);
  }

  /** A MOVE went out to the session: what it holds once answered. */
  sent(move) {
    own.lastMove = move;
    emit("last-move");
  }

  /**
   * An opened session: the history this browser kept of it (or null), then, when the session
   * holds another MOVE than that history's current entry (moved elsewhere since), that MOVE.
   */
  resume(kept, serviceMove) {
    if (kept) {
      own.history = kept.history;
      own.historyIndex = kept.index;
    }
    const cur = own.history[own.historyIndex].move;
    if (!this.sameMove(cur, serviceMove)) this.append({ label: "last MOVE on the service", move: serviceMove });
    own.moves = own.history.slice(1).map((e) => e.move);
    own.lastMove = serviceMove || null;
    if (serviceMove) this.setFromMove(serviceMove);
    emit("history");
  }

  /** A saved session's history, its entry `index` shown. */
  loadHistory(history, index) {
    own.history = history.length ? history : [{ label: "rest", move: null }];
    own.historyIndex = Math.min(index ?? 0, own.history.length - 1);
    own.moves = own.history.slice(1).map((e) => e.move);
    emit("history");
  }

  /** Make the current transforms a history entry; `seq` is the MOVE that applies it. */
  commit(label, seq) {
    const entry = { label, move: this.move() };
    this.append(entry);
    if (seq !== null && seq !== undefined) this.pending.set(seq, entry);
    emit("history");
    return entry;
  }

  /** Send the current transforms as a new history entry; `before` is where the handles go back when it cannot be sent. */
  sendAndCommit(label, before = null) {
    const seq = this.io.send(this.move());
    if (seq === null) {
      if (before) this.restore(before);
      this.io.refuse("the session's stream is closed: this move was not sent");
      return;
    }
    this.commit(label, seq);
  }

  async goto(index) {
    if (!state.sessionId || index < 0 || index >= state.history.length || index === state.historyIndex) return;
    own.historyIndex = index;
    const e = own.history[index];
    this.setFromMove(e.move);
    if (e.move) this.pending.set(this.io.send(e.move), e); else await this.io.reset(false);
    emit("history");
  }

  undo() { return this.goto(state.historyIndex - 1); }
  redo() { return this.goto(state.historyIndex + 1); }

  /** The service reset the session: a history entry at rest. */
  rested(record = true) {
    for (const h of Object.values(state.transforms)) { h.t = [0, 0, 0]; h.q = new THREE.Quaternion(); h.s = 1; h.pivot = null; }
    this.loadPivot();
    this.syncFields(true);
    this.extra.set(null);
    if (record && state.history[state.historyIndex].move !== null) {
      this.append({ label: "reset", move: null });
    }
    own.lastMove = null;
    emit("history");
  }

  /** A frame came back: a clamped MOVE puts its handles where the service applied them. */
  solved(seq, report) {
    const entry = this.pending.get(seq);
    for (const k of this.pending.keys()) if (k <= seq) this.pending.delete(k);
    if (!report || !report.clamped) return;
    if (!entry && seq !== state.seq) return;  // an older frame of a drag: the newest one decides
    const f = report.applied_fraction;
    const sent = entry ? entry.move : state.lastMove;
    if (!sent) return;
    const applied = { ...Moves.scaled(sent, f), ...this.extra.scaled(sent, f) };
    if (entry) { entry.move = applied; entry.label += ` · clamped to ${fmt(f)}`; emit("history"); }
    if (seq === state.seq) { own.lastMove = applied; emit("last-move"); }  // what the session holds
    if (!this.dragging && (!entry || entry === state.history[state.historyIndex])) this.setFromMove(applied);
  }

  /** A MOVE was refused: its entry leaves the history; the handles go back to what the session shows. */
  rejected(seq) {
    const entry = this.pending.get(seq);
    this.pending.delete(seq);
    if (this.dragging) return;
    const i = entry ? state.history.indexOf(entry) : -1;
    if (i > 0) {
      own.history.splice(i, 1);
      if (own.historyIndex >= i) own.historyIndex -= 1;
    }
    own.moves = own.history.slice(1).map((e) => e.move);
    own.lastMove = own.history[own.historyIndex].move;  // what the session holds
    this.setFromMove(own.lastMove);
    emit("history");
  }

  // ---------------------------------------------------------------- numeric fields
  /** Show the active handle's transform in the fields (all of them, or all but the one being edited). */
  syncFields(all = false) {
    const h = state.transforms[this.active];
    if (!h) return;
    const { angle, axis } = axisAngle(h.q);
    const t = this.toLocal(h.t);
    const vals = { tx: t[0], ty: t[1], tz: t[2], angle, scale: h.s };
    if (axis) { const a = this.toLocal(axis); Object.assign(vals, { ax: a[0], ay: a[1], az: a[2] }); }
    for (const [id, v] of Object.entries(vals)) {
      const el = $(id);
      if (!all && document.activeElement === el && !this.dragging) continue;
      const text = String(Number(v.toFixed(4)));
      el.value = text;
      this.shown[id] = [text, v];
    }
    this.updateLabel();
  }

  /** Set by the wiring: the picked nodes' positions [A, B, C] (pick tool). */
  picked() { return []; }

  // ---------------------------------------------------------------- local axes
  /**
   * Local axes for the move fields and the gizmo: {origin, axes: [x, y, z]} orthonormal (csys.js
   * makes them from picked nodes, a feature's axis or typed values), or null for the global ones.
   * The fields (t, axis, by, about) are read and shown in them.
   */
  setFrame(frame) {
    this.csys = frame ? { origin: frame.origin.slice(), axes: frame.axes.map((a) => a.clone()) } : null;
    this.loadPivot();
    this.syncFields(true);
  }

  /** Use the local axes (when set) for the fields and the gizmo. */
  useLocal(on) { this.local = on; this.loadPivot(); this.syncFields(true); }

  frame() { return this.local && this.csys ? this.csys.axes : null; }

  toLocal(v) {
    const e = this.frame();
    return e ? e.map((a) => a.x * v[0] + a.y * v[1] + a.z * v[2]) : v.slice();
  }

  toGlobal(v) {
    const e = this.frame();
    if (!e) return v.slice();
    return [0, 1, 2].map((k) => e[0].getComponent(k) * v[0] + e[1].getComponent(k) * v[1] + e[2].getComponent(k) * v[2]);
  }

  /** A field's value: the exact transform behind it when the user did not change what it shows. */
  field(id) {
    const el = $(id), s = this.shown[id];
    return s && s[0] === el.value ? s[1] : Number(el.value);
  }

  /** True when a move field shows what was applied last (nothing typed into it since). */
  unedited(el) {
    const s = this.shown[el.id];
    return !!s && s[0] === el.value;
  }

  applyFields() {
    if (!state.sessionId || !this.active) { this.io.refuse("create a session first"); return; }
    const h = state.transforms[this.active], before = this.snapshot();
    const axis = new THREE.Vector3(...this.toGlobal([this.field("ax"), this.field("ay"), this.field("az")]));
    const q = new THREE.Quaternion();
    const ang = this.field("angle");
    if (axis.lengthSq() > 0 && ang) q.setFromAxisAngle(axis.normalize(), THREE.MathUtils.degToRad(ang));
    const s = this.field("scale");
    h.t = this.toGlobal([this.field("tx"), this.field("ty"), this.field("tz")]);
    h.q = q;
    h.s = s > 0 ? s : 1;
    this.loadPivot();
    this.syncFields(true);
    this.sendAndCommit("numeric", before);
  }

  /**
   * Relative move: turn by dθ about an axis (x, y, z, or the line AB of two picked nodes) through a
   * pivot (the handle's current centre, the picked node A or the local origin), then translate by
   * (dx, dy, dz). A turn about a picked point makes it the handle's MOVE pivot.
   */
  moveBy() {
    if (!state.sessionId || !this.active) { this.io.refuse("create a session first"); return; }
    const h = state.transforms[this.active], before = this.snapshot();
    const d = this.toGlobal([Number($("dx").value) || 0, Number($("dy").value) || 0, Number($("dz").value) || 0]);
    const deg = Number($("dangle").value) || 0;
    for (const id of ["dx", "dy", "dz", "dangle"]) this.shown[id] = [$(id).value, Number($(id).value) || 0];
    const picked = this.picked(), about = $("daxis").value, through = $("dpivot").value;
    if ((about === "AB" && picked.length < 2) || (through === "A" && picked.length < 1)) {
      this.io.refuse(`pick ${about === "AB" ? "two nodes, A and B," : "a node A"} first (pick tool)`);
      return;
    }
    if (through === "origin" && !this.csys) { this.io.refuse("set local axes first: their origin is the pivot"); return; }
    const axis = about === "AB"
      ? new THREE.Vector3(...picked[1]).sub(new THREE.Vector3(...picked[0])).normalize()
      : new THREE.Vector3(...this.toGlobal([0, 1, 2].map((k) => (k === Number(about) ? 1 : 0))));
    if (deg && !(axis.lengthSq() > 0)) { this.io.refuse("the nodes A and B are the same point"); return; }
    const qd = new THREE.Quaternion().setFromAxisAngle(axis, THREE.MathUtils.degToRad(deg));
    const c = new THREE.Vector3(...h.centroid), uc = c.clone().add(new THREE.Vector3(...h.t));
    const P = through === "centre" ? uc.clone() : new THREE.Vector3(...this.turnPoint());
    // u'(x) = P + Rd (u(x) - P) + d: the handle's centre goes to P + Rd (uc - P) + d
    const ucNew = uc.clone().sub(P).applyQuaternion(qd).add(P).add(new THREE.Vector3(...d));
    h.t = ucNew.sub(c).toArray();
    if (deg) h.q = qd.multiply(h.q);
    if (deg && through !== "centre") h.pivot = P.toArray();
    this.loadPivot();
    this.syncFields(true);
    this.sendAndCommit(`by (${d.map(fmt).join(", ")})${deg ? ` ${fmt(deg)}°` : ""}`, before);
  }

  // ---------------------------------------------------------------- read-out
  updateLabel() {
    const h = state.transforms[this.active], el = $("gizmo-label");
    if (!h || !state.sessionId) { el.hidden = true; return; }
    const dist = Math.hypot(...h.t);
    const { angle } = axisAngle(h.q);
    el.textContent = `${this.active}: ${fmt(Number(dist.toFixed(4)))}${unitText()} · ${angle.toFixed(1)}°` +
      (h.s !== 1 ? ` · ×${fmt(h.s)}` : "");
    el.dataset.distance = String(dist);
    el.dataset.angle = String(angle);
    el.hidden = false;
  }

  /**
   * With "to nodes" on, a gizmo translated to within 12 px of a node on the surface (not one of a
   * handle, which moves with it) lands on that node exactly, where the node was when the drag
   * began; of nodes drawn on the same pixel, the nearest to the camera.
   */
  snapToNode() {
    if (!$("snap-node").checked || this.gizmo.mode !== "translate" || !state.V) return;
    const V = this.snapV && this.snapV.length === state.V.length ? this.snapV : state.V;
    const c = this.viewer.canvas, cw = c.clientWidth, ch = c.clientHeight, cam = this.viewer.camera;
    const p = this.screen(this.pivot.position), v = new THREE.Vector3(), near = [];
    for (let i = 0; i < state.boundary.length; i++) {
      if (!state.boundary[i] || state.role[i] === 2) continue;
      v.set(V[3 * i], V[3 * i + 1], V[3 * i + 2]).project(cam);
      if (v.z < -1 || v.z > 1) continue;
      const d = Math.hypot((v.x + 1) / 2 * cw - p.x, (1 - v.y) / 2 * ch - p.y);
      if (d < 12) near.push([d, v.z, i]);
    }
    if (!near.length) return;
    const dmin = Math.min(...near.map((x) => x[0]));
    const [, , i] = near.filter((x) => x[0] <= dmin + 1).sort((a, b) => a[1] - b[1])[0];
    this.pivot.position.set(V[3 * i], V[3 * i + 1], V[3 * i + 2]);
    this.snappedTo = i;
  }

  /** Canvas pixels (x, y) of a world point. */
  screen(p, out = new THREE.Vector3()) {
    const c = this.viewer.canvas;
    out.copy(p).project(this.viewer.camera);
    return { x: (out.x + 1) / 2 * c.clientWidth, y: (1 - out.y) / 2 * c.clientHeight };
  }

  /** How far the gizmo reaches on screen from its centre, in pixels (its handles' bounding box, projected). */
  gizmoReach(centre) {
    const g = this.gizmo._gizmo && this.gizmo._gizmo.gizmo && this.gizmo._gizmo.gizmo[this.gizmo.mode];
    if (!g) return 80;
    const box = this.reachBox || (this.reachBox = new THREE.Box3());
    box.setFromObject(g);
    if (box.isEmpty()) return 80;
    const v = new THREE.Vector3(), tmp = new THREE.Vector3();
    let r = 0;
    for (let k = 0; k < 8; k++) {
      v.set(k & 1 ? box.max.x : box.min.x, k & 2 ? box.max.y : box.min.y, k & 4 ? box.max.z : box.min.z);
      const s = this.screen(v, tmp);
      r = Math.max(r, Math.hypot(s.x - centre.x, s.y - centre.y));
    }
    return Number.isFinite(r) ? Math.min(r, 400) : 80;
  }

  /** The read-out beside the gizmo, never on it: below its reach, or above when there is no room below. */
  placeLabel() {
    const el = $("gizmo-label");
    if (el.hidden) return;
    const c = this.viewer.canvas, w = el.offsetWidth, h = el.offsetHeight;
    const p = this.screen(this.pivot.position);
    const reach = this.gizmoReach(p) + 6;
    let y = p.y + reach;
    if (y + h > c.clientHeight - 4 && p.y - reach - h >= 4) y = p.y - reach - h;
    const x = Math.max(4, Math.min(c.clientWidth - w - 4, p.x - w / 2));
    el.style.left = `${x}px`;
    el.style.top = `${Math.max(4, Math.min(c.clientHeight - h - 4, y))}px`;
  }

  // ---------------------------------------------------------------- presets
  /** Save the current MOVE under `name` (replacing a preset of that name) with the session. */
  savePreset(name) {
    const move = this.move();
    return this.io.updatePresets((list) => {
      let n = (name || "").trim();
      for (let k = list.length + 1; !n; k++) if (!list.some((p) => p.name === `preset ${k}`)) n = `preset ${k}`;
      const i = list.findIndex((p) => p.name === n);
      return i >= 0 ? list.map((p, k) => (k === i ? { name: n, move } : p)) : [...list, { name: n, move }];
    });
  }

  applyPreset(name) {
    const p = state.presets.find((x) => x.name === name);
    if (!p || !state.sessionId) return;
    const before = this.snapshot();
    this.setFromMove(p.move);
    this.sendAndCommit(`preset ${name}`, before);
  }

  deletePreset(name) {
    return this.io.updatePresets((list) => (list.some((p) => p.name === name)
      ? list.filter((p) => p.name !== name) : null));
  }
}
