// The rest values of the edits between features, measured on the page from the rest positions as
// the library measures them (solver/constraints/feature_edits.py): a fillet's fitted radius, the
// distance between two features' centroids (or along a direction), and the angle between two
// features' directions (a planar face set's outward normal, else a cylinder's axis).
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
const mul = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const norm = (a) => Math.hypot(...a);
export const unit = (a) => mul(a, 1 / norm(a));

/** Node i's position in the flat array V. */
export const at = (V, i) => [V[3 * i], V[3 * i + 1], V[3 * i + 2]];

function centroid(V, ids) {
  const c = [0, 0, 0];
  for (const i of ids) for (let k = 0; k < 3; k++) c[k] += V[3 * i + k];
  return mul(c, 1 / Math.max(1, ids.length));
}

/** Eigenvectors of a symmetric 3×3 matrix (rows), by cyclic Jacobi rotations: [values, vectors], ascending. */
export function eigen3(A) {
  const a = A.map((r) => r.slice()), v = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  for (let sweep = 0; sweep < 50; sweep++) {
    const off = Math.abs(a[0][1]) + Math.abs(a[0][2]) + Math.abs(a[1][2]);
    if (off <= 1e-300 || off <= 1e-15 * (Math.abs(a[0][0]) + Math.abs(a[1][1]) + Math.abs(a[2][2]))) break;
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
      if (a[p][q] === 0) continue;
      const th = (a[q][q] - a[p][p]) / (2 * a[p][q]);
      const t = Math.sign(th || 1) / (Math.abs(th) + Math.sqrt(th * th + 1)), c = 1 / Math.sqrt(t * t + 1), s = t * c;
      for (let k = 0; k < 3; k++) {  // A ← Jᵀ A J
        const x = a[k][p], y = a[k][q];
        a[k][p] = c * x - s * y; a[k][q] = s * x + c * y;
      }
      for (let k = 0; k < 3; k++) {
        const x = a[p][k], y = a[q][k];
        a[p][k] = c * x - s * y; a[q][k] = s * x + c * y;
      }
      for (let k = 0; k < 3; k++) {
        const x = v[k][p], y = v[k][q];
        v[k][p] = c * x - s * y; v[k][q] = s * x + c * y;
      }
    }
  }
  const order = [0, 1, 2].sort((i, j) => a[i][i] - a[j][j]);
  return [order.map((i) => a[i][i]), order.map((i) => [v[0][i], v[1][i], v[2][i]])];
}

/** The plane fitted to the points: [point (the centroid), unit normal]. */
function plane(P) {
  const c = mul(P.reduce(add, [0, 0, 0]), 1 / P.length), M = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
  for (const p of P) {
    const d = sub(p, c);
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) M[i][j] += d[i] * d[j];
  }
  return [c, eigen3(M)[1][0]];
}

function solve3(M, b) {
  const det = dot(M[0], cross(M[1], M[2]));
  const cols = [0, 1, 2].map((k) => M.map((r, i) => r.map((x, j) => (j === k ? b[i] : x))));
  return cols.map((C) => dot(C[0], cross(C[1], C[2])) / det);
}

/**
 * A fillet's fitted rest radius: planes fitted to the two faces' corner nodes, the axis's direction
 * of travel `g`, and the radius r minimizing Σ(|q − r g| − r)² over the fillet's corner nodes (a grid,
 * then Gauss-Newton). `used` marks the corner nodes. Null when the fit has no answer.
 */
export function filletRadius(V, used, ids, faceA, faceB) {
  const corner = (s) => s.filter((i) => used[i]).map((i) => at(V, i));
  const A = corner(faceA), B = corner(faceB), X = corner(ids);
  if (A.length < 3 || B.length < 3 || !X.length) return null;
  const [pa, na] = plane(A), [pb, nb] = plane(B), d0 = cross(na, nb);
  if (!(norm(d0) > 1e-6)) return null;
  const d = unit(d0);
  const side = [na, nb].map((n, k) => Math.sign(X.reduce((s, x) => s + dot(sub(x, k ? pb : pa), n), 0)));
  if (!side[0] || !side[1]) return null;
  const M = [na, nb, d], tm = X.reduce((s, x) => s + dot(x, d), 0) / X.length;
  const c0 = solve3(M, [dot(pa, na), dot(pb, nb), tm]), g = solve3(M, [side[0], side[1], 0]);
  const Q = X.map((x) => { const t = sub(x, c0); return sub(t, mul(d, dot(t, d))); });
  const size = Math.max(...Q.map(norm));
  const cost = (r) => Q.reduce((s, q) => s + (norm(sub(q, mul(g, r))) - r) ** 2, 0);
  let r = 0, best = Infinity;
  for (let k = 0; k < 400; k++) {
    const x = 1e-4 * size * 1e6 ** (k / 399), c = cost(x);
    if (c < best) { best = c; r = x; }
  }
  for (let it = 0; it < 50; it++) {
    let num = 0, den = 0;
    for (const q of Q) {
      const w = sub(q, mul(g, r)), rho = norm(w), jac = -dot(w, g) / rho - 1;
      num += jac * (rho - r); den += jac * jac;
    }
    const step = -num / den;
    r += step;
    if (Math.abs(step) <= 1e-15 * r) break;
  }
  return r > 0 ? r : null;
}

/** The distance between the centroids of `moving` and `reference` (every node), or along `direction`. */
export function featureDistance(V, moving, reference, direction = null) {
  const v = sub(centroid(V, moving), centroid(V, reference));
  return direction ? dot(v, unit(direction)) : norm(v);
}

/**
 * A feature's fitted direction from its boundary triangles (all corners in `ids`): the outward
 * normal of planar faces (within `planarDeg`), else a cylinder's axis: the direction the faces'
 * normals are orthogonal to. [direction, isAxis], or null.
 */
export function featureDirection(V, F, ids, planarDeg = 1) {
  const inside = new Set(ids), normals = [];
  for (let t = 0; t < F.length; t += 3) {
    if (!inside.has(F[t]) || !inside.has(F[t + 1]) || !inside.has(F[t + 2])) continue;
    const a = at(V, F[t]);
    normals.push(cross(sub(at(V, F[t + 1]), a), sub(at(V, F[t + 2]), a)));
  }
  if (!normals.length) return null;
  const mean = normals.reduce(add, [0, 0, 0]), size = norm(mean), cos = Math.cos(planarDeg * Math.PI / 180);
  if (size > 0 && normals.every((n) => dot(n, mean) / Math.max(norm(n) * size, 1e-300) >= cos)) return [mul(mean, 1 / size), false];
  if (normals.length < 4) return null;
  const M = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
  for (const n of normals) {
    const area = norm(n), u = mul(n, 1 / Math.max(area, 1e-300));
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) M[i][j] += area * u[i] * u[j];
  }
  return [eigen3(M)[1][0], true];
}

/**
 * The angle in degrees between two features' directions, as the library measures it (an axis has
 * no sense: the one that makes the angle at most 90°). `a`, `b`: [direction, isAxis].
 */
export function featureAngle(a, b) {
  const [v, vb] = b, ua = a[1];
  const u = (ua || vb) && dot(a[0], v) < 0 ? mul(a[0], -1) : a[0];
  return Math.atan2(norm(cross(u, v)), dot(u, v)) * 180 / Math.PI;
}
