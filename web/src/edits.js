// The Edits panel: the daily edits of the SPEC and their MOVE parameters (docs/guide/constraints.md,
// "Daily edits"), made as a CAE user makes them. A hole's or a boss's radius (a feature candidate,
// with its axis), a wall's thickness (a face region along its normal, with an optional opposite face,
// symmetric or not), a twist or a bend about an axis (two picked nodes, or a hole's axis; a rate or a
// table, twisttable.js), a node set mapped onto a line, a circle, a plane, a cylinder or a sphere
// (through picked nodes, or typed; editgeometry.js), a morph volume (a box lattice around a region, or
// typed, whose control points the gizmo drags), a fillet's radius, and the distance or the angle
// between two features (featureedits.js).
//
// An edit is a SPEC entry: it goes into the SPEC Create session sends (the regions' `specExtra`, as
// the symmetry panel's entries do), so a session has the edits it was created with; one added or
// removed after that asks for Create session again (the note under the list says so, with a button).
// A region an edit takes becomes the edit's selection and leaves the regions: a node belongs to one
// handle, one edit, or is fixed. The values (a radius, a distance, a rate, an amount, displacements)
// are the MOVE's: every MOVE the editor sends carries the current ones (gizmo.js asks `move()`), and
// the history, Undo and presets keep them with the handles'.
import { getJson, sessionSetup } from "./api.js";
import { $ } from "./dom.js";
import { circleThrough, mapGeometry, mapProjection, twistMode } from "./editgeometry.js";
import { BETWEEN, betweenControls, betweenEntry, restBetween } from "./featureedits.js";
import { controlKeys, controlPoint, LatticeView } from "./lattice.js";
import { updateRows } from "./inplace.js";
import { fmt } from "./panels.js";
import { on, state } from "./state.js";
import { editTable, readTable, showLaw, syncTwist, twistControls } from "./twisttable.js";

export { circleThrough };

/** The SPEC's (and the MOVE's) keys of the edits (solver/documents/edits.py). */
export const EDIT_KINDS = ["radius", "twist", "map", "offset", "lattice", "fillet", "distance", "angle"];
/** The edits this panel makes, and what its list calls each. */
const TOOLS = { radius: "radius", offset: "wall", twist: "twist", map: "map", lattice: "lattice", fillet: "fillet",
  distance: "distance", angle: "angle" };
/** The MOVE parameter a row's number field sets, by edit. */
const PARAM = { radius: "radius", offset: "distance", twist: "angle_deg_per_length", map: "amount", fillet: "radius",
  distance: "distance", angle: "angle_deg" };

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
const num = (x) => String(Number(Number(x).toPrecision(10)));
const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const norm = (a) => Math.hypot(...a);

/** Three numbers typed in a field ("x y z" or "x, y, z"), or null. */
function triple(text) {
  const v = String(text).trim().split(/[\s,;]+/).map(Number);
  return v.length === 3 && v.every(Number.isFinite) ? v : null;
}

export class EditsPanel {
  /**
   * @param {Viewer} viewer
   * @param {MeshView} meshView
   * @param {Regions} regions
   * @param {Moves} moves
   * @param {{pickedIds: Function, refuse: Function, create: Function}} io pickedIds() the picked
   *   nodes' ids (pick tool), refuse(text) says why an action is not possible, create() runs Create session
   */
  constructor(viewer, meshView, regions, moves, io) {
    Object.assign(this, { meshView, regions, moves, io });
    this.values = {};       // the MOVE's edit entries now: {kind: {name: parameters}}
    this.features = null;   // the open mesh's hole and boss candidates (GET .../features)
    this.featuresOf = null; // the mesh they were found on
    this.live = null;       // the seq of a slider's drag not committed yet
    this.lattice = null;    // the lattice whose control points are drawn, and its chosen point
    this.view = new LatticeView(viewer, (d, done) => this.dragPoint(d, done));
    $("edit-kind").addEventListener("change", () => this.form());
    $("edit-region").addEventListener("change", () => this.boxAround());
    $("edit-add").addEventListener("click", () => this.add());
    $("edit-rebuild").addEventListener("click", () => this.io.create());
    $("sec-edits").addEventListener("toggle", () => { if ($("sec-edits").open) this.loadFeatures(); });
    const list = $("edit-list");
    list.addEventListener("input", (ev) => this.sliding(ev));
    list.addEventListener("change", (ev) => this.changed(ev));
    list.addEventListener("keydown", (ev) => {
      if (ev.key === "Enter" && ev.target.matches("input[type=number], input[data-axis]")) { ev.preventDefault(); this.setRow(ev.target); }
    });
    list.addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-act]"), li = b && b.closest("li[data-kind]");
      if (!b) return;
      if (b.dataset.act === "set") this.setRow(b);
      else if (b.dataset.act.startsWith("point-")) editTable(li, b.dataset.act, b);
      else this.remove(li.dataset.kind, li.dataset.name);
    });
    list.addEventListener("pointerover", (ev) => this.preview(ev.target.closest("li[data-kind]")));
    list.addEventListener("pointerleave", () => this.meshView.setPreview(null));
    on("mesh", () => {
      Object.assign(this, { values: {}, features: null, featuresOf: null, lattice: null });
      $("edit-feature").innerHTML = '<option value="">— open the panel to find them —</option>';
      this.form();
      this.render();
    });
    // a SPEC read back (imported, or a session opened) brings its own edits
    on("regions", () => { this.regionChoices(); if (this.names() !== this.rendered) this.render(); });
    on("session", () => { this.render(); this.loadServiceRest(); });
    this.form();
  }

  /**
   * The rest values the service measured at set-up (the session's `edits_at_rest`): the library's
   * own fits, which the Shapes panel's changes and the rows' "rest" then use in place of the page's.
   */
  async loadServiceRest() {
    const id = state.sessionId;
    this.serviceRest = new Map();
    if (!id) return;
    let doc;
    try { doc = await sessionSetup(id); } catch { return; }
    if (state.sessionId !== id || !doc.edits_at_rest) return;
    for (const d of doc.edits_at_rest) this.serviceRest.set(`${d.kind}/${d.name}`, d.rest);
    this.render();
  }

  /** The service's rest value of an edit the open session has as the page has it (undefined: none). */
  restOfService(kind, name) {
    const e = this.list(kind).find((x) => x.name === name), sent = this.sent(kind, name);
    if (!this.serviceRest || !e || !sent || JSON.stringify(sent) !== JSON.stringify(e)) return undefined;
    return this.serviceRest.get(`${kind}/${name}`);
  }

  // ---------------------------------------------------------------- SPEC entries
  list(kind) { return this.regions.specExtra[kind] || []; }

  setList(kind, list) {
    if (list.length) this.regions.specExtra[kind] = list; else delete this.regions.specExtra[kind];
  }

  /** The open session's entry of this edit (null: the session was not created with it). */
  sent(kind, name) {
    const s = state.sessionId && state.specSent ? state.specSent[kind] || [] : [];
    return s.find((e) => e.name === name) || null;
  }

  /** The MOVE's edit entries: the values of the edits the open session has. */
  move() {
    const out = {};
    for (const [kind, byName] of Object.entries(this.values)) {
      for (const [name, v] of Object.entries(byName)) {
        if (this.sent(kind, name)) (out[kind] = out[kind] || {})[name] = structuredClone(v);
      }
    }
    return out;
  }

  /** A MOVE shown (undo, redo, a preset, a refusal; null: rest): its edit entries become the values. */
  fromMove(move) {
    this.values = {};
    for (const kind of EDIT_KINDS) if (move && move[kind]) this.values[kind] = structuredClone(move[kind]);
    this.sync();
  }

  /** Names of the selections the SPEC has now (regions and other entries'). */
  taken() { return new Set([...state.regions.map((r) => r.name), ...Object.keys(this.regions.extraSelections)]); }

  /** A region's nodes as an edit's selection `sel` (a named set stays the set); the region leaves the regions. */
  take(region, sel) {
    this.regions.extraSelections[sel] = region.source && region.source.set ? { set: region.source.set }
      : { ids: this.regions.idsOf(region, true) };
    this.regions.remove(region.id);
  }

  region(id) {
    const r = state.regions.find((x) => String(x.id) === String(id) && x.count > 0);
    return r || null;
  }

  /** The rest positions of the picked nodes (pick tool), as many as `n` asks, or null with the reason said. */
  picks(n, what) {
    const ids = this.io.pickedIds();
    if (ids.length < n) { this.io.refuse(`pick ${n} nodes for the ${what} first (pick tool: ${ids.length} picked)`); return null; }
    return ids.slice(0, n).map((i) => [0, 1, 2].map((k) => state.V0[3 * i + k]));
  }

  /** Add the edit the form describes to the SPEC. */
  add() {
    if (!state.V) { this.io.refuse("open a mesh first"); return; }
    const kind = $("edit-kind").value;
    const given = $("edit-name").value.trim().replace(/[^A-Za-z0-9_.:=-]/g, "_");
    const r = this.region($("edit-region").value);
    const f = this.features && this.features[Number($("edit-feature").value)];
    const base = given || (kind === "radius" ? f && f.name : r && r.name) || `${TOOLS[kind]}${this.list(kind).length + 1}`;
    let name = base;
    for (let k = 2; this.list(kind).some((e) => e.name === name); k++) name = `${base}_${k}`;
    const sel = `${kind}.${name}`;
    if (this.taken().has(sel)) { this.io.refuse(`the selection name ${sel} is taken: give the edit another name`); return; }
    const entry = this.entry(kind, name, sel, r, f);
    if (!entry) return;
    this.setList(kind, [...this.list(kind), entry]);
    $("edit-name").value = "";
    this.render();
    this.regions.changed();  // the SPEC changed: lists, legend and choices follow
  }

  /** The SPEC entry of a new edit (null: refused, the reason said). */
  entry(kind, name, sel, r, f) {
    const need = (ok, text) => { if (!ok) this.io.refuse(text); return ok; };
    if (kind === "radius") {
      if (!need(f, "find and choose a hole or a boss (Feature candidates)")) return null;
      this.regions.extraSelections[sel] = structuredClone(f.selection);
      return { name, selection: sel, axis: { point: f.center.slice(), direction: f.axis.slice() } };
    }
    if (kind === "lattice") {
      const min = triple($("edit-min").value), max = triple($("edit-max").value), counts = triple($("edit-counts").value);
      if (!need(min && max, "type the box's min and max corners (x y z each), or choose a region to put it around")) return null;
      if (!need(min.every((x, k) => max[k] > x), "the box's max must exceed its min along x, y and z")) return null;
      if (!need(counts && counts.every((c) => Number.isInteger(c) && c >= 1 && c <= 16),
        "counts are three whole numbers of control points, 1 to 16 each")) return null;
      const out = { name, box: { min, max }, counts };
      if (r) { this.take(r, sel); out.selection = sel; }
      return out;
    }
    if (BETWEEN[kind]) return betweenEntry(this, kind, name, sel, r);
    if (!need(r, "choose the region the edit moves")) return null;
    if (kind === "offset") {
      const opp = this.region($("edit-opposite").value);
      if (!need(!opp || opp !== r, "the opposite face is another region than the face")) return null;
      if (!need(opp || !$("edit-symmetric").checked, "symmetric needs an opposite face")) return null;
      this.take(r, sel);
      const out = { name, selection: sel };
      if (opp) { this.take(opp, `${sel}.opposite`); out.opposite = `${sel}.opposite`; }
      if ($("edit-symmetric").checked) out.symmetric = true;
      return out;
    }
    if (kind === "twist") {
      const axis = this.axis();
      const mode = axis && twistMode(axis, () => this.io.pickedIds().map((i) => [0, 1, 2].map((k) => state.V0[3 * i + k])),
        this.io.refuse);
      if (!mode) return null;
      this.take(r, sel);
      return { name, selection: sel, axis, ...mode };
    }
    const geometry = mapGeometry((n, what) => this.picks(n, what), this.io.refuse);
    const projection = geometry && mapProjection(geometry, this.io.refuse);
    if (!projection) return null;
    this.take(r, sel);
    return { name, selection: sel, geometry, ...projection };
  }

  /** The twist's axis: the line from picked node A to B, or a hole's or boss's axis. */
  axis() {
    const v = $("edit-axis").value;
    if (v === "AB") {
      const p = this.picks(2, "axis (A and B)");
      if (!p) return null;
      const d = sub(p[1], p[0]);
      if (!(norm(d) > 0)) { this.io.refuse("the picked nodes A and B are the same point"); return null; }
      return { point: p[0], direction: d };
    }
    const f = this.features && this.features[Number(v)];
    return f ? { point: f.center.slice(), direction: f.axis.slice() } : (this.io.refuse("choose an axis"), null);
  }

  /** The selections an edit entry names (its own, an opposite face, a fillet's faces, a reference). */
  selectionsOf(e) { return [e.selection, e.opposite, e.reference, ...(e.faces || [])].filter(Boolean); }

  remove(kind, name) {
    const e = this.list(kind).find((x) => x.name === name);
    if (!e) return;
    this.setList(kind, this.list(kind).filter((x) => x !== e));
    for (const s of this.selectionsOf(e)) delete this.regions.extraSelections[s];
    if (this.values[kind]) delete this.values[kind][name];
    if (this.lattice && kind === "lattice" && this.lattice.name === name) this.lattice = null;
    this.meshView.setPreview(null);
    this.render();
    this.regions.changed();
  }

  // ---------------------------------------------------------------- the form
  /** The fields the chosen edit asks for. */
  form() {
    const kind = $("edit-kind").value;
    for (const el of document.querySelectorAll("#sec-edits [data-for]")) el.hidden = !el.dataset.for.split(" ").includes(kind);
    if ((kind === "radius" || kind === "twist") && $("sec-edits").open) this.loadFeatures();  // found when needed
    this.regionChoices();
  }

  regionChoices() {
    const opts = state.regions.filter((r) => r.count > 0)
      .map((r) => `<option value="${r.id}">${esc(r.name)} (${r.kind}, ${fmt(r.count)})</option>`).join("");
    for (const [id, none] of [["edit-region", "— region —"], ["edit-opposite", "— none —"], ["edit-face-a", "— region —"],
      ["edit-face-b", "— region —"], ["edit-reference", "— region —"]]) {
      const el = $(id), cur = el.value;
      el.innerHTML = `<option value="">${$("edit-kind").value === "lattice" && id === "edit-region"
        ? "— none: boundary nodes in the box —" : none}</option>${opts}`;
      if ([...el.options].some((o) => o.value === cur)) el.value = cur;
    }
  }

  /** A lattice's box around the chosen region: its bounding box, 1 % of the model's size larger each way. */
  boxAround() {
    const r = this.region($("edit-region").value);
    if ($("edit-kind").value !== "lattice" || !r) return;
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity], pad = 0.01 * state.diag;
    for (const i of this.regions.idsOf(r, true)) {
      for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], state.V0[3 * i + k]); hi[k] = Math.max(hi[k], state.V0[3 * i + k]); }
    }
    $("edit-min").value = lo.map((x) => num(x - pad)).join(" ");
    $("edit-max").value = hi.map((x) => num(x + pad)).join(" ");
  }

  /** The open mesh's holes and bosses, for the radius and the twist's axis (found once per mesh). */
  async loadFeatures() {
    const id = state.meshId;
    if (!id || state.surface || this.featuresOf === id) return;
    this.featuresOf = id;
    try {
      const list = await getJson(`/v1/meshes/${id}/features?ids=true`);
      if (state.meshId !== id) return;
      this.features = list.filter((f) => (f.kind === "hole" || f.kind === "boss") && f.axis);
    } catch (e) { this.featuresOf = null; this.io.refuse(e); return; }
    const opts = this.features.map((f, k) => `<option value="${k}">${esc(f.name)} (${f.kind}, r ${fmt(Number(f.radius.toPrecision(6)))})</option>`).join("");
    $("edit-feature").innerHTML = opts || '<option value="">no hole or boss found</option>';
    $("edit-axis").innerHTML = '<option value="AB">picked nodes A → B</option>' +
      this.features.map((f, k) => `<option value="${k}">axis of ${esc(f.name)}</option>`).join("");
  }

  // ---------------------------------------------------------------- the list and its values
  /** The rest radius of a radius edit: the mean distance of its nodes from its axis. */
  restRadius(e) {
    const ids = this.regions.resolve(this.regions.extraSelections[e.selection] || { ids: [] });
    const d = e.axis.direction, n = norm(d), u = d.map((x) => x / n);
    let s = 0;
    for (const i of ids) {
      const v = sub([0, 1, 2].map((k) => state.V0[3 * i + k]), e.axis.point), a = dot(v, u);
      s += Math.sqrt(Math.max(0, dot(v, v) - a * a));
    }
    return ids.length ? s / ids.length : 1;
  }

  /**
   * The rest value of a radius, fillet, distance or angle edit, measured on the page (null: none);
   * `kind` and `name` name the SPEC's entry (what the Shapes panel asks for, to add changes).
   */
  rest(kind, name) {
    const e = this.list(kind).find((x) => x.name === name);
    if (!e || !(kind === "radius" || BETWEEN[kind])) return null;
    const measured = this.restOfService(kind, name);
    if (measured !== undefined) return measured;
    if (kind === "radius") return this.restRadius(e);
    this.rests = this.rests || new WeakMap();  // a fillet's fit is not redone at every frame
    if (!this.rests.has(e)) this.rests.set(e, restBetween(this, kind, e));
    return this.rests.get(e);
  }

  /** The edits listed, by name (what the list shows). */
  names() { return JSON.stringify(Object.keys(TOOLS).map((k) => this.list(k).map((e) => e.name))); }

  render() {
    this.rendered = this.names();
    const rows = [];
    for (const kind of Object.keys(TOOLS)) {
      for (const e of this.list(kind)) {
        const ready = !!this.sent(kind, e.name);
        let controls;
        if (kind === "lattice") {
          const keys = controlKeys(e).map((k) => `<option>${k}</option>`).join("");
          controls = `<label>point <select data-param="point">${keys}</select></label>` +
            [0, 1, 2].map((a) => `<input data-axis="${a}" type="number" step="any" aria-label="d${"xyz"[a]}">`).join("");
        } else if (BETWEEN[kind]) {
          controls = betweenControls(kind, e, this.rest(kind, e.name), this.restOfService(kind, e.name) !== undefined);
        } else if (kind === "twist") {
          controls = twistControls();
        } else {
          const unit = { radius: "r", offset: "d", map: "amount" }[kind];
          controls = `<label>${unit} <input type="number" step="any" data-param="${PARAM[kind]}"></label>`;
          if (kind === "radius") {
            const r0 = this.rest(kind, e.name);
            controls += `<input type="range" data-param="radius" min="${num(0.5 * r0)}" max="${num(1.5 * r0)}" step="${num(r0 / 200)}">`;
          } else if (kind === "map") {
            controls += '<input type="range" data-param="amount" min="0" max="1" step="0.01">';
          }
        }
        rows.push(`<li data-kind="${kind}" data-name="${esc(e.name)}" class="${ready ? "" : "future"}">
          <span class="name" title="${ready ? "in the open session" : "not in the open session: Create session to use it"}">${TOOLS[kind]} ${esc(e.name)}</span>
          ${controls}<button data-act="set" title="send this value (Enter in a field)">Set</button>
          <button data-act="remove" title="take the edit out of the SPEC">×</button></li>`);
      }
    }
    // in place: a row being used (a slider under the pointer) stays when the list is shown again
    updateRows($("edit-list"), rows.join(""), (li) => `${li.dataset.kind}/${li.dataset.name}`);
    if (this.lattice && !this.list("lattice").some((e) => e.name === this.lattice.name)) this.lattice = null;
    this.sync();
    this.note();
  }

  /** The values into the rows (not into the field being typed in), and the lattice into the view. */
  sync() {
    for (const li of $("edit-list").querySelectorAll("li[data-kind]")) {
      const { kind, name } = li.dataset, v = (this.values[kind] || {})[name] || {};
      const e = this.list(kind).find((x) => x.name === name);
      if (!e) continue;
      const put = (el, x) => { if (el && document.activeElement !== el) el.value = num(x); };
      if (kind === "lattice") {
        const sel = li.querySelector("select"), cur = this.lattice && this.lattice.name === name ? this.lattice.key : sel.value;
        sel.value = cur;
        const d = (v.displacements || {})[cur] || [0, 0, 0];
        for (const el of li.querySelectorAll("input[data-axis]")) put(el, d[Number(el.dataset.axis)]);
        continue;
      }
      if (kind === "twist") { syncTwist(li, v); continue; }
      const rest = this.rest(kind, name) ?? 0, change = (BETWEEN[kind] || { delta: "delta" }).delta;
      const x = v[PARAM[kind]] ?? (v[change] !== undefined ? rest + v[change] : rest);
      for (const el of li.querySelectorAll(`input[data-param]`)) put(el, x);
    }
    this.showLattice();
  }

  showLattice() {
    const L = this.lattice || (this.list("lattice")[0] ? { name: this.list("lattice")[0].name, key: "0,0,0" } : null);
    const e = L && this.list("lattice").find((x) => x.name === L.name);
    if (!e) { this.view.show(null); return; }
    this.lattice = L;
    const ready = !!this.sent("lattice", e.name);
    this.view.show(e, ((this.values.lattice || {})[e.name] || {}).displacements, L.key, ready);
  }

  /** What the SPEC's edits and the open session's differ by, said under the list. */
  note() {
    const now = JSON.stringify(EDIT_KINDS.map((k) => this.list(k)));
    const sent = state.specSent ? JSON.stringify(EDIT_KINDS.map((k) => state.specSent[k] || [])) : null;
    const any = EDIT_KINDS.some((k) => this.list(k).length);
    const stale = state.sessionId && sent !== now;
    $("edit-note").textContent = stale
      ? "The edits differ from those the open session was created with: create the session again to use them " +
        "(a moved session asks first)."
      : any && !state.sessionId ? "Create session to move the edits." : "";
    $("edit-note").hidden = !$("edit-note").textContent;
    $("edit-rebuild").hidden = !stale;
  }

  /** Show an edit's nodes in the preview colour while the pointer is on its row. */
  preview(li) {
    const e = li && this.list(li.dataset.kind).find((x) => x.name === li.dataset.name);
    const ids = [];
    for (const s of e ? this.selectionsOf(e) : []) if (this.regions.extraSelections[s]) ids.push(...this.regions.resolve(this.regions.extraSelections[s]));
    this.meshView.setPreview(ids.length ? ids : null);
  }

  // ---------------------------------------------------------------- sending values
  /**
   * Set an edit's MOVE parameters and send the MOVE: a history entry (`done`), or a step of a drag
   * (committed by the drag's last step). A value the session cannot take yet is refused in words.
   */
  apply(kind, name, value, label, done = true) {
    if (!state.sessionId) { this.io.refuse("create a session first: the edits are part of its SPEC"); this.sync(); return; }
    if (!this.sent(kind, name)) {
      this.io.refuse(`the ${TOOLS[kind]} edit ${name} is not in the open session's SPEC: create the session again to use it`);
      this.sync();
      return;
    }
    const before = structuredClone(this.values), seq0 = state.seq;
    (this.values[kind] = this.values[kind] || {})[name] = value;
    if (!done) {
      const seq = this.moves.io.send(this.moves.move());
      if (seq === null) { this.values = before; this.sync(); return; }
      this.live = seq;
      if (kind === "lattice") this.showLattice();
      return;
    }
    if (this.live !== null) {
      this.moves.commit(label, this.live);
      this.live = null;
    } else {
      this.moves.sendAndCommit(label);
      if (state.seq === seq0) this.values = before;  // not sent: the values stay as they were
    }
    this.sync();
  }

  /** The value a row's field (or its Set button) holds, applied. */
  setRow(el) {
    const li = el.closest("li[data-kind]"), { kind, name } = li.dataset;
    if (kind === "lattice") {
      const key = li.querySelector("select").value;
      const d = [...li.querySelectorAll("input[data-axis]")].map((x) => Number(x.value));
      if (!d.every(Number.isFinite)) { this.io.refuse("a displacement is three numbers"); return; }
      const prev = (this.values.lattice || {})[name] || { displacements: {} };
      this.lattice = { name, key };
      this.apply(kind, name, { displacements: { ...prev.displacements, [key]: d } }, `lattice ${name} ${key} (${d.map(fmt).join(", ")})`);
      return;
    }
    if (kind === "twist" && li.querySelector("select[data-param=law]").value === "table") {
      const table = readTable(li);
      if (typeof table === "string") { this.io.refuse(`twist ${name}: ${table}`); return; }
      document.activeElement.blur();
      this.apply(kind, name, { table }, `twist ${name} table (${table.length} point${table.length === 1 ? "" : "s"})`);
      return;
    }
    const field = li.querySelector("input[type=number]"), x = Number(field.value);
    if (field.value.trim() === "" || !Number.isFinite(x)) { this.io.refuse(`type a number for the ${TOOLS[kind]} edit ${name}`); return; }
    if ((kind === "radius" || kind === "fillet") && !(x > 0)) { this.io.refuse("a radius is a positive length"); this.sync(); return; }
    if (kind === "angle" && !(x >= 0 && x <= 180)) { this.io.refuse("an angle between two features is 0° to 180°"); this.sync(); return; }
    field.blur();
    this.apply(kind, name, { [PARAM[kind]]: x }, this.label(kind, name, x));
  }

  label(kind, name, x) {
    return { radius: `radius ${name} r ${fmt(x)}`, offset: `wall ${name} ${fmt(x)}`,
      twist: `twist ${name} ${fmt(x)}°/length`, map: `map ${name} ${fmt(x)}`, fillet: `fillet ${name} r ${fmt(x)}`,
      distance: `distance ${name} ${fmt(x)}`, angle: `angle ${name} ${fmt(x)}°` }[kind];
  }

  /** A slider moved: the value goes out at once, as a drag (its release commits it). */
  sliding(ev) {
    const t = ev.target;
    if (t.type !== "range") return;
    const li = t.closest("li[data-kind]"), { kind, name } = li.dataset, x = Number(t.value);
    li.querySelector("input[type=number]").value = num(x);
    this.apply(kind, name, { [PARAM[kind]]: x }, this.label(kind, name, x), false);
  }

  changed(ev) {
    const t = ev.target, li = t.closest("li[data-kind]");
    if (!li) return;
    if (t.type === "range") {
      const { kind, name } = li.dataset, x = Number(t.value);
      this.apply(kind, name, { [PARAM[kind]]: x }, this.label(kind, name, x));
    } else if (t.matches("select[data-param=point]")) {
      this.lattice = { name: li.dataset.name, key: t.value };
      this.sync();
    } else if (t.matches("select[data-param=law]")) {
      showLaw(li);
    }
  }

  /** The gizmo on a control point moved it by `d` from its rest place. */
  dragPoint(d, done) {
    const L = this.lattice;
    if (!L) return;
    const prev = (this.values.lattice || {})[L.name] || { displacements: {} };
    this.apply("lattice", L.name, { displacements: { ...prev.displacements, [L.key]: d } },
      `lattice ${L.name} ${L.key} drag`, done);
  }

  /** True when a pointer event is on the lattice's gizmo, or it is being dragged (no region tool takes it). */
  busy(ev) { return this.view.dragging || (ev !== undefined && this.view.under(ev)); }

  /** What the tests read: the SPEC's edit entries, the values, the lattice shown. */
  snapshot() {
    const spec = {};
    for (const k of EDIT_KINDS) if (this.list(k).length) spec[k] = structuredClone(this.list(k));
    const L = this.lattice && this.list("lattice").find((e) => e.name === this.lattice.name);
    const point = L ? controlPoint(L, ...this.lattice.key.split(",").map(Number)) : null;
    return { spec, values: structuredClone(this.values), lattice: L ? { ...this.lattice, rest: point,
      at: this.view.target.position.toArray() } : null };
  }
}
