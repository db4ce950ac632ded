// Flood fill of a face region: click a boundary face with the fill tool and the region grows across
// the boundary faces next to it (sharing an edge) as long as the normal turns by less than the
// typed feature angle from one face to the next (normals of the rest shape). The nodes of the
// faces reached go into the region of the chosen role, as a box does (Shift adds, Ctrl subtracts).
import { $ } from "./dom.js";
import { fmt } from "./panels.js";
import { on, state } from "./state.js";

/** Unit normal of each boundary triangle of F over positions V (zeros for a degenerate one). */
export function faceNormals(V, F) {
  const N = new Float64Array(F.length);
  for (let f = 0; f < F.length; f += 3) {
    const a = 3 * F[f], b = 3 * F[f + 1], c = 3 * F[f + 2];
    const ux = V[b] - V[a], uy = V[b + 1] - V[a + 1], uz = V[b + 2] - V[a + 2];
    const vx = V[c] - V[a], vy = V[c + 1] - V[a + 1], vz = V[c + 2] - V[a + 2];
    const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
    const len = Math.hypot(nx, ny, nz);
    if (len > 0) { N[f] = nx / len; N[f + 1] = ny / len; N[f + 2] = nz / len; }
  }
  return N;
}

/** Faces around each edge: Map of edge key (lo * n + hi) to face ids. */
function edgeFaces(F, n) {
  const m = new Map();
  for (let f = 0; f < F.length / 3; f++) {
    for (let k = 0; k < 3; k++) {
      const a = F[3 * f + k], b = F[3 * f + (k + 1) % 3];
      const key = Math.min(a, b) * n + Math.max(a, b);
      const list = m.get(key);
      if (list) list.push(f); else m.set(key, [f]);
    }
  }
  return m;
}

export class FloodFill {
  constructor(viewer, regions, history) {
    this.viewer = viewer;
    this.regions = regions;
    this.history = history;
    this.cache = null;  // {F, normals, edges} of the open mesh
    on("mesh", () => { this.cache = null; });
    viewer.canvas.addEventListener("pointerdown", (ev) => this.down(ev));
  }

  tables() {
    if (!this.cache || this.cache.F !== state.F) {
      this.cache = { F: state.F, normals: faceNormals(state.V0, state.F), edges: edgeFaces(state.F, state.V0.length / 3) };
    }
    return this.cache;
  }

  /** The boundary face with corners a, b, c (any order), or -1. */
  faceOf(a, b, c) {
    const { F, edges } = this.tables(), n = state.V0.length / 3;
    for (const f of edges.get(Math.min(a, b) * n + Math.max(a, b)) || []) {
      if (F[3 * f] === c || F[3 * f + 1] === c || F[3 * f + 2] === c) return f;
    }
    return -1;
  }

  /** The faces reached from `seed` across edges where the normal turns by less than `angleDeg`. */
  fill(seed, angleDeg) {
    const { F, normals: N, edges } = this.tables(), n = state.V0.length / 3;
    const cos = Math.cos(angleDeg * Math.PI / 180), seen = new Uint8Array(F.length / 3), out = [seed], stack = [seed];
    seen[seed] = 1;
    while (stack.length) {
      const f = stack.pop();
      for (let k = 0; k < 3; k++) {
        const a = F[3 * f + k], b = F[3 * f + (k + 1) % 3];
        for (const g of edges.get(Math.min(a, b) * n + Math.max(a, b))) {
          if (seen[g]) continue;
          const dot = N[3 * f] * N[3 * g] + N[3 * f + 1] * N[3 * g + 1] + N[3 * f + 2] * N[3 * g + 2];
          if (dot > cos) { seen[g] = 1; out.push(g); stack.push(g); }
        }
      }
    }
    return out;
  }

  angle() {
    const a = Number($("fill-angle").value);
    return a > 0 && a <= 180 ? a : null;
  }

  down(ev) {
    if ($("tool-fill") === null || !$("tool-fill").checked || ev.button !== 0 || !state.V || this.regions.busy(ev)) return;
    const note = $("fill-note"), angle = this.angle();
    if (angle === null) { note.textContent = "the feature angle is a number of degrees, above 0 and at most 180"; return; }
    const hit = this.regions.pick(ev.clientX, ev.clientY);
    if (!hit || !hit.face) return;
    const seed = this.faceOf(hit.face.a, hit.face.b, hit.face.c);
    if (seed < 0) return;
    const faces = this.fill(seed, angle), F = state.F, mark = new Uint8Array(state.V0.length / 3), ids = [];
    for (const f of faces) for (let k = 0; k < 3; k++) mark[F[3 * f + k]] = 1;
    for (let i = 0; i < mark.length; i++) if (mark[i]) ids.push(i);
    note.textContent = `filled ${fmt(faces.length)} faces, ${fmt(ids.length)} nodes (normals turning < ${fmt(angle)}°)`;
    note.dataset.faces = String(faces.length);
    this.history.label(`fill ${fmt(faces.length)} faces at ${fmt(angle)}°`);
    this.regions.select(ids, ev, "replace");
  }
}
