// The open mesh: the owner of the state's "mesh" group (state.js). Opening a mesh, its length
// unit and its current positions are written here and nowhere else.
import { claim, emit } from "./state.js";

const own = claim("mesh");

/**
 * Make the mesh of a geometry bundle the open one.
 *
 * @param {string} id the mesh's id on the service
 * @param {object} header the bundle's header (name, sets, bbox, elements)
 * @param {object} meta the mesh's record (format, info)
 * @param {object} arrays the bundle's arrays (V, F, T, boundary, set:<name>; labels for a deck)
 */
export function loadMesh(id, header, meta, arrays) {
  own.meshId = id;
  own.meshName = header.name || id;
  own.meshFormat = meta.format;
  own.meshInfo = meta.info || {};
  own.V0 = Float32Array.from(arrays.V);
  own.V = Float32Array.from(arrays.V);
  own.F = arrays.F;
  own.T = arrays.T;
  own.boundary = arrays.boundary;
  const n = own.V.length / 3;
  // vertices that belong to an element: the mid-side nodes of quadratic elements do not
  const used = new Uint8Array(n);
  const src = own.T.length ? own.T : own.F;
  for (let k = 0; k < src.length; k++) used[src[k]] = 1;
  own.used = used;
  const sets = {};
  for (const name of header.sets) sets[name] = arrays[`set:${name}`];
  own.sets = sets;
  own.labels = arrays.labels || null;
  own.elementLabels = arrays.element_labels || null;
  own.elementIds = arrays.element_ids || null;
  own.tetElement = arrays.tet_element || null;
  const lo = header.bbox[0], hi = header.bbox[1];
  own.bbox = header.bbox;
  own.diag = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) || 1;
  // mixed meshes: T also carries the corner tets of hexahedra, wedges and pyramids
  own.elements = header.elements ?? own.T.length / 4;
  own.surface = own.elements === 0;
  own.units = localStorage.getItem(`tetmorph-units:${own.meshName}`) ?? "mm";
  emit("mesh");
}

/** The length unit shown, kept per mesh name in this browser. */
export function setUnits(units) {
  own.units = units;
  if (own.meshName) localStorage.setItem(`tetmorph-units:${own.meshName}`, units);
  emit("units");
}

/** New current positions (a frame, or the rest shape), written into the same array. */
export function setPositions(P) {
  own.V.set(P);
  emit("positions");
}

/** The boundary vertices' positions (`ids` ascending, `B` 3 coordinates each) of a boundary-first frame. */
export function setBoundaryPositions(ids, B) {
  const V = own.V;
  for (let k = 0; k < ids.length; k++) {
    const i = 3 * ids[k];
    V[i] = B[3 * k]; V[i + 1] = B[3 * k + 1]; V[i + 2] = B[3 * k + 2];
  }
  emit("positions");
}
