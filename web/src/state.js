// The editor's state, grouped by the module that owns each field, plus the signals through which
// an owner says what it changed (the three.js editor's Editor + Signals, in miniature).
//
// Every module reads the state through `state`, whose fields are getters only: assigning one
// throws. The owner of a group takes the group's writer once, with `claim(group)`, and writes
// only inside its own methods, each of which ends by emitting one of SIGNALS. A second claim
// throws, and so does emitting (or listening to) a name SIGNALS does not declare, so a typo
// cannot pass silently. ESLint (web/eslint.config.js) refuses `state.x = ...` and mutating
// calls on state fields everywhere, and a claim of another module's group.

/** The fields, each declared once, by group; the comment after a group's name is its owner. */
const GROUPS = {
  // mesh.js: the open mesh
  mesh: {
    meshId: null,      // id on the service
    meshName: "",      // file name shown
    meshFormat: null,  // format it was uploaded in ("arrays": sent as arrays)
    meshInfo: {},      // what reading it reported (dropped cells, ...)
    V0: null,          // rest positions, Float32Array of 3n
    V: null,           // current positions (rewritten in place by setPositions / setBoundaryPositions)
    F: null,           // boundary triangles, 3 vertex ids each
    T: null,           // tets, 4 vertex ids each (the corner tets of every element)
    boundary: null,    // 1 per vertex on the boundary
    used: null,        // 1 per vertex of an element (mid-side nodes of quadratic elements are not)
    sets: {},          // named node sets: name -> vertex ids
    labels: null,      // the deck's own node number per vertex (Abaqus, Nastran, CDB, LS-DYNA), or null
    elementLabels: null, // the deck's element number per row of T, or null
    elementIds: null,  // the deck's id of each element where they are not 1, 2, ... (else null)
    tetElement: null,  // the element of each row of T for mixed meshes (else null: row k is element k)
    elements: 0,       // element count (0: a surface)
    surface: false,    // a surface mesh (no elements): it must be tetrahedralized first
    diag: 1,           // bounding-box diagonal
    bbox: null,        // [[x, y, z], [x, y, z]]
    units: "",         // length unit shown ("mm", ...), kept per mesh name in this browser
  },
  // selection.js: the regions
  selection: {
    regions: [],        // [{id, name, kind: "fixed"|"handle", color, visible, count, source}]
    activeRegion: null, // id of the region new selections go into
    role: null,         // per vertex, Uint8Array: 0 none, 1 fixed, 2 handle
  },
  // gizmo.js: the handles' moves and their history
  moves: {
    transforms: {},   // handle name -> {centroid, t, q, s}
    centroid: null,   // centroid of the active handle
    history: [{ label: "rest", move: null }],  // undo history, entry 0 the rest shape
    historyIndex: 0,  // the entry shown
    moves: [],        // the history's MOVEs (entries 1..)
    lastMove: null,   // the MOVE the session holds (as far as this tab knows)
  },
  // session.js: the session and its stream
  session: {
    sessionId: null,  // the open session
    specSent: null,   // the SPEC it was created from
    presets: [],      // its named presets, as the service keeps them
    ws: null,         // its stream (stream.js Stream)
    seq: 0,           // seq of the last MOVE sent
    lastSeq: 0,       // seq of the last MOVE answered (a frame or a refusal)
    sentAt: 0,        // performance.now() of the last send
    roundTripMs: undefined,         // send to full frame, of the last MOVE answered in full
    boundaryRoundTripMs: undefined, // send to boundary frame drawn
    boundaryReceived: 0,  // boundary frames received
    boundarySkipped: 0,   // boundary frames never drawn (overtaken by their full frame)
  },
  // meshview.js: view options and the views derived from the positions
  view: {
    clip: false,        // the section plane is on
    threshold: 0.2,     // scaled Jacobian below which a tet is poor
    visibleFaces: 0,    // surface triangles drawn (hide / isolate)
    sjRest: null,       // scaled Jacobian per tet at rest
    sj: null,           // scaled Jacobian per tet now
    frames: 0,          // position updates applied
    applyMs: 0,         // time the last one took
    boundaryFrames: 0,  // boundary frames applied
    boundaryApplyMs: 0, // time the last one took
    cut: 0,             // tets in the section
    badCount: 0,        // tets below the threshold
    invertedTets: 0,    // inverted tets
  },
  // panels.js: feedback
  feedback: {
    error: null,        // the error shown (messages.js explain()), or null
    report: null,       // the REPORT shown
    busy: null,         // {what, t0, delayMs, shown} while busy
    busyLog: [],        // the last busy spells: [{what, ms, shown}]
    histogramTicks: [], // labels of the quality histogram's count axis
  },
  // shapes.js: the design of experiments
  shapes: {
    doeJob: null,       // id of the last batch run
  },
};

/** The module that owns each group (for the error an assignment raises). */
const OWNERS = { mesh: "mesh.js", selection: "selection.js", moves: "gizmo.js", session: "session.js",
  view: "meshview.js", feedback: "panels.js", shapes: "shapes.js" };

/** Every signal, with who emits it and what it says. */
export const SIGNALS = Object.freeze([
  "mesh",            // mesh.js: a mesh was opened
  "units",           // mesh.js: the length unit changed
  "positions",       // mesh.js: the current positions changed
  "regions",         // selection.js: regions added, removed, renamed, activated or changed
  "selection",       // selection.js: membership of vertices changed
  "history",         // gizmo.js: the history or the entry shown changed
  "active-handle",   // gizmo.js: the handle the gizmo is on (name, or null)
  "last-move",       // gizmo.js: the MOVE the session holds changed
  "session",         // session.js: a session was opened or closed
  "stream",          // session.js: a MOVE was sent or answered, the stream opened or closed
  "presets",         // session.js: the session's presets changed
  "sessions-changed", // session.js: sessions were created or deleted on the service
  "open-sessions",   // panels.js: the user asked for the session list
  "view-options",    // meshview.js: the section or the threshold changed
  "frame",           // meshview.js: positions applied (counts and times)
  "derived",         // meshview.js: the derived views were recomputed
  "legend",          // meshview.js: the colour legend needs drawing
  "error",           // panels.js: an error was shown or cleared
  "report",          // panels.js: the REPORT shown changed
  "busy",            // panels.js: busy started or ended
  "histogram",       // panels.js: the quality histogram was drawn
  "doe-job",         // shapes.js: a batch run finished
]);
const declared = new Set(SIGNALS);

const store = {};
const readView = {};
for (const [group, fields] of Object.entries(GROUPS)) {
  for (const [k, v] of Object.entries(fields)) {
    if (k in store) throw new Error(`state.${k} is declared twice`);
    store[k] = v;
    Object.defineProperty(readView, k, {
      enumerable: true,
      get: () => store[k],
      set: () => { throw new TypeError(`state.${k} is read-only here: it is written by ${OWNERS[group]}`); },
    });
  }
}

/** The state, read-only: every field a getter; assigning one, or adding a field, throws. */
export const state = Object.freeze(readView);

const claimed = new Set();

/**
 * The writer of one group, for its owner module only (a second claim throws): its fields are
 * readable and assignable; any other name throws.
 */
export function claim(group) {
  if (!(group in GROUPS)) throw new Error(`no state group ${group}`);
  if (claimed.has(group)) throw new Error(`the state group ${group} is claimed already (owner: ${OWNERS[group]})`);
  claimed.add(group);
  const writer = {};
  for (const k of Object.keys(GROUPS[group])) {
    Object.defineProperty(writer, k, { enumerable: true, get: () => store[k], set: (v) => { store[k] = v; } });
  }
  return Object.freeze(writer);
}

const handlers = new Map();

function check(name) {
  if (!declared.has(name)) throw new Error(`undeclared signal ${name}: declare it in SIGNALS (state.js)`);
}

/** Subscribe to a signal; returns a function that unsubscribes. */
export function on(name, fn) {
  check(name);
  if (!handlers.has(name)) handlers.set(name, new Set());
  handlers.get(name).add(fn);
  return () => handlers.get(name).delete(fn);
}

/** Tell every subscriber of `name`. */
export function emit(name, ...args) {
  check(name);
  for (const fn of handlers.get(name) || []) fn(...args);
}
