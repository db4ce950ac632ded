// The test hook: what automation (the browser tests, the documentation's pictures) reads of the
// editor's state, through named read-only accessors. Not an API for users or other code: the
// editor itself never reads it, and it may change with the tests that use it.
//
// Every accessor answers a copy (changing it changes nothing in the editor):
//
//   tetmorph.mesh()      {open, id, name, vertices, elements, diag} of the open mesh
//                        (open false, id null and vertices 0 before one is opened)
//   tetmorph.rest()      rest positions, [x0, y0, z0, x1, ...]          (null: no mesh)
//   tetmorph.tets()      tets, 4 vertex ids each (the corner tets of every element)
//   tetmorph.boundary()  per vertex, 1 on the boundary, else 0
//   tetmorph.set(name)   the vertex ids of a named set of the file      (null: no such set)
//   tetmorph.role()      per vertex, 0 in no region, 1 fixed, 2 handle  (null: no mesh)
//   tetmorph.session()   {id, stream, seq, lastSeq, lastMove, presets, historyLength, roundTripMs,
//                        boundaryRoundTripMs, boundaryReceived, boundarySkipped}: the open session
//                        (id null: none); stream is {open, readyState} of its WebSocket, or null;
//                        seq is the last MOVE sent, lastSeq the last answered; presets
//                        [{name, move}]; the round trips (ms) are of the last MOVE answered
//   tetmorph.history()   {index, entries: [{label, move}]}: the undo history, entry 0 the rest
//                        shape (move null), entry index the one shown
//   tetmorph.view()      {clip, threshold, cut, badCount, invertedTets, visibleFaces, frames,
//                        applyMs, boundaryFrames, boundaryApplyMs}: view options, and the counts
//                        and times (ms) derived from the positions
//   tetmorph.quality()   scaled Jacobian per tet, now                   (null: no mesh)
//   tetmorph.report()    the REPORT the panel shows, or null
//   tetmorph.error()     the error shown ({code, message, text, ...}), or null
//   tetmorph.busyLog()   the last busy spells, [{what, ms, shown}]
//
// main.js adds the helpers that say where things are on screen (pivotScreen, screenOf, camera, ...).
import { state } from "./state.js";

const list = (a) => (a ? Array.from(a) : null);
const copy = (x) => (x === null || x === undefined ? null : structuredClone(x));

/** The state accessors of window.tetmorph (see the list above). */
export function stateAccessors() {
  return {
    mesh: () => ({ open: state.V !== null, id: state.meshId, name: state.meshName,
      vertices: state.V ? state.V.length / 3 : 0, elements: state.elements, diag: state.diag }),
    rest: () => list(state.V0),
    tets: () => list(state.T),
    boundary: () => list(state.boundary),
    set: (name) => (Object.hasOwn(state.sets, name) ? list(state.sets[name]) : null),
    role: () => list(state.role),
    session: () => ({
      id: state.sessionId,
      stream: state.ws ? { open: state.ws.open, readyState: state.ws.readyState } : null,
      seq: state.seq, lastSeq: state.lastSeq, lastMove: copy(state.lastMove),
      presets: copy(state.presets), historyLength: state.history.length,
      roundTripMs: state.roundTripMs, boundaryRoundTripMs: state.boundaryRoundTripMs,
      boundaryReceived: state.boundaryReceived, boundarySkipped: state.boundarySkipped,
    }),
    history: () => ({ index: state.historyIndex,
      entries: state.history.map((e) => ({ label: e.label, move: copy(e.move) })) }),
    view: () => ({ clip: state.clip, threshold: state.threshold, cut: state.cut, badCount: state.badCount,
      invertedTets: state.invertedTets, visibleFaces: state.visibleFaces, frames: state.frames,
      applyMs: state.applyMs, boundaryFrames: state.boundaryFrames, boundaryApplyMs: state.boundaryApplyMs }),
    quality: () => list(state.sj),
    report: () => copy(state.report),
    error: () => copy(state.error),
    busyLog: () => copy(state.busyLog),
  };
}
