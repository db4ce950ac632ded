// DOE set-up: per shape (the session's presets) a lower and an upper bound and its levels, the safe
// bounds of `tetmorph bounds` offered (POST /v1/sessions/{id}/bounds: the largest values either way
// that invert no element), and two plan generators that fill the PLAN: full factorial (every
// combination of the shapes' levels) and Latin hypercube (n rows, a seed: each shape's range cut in n
// equal strata, one value in each). The PLAN is the CSV `tetmorph doe` and `tetmorph study` read: a
// header of shape names, a row of values per variant.
import { postJson } from "./api.js";
import { $ } from "./dom.js";
import { clearError, fmt, setBusy, showError } from "./panels.js";
import { on, state } from "./state.js";

/** Most rows a generated plan may have (the service's PLAN_ROWS_MAX is larger; a page holds this). */
export const PLAN_ROWS = 10000;

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

/** A seeded generator of uniform numbers in [0, 1) (mulberry32): the same seed, the same plan. */
export function uniform(seed) {
  let a = (Number(seed) >>> 0) || 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

/** Every combination of the levels ([[values of shape 0], ...]), the first shape varying slowest. */
export function fullFactorial(levels) {
  let rows = [[]];
  for (const vals of levels) rows = rows.flatMap((r) => vals.map((v) => [...r, v]));
  return rows;
}

/**
 * Latin hypercube of n rows over [lo, hi] per shape: each shape's range in n equal strata, each
 * stratum holding exactly one row's value (a random point in it), the strata shuffled per shape.
 */
export function latinHypercube(bounds, n, seed) {
  const rnd = uniform(seed), rows = Array.from({ length: n }, () => []);
  for (const [lo, hi] of bounds) {
    const perm = Array.from({ length: n }, (_, k) => k);
    for (let k = n - 1; k > 0; k--) { const j = Math.floor(rnd() * (k + 1)); [perm[k], perm[j]] = [perm[j], perm[k]]; }
    const w = (hi - lo) / n;
    for (let i = 0; i < n; i++) rows[i].push(Math.min(hi, lo + w * (perm[i] + rnd())));
  }
  return rows;
}

/** The PLAN CSV of rows under the shape names. */
export function planCsv(names, rows) {
  return `${names.join(",")}\n${rows.map((r) => r.map((v) => String(v)).join(",")).join("\n")}\n`;
}

export class DoePlanPanel {
  /** `shapes`: the ShapesPanel (its shapes() are the MOVEs at value 1). */
  constructor(shapes) {
    this.shapes = shapes;
    this.safe = {};     // shape -> {lo, hi}: the service's safe bounds, for the session they were asked of
    this.safeOf = null; // that session's id
    this.typed = {};    // shape -> {lo, hi, levels}: what was typed (kept across re-renders)
    $("doe-setup").addEventListener("input", (ev) => {
      const f = ev.target.dataset.field, n = ev.target.dataset.shape;
      if (f && n !== undefined) this.typed[n] = { ...this.typed[n], [f]: ev.target.value };
    });
    $("doe-setup").addEventListener("click", (ev) => {
      const b = ev.target.closest("button[data-use]");
      if (b) this.useSafe(b.dataset.use);
    });
    $("doe-bounds").addEventListener("click", () => this.askBounds());
    $("doe-ff").addEventListener("click", () => this.generate("ff"));
    $("doe-lhs").addEventListener("click", () => this.generate("lhs"));
    on("presets", () => this.render());
    on("mesh", () => { this.typed = {}; this.safe = {}; this.render(); });
    this.render();
  }

  names() { return state.presets.map((p) => p.name); }

  /** Per shape: bounds, levels, and the safe bounds when asked for. */
  render() {
    const names = this.names();
    if (this.safeOf !== state.sessionId) { this.safe = {}; this.safeOf = state.sessionId; }
    const cell = (n, f, dflt, label) => `<td><input type="text" data-shape="${esc(n)}" data-field="${f}"
      value="${esc(this.typed[n] && this.typed[n][f] !== undefined ? this.typed[n][f] : dflt)}" aria-label="${label} of ${esc(n)}"></td>`;
    $("doe-setup").innerHTML = names.length
      ? "<tr><th>shape</th><th>low</th><th>high</th><th title='a count of levels from low to high, or the values themselves, e.g. 0, 0.5, 1'>levels</th><th>safe</th></tr>" +
        names.map((n) => {
          const s = this.safe[n];
          return `<tr data-shape="${esc(n)}"><td class="name" title="${esc(n)}">${esc(n)}</td>${cell(n, "lo", "0", "low bound")}
            ${cell(n, "hi", "1", "high bound")}${cell(n, "levels", "3", "levels")}
            <td data-safe="${esc(n)}">${s ? `<button data-use="${esc(n)}" title="use the safe bounds as low and high">` +
              `${fmt(s.lo)} … ${fmt(s.hi)}</button>` : ""}</td></tr>`;
        }).join("")
      : "";
  }

  /** The number typed in a shape's field (an error naming it when it is not one). */
  num(n, f) {
    const row = this.field(n, f), v = Number(row.value.trim());
    if (row.value.trim() === "" || !Number.isFinite(v)) throw new Error(`the ${f === "lo" ? "low" : "high"} bound of ${n} is not a number: "${row.value}"`);
    return v;
  }

  field(n, f) {
    return [...$("doe-setup").querySelectorAll("input[data-field]")].find((i) => i.dataset.shape === n && i.dataset.field === f);
  }

  /** [lo, hi] of a shape, checked. */
  bounds(n) {
    const lo = this.num(n, "lo"), hi = this.num(n, "hi");
    if (!(lo <= hi)) throw new Error(`the bounds of ${n} are the wrong way round: low ${lo} > high ${hi}`);
    return [lo, hi];
  }

  /** A shape's levels: a count spread from low to high, or the values listed. */
  levels(n) {
    const text = this.field(n, "levels").value.trim(), parts = text.split(/[\s,;]+/).filter(Boolean);
    if (parts.length === 1 && /^\d+$/.test(parts[0])) {
      const k = Number(parts[0]), [lo, hi] = this.bounds(n);
      if (k < 1) throw new Error(`${n} needs at least 1 level`);
      if (k === 1) return [lo];
      return Array.from({ length: k }, (_, i) => (i === k - 1 ? hi : lo + (hi - lo) * i / (k - 1)));
    }
    const vals = parts.map(Number);
    if (!vals.length || !vals.every(Number.isFinite)) throw new Error(`the levels of ${n} are neither a count nor numbers: "${text}"`);
    return vals;
  }

  /** Fill the PLAN with a generated design. */
  generate(kind) {
    const names = this.names();
    if (!names.length) { showError("save a preset first: the presets are the shapes"); return; }
    clearError();
    try {
      let rows;
      if (kind === "ff") {
        const levels = names.map((n) => this.levels(n));
        const count = levels.reduce((a, l) => a * l.length, 1);
        if (count > PLAN_ROWS) throw new Error(`a full factorial of these levels has ${fmt(count)} rows; at most ${fmt(PLAN_ROWS)}`);
        rows = fullFactorial(levels);
      } else {
        const n = Number($("doe-lhs-n").value), seed = Number($("doe-lhs-seed").value);
        if (!Number.isInteger(n) || n < 1 || n > PLAN_ROWS) throw new Error(`rows must be a whole number from 1 to ${fmt(PLAN_ROWS)}`);
        if (!Number.isInteger(seed) || seed < 0) throw new Error("the seed must be a whole number, 0 or more");
        rows = latinHypercube(names.map((k) => this.bounds(k)), n, seed);
      }
      const plan = $("doe-plan");
      plan.value = planCsv(names, rows);
      plan.dataset.edited = "1";  // the sliders no longer rewrite it
      $("doe-status").textContent = `${kind === "ff" ? "full factorial" : "Latin hypercube"}: ${fmt(rows.length)} rows`;
    } catch (e) { showError(e.message); }
  }

  /** Ask the service for the safe bounds of every shape (`tetmorph bounds`). */
  async askBounds() {
    if (!state.sessionId) { showError("create a session first"); return; }
    if (!state.presets.length) { showError("save a preset first: the presets are the shapes"); return; }
    clearError();
    setBusy("finding the safe bounds");
    try {
      const id = state.sessionId;
      const doc = await postJson(`/v1/sessions/${id}/bounds`, { shapes: this.shapes.shapes() });
      if (state.sessionId !== id) return;
      this.safe = {};
      for (const [n, b] of Object.entries(doc.bounds)) this.safe[n] = { lo: b.negative.value, hi: b.positive.value };
      this.safeOf = id;
      this.render();
    } catch (e) { showError(e); } finally { setBusy(null); }
  }

  /** The safe bounds of a shape as its low and high. */
  useSafe(n) {
    const s = this.safe[n];
    if (!s) return;
    for (const [f, v] of [["lo", s.lo], ["hi", s.hi]]) {
      this.field(n, f).value = String(v);
      this.typed[n] = { ...this.typed[n], [f]: String(v) };
    }
  }
}
