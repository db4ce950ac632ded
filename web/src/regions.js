// Region editing beyond painting: rename and merge regions, pick nodes or elements by the deck's
// own ids and ranges ("1-100, 205, 300-310"), and undo / redo of region edits. Region edits have
// a history of their own (RegionHistory); Ctrl+Z and Ctrl+Shift+Z (or Ctrl+Y) act on the kind of
// edit made last, region edit or move (UndoKeys), and the Regions panel says which.
import { $ } from "./dom.js";
import { fmt } from "./panels.js";
import { on, state } from "./state.js";

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
/** Most steps the region history keeps. */
const HISTORY_MAX = 100;

/**
 * Ranges of ids typed as "1-100, 205, 300-310" (commas or spaces between the parts; a part is an
 * id or lo-hi). Answers [[lo, hi], ...]; throws an Error naming the first part that is neither.
 */
export function parseRanges(text) {
  const parts = String(text).split(/[\s,;]+/).filter(Boolean);
  if (!parts.length) throw new Error("type ids or ranges, e.g. 1-100, 205, 300-310");
  return parts.map((p) => {
    const m = /^(\d+)(?:-(\d+))?$/.exec(p);
    if (!m) throw new Error(`“${p}” is neither an id nor a range lo-hi`);
    const lo = Number(m[1]), hi = m[2] === undefined ? lo : Number(m[2]);
    if (hi < lo) throw new Error(`the range “${p}” runs backwards`);
    return [lo, hi];
  });
}

/** A test id -> whether it is in `ranges` (sorted, binary search). */
function inRanges(ranges) {
  const r = ranges.slice().sort((a, b) => a[0] - b[0]);
  return (id) => {
    let lo = 0, hi = r.length - 1;
    while (lo <= hi) {
      const mid = (lo + hi) >> 1;
      if (id < r[mid][0]) hi = mid - 1; else if (id > r[mid][1]) lo = mid + 1; else return true;
    }
    return false;
  };
}

/** Vertex counts per region id of an owner array. */
function countsOf(owner) {
  const c = new Map();
  for (let i = 0; i < owner.length; i++) if (owner[i]) c.set(owner[i], (c.get(owner[i]) || 0) + 1);
  return c;
}

const sameArray = (a, b) => a === b || (!!a && !!b && a.length === b.length && a.every((x, i) => x === b[i]));
const shape = (snap) => JSON.stringify(snap.regions.map((r) => [r.id, r.name, r.kind, r.handleName || ""]));

/** What changed from snapshot a to b, in words (the history's label when none was given). */
function describe(a, b) {
  const before = new Map(a.regions.map((r) => [r.id, r])), after = new Map(b.regions.map((r) => [r.id, r]));
  const out = [];
  for (const r of b.regions) {
    const old = before.get(r.id);
    if (!old) out.push(`new ${r.kind} ${r.name}`);
    else if (old.name !== r.name) out.push(`rename ${old.name} → ${r.name}`);
  }
  for (const r of a.regions) if (!after.has(r.id)) out.push(`delete ${r.name}`);
  const ca = countsOf(a.owner), cb = countsOf(b.owner);
  for (const r of b.regions) {
    const x = ca.get(r.id) || 0, y = cb.get(r.id) || 0;
    if (x !== y && before.has(r.id)) out.push(`${r.name} ${fmt(x)} → ${fmt(y)}`);
  }
  if (!sameArray(a.domain, b.domain)) out.push("domain");
  return out.join(", ") || "regions";
}

/** Undo and redo of region edits: snapshots taken after each edit (a brush stroke is one edit). */
export class RegionHistory {
  constructor(regions) {
    this.regions = regions;
    this.undoStack = [];
    this.redoStack = [];
    this.base = null;       // the regions as of the last step
    this.nextLabel = null;  // the label of the edit being made, when its maker says it
    this.queued = false;
    this.onChange = () => {};
    regions.history = this;  // Regions.reset() clears it
    on("regions", () => this.schedule());
    on("selection", () => this.schedule());
    // a stroke of the brush is one step: taken when the pointer is released
    regions.viewer.canvas.addEventListener("pointerup", () => this.schedule());
  }

  clear() { this.undoStack = []; this.redoStack = []; this.base = null; this.nextLabel = null; this.onChange(); }

  /** Say what the edit about to be made is (shown in the history). */
  label(text) { this.nextLabel = text; }

  schedule() {
    if (this.queued) return;
    this.queued = true;
    queueMicrotask(() => { this.queued = false; this.commit(); });
  }

  /** Take a step when the regions differ from the last one (not during a box or brush drag). */
  commit() {
    if (!state.V || this.regions.drag || !this.regions.owner) return;
    const snap = this.regions.snapshot();
    const base = this.base;
    if (!base || base.owner.length !== snap.owner.length) { this.base = snap; this.nextLabel = null; return; }
    if (sameArray(base.owner, snap.owner) && sameArray(base.domain, snap.domain) && shape(base) === shape(snap)) {
      this.nextLabel = null;
      return;
    }
    this.undoStack.push({ snap: base, label: this.nextLabel || describe(base, snap) });
    if (this.undoStack.length > HISTORY_MAX) this.undoStack.shift();
    this.redoStack = [];
    this.nextLabel = null;
    this.base = snap;
    this.onChange("edit");
  }

  canUndo() { return this.undoStack.length > 0; }
  canRedo() { return this.redoStack.length > 0; }

  undo() { return this.step(this.undoStack, this.redoStack); }
  redo() { return this.step(this.redoStack, this.undoStack); }

  step(from, to) {
    this.commit();
    const e = from.pop();
    if (!e) return false;
    to.push({ snap: this.base, label: e.label });
    this.base = e.snap;
    this.regions.restore(e.snap);
    this.onChange("step");
    return true;
  }
}

/**
 * Ctrl+Z and Ctrl+Shift+Z / Ctrl+Y: they act on the kind of edit made last (a region edit, or a
 * move of the open session); when that kind has nothing to undo (redo), on the other.
 */
export class UndoKeys {
  constructor(history, moves) {
    this.history = history;
    this.moves = moves;
    this.last = "moves";
    this.seenTop = null;
    on("history", () => {
      const top = state.history[state.history.length - 1];
      if (top !== this.seenTop && state.historyIndex === state.history.length - 1 && state.history.length > 1)
        this.last = "moves";  // a new move (or a session's history read back)
      this.seenTop = top;
      this.note();
    });
    on("session", () => { if (state.sessionId) this.last = "moves"; this.note(); });
    history.onChange = (why) => { if (why === "edit") this.last = "regions"; this.note(); };
  }

  movesCan(dir) {
    if (!state.sessionId) return false;
    return dir < 0 ? state.historyIndex > 0 : state.historyIndex < state.history.length - 1;
  }

  /** The history the key acts on now: "regions", "moves" or null (nothing to do). */
  target(dir) {
    const r = dir < 0 ? this.history.canUndo() : this.history.canRedo(), m = this.movesCan(dir);
    if (this.last === "regions") return r ? "regions" : m ? "moves" : null;
    return m ? "moves" : r ? "regions" : null;
  }

  undo() { this.act(-1); }
  redo() { this.act(1); }

  act(dir) {
    const t = this.target(dir);
    if (t === "regions") { if (dir < 0) this.history.undo(); else this.history.redo(); }
    else if (t === "moves") { if (dir < 0) this.moves.undo(); else this.moves.redo(); }
  }

  /** The line under the region history: what Ctrl+Z would undo now. */
  note() {
    const el = $("region-keys");
    const t = this.target(-1), h = this.history;
    $("region-undo").disabled = !h.canUndo();
    $("region-redo").disabled = !h.canRedo();
    $("region-undo").title = h.canUndo() ? `undo: ${h.undoStack[h.undoStack.length - 1].label}` : "no region edit to undo";
    $("region-redo").title = h.canRedo() ? `redo: ${h.redoStack[h.redoStack.length - 1].label}` : "no region edit to redo";
    el.dataset.target = t || "";
    el.textContent = t === "regions" ? `Ctrl+Z undoes the region edit “${h.undoStack[h.undoStack.length - 1].label}”`
      : t === "moves" ? "Ctrl+Z undoes the last move (the session's history)" : "Ctrl+Z: nothing to undo";
  }
}

/** The Regions panel's editing row: rename, merge, pick by ids, region undo and redo. */
export class RegionTools {
  constructor(regions, refuse) {
    this.regions = regions;
    this.refuse = refuse;
    this.history = new RegionHistory(regions);
    $("region-rename").addEventListener("click", () => this.rename());
    $("region-name").addEventListener("keydown", (ev) => { if (ev.key === "Enter") { ev.preventDefault(); this.rename(); } });
    $("region-merge").addEventListener("click", () => this.merge());
    $("pick-apply").addEventListener("click", (ev) => this.pick(ev));
    $("pick-ids").addEventListener("keydown", (ev) => { if (ev.key === "Enter") { ev.preventDefault(); this.pick(ev); } });
    $("region-undo").addEventListener("click", () => this.history.undo());
    $("region-redo").addEventListener("click", () => this.history.redo());
    on("regions", () => this.render());
  }

  /** The region choices of the merge row, and the active region's name in the rename field. */
  render() {
    const opts = state.regions.map((r) => `<option value="${r.id}">${esc(r.name)} (${r.kind})</option>`).join("");
    for (const id of ["merge-from", "merge-into"]) {
      const el = $(id), cur = el.value;
      el.innerHTML = opts;
      if ([...el.options].some((o) => o.value === cur)) el.value = cur;
    }
    const a = this.regions.active, name = $("region-name");
    if (document.activeElement !== name) name.value = a ? a.name : "";
    if (a && $("merge-into").value === String(a.id) && $("merge-from").value === String(a.id)) {
      const other = state.regions.find((r) => r.id !== a.id);
      if (other) $("merge-from").value = String(other.id);
    }
  }

  rename() {
    const a = this.regions.active, name = $("region-name").value.trim();
    if (!a) { this.refuse("choose a region to rename (click its name in the list)"); return; }
    if (name === a.name) return;
    this.history.label(`rename ${a.name} → ${name}`);
    if (!this.regions.rename(a.id, name)) {
      this.history.label(null);
      this.refuse(`“${name}” cannot name a region: it is taken, or not a plain name (letters, digits, _ . : = -)`);
    }
  }

  /** Merge: the first region's vertices join the second, and the first goes. */
  merge() {
    const from = this.regions.byId.get(Number($("merge-from").value));
    const into = this.regions.byId.get(Number($("merge-into").value));
    if (!from || !into) { this.refuse("choose two regions to merge"); return; }
    if (from === into) { this.refuse("choose two different regions to merge"); return; }
    this.history.label(`merge ${from.name} into ${into.name}`);
    const ids = this.regions.idsOf(from);
    this.regions.remove(from.id);
    this.regions.apply(ids, "add", into);
    this.regions.activate(into.id);
  }

  /**
   * Pick by id: the nodes (or the corner nodes of the elements) whose ids, as the deck numbers
   * them, are in the typed ranges, into the region of the chosen role (Shift adds, Ctrl subtracts).
   */
  pick(ev) {
    const note = $("pick-note");
    if (!state.V) { this.refuse("open a mesh first"); return; }
    let ranges;
    try { ranges = parseRanges($("pick-ids").value); } catch (e) { note.textContent = e.message; return; }
    const has = inRanges(ranges), kind = $("pick-kind").value, n = state.V.length / 3, ids = [];
    let found = 0;
    if (kind === "nodes") {
      const labels = state.labels;
      for (let i = 0; i < n; i++) {
        if (!has(labels ? labels[i] : i)) continue;
        found++;
        if (state.used[i]) ids.push(i);
      }
    } else {
      const T = state.T, rows = T.length / 4;
      const labels = state.elementLabels;
      if (!labels && rows !== state.elements) { note.textContent = "this file does not number its elements: pick nodes"; return; }
      const at = labels ? (r) => labels[r] : (r) => r + 1;  // a tet mesh without numbers: 1…M in file order
      const mark = new Uint8Array(n), seen = new Set();
      for (let r = 0; r < rows; r++) {
        const e = at(r);
        if (!has(e)) continue;
        seen.add(e);
        for (let k = 0; k < 4; k++) mark[T[4 * r + k]] = 1;
      }
      found = seen.size;
      for (let i = 0; i < n; i++) if (mark[i]) ids.push(i);
    }
    const asked = ranges.reduce((s, [lo, hi]) => s + hi - lo + 1, 0);
    const what = kind === "nodes" ? "node" : "element";
    const numbering = kind === "nodes" ? (state.labels ? "the deck's node numbers" : "vertex ids from 0")
      : (state.elementLabels ? "the deck's element numbers" : "element numbers 1…M");
    note.textContent = `${fmt(found)} of ${fmt(asked)} ${what} ids found (${numbering}): ${fmt(ids.length)} nodes`;
    if (!found) return;
    this.history.label(`pick ${kind} ${$("pick-ids").value.trim()}`);
    this.regions.select(ids, ev, "replace");
  }
}
