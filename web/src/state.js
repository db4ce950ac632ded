// The editor's state: one object every module reads, plus a small signal bus through which
// modules say what changed (the three.js editor's Editor + Signals, in miniature).

export const state = {
  // the open mesh: rest and current positions, boundary faces, tets (corner tets of every
  // element), which vertices are on the boundary and which belong to an element
  meshId: null, meshName: "", V0: null, V: null, F: null, T: null, boundary: null, used: null, sets: {},
  elements: 0, diag: 1, bbox: null, units: "",
  // selection: 0 none, 1 fixed, 2 handle, per vertex (derived from the regions)
  role: null,
  // the session and its stream
  sessionId: null, ws: null, seq: 0, lastSeq: 0, sentAt: 0, roundTripMs: undefined,
  moves: [], lastMove: null, centroid: null,
  // derived views
  sjRest: null, sj: null, report: null, frames: 0, applyMs: 0, cut: 0, clip: false,
  threshold: 0.2, badCount: 0, invertedTets: 0,
  // feedback
  error: null, busy: null, busyLog: [],
};

const handlers = new Map();

/** Subscribe to a signal; returns a function that unsubscribes. */
export function on(name, fn) {
  if (!handlers.has(name)) handlers.set(name, new Set());
  handlers.get(name).add(fn);
  return () => handlers.get(name).delete(fn);
}

/** Tell every subscriber of `name`. */
export function emit(name, ...args) {
  for (const fn of handlers.get(name) || []) fn(...args);
}
