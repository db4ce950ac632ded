// The Edits panel's edits between features (docs/guide/constraints.md, "Daily edits"): a fillet's
// radius (the fillet region and the two planar face regions it joins), and the distance or the angle
// between a moving region and a reference region. Each row shows the rest value, measured on the page
// from the rest positions as the library measures it (featurefit.js), and starts its field there.
import { $ } from "./dom.js";
import { featureAngle, featureDirection, featureDistance, filletRadius } from "./featurefit.js";
import { state } from "./state.js";

/** Per edit: the MOVE's value key, its change key, the unit shown, and what the rest value is. */
export const BETWEEN = {
  fillet: { param: "radius", delta: "delta", unit: "r", rest: "the fitted rest radius" },
  distance: { param: "distance", delta: "delta", unit: "d", rest: "the rest distance" },
  angle: { param: "angle_deg", delta: "delta_deg", unit: "°", rest: "the rest angle" },
};

/**
 * Three numbers typed in a field ("x y z" or "x, y, z"), null when empty, false when not three numbers
 * (or, for a direction, all zero).
 */
function typedTriple(id, direction = true) {
  const text = $(id).value.trim();
  if (!text) return null;
  const v = text.split(/[\s,;]+/).map(Number);
  return v.length === 3 && v.every(Number.isFinite) && (!direction || v.some((x) => x !== 0)) ? v : false;
}

/**
 * The SPEC entry of a new fillet, distance or angle edit from the form (null: refused, said).
 * `panel` is the EditsPanel (its regions, take() and refuse), `r` the chosen region.
 */
export function betweenEntry(panel, kind, name, sel, r) {
  const need = (ok, text) => { if (!ok) panel.io.refuse(text); return ok; };
  if (!need(r, kind === "fillet" ? "choose the fillet's region" : "choose the region that moves")) return null;
  if (kind === "fillet") {
    const a = panel.region($("edit-face-a").value), b = panel.region($("edit-face-b").value);
    if (!need(a && b, "choose the two planar face regions the fillet joins")) return null;
    if (!need(a !== b && a !== r && b !== r, "the fillet and its two faces are three different regions")) return null;
    panel.take(r, sel);
    panel.take(a, `${sel}.face1`);
    panel.take(b, `${sel}.face2`);
    return { name, selection: sel, faces: [`${sel}.face1`, `${sel}.face2`] };
  }
  const ref = panel.region($("edit-reference").value);
  if (!need(ref, "choose the reference region (it stays where it is)")) return null;
  if (!need(ref !== r, "the reference is another region than the one that moves")) return null;
  // the optional typed fields: SPEC key, field, what the refusal calls it, whether it is a direction
  const fields = kind === "distance" ? [["direction", "edit-along", "direction", true]]
    : [["axis", "edit-turn-axis", "axis", true], ["direction", "edit-dir-moving", "direction", true],
      ["reference_direction", "edit-dir-reference", "reference direction", true], ["pivot", "edit-pivot", "pivot", false]];
  const out = { name, selection: sel, reference: `${sel}.reference` };
  for (const [key, id, said, direction] of fields) {
    const typed = typedTriple(id, direction);
    if (!need(typed !== false, `the ${said} is three numbers${direction ? ", not all zero" : ""} (or leave it empty)`)) return null;
    if (typed) out[key] = typed;
  }
  if (kind === "angle") {
    const planar = Number($("edit-planar").value);
    if (!need($("edit-planar").value.trim() !== "" && planar >= 0 && planar <= 180,
      "planar within is an angle in degrees, 0 to 180")) return null;
    if (planar !== 1) out.planar_deg = planar;  // 1°: the SPEC's default
  }
  panel.take(r, sel);
  panel.take(ref, `${sel}.reference`);
  return out;
}

/** The rest value of a fillet, distance or angle edit, measured on the page (null: no fit). */
export function restBetween(panel, kind, e) {
  const ids = (s) => panel.regions.resolve(panel.regions.extraSelections[s] || { ids: [] });
  if (kind === "fillet") return filletRadius(state.V0, state.used, ids(e.selection), ids(e.faces[0]), ids(e.faces[1]));
  if (kind === "distance") return featureDistance(state.V0, ids(e.selection), ids(e.reference), e.direction || null);
  const dir = (given, s) => (given ? [given, false] : featureDirection(state.V0, state.F, ids(s), e.planar_deg ?? 1));
  const a = dir(e.direction, e.selection), b = dir(e.reference_direction, e.reference);
  return a && b ? featureAngle(a, b) : null;
}

/** The row's controls: the value field, a slider about the rest value, the rest value said. */
export function betweenControls(kind, e, rest, byService = false) {
  const b = BETWEEN[kind], r0 = rest ?? 1;
  const [lo, hi] = kind === "angle" ? [Math.max(0, r0 - 30), Math.min(180, r0 + 30)] : [0.5 * r0, 1.5 * r0];
  const n = (x) => String(Number(Number(x).toPrecision(10)));
  const said = rest === null ? "rest: no fit on the page" : `rest ${Number(rest.toPrecision(6))}`;
  return `<label>${b.unit} <input type="number" step="any" data-param="${b.param}"></label>` +
    `<input type="range" data-param="${b.param}" min="${n(lo)}" max="${n(hi)}" step="${n((hi - lo) / 200)}">` +
    `<span class="muted" data-rest title="${b.rest}, measured ${byService ? "by the service at set-up" :
      "on the page from the rest positions"}">${said}</span>`;
}
