// The REPORT's notes that need words: which nodes conflicting constraints hold and what to do about
// them, and when a free node moving further than the handles is worth a warning (panels.js shows them).
import { fmt } from "./panels.js";  // used when called, after both modules are loaded

/** A free node is worth a warning when it moves more than this many times as far as the handles. */
export const FREE_RATIO_WARN = 1.05;
// nodes and constraints named in a row before "…"
const FIRST = 5;

/**
 * The warning of a free node moving further than the handles, or null when it is not worth one
 * (at most FREE_RATIO_WARN times as far: an ordinary morph).
 */
export function freeWarning(handleMax, freeMax) {
  if (handleMax === undefined || handleMax === null || freeMax === undefined || freeMax === null) return null;
  if (!(handleMax > 0) || !(freeMax > FREE_RATIO_WARN * handleMax)) return null;
  const ratio = Number((freeMax / handleMax).toPrecision(3));
  return `a free node moves ${fmt(ratio)}× as far as the handles (warned above ${fmt(FREE_RATIO_WARN)}×): ` +
    "check the displacement colouring, or limit the morph with a domain";
}

/**
 * The rows of conflicting constraints: how many, the constraints and the first nodes they hold
 * (numbered as in the deck when it numbers them), and what to do.
 *
 * @param {object[]} list the REPORT's conflicting_constraints ({kind, name, vertices, residual})
 * @param {Int32Array|null} labels the deck's node number per vertex, or null
 * @returns {{count: string, nodes: string, fix: string}}
 */
export function conflictRows(list, labels) {
  const names = [], nodes = [];
  let worst = 0;
  for (const e of list) {
    const n = `${e.kind} “${e.name}”`;
    if (!names.includes(n)) names.push(n);
    for (const v of e.vertices || []) if (!nodes.includes(v)) nodes.push(v);
    if (Number.isFinite(e.residual)) worst = Math.max(worst, e.residual);
  }
  const node = (v) => fmt(labels ? labels[v] : v);
  const shown = nodes.slice(0, FIRST).map(node).join(", ") + (nodes.length > FIRST ? ` … (first ${FIRST} of ` +
    `${fmt(nodes.length)})` : "");
  const kinds = names.slice(0, 3).join(", ") + (names.length > 3 ? ` and ${names.length - 3} more` : "");
  return {
    count: `${fmt(list.length)} rows of ${kinds}` + (worst ? `, residual up to ${fmt(Number(worst.toPrecision(3)))}` : ""),
    nodes: nodes.length ? `${labels ? "deck nodes" : "nodes"} ${shown}` : "",
    fix: "these nodes are held by constraints that want them in different places: take them out of one region " +
      "(a node both fixed and in a handle), or move the handles so that the constraints agree",
  };
}
