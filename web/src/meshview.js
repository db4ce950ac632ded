// The mesh in the view: the shaded boundary surface with its edges, coloured by region, by
// displacement magnitude, or by element quality (each surface triangle flat in the colour of the
// tet it is a face of); the rest shape as a ghost; the tets cut by the clipping plane; and the
// poor and inverted tets drawn through the surface (clipped like it). Positions come from the
// state (rest shape, then each streamed frame).
import * as THREE from "three";
import { cutTetsAlong, scaledJacobians, tetFaces, tetMetric } from "./quality.js";
import { setBoundaryPositions, setPositions } from "./mesh.js";
import { claim, emit, state } from "./state.js";

// the owner of the state's "view" group: the view options and the views derived from the positions
const own = claim("view");

// poor and inverted tets: magenta and near-black, colours the displacement rainbow (blue to red
// through cyan, green and yellow) never takes, so the overlay reads on either colouring
export const QUALITY_COLORS = { inverted: [0.12, 0.12, 0.12], poor: [0.85, 0.0, 0.85], good: [0.72, 0.8, 0.9] };
export const NONE_COLOR = [0.78, 0.8, 0.83];
/** The vertices a feature candidate would select, while the pointer is on it in the list. */
export const PREVIEW_COLOR = [0.95, 0.45, 0.05];

/** Rainbow colour map (blue → cyan → green → yellow → red) of t in [0, 1], as CAE post-processors draw. */
export function rainbow(t) {
  const x = Math.min(1, Math.max(0, t)) * 4;
  const k = Math.min(3, Math.floor(x)), f = x - k;
  switch (k) {
    case 0: return [0, f, 1];
    case 1: return [0, 1, 1 - f];
    case 2: return [f, 1, 0];
    default: return [1, 1 - f, 0];
  }
}

/** The faces of a tet, as corner indices (any order: faces are matched as vertex sets). */
const TET_FACES = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

export const css = (c) => `rgb(${Math.round(255 * c[0])}, ${Math.round(255 * c[1])}, ${Math.round(255 * c[2])})`;

export class MeshView {
  constructor(viewer) {
    this.viewer = viewer;
    // clipNormal: the section plane's unit normal (an axis, or any direction); clipPos: where along it, 0..1;
    // clipFlip: false keeps the side below the plane (along the normal: below the cut), true the side above
    this.options = { edges: true, clip: false, clipAxis: 2, clipNormal: [0, 0, 1], clipPos: 0.5, clipFlip: false, bad: true,
      colorBy: "regions", ghost: false, qualityMetric: "scaled_jacobian" };
    /** Colour of vertex i by region, or null when it is in none (set by the selection). */
    this.regionColor = () => null;
    this.clipPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
    this.surfGeom = new THREE.BufferGeometry();
    this.surfMat = new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.8, metalness: 0.0,
      side: THREE.DoubleSide, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
    this.surface = new THREE.Mesh(this.surfGeom, this.surfMat);
    // the quality contour: the surface's triangles unshared, each flat in its tet's colour; drawn in
    // place of the surface (which stays, unseen, for picking and the edges)
    this.qualGeom = new THREE.BufferGeometry();
    this.qualMat = new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.8, metalness: 0.0,
      side: THREE.DoubleSide, flatShading: true, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
    this.qualMesh = new THREE.Mesh(this.qualGeom, this.qualMat);
    this.qualMesh.visible = false;
    this.edgeMat = new THREE.LineBasicMaterial({ color: 0x38424f, transparent: true, opacity: 0.35 });
    this.edges = null;
    this.cutGeom = new THREE.BufferGeometry();
    this.cutMesh = new THREE.Mesh(this.cutGeom, new THREE.MeshStandardMaterial({ vertexColors: true,
      side: THREE.DoubleSide, flatShading: true }));
    this.badGeom = new THREE.BufferGeometry();
    this.badMat = new THREE.MeshBasicMaterial({ vertexColors: true, transparent: true, opacity: 0.85,
      depthTest: false, side: THREE.DoubleSide });
    this.badMesh = new THREE.Mesh(this.badGeom, this.badMat);
    this.badMesh.renderOrder = 10;
    this.ghostGeom = new THREE.BufferGeometry();
    this.ghostMat = new THREE.MeshBasicMaterial({ color: 0x7d8a99, transparent: true, opacity: 0.22,
      depthWrite: false, side: THREE.DoubleSide });
    this.ghost = new THREE.Mesh(this.ghostGeom, this.ghostMat);
    this.ghostEdgeMat = new THREE.LineBasicMaterial({ color: 0x7d8a99, transparent: true, opacity: 0.35 });
    this.ghostEdges = null;
    this.ghost.visible = false;
    this.ghost.renderOrder = 5;
    for (const m of this.clipped()) m.clippingPlanes = [];
    viewer.scene.add(this.surface, this.qualMesh, this.cutMesh, this.badMesh, this.ghost);
    this.dispMax = 0;
  }

  /** The materials the section plane clips. */
  clipped() { return [this.surfMat, this.qualMat, this.edgeMat, this.badMat, this.ghostMat, this.ghostEdgeMat]; }

  /** Show the mesh of the state (after a new mesh was loaded into it). */
  load() {
    const g = this.surfGeom;
    g.setAttribute("position", new THREE.BufferAttribute(state.V, 3));
    g.setIndex(new THREE.BufferAttribute(state.F, 1));
    g.setAttribute("color", new THREE.BufferAttribute(new Float32Array(state.V.length), 3));
    g.computeVertexNormals();
    g.computeBoundingSphere();
    const scene = this.viewer.scene;
    if (this.edges) { scene.remove(this.edges); this.edges.geometry.dispose(); }
    const edgeIndex = this.edgeIndex();
    this.edges = new THREE.LineSegments(this.indexed(g.getAttribute("position"), edgeIndex), this.edgeMat);
    this.edges.visible = this.options.edges;
    scene.add(this.edges);
    // the rest shape, for the ghost
    const rest = new THREE.BufferAttribute(state.V0, 3);
    this.ghostGeom.setAttribute("position", rest);
    this.ghostGeom.setIndex(new THREE.BufferAttribute(state.F, 1));
    this.ghostGeom.computeBoundingSphere();
    if (this.ghostEdges) { this.ghost.remove(this.ghostEdges); this.ghostEdges.geometry.dispose(); }
    this.ghostEdges = new THREE.LineSegments(this.indexed(rest, edgeIndex), this.ghostEdgeMat);
    this.ghost.add(this.ghostEdges);
    this.ghost.visible = this.options.ghost;
    own.visibleFaces = state.F.length / 3;
    this.faceFilter = null;
    this.owners = null;
    this.qualFaces = null;
    this.qualMesh.visible = false;  // until the quality contour is chosen for this mesh
    this.surfMat.visible = true;
    own.sjRest = scaledJacobians(state.V0, state.T);
    own.sj = own.sjRest.slice();
    this.dispMax = 0;
    emit("frame");
  }

  /**
   * Draw only the surface triangles `keep(a, b, c)` accepts (null: all of them), edges alike; hidden
   * triangles cannot be picked either. Answers the number of triangles drawn.
   */
  setFaceFilter(keep) {
    const F = state.F;
    let idx = F;
    if (keep) {
      const out = [];
      for (let f = 0; f < F.length; f += 3) if (keep(F[f], F[f + 1], F[f + 2])) out.push(F[f], F[f + 1], F[f + 2]);
      idx = Uint32Array.from(out);
    }
    this.faceFilter = keep;
    this.surfGeom.setIndex(new THREE.BufferAttribute(idx, 1));
    const scene = this.viewer.scene;
    if (this.edges) { scene.remove(this.edges); this.edges.geometry.dispose(); }
    this.edges = new THREE.LineSegments(this.indexed(this.surfGeom.getAttribute("position"), this.edgeIndex(idx)),
      this.edgeMat);
    this.edges.visible = this.options.edges;
    scene.add(this.edges);
    own.visibleFaces = idx.length / 3;
    this.qualFaces = null;
    if (this.options.colorBy === "quality") this.recolor();
    emit("frame");
    return own.visibleFaces;
  }

  /** Surface opacity (1: opaque); below 1 the section and the poor tets show through. */
  setOpacity(a) {
    this.options.opacity = a;
    this.surfMat.opacity = a;
    this.surfMat.transparent = a < 1;
    this.surfMat.depthWrite = a >= 1;
    this.surfMat.needsUpdate = true;
    this.qualMat.opacity = a;
    this.qualMat.transparent = a < 1;
    this.qualMat.depthWrite = a >= 1;
    this.qualMat.needsUpdate = true;
  }

  /** Whether the section plane is on (the panels say how many tets it cuts). */
  setClip(on) {
    own.clip = on;
    emit("view-options");
  }

  /** The scaled Jacobian below which a tet counts as poor. */
  setThreshold(t) {
    own.threshold = t;
    emit("view-options");
  }

  setEdges(on) {
    this.options.edges = on;
    if (this.edges) this.edges.visible = on;
  }

  setGhost(on) {
    this.options.ghost = on;
    this.ghost.visible = on && !!state.V0;
  }

  setColorBy(mode) {
    this.options.colorBy = mode;
    this.recolor();
    this.refresh();  // the section's colours follow
    emit("legend");
  }

  /** Unique surface edges as an index (pairs of vertex ids). */
  edgeIndex(F = state.F) {
    const n = state.V.length / 3;
    const seen = new Set(), idx = [];
    for (let f = 0; f < F.length; f += 3) {
      for (let k = 0; k < 3; k++) {
        const a = F[f + k], b = F[f + (k + 1) % 3];
        const key = a < b ? a * n + b : b * n + a;
        if (!seen.has(key)) { seen.add(key); idx.push(a, b); }
      }
    }
    return new Uint32Array(idx);
  }

  /** A geometry over a shared position buffer (no copies per frame). */
  indexed(position, index) {
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", position);
    g.setIndex(new THREE.BufferAttribute(index, 1));
    return g;
  }

  /** Bounding box of the surface as drawn. */
  box() {
    return new THREE.Box3().setFromBufferAttribute(this.surfGeom.getAttribute("position"));
  }

  /**
   * Colour the surface: by region, or by displacement magnitude from the rest shape, scaled to the
   * largest over every node, interior ones included (a morph inside a fixed skin shows in the section).
   */
  recolor() {
    if (!state.V) return;
    const col = this.surfGeom.getAttribute("color").array;
    const n = state.V.length / 3;
    const quality = this.options.colorBy === "quality";
    this.surfMat.visible = !quality;
    this.qualMesh.visible = quality;
    if (quality) {
      this.colorByQuality();
    } else if (this.options.colorBy === "displacement") {
      const V = state.V, V0 = state.V0;
      let max = 0;
      const d = this.dispScratch && this.dispScratch.length === n ? this.dispScratch : (this.dispScratch = new Float32Array(n));
      for (let i = 0; i < n; i++) {
        const x = V[3 * i] - V0[3 * i], y = V[3 * i + 1] - V0[3 * i + 1], z = V[3 * i + 2] - V0[3 * i + 2];
        d[i] = Math.sqrt(x * x + y * y + z * z);
        if (d[i] > max) max = d[i];
      }
      this.dispMax = max;
      for (let i = 0; i < n; i++) {
        const c = rainbow(max > 0 ? d[i] / max : 0);
        col[3 * i] = c[0]; col[3 * i + 1] = c[1]; col[3 * i + 2] = c[2];
      }
    } else {
      for (let i = 0; i < n; i++) {
        const c = this.regionColor(i) || NONE_COLOR;
        col[3 * i] = c[0]; col[3 * i + 1] = c[1]; col[3 * i + 2] = c[2];
      }
    }
    if (this.preview) {
      for (const i of this.preview) { col[3 * i] = PREVIEW_COLOR[0]; col[3 * i + 1] = PREVIEW_COLOR[1]; col[3 * i + 2] = PREVIEW_COLOR[2]; }
    }
    this.surfGeom.getAttribute("color").needsUpdate = true;
  }

  /**
   * Quality contour, per element: each surface triangle flat in the colour of the tet it is a face
   * of (the lowest scaled Jacobian or dihedral angle, the highest aspect ratio is the worst), blue
   * for the best element of the mesh to red for the worst; `qualityRange` is [min, max] over the
   * tets. A triangle no tet has as a face (none on meshes read so far) is drawn grey.
   */
  colorByQuality() {
    const metric = this.options.qualityMetric;
    const q = this.qualityValues = tetMetric(state.V, state.T, metric, this.qualityValues);
    let lo = Infinity, hi = -Infinity;
    for (let t = 0; t < q.length; t++) { if (q[t] < lo) lo = q[t]; if (q[t] > hi) hi = q[t]; }
    this.qualityRange = [lo, hi];
    const owners = this.faceOwners(), faces = this.drawnFaces();
    if (!this.qualGeom.getAttribute("color") || this.qualGeom.getAttribute("color").count !== 3 * faces.length) {
      this.qualGeom.setAttribute("position", new THREE.BufferAttribute(new Float32Array(9 * faces.length), 3));
      this.qualGeom.setAttribute("color", new THREE.BufferAttribute(new Float32Array(9 * faces.length), 3));
    }
    const col = this.qualGeom.getAttribute("color").array;
    const shown = this.previewMask(state.V.length / 3), F = state.F;
    for (let k = 0; k < faces.length; k++) {
      const t = owners[faces[k]];
      const c = t >= 0 ? this.qualityColor(q[t]) : NONE_COLOR;
      for (let j = 0; j < 3; j++) {
        const d = shown && shown[F[3 * faces[k] + j]] ? PREVIEW_COLOR : c;  // a hovered candidate shows over the contour
        col[9 * k + 3 * j] = d[0]; col[9 * k + 3 * j + 1] = d[1]; col[9 * k + 3 * j + 2] = d[2];
      }
    }
    this.qualGeom.getAttribute("color").needsUpdate = true;
    this.placeQuality();
  }

  /** Per vertex, 1 where the preview is shown (null: no preview). */
  previewMask(n) {
    if (!this.preview) return null;
    const mask = new Uint8Array(n);
    for (const i of this.preview) mask[i] = 1;
    return mask;
  }

  /** The colour of a quality value: the contour's map over the mesh's range, red the worst. */
  qualityColor(v) {
    const [lo, hi] = this.qualityRange, span = hi - lo || 1;
    return rainbow(this.options.qualityMetric === "aspect_ratio" ? (v - lo) / span : (hi - v) / span);
  }

  /** The quality contour's triangles where the surface is now (flat normals). */
  placeQuality() {
    if (!this.qualMesh.visible || !this.qualFaces) return;
    const F = state.F, V = state.V, faces = this.qualFaces, pos = this.qualGeom.getAttribute("position").array;
    for (let k = 0; k < faces.length; k++) {
      for (let j = 0; j < 3; j++) {
        const v = 3 * F[3 * faces[k] + j];
        pos[9 * k + 3 * j] = V[v]; pos[9 * k + 3 * j + 1] = V[v + 1]; pos[9 * k + 3 * j + 2] = V[v + 2];
      }
    }
    this.qualGeom.getAttribute("position").needsUpdate = true;
    this.qualGeom.computeVertexNormals();
    this.qualGeom.computeBoundingSphere();
  }

  /** The surface triangles drawn (all, or those hide / isolate keeps), as indices into F. */
  drawnFaces() {
    if (this.qualFaces) return this.qualFaces;
    const F = state.F, keep = this.faceFilter, out = [];
    for (let f = 0; f < F.length / 3; f++) if (!keep || keep(F[3 * f], F[3 * f + 1], F[3 * f + 2])) out.push(f);
    return (this.qualFaces = Uint32Array.from(out));
  }

  /**
   * The tet each surface triangle is a face of (-1: none), found once per mesh: the triangles
   * bucketed by their smallest vertex, then every tet face with three boundary vertices looked up.
   */
  faceOwners() {
    const F = state.F, T = state.T, nf = F.length / 3;
    if (this.owners && this.owners.length === nf) return this.owners;
    const n = state.V.length / 3, start = new Uint32Array(n + 1), owners = new Int32Array(nf).fill(-1);
    const sort3 = (a, b, c) => {
      if (a > b) [a, b] = [b, a];
      if (b > c) [b, c] = [c, b];
      if (a > b) [a, b] = [b, a];
      return [a, b, c];
    };
    for (let f = 0; f < nf; f++) start[Math.min(F[3 * f], F[3 * f + 1], F[3 * f + 2]) + 1]++;
    for (let i = 0; i < n; i++) start[i + 1] += start[i];
    const fill = start.slice(0, n), mid = new Uint32Array(nf), max = new Uint32Array(nf), face = new Uint32Array(nf);
    for (let f = 0; f < nf; f++) {
      const [a, b, c] = sort3(F[3 * f], F[3 * f + 1], F[3 * f + 2]);
      const k = fill[a]++;
      mid[k] = b; max[k] = c; face[k] = f;
    }
    const B = state.boundary;
    for (let t = 0; t < T.length / 4; t++) {
      for (const [i, j, l] of TET_FACES) {
        const x = T[4 * t + i], y = T[4 * t + j], z = T[4 * t + l];
        if (!B[x] || !B[y] || !B[z]) continue;
        const [a, b, c] = sort3(x, y, z);
        for (let k = start[a]; k < start[a + 1]; k++) {
          if (mid[k] === b && max[k] === c && owners[face[k]] < 0) { owners[face[k]] = t; break; }
        }
      }
    }
    return (this.owners = owners);
  }

  /** The colour drawn on each surface triangle in the quality contour (null: not drawn, or another colouring). */
  faceColors() {
    const out = new Array(state.F ? state.F.length / 3 : 0).fill(null);
    if (!this.qualMesh.visible || !this.qualFaces) return out;
    const col = this.qualGeom.getAttribute("color").array;
    this.qualFaces.forEach((f, k) => { out[f] = Array.from(col.slice(9 * k, 9 * k + 3)); });
    return out;
  }

  /** The tets of the section and the colour each is drawn in. */
  sectionColors() {
    const col = this.cutGeom.getAttribute("color");
    const tets = this.cutTets || [];
    return { tets: Array.from(tets), colors: col ? tets.map((_, k) => Array.from(col.array.slice(36 * k, 36 * k + 3))) : [] };
  }

  setQualityMetric(metric) {
    this.options.qualityMetric = metric;
    if (this.options.colorBy === "quality") { this.recolor(); this.refresh(); emit("legend"); }
  }

  /** Show these vertices in the preview colour over any colouring (null: none). */
  setPreview(ids) {
    this.preview = ids && ids.length ? ids : null;
    this.recolor();
  }

  /** Boundary positions of a boundary-first frame (boundary vertices in ascending order): the surface only. */
  applyBoundary(B) {
    const t0 = performance.now();
    if (!this.boundaryIds || this.boundaryIds.length !== B.length / 3) {
      const ids = [];
      for (let i = 0; i < state.boundary.length; i++) if (state.boundary[i]) ids.push(i);
      this.boundaryIds = Int32Array.from(ids);
    }
    const ids = this.boundaryIds;
    if (ids.length * 3 !== B.length) return;  // not this mesh's boundary: wait for the full frame
    setBoundaryPositions(ids, B);
    this.surfGeom.getAttribute("position").needsUpdate = true;
    this.surfGeom.computeVertexNormals();
    this.placeQuality();
    own.boundaryFrames += 1;
    own.boundaryApplyMs = performance.now() - t0;
    emit("frame");
  }

  /** New positions (a frame, or the rest shape): normals, quality and derived views follow. */
  applyPositions(P) {
    const t0 = performance.now();
    setPositions(P);
    this.surfGeom.getAttribute("position").needsUpdate = true;  // the edges share this buffer
    this.surfGeom.computeVertexNormals();
    this.surfGeom.computeBoundingSphere();
    own.sj = scaledJacobians(state.V, state.T, own.sj);
    own.frames += 1;
    if (this.options.colorBy === "displacement" || this.options.colorBy === "quality") { this.recolor(); emit("legend"); }
    this.refresh();
    own.applyMs = performance.now() - t0;
    emit("frame");
  }

  colorOf(sj) {
    if (sj <= 1e-12) return QUALITY_COLORS.inverted;
    if (sj < state.threshold) return QUALITY_COLORS.poor;
    return QUALITY_COLORS.good;
  }

  /**
   * The four faces of each listed tet, each corner in colour(t, v) of its tet t and vertex v (default:
   * the tet's good, poor or inverted).
   */
  trianglesOf(tets, geom, colour = (t) => this.colorOf(state.sj[t])) {
    const F = tetFaces(state.T, tets);
    const pos = new Float32Array(F.length * 3), col = new Float32Array(F.length * 3);
    for (let i = 0; i < F.length; i++) {
      const v = F[i];
      pos[3 * i] = state.V[3 * v]; pos[3 * i + 1] = state.V[3 * v + 1]; pos[3 * i + 2] = state.V[3 * v + 2];
      const c = colour(tets[Math.floor(i / 12)], v);
      col[3 * i] = c[0]; col[3 * i + 1] = c[1]; col[3 * i + 2] = c[2];
    }
    geom.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    geom.setAttribute("color", new THREE.BufferAttribute(col, 3));
    geom.computeVertexNormals();
    geom.computeBoundingSphere();
  }

  /** Cross-section, bad-element overlay and counts, then tell the panels (signal "derived"). */
  refresh() {
    if (!state.V) return;
    const o = this.options;
    // cross-section: the surface is clipped, the tets cut by the plane are drawn coloured by quality
    const planes = o.clip ? [this.clipPlane] : [];
    if (o.clip) {
      const n = o.clipNormal, V = state.V;
      let lo = Infinity, hi = -Infinity;
      for (let i = 0; i < V.length; i += 3) {
        const d = n[0] * V[i] + n[1] * V[i + 1] + n[2] * V[i + 2];
        if (d < lo) lo = d;
        if (d > hi) hi = d;
      }
      const c = lo + o.clipPos * (hi - lo);
      // three.js keeps what is on the plane's positive side: n·x <= c, or n·x >= c flipped
      const sign = o.clipFlip ? 1 : -1;
      this.clipPlane.normal.set(sign * n[0], sign * n[1], sign * n[2]);
      this.clipPlane.constant = -sign * c;
      const tets = this.cutTets = cutTetsAlong(V, state.T, n, c);
      own.cut = tets.length;
      // with the quality contour on, the section's tets wear its metric's colours too; with the
      // displacement on, the section is coloured by it, corner by corner, on the surface's scale
      const q = o.colorBy === "quality" && this.qualityValues && this.qualityValues.length === state.T.length / 4
        ? this.qualityValues : null;
      const d = o.colorBy === "displacement" && this.dispScratch && this.dispScratch.length === V.length / 3
        ? this.dispScratch : null, max = this.dispMax;
      this.trianglesOf(tets, this.cutGeom, q ? (t) => this.qualityColor(q[t])
        : d ? (_t, v) => rainbow(max > 0 ? d[v] / max : 0) : undefined);
    } else {
      this.cutTets = null;
      this.cutGeom.deleteAttribute("position");
      this.cutGeom.deleteAttribute("color");
      own.cut = 0;
    }
    if (this.surfMat.clippingPlanes.length !== planes.length) {
      for (const m of this.clipped()) {
        m.clippingPlanes = planes;
        m.needsUpdate = true;
      }
    }
    this.cutMesh.visible = o.clip;
    // poor and inverted elements: counted always, drawn through the surface when asked
    const sj = state.sj, t = state.threshold;
    let count = 0, inverted = 0;
    for (let k = 0; k < sj.length; k++) if (sj[k] < t) { count++; if (sj[k] <= 1e-12) inverted++; }
    own.badCount = count;
    own.invertedTets = inverted;
    if (o.bad && count) {
      const bad = new Uint32Array(count);
      for (let k = 0, j = 0; k < sj.length; k++) if (sj[k] < t) bad[j++] = k;
      this.trianglesOf(bad, this.badGeom);
    } else {
      this.badGeom.deleteAttribute("position");
    }
    this.badMesh.visible = o.bad && count > 0;
    emit("derived");
  }
}
