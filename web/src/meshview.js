// The mesh in the view: the shaded boundary surface with its edges, the tets cut by the
// clipping plane, and the poor and inverted tets drawn through the surface. Positions come
// from the state (rest shape, then each streamed frame).
import * as THREE from "three";
import { cutTets, scaledJacobians, tetFaces } from "./quality.js";
import { emit, state } from "./state.js";

export const LOW_QUALITY = 0.2; // scaled Jacobian below which an element is coloured as poor
export const COLORS = { none: [0.78, 0.8, 0.83], fixed: [0.16, 0.4, 0.85], handle: [0.95, 0.55, 0.1] };

export class MeshView {
  constructor(viewer) {
    this.viewer = viewer;
    this.options = { edges: true, clip: false, clipAxis: 2, clipPos: 0.5, bad: true };
    this.clipPlane = new THREE.Plane(new THREE.Vector3(0, 0, -1), 0);
    this.surfGeom = new THREE.BufferGeometry();
    this.surfMat = new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.8, metalness: 0.0,
      side: THREE.DoubleSide, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
    this.surface = new THREE.Mesh(this.surfGeom, this.surfMat);
    this.edgeMat = new THREE.LineBasicMaterial({ color: 0x38424f, transparent: true, opacity: 0.35 });
    this.edges = null;
    this.cutGeom = new THREE.BufferGeometry();
    this.cutMesh = new THREE.Mesh(this.cutGeom, new THREE.MeshStandardMaterial({ vertexColors: true,
      side: THREE.DoubleSide, flatShading: true }));
    this.badGeom = new THREE.BufferGeometry();
    this.badMesh = new THREE.Mesh(this.badGeom, new THREE.MeshBasicMaterial({ vertexColors: true,
      transparent: true, opacity: 0.85, depthTest: false, side: THREE.DoubleSide }));
    this.badMesh.renderOrder = 10;
    viewer.scene.add(this.surface, this.cutMesh, this.badMesh);
  }

  /** Show the mesh of the state (after a new mesh was loaded into it). */
  load() {
    const g = this.surfGeom;
    g.setAttribute("position", new THREE.BufferAttribute(state.V, 3));
    g.setIndex(new THREE.BufferAttribute(state.F, 1));
    g.setAttribute("color", new THREE.BufferAttribute(new Float32Array(state.V.length), 3));
    g.computeVertexNormals();
    g.computeBoundingSphere();
    if (this.edges) { this.viewer.scene.remove(this.edges); this.edges.geometry.dispose(); }
    this.edges = new THREE.LineSegments(this.edgeGeometry(), this.edgeMat);
    this.edges.visible = this.options.edges;
    this.viewer.scene.add(this.edges);
    state.sjRest = scaledJacobians(state.V0, state.T);
    state.sj = state.sjRest.slice();
  }

  setEdges(on) {
    this.options.edges = on;
    if (this.edges) this.edges.visible = on;
  }

  /** Unique surface edges as an index into the shared position buffer (no copies per frame). */
  edgeGeometry() {
    const F = state.F, n = state.V.length / 3;
    const seen = new Set(), idx = [];
    for (let f = 0; f < F.length; f += 3) {
      for (let k = 0; k < 3; k++) {
        const a = F[f + k], b = F[f + (k + 1) % 3];
        const key = a < b ? a * n + b : b * n + a;
        if (!seen.has(key)) { seen.add(key); idx.push(a, b); }
      }
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute("position", this.surfGeom.getAttribute("position"));
    g.setIndex(new THREE.BufferAttribute(new Uint32Array(idx), 1));
    return g;
  }

  /** Bounding box of the surface as drawn. */
  box() {
    return new THREE.Box3().setFromBufferAttribute(this.surfGeom.getAttribute("position"));
  }

  /** Colour the surface by selection role. */
  recolor() {
    const col = this.surfGeom.getAttribute("color");
    const n = state.role.length;
    for (let i = 0; i < n; i++) {
      const c = state.role[i] === 1 ? COLORS.fixed : state.role[i] === 2 ? COLORS.handle : COLORS.none;
      col.array[3 * i] = c[0]; col.array[3 * i + 1] = c[1]; col.array[3 * i + 2] = c[2];
    }
    col.needsUpdate = true;
  }

  /** New positions (a frame, or the rest shape): normals, quality and derived views follow. */
  applyPositions(P) {
    const t0 = performance.now();
    state.V.set(P);
    this.surfGeom.getAttribute("position").needsUpdate = true;  // the edges share this buffer
    this.surfGeom.computeVertexNormals();
    this.surfGeom.computeBoundingSphere();
    state.sj = scaledJacobians(state.V, state.T, state.sj);
    state.frames += 1;
    this.refresh();
    state.applyMs = performance.now() - t0;
  }

  colorOf(sj) {
    if (sj <= 1e-12) return [0.85, 0.1, 0.1];
    if (sj < LOW_QUALITY) return [0.98, 0.6, 0.1];
    return [0.72, 0.8, 0.9];
  }

  trianglesOf(tets, geom) {
    const F = tetFaces(state.T, tets);
    const pos = new Float32Array(F.length * 3), col = new Float32Array(F.length * 3);
    for (let i = 0; i < F.length; i++) {
      const v = F[i];
      pos[3 * i] = state.V[3 * v]; pos[3 * i + 1] = state.V[3 * v + 1]; pos[3 * i + 2] = state.V[3 * v + 2];
      const c = this.colorOf(state.sj[tets[Math.floor(i / 12)]]);
      col[3 * i] = c[0]; col[3 * i + 1] = c[1]; col[3 * i + 2] = c[2];
    }
    geom.setAttribute("position", new THREE.BufferAttribute(pos, 3));
    geom.setAttribute("color", new THREE.BufferAttribute(col, 3));
    geom.computeVertexNormals();
    geom.computeBoundingSphere();
  }

  /** Cross-section, bad-element overlay, then tell the panels (signal "derived"). */
  refresh() {
    if (!state.V) return;
    const o = this.options;
    // cross-section: the surface is clipped, the tets cut by the plane are drawn coloured by quality
    if (o.clip) {
      const axis = o.clipAxis;
      let lo = Infinity, hi = -Infinity;
      for (let i = axis; i < state.V.length; i += 3) { lo = Math.min(lo, state.V[i]); hi = Math.max(hi, state.V[i]); }
      const c = lo + o.clipPos * (hi - lo);
      this.clipPlane.normal.set(0, 0, 0).setComponent(axis, -1);
      this.clipPlane.constant = c;
      this.surfMat.clippingPlanes = [this.clipPlane];
      this.edgeMat.clippingPlanes = [this.clipPlane];
      const tets = cutTets(state.V, state.T, axis, c);
      state.cut = tets.length;
      this.trianglesOf(tets, this.cutGeom);
    } else {
      this.surfMat.clippingPlanes = [];
      this.edgeMat.clippingPlanes = [];
      this.cutGeom.deleteAttribute("position");
      state.cut = 0;
    }
    this.cutMesh.visible = o.clip;
    this.surfMat.needsUpdate = true;
    this.edgeMat.needsUpdate = true;
    // inverted and poor elements, drawn through the surface
    const bad = [];
    if (o.bad) for (let t = 0; t < state.sj.length; t++) if (state.sj[t] < LOW_QUALITY) bad.push(t);
    state.badCount = bad.length;
    if (bad.length) this.trianglesOf(bad, this.badGeom); else this.badGeom.deleteAttribute("position");
    this.badMesh.visible = bad.length > 0;
    emit("derived");
  }
}
