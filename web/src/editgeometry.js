// What the Edits panel's form says about geometry: a map's line, circle, plane, cylinder or sphere
// (through picked nodes, or typed) and its projection (nearest, or along a typed direction), and a
// twist's mode (twist, or bend toward a typed direction or one from two picked nodes). Each function
// returns the SPEC's fields (solver/documents/geometry.py, solver/documents/edits.py), or null with
// the reason said through `refuse`.
import { $ } from "./dom.js";

const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => Math.hypot(...a);

/** The circle through three points: {center, normal, radius}, or null when they are on one line. */
export function circleThrough(a, b, c) {
  const ab = sub(b, a), ac = sub(c, a), n = cross(ab, ac), nn = dot(n, n);
  if (!(nn > 1e-24 * dot(ab, ab) * dot(ac, ac))) return null;
  // the centre a + (|ab|² (ac × n) + |ac|² (n × ab)) / (2 |n|²)
  const p = cross(ac, n).map((x) => x * dot(ab, ab)), q = cross(n, ab).map((x) => x * dot(ac, ac));
  const center = a.map((x, k) => x + (p[k] + q[k]) / (2 * nn));
  return { center, normal: n, radius: norm(sub(a, center)) };
}

/** Three numbers in the field `id`, or null. */
function typed(id) {
  const v = $(id).value.trim().split(/[\s,;]+/).map(Number);
  return v.length === 3 && v.every(Number.isFinite) ? v : null;
}

/** How many picked nodes each geometry takes, and what they are. */
const THROUGH = { line: [2, "line (A, B)"], circle: [3, "circle (A, B, C)"], plane: [3, "plane (A, B, C)"],
  cylinder: [3, "cylinder (axis A → B, through C)"], sphere: [2, "sphere (centre A, through B)"] };

/**
 * The map's geometry: through the picked nodes, or typed (point or centre, direction, radius).
 * `picks(n, what)` the rest positions of n picked nodes (null: refused).
 */
export function mapGeometry(picks, refuse) {
  const g = $("edit-geometry").value;
  if ($("edit-gsource").value === "typed") {
    const p = typed("edit-gpoint"), d = typed("edit-gdir"), r = Number($("edit-gradius").value);
    if (!p) { refuse(`type the ${g === "sphere" || g === "circle" ? "centre" : "point"} (x y z)`); return null; }
    if (g !== "sphere" && !(d && norm(d) > 0)) { refuse(`type the ${g}'s ${g === "plane" || g === "circle" ? "normal" : "direction"} (x y z, not all zero)`); return null; }
    if ((g === "circle" || g === "cylinder" || g === "sphere") && !(r > 0)) { refuse(`type the ${g}'s radius (a positive length)`); return null; }
    return { line: { line: { point: p, direction: d } }, plane: { plane: { point: p, normal: d } },
      circle: { circle: { center: p, normal: d, radius: r } }, cylinder: { cylinder: { point: p, axis: d, radius: r } },
      sphere: { sphere: { center: p, radius: r } } }[g];
  }
  const p = picks(THROUGH[g][0], THROUGH[g][1]);
  if (!p) return null;
  if (g === "line" || g === "sphere" || g === "cylinder") {
    const d = sub(p[1], p[0]);
    if (!(norm(d) > 0)) { refuse("the picked nodes A and B are the same point"); return null; }
    if (g === "line") return { line: { point: p[0], direction: d } };
    if (g === "sphere") return { sphere: { center: p[0], radius: norm(d) } };
    const r = norm(cross(sub(p[2], p[0]), d)) / norm(d);
    if (!(r > 0)) { refuse("the picked node C is on the axis A → B: it gives the cylinder no radius"); return null; }
    return { cylinder: { point: p[0], axis: d, radius: r } };
  }
  const c = circleThrough(...p);
  if (!c) { refuse("the picked nodes A, B and C are on one line: they make no plane or circle"); return null; }
  return g === "plane" ? { plane: { point: p[0], normal: c.normal } } : { circle: c };
}

/** The map's projection fields: {} (nearest) or {projection: "along", direction}. */
export function mapProjection(geometry, refuse) {
  if ($("edit-projection").value !== "along") return {};
  if (geometry.line || geometry.circle) { refuse("projection along a direction maps onto a plane, a cylinder or a sphere; a line or a circle is reached by nearest"); return null; }
  const d = typed("edit-pdir");
  if (!(d && norm(d) > 0)) { refuse("type the direction to project along (x y z, not all zero)"); return null; }
  return { projection: "along", direction: d };
}

/**
 * The twist's mode fields for its axis: {} (twist) or {mode: "bend", toward}. Toward is typed, or
 * from the last two picked nodes (`pickedPoints()`: every picked node's rest position).
 */
export function twistMode(axis, pickedPoints, refuse) {
  if ($("edit-twist-mode").value !== "bend") return {};
  let t;
  if ($("edit-toward-from").value === "picked") {
    const p = pickedPoints();
    if (p.length < 2) { refuse(`pick two nodes for the bend's direction first (pick tool: ${p.length} picked)`); return null; }
    t = sub(p[p.length - 1], p[p.length - 2]);
  } else {
    t = typed("edit-toward");
    if (!t) { refuse("type the direction the axis bends toward (x y z)"); return null; }
  }
  const d = axis.direction;
  if (!(norm(cross(d, t)) > 1e-9 * norm(d) * norm(t))) { refuse("the bend's direction runs along the axis: it must point off it"); return null; }
  return { mode: "bend", toward: t };
}
