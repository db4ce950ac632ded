// Local coordinate systems for the moves: from three picked nodes, from a feature candidate's axis
// (a hole or boss: its axis; a plane: its normal), or typed (an origin, an x and a z direction).
// Each becomes an orthonormal right-handed frame; the move fields, the relative moves and the
// gizmo's arrows and rings then work in it (gizmo.js), and its origin is a pivot the turns can use.
// The typed fields always show the frame in use, so a frame from picks or a feature can be edited.
import * as THREE from "three";
import { $ } from "./dom.js";
import { fmt } from "./panels.js";

const EPS = 1e-9;

/**
 * The frame of an origin, an x direction and a z direction: z normalised, x made normal to z
 * (Gram-Schmidt) and normalised, y = z × x. Answers {origin, axes: [x, y, z] (THREE.Vector3)}, or
 * {error} saying in words what is wrong with the input.
 */
export function orthonormal(origin, x, z) {
  const ok = (v) => Array.isArray(v) && v.length === 3 && v.every(Number.isFinite);
  if (!ok(origin)) return { error: "the origin needs three numbers (x y z)" };
  if (!ok(x) || !ok(z)) return { error: `the ${ok(x) ? "z" : "x"} axis needs three numbers (dx dy dz)` };
  const e3 = new THREE.Vector3(...z), e1 = new THREE.Vector3(...x);
  const lz = e3.length(), lx = e1.length();
  if (!(lz > 0)) return { error: "the z axis is zero: give its direction" };
  if (!(lx > 0)) return { error: "the x axis is zero: give its direction" };
  e3.divideScalar(lz);
  e1.addScaledVector(e3, -e1.dot(e3));
  if (e1.length() <= EPS * lx) return { error: "the x axis is along the z axis: give an x axis across it" };
  e1.normalize();
  return { origin: origin.slice(), axes: [e1, e3.clone().cross(e1), e3] };
}

/** The global axis least aligned with z (the first of x, y, z on a tie): the x direction of a frame about z. */
export function across(z) {
  const a = z.map(Math.abs);
  const k = a.indexOf(Math.min(...a));
  return [0, 1, 2].map((j) => (j === k ? 1 : 0));
}

/** "x y z" of a vector, for a text field. */
const text = (v) => v.map((x) => String(Number(x.toFixed(6)))).join(" ");

/** Three numbers of a text field ("1 0 0", "1, 0, 0"), or null. */
export function parseVec(s) {
  const v = String(s).trim().split(/[\s,;]+/).map(Number);
  return v.length === 3 && v.every(Number.isFinite) ? v : null;
}

export class CsysPanel {
  /**
   * @param {Moves} moves  the moves (gizmo.js), which use the frame
   * @param {{picked: () => number[][], pickedIds: () => number[], refuse: (text) => void}} io
   *   picked(): the positions of the picked nodes A, B, C; pickedIds() their vertex ids; refuse(text) says why not
   */
  constructor(moves, io) {
    this.moves = moves;
    this.io = io;
    $("csys-from-picks").addEventListener("click", () => this.fromPicks());
    $("csys-set").addEventListener("click", () => this.typed());
    for (const id of ["csys-origin", "csys-x", "csys-z"]) {
      $(id).addEventListener("keydown", (ev) => { if (ev.key === "Enter") { ev.preventDefault(); this.typed(); } });
    }
    $("local").addEventListener("change", () => moves.useLocal($("local").checked));
  }

  /** Use a frame ({origin, axes} or {error}) from `what`; answers whether it was taken. */
  use(frame, what) {
    if (frame.error) { this.io.refuse(frame.error); return false; }
    this.moves.setFrame(frame);
    const e = frame.axes.map((a) => a.toArray().map((x) => fmt(Number(x.toFixed(4)))).join(" "));
    $("csys-text").textContent = `x (${e[0]}) · y (${e[1]}) · z (${e[2]}), ${what}`;
    this.showFields(frame);
    $("local").checked = true;
    this.moves.useLocal(true);
    return true;
  }

  /** A as the origin, x along AB, z normal to the plane ABC. */
  fromPicks() {
    const p = this.io.picked();
    if (p.length !== 3) { this.io.refuse("pick three nodes first (pick tool): A the origin, B along x, C in the xy plane"); return false; }
    const [A, B, C] = p.map((v) => new THREE.Vector3(...v));
    const x = B.clone().sub(A), z = x.clone().cross(C.clone().sub(A));
    if (!(x.lengthSq() > 0) || !(z.lengthSq() > 0)) { this.io.refuse("the three picked nodes are on one line"); return false; }
    return this.use(orthonormal(A.toArray(), x.toArray(), z.toArray()), `from vertices ${this.io.pickedIds().join(", ")}`);
  }

  /**
   * A feature candidate's frame: a hole's or a boss's axis (origin its centre), a plane's normal
   * (origin its point) as z; x the global axis least aligned with it, made normal to it.
   */
  fromFeature(f) {
    const z = f.axis || f.normal, origin = f.center || f.point;
    if (!z || !origin) { this.io.refuse(`${f.name} has no axis or normal`); return false; }
    return this.use(orthonormal(origin, across(z), z), `from the ${f.axis ? "axis" : "normal"} of ${f.name}`);
  }

  /**
   * The typed origin, x and z (x made normal to z). Refused, the fields go back to the frame in use
   * (empty with the global axes) and the refusal says what was typed and what stays in use.
   */
  typed() {
    const ids = ["csys-origin", "csys-x", "csys-z"], typed = ids.map((id) => $(id).value.trim());
    const [o, x, z] = typed.map(parseVec);
    const frame = orthonormal(o, x, z);
    if (!frame.error) return this.use(frame, "typed");
    const cur = this.moves.csys;
    this.showFields(cur);
    const kept = cur ? `the local axes in use stay: ${$("csys-text").textContent}`
      : "the global axes stay in use";
    this.io.refuse(`Local axes not set: ${frame.error}. Typed: origin (${typed[0]}), x (${typed[1]}), ` +
      `z (${typed[2]}); ${kept}.`);
    return false;
  }

  /** The typed-axes fields showing a frame (empty for none). */
  showFields(frame) {
    $("csys-origin").value = frame ? text(frame.origin) : "";
    $("csys-x").value = frame ? text(frame.axes[0].toArray()) : "";
    $("csys-z").value = frame ? text(frame.axes[2].toArray()) : "";
  }

  /** A new mesh: the global axes again, the fields empty. */
  reset() {
    this.moves.setFrame(null);
    $("local").checked = false;
    this.moves.useLocal(false);
    $("csys-text").textContent = "global x y z";
    this.showFields(null);
  }
}
