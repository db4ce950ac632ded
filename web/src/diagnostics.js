// Constraint diagnostics: the nodes of conflicting (and redundant) constraints, listed by node with
// the regions that hold each, the constraints on it and the residual; a click marks the node, flags
// its regions in the Regions list and frames it. The lists come from what the service says: the
// refusal of a SPEC or MOVE (details nodes, regions, residual), the REPORT of each frame
// (conflicting_constraints) and the session's constraints at rest (GET /v1/sessions/{id}).
// The cyclic faces' pairs are drawn too: each node of face A joined to the node of face B nearest
// to its image, coloured by the gap (blue: none, red: the tolerance or more).
import * as THREE from "three";
import { sessionSetup } from "./api.js";
import { $ } from "./dom.js";
import { fmt, unitText } from "./panels.js";
import { on, state } from "./state.js";

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

/** Rows by node from REPORT constraint entries: {node, names, residual, status}. */
function rowsOfEntries(entries, status) {
  const rows = new Map();
  for (const e of entries || []) {
    for (const v of e.vertices || []) {
      const r = rows.get(v) || { node: v, names: [], residual: 0, status };
      const label = `${e.kind} ${e.name}`;
      if (!r.names.includes(label)) r.names.push(label);
      r.residual = Math.max(r.residual, e.residual || 0);
      rows.set(v, r);
    }
  }
  return [...rows.values()];
}

export class Diagnostics {
  constructor(viewer, meshView, regions) {
    Object.assign(this, { viewer, meshView, regions });
    this.rows = [];
    this.source = "";
    this.marker = new THREE.Points(new THREE.BufferGeometry(),
      new THREE.PointsMaterial({ color: 0xe0115f, size: 12, sizeAttenuation: false, depthTest: false }));
    this.marker.renderOrder = 30;
    this.marker.visible = false;
    viewer.scene.add(this.marker);
    this.restRows = [];  // the open session's constraints at rest
    this.reportRows = [];  // the REPORT's conflicting constraints
    this.errorRows = [];   // a refusal's nodes
    $("diag-list").addEventListener("click", (ev) => {
      const li = ev.target.closest("li[data-node]");
      if (li) this.focus(Number(li.dataset.node));
    });
    on("error", () => {
      const e = state.error, d = (e && e.details) || {};
      this.errorRows = e && e.code === "conflicting_constraints" ? this.fromDetails(d) : [];
      this.render();
    });
    on("report", () => {
      const rep = state.report || {};
      this.reportRows = rowsOfEntries(rep.conflicting_constraints, "conflicting");
      this.render();
    });
    on("session", () => this.loadRest());
    on("mesh", () => { this.restRows = []; this.reportRows = []; this.errorRows = []; this.render(); });
    on("regions", () => this.flagRegions());
  }

  /** Rows of a refusal: its nodes and regions (the library's), or its REPORT's entries. */
  fromDetails(d) {
    if (Array.isArray(d.nodes)) {
      return d.nodes.map((v, k) => ({ node: v, names: (d.regions && d.regions[k]) || [], residual: d.residual || 0,
        status: "conflicting", fromService: true }));
    }
    return rowsOfEntries((d.report || {}).conflicting_constraints || d.conflicting_constraints, "conflicting");
  }

  async loadRest() {
    const id = state.sessionId;
    this.restRows = [];
    this.render();
    if (!id) return;
    let doc;
    try { doc = await sessionSetup(id); } catch { return; }
    if (state.sessionId !== id) return;
    const rest = doc.constraints_at_rest || {};
    this.restRows = [...rowsOfEntries(rest.conflicting_constraints, "conflicting"),
      ...rowsOfEntries(rest.redundant_constraints, "redundant")];
    this.render();
  }

  /** The editor's regions holding vertex v (by name). */
  regionsOf(v) {
    const r = this.regions.owner ? this.regions.byId.get(this.regions.owner[v]) : null;
    return r ? [r.name] : [];
  }

  render() {
    // a refusal first, then the REPORT shown, then what the session found at rest
    const [rows, source] = this.errorRows.length ? [this.errorRows, "refused"]
      : this.reportRows.length ? [this.reportRows, "this move"] : [this.restRows, "at rest"];
    this.rows = rows.slice().sort((a, b) => (a.status === b.status ? a.node - b.node : a.status === "conflicting" ? -1 : 1));
    this.source = source;
    const el = $("diag"), list = $("diag-list");
    el.hidden = !this.rows.length;
    if (!this.rows.length) { this.focus(null); list.innerHTML = ""; return; }
    const nc = this.rows.filter((r) => r.status === "conflicting").length, nr = this.rows.length - nc;
    $("diag-note").textContent = `${source}: ${nc} node${nc === 1 ? "" : "s"} of conflicting constraints` +
      (nr ? `, ${nr} of redundant ones (they hold)` : "") + "; click one to see it";
    list.innerHTML = this.rows.map((r) => {
      const regs = r.fromService ? r.names : [...this.regionsOf(r.node), ...r.names];
      const label = state.labels ? `node ${state.labels[r.node]} (vertex ${r.node})` : `vertex ${r.node}`;
      const res = r.status === "conflicting" ? ` · residual ${fmt(r.residual)}${unitText()}` : " · redundant";
      return `<li data-node="${r.node}" data-status="${r.status}" class="${r.status}"><span class="name">${esc(label)}</span>` +
        `<span class="muted" data-key="regions">${esc(regs.join(", "))}</span><span data-key="residual">${esc(res)}</span></li>`;
    }).join("");
  }

  /** Mark vertex v (null: nothing), flag its regions and frame it. */
  focus(v) {
    this.focused = v;
    for (const li of $("diag-list").querySelectorAll("li")) li.classList.toggle("active", Number(li.dataset.node) === v);
    if (v === null || !state.V) {
      this.marker.visible = false;
      this.flagRegions();
      this.viewer.draw();
      return;
    }
    const p = new THREE.Vector3(state.V[3 * v], state.V[3 * v + 1], state.V[3 * v + 2]);
    this.marker.geometry.setAttribute("position", new THREE.Float32BufferAttribute(p.toArray(), 3));
    this.marker.visible = true;
    this.meshView.setPreview([v]);
    this.flagRegions();
    const half = 0.08 * state.diag;
    this.viewer.fit(new THREE.Box3(p.clone().subScalar(half), p.clone().addScalar(half)));
    this.viewer.draw();
  }

  /** In the Regions list, flag the regions that hold the focused node. */
  flagRegions() {
    const row = this.rows.find((r) => r.node === this.focused);
    const names = new Set(row ? [...this.regionsOf(row.node), ...row.names] : []);
    for (const li of $("regions").querySelectorAll("li[data-id]")) {
      const r = this.regions.byId.get(Number(li.dataset.id));
      li.classList.toggle("flagged", !!r && names.has(r.name));
    }
  }
}

/** Rotation of p about the axis (point c, unit direction d) by angle a (radians), into out. */
function rotate(p, c, d, a, out) {
  return out.copy(p).sub(c).applyAxisAngle(d, a).add(c);
}

/**
 * The pairs of a SPEC cyclic entry: every node of face A with the node of face B nearest to A's
 * image turned by the angle, and the gap. Answers {a, b, gap} (vertex ids, model units), or null
 * when a face is not a set or region of the open mesh.
 */
export function cyclicPairs(entry, idsOf) {
  const A = idsOf(entry.faces[0]), B = idsOf(entry.faces[1]);
  if (!A || !B || !A.length || !B.length) return null;
  const V = state.V0, c = new THREE.Vector3(...entry.axis.point), d = new THREE.Vector3(...entry.axis.direction).normalize();
  const ang = entry.angle_deg * Math.PI / 180;
  // a grid over B of cells about the spacing of its nodes
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (const j of B) for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], V[3 * j + k]); hi[k] = Math.max(hi[k], V[3 * j + k]); }
  const span = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-12);
  const h = span / Math.max(1, Math.cbrt(B.length) * 2), cells = new Map();
  const key = (x, y, z) => `${Math.floor((x - lo[0]) / h)},${Math.floor((y - lo[1]) / h)},${Math.floor((z - lo[2]) / h)}`;
  for (const j of B) {
    const kk = key(V[3 * j], V[3 * j + 1], V[3 * j + 2]);
    const list = cells.get(kk);
    if (list) list.push(j); else cells.set(kk, [j]);
  }
  const a = [], b = [], gap = [], p = new THREE.Vector3(), q = new THREE.Vector3();
  for (const i of A) {
    rotate(p.set(V[3 * i], V[3 * i + 1], V[3 * i + 2]), c, d, ang, q);
    const cx = Math.floor((q.x - lo[0]) / h), cy = Math.floor((q.y - lo[1]) / h), cz = Math.floor((q.z - lo[2]) / h);
    let best = -1, bd = Infinity;
    for (let r = 1; r <= 64 && best < 0; r *= 2) {  // widen the search until a node is found
      for (let x = cx - r; x <= cx + r; x++) for (let y = cy - r; y <= cy + r; y++) for (let z = cz - r; z <= cz + r; z++) {
        for (const j of cells.get(`${x},${y},${z}`) || []) {
          const dd = (V[3 * j] - q.x) ** 2 + (V[3 * j + 1] - q.y) ** 2 + (V[3 * j + 2] - q.z) ** 2;
          if (dd < bd) { bd = dd; best = j; }
        }
      }
    }
    if (best < 0) {  // far outside the grid: every node of B
      for (const j of B) {
        const dd = (V[3 * j] - q.x) ** 2 + (V[3 * j + 1] - q.y) ** 2 + (V[3 * j + 2] - q.z) ** 2;
        if (dd < bd) { bd = dd; best = j; }
      }
    }
    a.push(i); b.push(best); gap.push(Math.sqrt(bd));
  }
  return { a, b, gap };
}

/** The cyclic pairs drawn in the view (a checkbox of the symmetry panel), with their largest gap. */
export class CyclicPairs {
  constructor(viewer, regions) {
    Object.assign(this, { viewer, regions });
    this.group = new THREE.Group();
    this.group.renderOrder = 26;
    viewer.scene.add(this.group);
    this.result = [];
    $("cyc-pairs").addEventListener("change", () => this.render());
    on("regions", () => this.render());
    on("mesh", () => this.render());
  }

  /** Vertex ids of a face: a region, a named set, or a selection kept for the SPEC. */
  idsOf(name) {
    const r = state.regions.find((x) => x.name === name);
    if (r) return this.regions.idsOf(r);
    if (state.sets && state.sets[name]) return Array.from(state.sets[name]);
    const sel = this.regions.extraSelections[name];
    return sel ? this.regions.resolve(sel) : null;
  }

  render() {
    for (const m of [...this.group.children]) { this.group.remove(m); m.geometry.dispose(); m.material.dispose(); }
    this.result = [];
    const note = $("cyc-pairs-note");
    if (!$("cyc-pairs").checked || !state.V) { note.textContent = ""; this.viewer.draw(); return; }
    const lines = [];
    for (const c of this.regions.specExtra.cyclic || []) {
      const pr = cyclicPairs(c, (n) => this.idsOf(n));
      if (!pr) { lines.push(`${c.name}: faces not found`); continue; }
      const tol = c.tolerance || 1e-3 * state.diag;  // the service's default tolerance is relative to the size
      const pos = [], col = [], V = state.V0;
      let worst = 0;
      for (let k = 0; k < pr.a.length; k++) {
        const i = pr.a[k], j = pr.b[k], t = Math.min(1, pr.gap[k] / tol);
        if (pr.gap[k] > pr.gap[worst]) worst = k;
        pos.push(V[3 * i], V[3 * i + 1], V[3 * i + 2], V[3 * j], V[3 * j + 1], V[3 * j + 2]);
        const rgb = [0.1 + 0.85 * t, 0.3 * (1 - t), 0.9 * (1 - t)];
        col.push(...rgb, ...rgb);
      }
      const g = new THREE.BufferGeometry();
      g.setAttribute("position", new THREE.Float32BufferAttribute(pos, 3));
      g.setAttribute("color", new THREE.Float32BufferAttribute(col, 3));
      const seg = new THREE.LineSegments(g, new THREE.LineBasicMaterial({ vertexColors: true, depthTest: false }));
      seg.renderOrder = 26;
      this.group.add(seg);
      const name = (v) => (state.labels ? `node ${state.labels[v]}` : `vertex ${v}`);
      this.result.push({ name: c.name, pairs: pr.a.length, max: pr.gap[worst], a: pr.a[worst], b: pr.b[worst], tolerance: tol });
      lines.push(`${c.name}: ${fmt(pr.a.length)} pairs, largest gap ${fmt(pr.gap[worst])}${unitText()} ` +
        `(${name(pr.a[worst])} → ${name(pr.b[worst])}), ${pr.gap.filter((x) => x > tol).length} beyond the tolerance ${fmt(tol)}`);
    }
    note.textContent = lines.join("\n");
    this.viewer.draw();
  }
}
