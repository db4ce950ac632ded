// The edits' part of a shape variant's MOVE, combined as the library combines it
// (solver/workflows/shapes.py, solver/constraints/edit_values.py `combined_value`): a radius, a
// fillet's radius, a distance or an angle adds as its change from the rest value (a shape that gives
// a new value counts as that value less the rest one), twist rates add, twist tables add over every
// row's position, map amounts, wall distances and control-point displacements add.
import { EDIT_KINDS } from "./edits.js";

/** The change key of the edits set by a value, and their value key. */
const CHANGE = { radius: ["radius", "delta"], fillet: ["radius", "delta"], distance: ["distance", "delta"],
  angle: ["angle_deg", "delta_deg"] };

/** A twist table's angle at axial position s: linear between rows, the end row's beyond them. */
function tableAt(table, s) {
  if (s <= table[0].at) return table[0].angle_deg;
  for (let k = 1; k < table.length; k++) {
    const a = table[k - 1], b = table[k];
    if (s <= b.at) return a.angle_deg + (b.angle_deg - a.angle_deg) * (s - a.at) / (b.at - a.at);
  }
  return table[table.length - 1].angle_deg;
}

/**
 * The MOVE's edit entries of shape values {name: theta}. `shapes`: {name: MOVE at value 1};
 * `rest(kind, name)`: an edit's rest value (a radius, a distance, an angle), null when unknown.
 */
export function combineEdits(shapes, values, rest) {
  const steps = {};  // kind -> edit -> [[theta, value]]
  for (const [shape, move] of Object.entries(shapes)) {
    const th = values[shape] || 0;
    for (const kind of EDIT_KINDS) {
      for (const [edit, v] of Object.entries((move && move[kind]) || {})) {
        ((steps[kind] = steps[kind] || {})[edit] = steps[kind][edit] || []).push([th, v]);
      }
    }
  }
  const out = {};
  for (const [kind, named] of Object.entries(steps)) {
    out[kind] = {};
    for (const [edit, given] of Object.entries(named)) {
      let v;
      if (CHANGE[kind]) {
        const [key, change] = CHANGE[kind], r0 = rest(kind, edit);
        const delta = (s) => (s[key] !== undefined ? (r0 === null ? 0 : s[key] - r0) : s[change] || 0);
        v = { [change]: given.reduce((sum, [t, s]) => sum + t * delta(s), 0) };
      } else if (kind === "twist") {
        const tables = given.filter(([, s]) => s.table);
        if (!tables.length) {
          v = { angle_deg_per_length: given.reduce((sum, [t, s]) => sum + t * (s.angle_deg_per_length || 0), 0) };
        } else {
          const at = [...new Set(tables.flatMap(([, s]) => s.table.map((r) => r.at)))].sort((a, b) => a - b);
          v = { table: at.map((x) => ({ at: x, angle_deg: tables.reduce((sum, [t, s]) => sum + t * tableAt(s.table, x), 0) })) };
        }
      } else if (kind === "map") {
        v = { amount: given.reduce((sum, [t, s]) => sum + t * (s.amount ?? 1), 0) };
      } else if (kind === "offset") {
        v = { distance: given.reduce((sum, [t, s]) => sum + t * (s.distance || 0), 0) };
      } else {
        const d = {};
        for (const [t, s] of given) {
          for (const [key, x] of Object.entries(s.displacements || {})) d[key] = (d[key] || [0, 0, 0]).map((y, a) => y + t * x[a]);
        }
        v = { displacements: d };
      }
      out[kind][edit] = v;
    }
  }
  return out;
}

/**
 * The MOVE's edit entries scaled by f in [0, 1], as the service's clamp scales them
 * (solver/constraints/edit_values.py `scaled_value`): a new radius, fillet radius, distance or angle
 * goes f of the way from its rest value `rest(kind, name)` (the value itself when that is unknown:
 * the service then keeps it), a change (delta) and every other parameter are multiplied by f.
 */
export function scaleEdits(move, f, rest) {
  const out = {};
  for (const kind of EDIT_KINDS) {
    if (!move || !move[kind]) continue;
    out[kind] = {};
    for (const [name, v] of Object.entries(move[kind])) {
      let s;
      if (CHANGE[kind]) {
        const [key, change] = CHANGE[kind];
        if (v[key] !== undefined) {
          const r0 = rest(kind, name);
          s = { [key]: f === 1 || r0 === null || r0 === undefined ? v[key] : r0 + f * (v[key] - r0) };
        } else {
          s = { [change]: f * (v[change] || 0) };
        }
      } else if (kind === "twist") {
        s = v.table ? { table: v.table.map((r) => ({ at: r.at, angle_deg: f * r.angle_deg })) }
          : { angle_deg_per_length: f * v.angle_deg_per_length };
      } else if (kind === "map") {
        s = { amount: f * (v.amount ?? 1) };
      } else if (kind === "offset") {
        s = { distance: f * v.distance };
      } else {
        s = { displacements: Object.fromEntries(Object.entries(v.displacements || {}).map(([k, d]) => [k, d.map((x) => f * x)])) };
      }
      out[kind][name] = s;
    }
  }
  return out;
}
