// Moving the handle: the translate/rotate gizmo on a pivot at the handle's centroid, the
// numeric inputs, and the list of MOVEs behind Undo.
import * as THREE from "three";
import { TransformControls } from "three/addons/controls/TransformControls.js";
import { $, radio } from "./dom.js";
import { state } from "./state.js";

export class Moves {
  /**
   * @param {Viewer} viewer
   * @param {{send: Function, reset: Function, refuse: Function}} io  send(move) streams a MOVE,
   *   reset() returns the session to rest, refuse(text) shows why an action is not possible.
   */
  constructor(viewer, io) {
    this.viewer = viewer;
    this.io = io;
    this.pivot = new THREE.Object3D();
    viewer.scene.add(this.pivot);
    this.gizmo = new TransformControls(viewer.camera, viewer.canvas);
    this.gizmo.addEventListener("dragging-changed", (ev) => {
      viewer.orbit.enabled = !ev.value && radio("tool") === "orbit";
      if (!ev.value && state.lastMove) this.push(state.lastMove);
    });
    this.gizmo.addEventListener("objectChange", () => this.io.send(this.fromPivot()));
    this.helper = this.gizmo.getHelper();
    viewer.scene.add(this.helper);
    this.helper.visible = false;
    for (const r of document.querySelectorAll("input[name=gizmo]")) {
      r.addEventListener("change", () => this.gizmo.setMode(radio("gizmo")));
    }
  }

  get dragging() { return this.gizmo.dragging; }

  /** Put the gizmo on the handle's centroid (a new session). */
  attach(centroid) {
    state.centroid = centroid;
    state.moves = [];
    this.pivot.position.set(...centroid);
    this.pivot.quaternion.identity();
    this.gizmo.attach(this.pivot);
    this.helper.visible = true;
    this.gizmo.setSize(0.9);
  }

  detach() {
    state.moves = []; state.lastMove = null;
    this.gizmo.detach();
    this.helper.visible = false;
  }

  /** Back to the rest pose (after a reset). */
  rest() {
    state.moves = []; state.lastMove = null;
    this.pivot.position.set(...state.centroid);
    this.pivot.quaternion.identity();
  }

  fromPivot() {
    const c = state.centroid, p = this.pivot;
    const t = [p.position.x - c[0], p.position.y - c[1], p.position.z - c[2]];
    const q = p.quaternion;
    return { handles: { handle: { translation: t, rotation: { quaternion: [q.w, q.x, q.y, q.z] }, pivot: c } } };
  }

  setPivot(move) {
    const c = state.centroid;
    const h = move.handles.handle;
    this.pivot.position.set(c[0] + h.translation[0], c[1] + h.translation[1], c[2] + h.translation[2]);
    const q = h.rotation.quaternion;
    this.pivot.quaternion.set(q[1], q[2], q[3], q[0]);
  }

  push(move) { state.moves.push(move); }

  applyNumeric() {
    if (!state.sessionId) { this.io.refuse("create a session first"); return; }
    const axis = new THREE.Vector3(Number($("ax").value), Number($("ay").value), Number($("az").value));
    const q = new THREE.Quaternion();
    if (axis.lengthSq() > 0) q.setFromAxisAngle(axis.normalize(), THREE.MathUtils.degToRad(Number($("angle").value)));
    const move = { handles: { handle: { translation: [Number($("tx").value), Number($("ty").value), Number($("tz").value)],
      rotation: { quaternion: [q.w, q.x, q.y, q.z] }, pivot: state.centroid } } };
    this.setPivot(move);
    this.io.send(move);
    this.push(move);
  }

  async undo() {
    if (!state.sessionId) return;
    state.moves.pop();
    const prev = state.moves[state.moves.length - 1];
    if (prev) { this.setPivot(prev); this.io.send(prev); } else { await this.io.reset(); }
  }
}
