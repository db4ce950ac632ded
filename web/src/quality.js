// Per-tet quality in the browser, the same definitions as solver/quality.py:
// scaled Jacobian = sqrt(2) * 6V / max over corners of the product of the three edge
// lengths at that corner (Verdict); a tet is inverted when 6V <= 0 or |sj| <= 1e-12.

const EDGES_AT = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/** Scaled Jacobian of every tet. V: Float32Array (n*3), T: Uint32Array (m*4). */
export function scaledJacobians(V, T, out) {
  const m = T.length / 4;
  const sj = out && out.length === m ? out : new Float32Array(m);
  const p = new Float64Array(12);
  for (let t = 0; t < m; t++) {
    for (let k = 0; k < 4; k++) {
      const v = 3 * T[4 * t + k];
      p[3 * k] = V[v]; p[3 * k + 1] = V[v + 1]; p[3 * k + 2] = V[v + 2];
    }
    const ax = p[3] - p[0], ay = p[4] - p[1], az = p[5] - p[2];
    const bx = p[6] - p[0], by = p[7] - p[1], bz = p[8] - p[2];
    const cx = p[9] - p[0], cy = p[10] - p[1], cz = p[11] - p[2];
    const det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
    let best = 0;
    for (let k = 0; k < 4; k++) {
      let prod = 1;
      for (const j of EDGES_AT[k]) {
        const dx = p[3 * j] - p[3 * k], dy = p[3 * j + 1] - p[3 * k + 1], dz = p[3 * j + 2] - p[3 * k + 2];
        prod *= Math.sqrt(dx * dx + dy * dy + dz * dz);
      }
      if (prod > best) best = prod;
    }
    sj[t] = best > 0 ? Math.max(-1, Math.min(1, Math.SQRT2 * det / best)) : 0;
  }
  return sj;
}

/** Counts of sj values in `bins` equal bins over [-1, 1]. */
export function histogram(sj, bins) {
  const h = new Uint32Array(bins);
  for (let i = 0; i < sj.length; i++) {
    const b = Math.min(bins - 1, Math.max(0, Math.floor((sj[i] + 1) / 2 * bins)));
    h[b]++;
  }
  return h;
}

/** Tets with vertices on both sides of the plane n . x = c, n a unit [nx, ny, nz] (the crinkle cross-section). */
export function cutTetsAlong(V, T, n, c) {
  const m = T.length / 4, out = [];
  for (let t = 0; t < m; t++) {
    let below = 0;
    for (let k = 0; k < 4; k++) {
      const v = 3 * T[4 * t + k];
      if (n[0] * V[v] + n[1] * V[v + 1] + n[2] * V[v + 2] < c) below++;
    }
    if (below > 0 && below < 4) out.push(t);
  }
  return out;
}

/** Tets with vertices on both sides of the plane x[axis] = c (the crinkle cross-section). */
export function cutTets(V, T, axis, c) {
  const m = T.length / 4;
  const out = [];
  for (let t = 0; t < m; t++) {
    let below = 0;
    for (let k = 0; k < 4; k++) if (V[3 * T[4 * t + k] + axis] < c) below++;
    if (below > 0 && below < 4) out.push(t);
  }
  return out;
}

/** Triangles (vertex ids) of the four faces of each listed tet, outward for positive tets. */
export function tetFaces(T, tets) {
  const F = new Uint32Array(tets.length * 12);
  const faces = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
  let i = 0;
  for (const t of tets) {
    for (const f of faces) for (const k of f) F[i++] = T[4 * t + k];
  }
  return F;
}

const FACES = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];
const EDGES = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];
/** Cap of the aspect ratio of flat tets, as solver/validity/quality.py caps it. */
const ASPECT_CAP = 1e12;

/**
 * Per-tet quality metric, the definitions of solver/validity/quality.py: "aspect_ratio"
 * (h_max / (2 sqrt(6) r_in), 1 for the regular tet), "min_dihedral_deg" (the smallest of the six
 * interior dihedral angles, pi minus the angle of the outward normals of the two faces at an edge),
 * or "scaled_jacobian".
 */
export function tetMetric(V, T, metric, out) {
  if (metric === "scaled_jacobian") return scaledJacobians(V, T, out);
  const m = T.length / 4, q = out && out.length === m ? out : new Float32Array(m);
  const p = new Float64Array(12), n = new Float64Array(12);
  for (let t = 0; t < m; t++) {
    for (let k = 0; k < 4; k++) {
      const v = 3 * T[4 * t + k];
      p[3 * k] = V[v]; p[3 * k + 1] = V[v + 1]; p[3 * k + 2] = V[v + 2];
    }
    let area = 0;
    for (let f = 0; f < 4; f++) {  // area-weighted normals of the faces opposite each vertex
      const [a, b, c] = FACES[f];
      const ux = p[3 * b] - p[3 * a], uy = p[3 * b + 1] - p[3 * a + 1], uz = p[3 * b + 2] - p[3 * a + 2];
      const vx = p[3 * c] - p[3 * a], vy = p[3 * c + 1] - p[3 * a + 1], vz = p[3 * c + 2] - p[3 * a + 2];
      n[3 * f] = 0.5 * (uy * vz - uz * vy); n[3 * f + 1] = 0.5 * (uz * vx - ux * vz); n[3 * f + 2] = 0.5 * (ux * vy - uy * vx);
      area += Math.hypot(n[3 * f], n[3 * f + 1], n[3 * f + 2]);
    }
    if (metric === "aspect_ratio") {
      const ax = p[3] - p[0], ay = p[4] - p[1], az = p[5] - p[2];
      const bx = p[6] - p[0], by = p[7] - p[1], bz = p[8] - p[2];
      const cx = p[9] - p[0], cy = p[10] - p[1], cz = p[11] - p[2];
      const vol = Math.abs(ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6;
      let h2 = 0;
      for (const [i, j] of EDGES) {
        const dx = p[3 * j] - p[3 * i], dy = p[3 * j + 1] - p[3 * i + 1], dz = p[3 * j + 2] - p[3 * i + 2];
        h2 = Math.max(h2, dx * dx + dy * dy + dz * dz);
      }
      const rin = 3 * vol / Math.max(area, 1e-300);
      const ar = Math.sqrt(h2) / (2 * Math.sqrt(6) * rin);
      q[t] = Number.isFinite(ar) ? Math.min(ar, ASPECT_CAP) : ASPECT_CAP;
    } else {
      let lo = Infinity;
      for (const [i, j] of EDGES) {
        let k = -1, l = -1;
        for (let x = 0; x < 4; x++) if (x !== i && x !== j) { if (k < 0) k = x; else l = x; }
        const nk = Math.max(Math.hypot(n[3 * k], n[3 * k + 1], n[3 * k + 2]), 1e-300);
        const nl = Math.max(Math.hypot(n[3 * l], n[3 * l + 1], n[3 * l + 2]), 1e-300);
        const cos = -(n[3 * k] * n[3 * l] + n[3 * k + 1] * n[3 * l + 1] + n[3 * k + 2] * n[3 * l + 2]) / (nk * nl);
        lo = Math.min(lo, Math.acos(Math.min(1, Math.max(-1, cos))) * 180 / Math.PI);
      }
      q[t] = lo;
    }
  }
  return q;
}
