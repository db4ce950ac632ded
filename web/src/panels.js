// The panels' read-outs: REPORT table, error panel, scaled-Jacobian histogram with its
// draggable threshold, the colour legend in the view, model size and units, the session
// status line and the busy indicator.
import { $ } from "./dom.js";
import { explain } from "./messages.js";
import { css, QUALITY_COLORS, rainbow } from "./meshview.js";
import { histogram } from "./quality.js";
import { conflictRows, freeWarning } from "./reportnotes.js";
import { claim, emit, on, state } from "./state.js";

// the owner of the state's "feedback" group: the error, the REPORT and the busy indicator shown
const own = claim("feedback");

// ------------------------------------------------------------------ numbers
/** A number as the panels show it: counts exact with thousands separators, measures to 4 digits. */
export function fmt(v) {
  if (typeof v === "boolean") return v ? "yes" : "no";
  if (typeof v !== "number") return String(v);
  if (!Number.isFinite(v)) return String(v);
  if (Number.isInteger(v)) return v.toLocaleString("en-US");
  const a = Math.abs(v);
  if (a !== 0 && (a < 1e-3 || a >= 1e7)) return v.toExponential(3);
  return Number(v.toPrecision(4)).toLocaleString("en-US", { maximumFractionDigits: 8 });
}

export const unitText = () => (state.units ? ` ${state.units}` : "");

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

// ------------------------------------------------------------------ errors
export function showError(e) {
  const x = explain(e);
  $("errors").hidden = false;
  const lines = [];
  if (x.report) {
    const r = x.report;
    lines.push(`inverted elements: ${fmt(r.inverted_elements)}`);
    if (r.safe_fraction !== undefined) lines.push(`safe fraction: ${fmt(r.safe_fraction)}`);
  }
  // a MOVE's refusal carries them in its REPORT, a refusal at rest (Create session) in its details
  const conflicts = x.report ? x.report.conflicting_constraints
    : x.code === "conflicting_constraints" ? (x.details || {}).conflicting_constraints : null;
  if (conflicts && conflicts.length) {
    const c = conflictRows(conflicts, state.labels);
    lines.push(`conflicting constraints: ${c.count}`, ...(c.nodes ? [`at ${c.nodes}`] : []), c.fix);
  }
  $("error-text").innerHTML = `<div class="what">${esc(x.text)}</div>` +
    (x.hint ? `<div class="hint">${esc(x.hint)}</div>` : "") +
    (lines.length ? `<div class="facts">${lines.map(esc).join("<br>")}</div>` : "") +
    (x.code ? `<div class="code">code ${esc(x.code)}${x.message && x.message !== x.text
      ? ` · <span class="raw">${esc(x.message)}</span>` : ""}</div>` : "") +
    (x.action === "sessions" ? '<button id="error-sessions">Open the session list</button>' : "");
  const b = $("error-sessions");
  if (b) b.addEventListener("click", () => emit("open-sessions"));
  own.error = x;
  emit("error");
  if (x.code === "network") watchService();
}

// While "the service does not answer" is shown, ask it every 2 s; the message goes when it answers.
let watching = null;
function watchService() {
  if (watching) return;
  watching = setInterval(async () => {
    if (!state.error || state.error.code !== "network") { clearInterval(watching); watching = null; return; }
    try {
      const r = await fetch("/health", { cache: "no-store" });
      if (!r.ok) return;
    } catch { return; }
    clearInterval(watching);
    watching = null;
    if (state.error && state.error.code === "network") clearError();
  }, 2000);
}

export function clearError() {
  $("errors").hidden = true;
  $("error-text").textContent = "";
  own.error = null;
  emit("error");
}

// ------------------------------------------------------------------ confirmation
/**
 * Ask before something that cannot be taken back: answers true when the user chose `ok`, false on
 * Cancel, Esc or closing the dialog. Cancel has the focus, so Enter alone does not confirm.
 */
export function ask(text, ok = "OK") {
  const dlg = $("confirm-dialog"), yes = $("confirm-ok"), no = $("confirm-cancel");
  if (dlg.open) dlg.close();
  $("confirm-text").textContent = text;
  yes.textContent = ok;
  return new Promise((resolve) => {
    const done = (answer) => {
      dlg.removeEventListener("close", closed);
      yes.onclick = null; no.onclick = null;
      if (dlg.open) dlg.close();
      resolve(answer);
    };
    const closed = () => done(false);
    yes.onclick = () => done(true);
    no.onclick = () => done(false);
    dlg.addEventListener("close", closed);
    dlg.showModal();
    no.focus();
  });
}

// ------------------------------------------------------------------ status
export function setStatus(text) { $("session-status").textContent = text; }
export function setProgress(f) { $("progress").value = f; }

// ------------------------------------------------------------------ REPORT
const ROWS = [
  ["mesh", "mesh"], ["elements", "elements"], ["vertices", "vertices"],
  ["seq", "MOVE #"], ["dropped", "superseded MOVEs"],
  ["inverted_elements", "inverted elements"], ["degenerate_elements", "degenerate elements"],
  ["min_scaled_jacobian", "min scaled Jacobian"], ["safe_fraction", "safe fraction"],
  ["clamped", "clamped"], ["applied_fraction", "applied fraction"],
  ["inverted_elements_unclamped", "inverted before clamping"],
  ["constraint_residual_max", "constraint residual", true], ["max_displacement", "max displacement", true],
  ["max_handle_displacement", "max handle displacement", true],
  ["max_free_displacement", "max free displacement", true],
  ["solve_ms", "server update ms"], ["round_trip_ms", "round trip ms"], ["apply_ms", "frame applied ms"],
  ["reset", "reset"],
];

/** The REPORT the panel shows (null: none), without drawing it. */
export function setReport(rep) {
  own.report = rep;
  emit("report");
}

export function showReport(rep) {
  setReport(rep);
  const rows = [];
  const row = (key, label, value, bad = false) =>
    rows.push(`<tr class="${bad ? "bad" : ""}" data-key="${key}"><td title="${key}">${esc(label)}</td>` +
      `<td>${esc(value)}</td></tr>`);
  if (rep.rejected) row("rejected", "MOVE", "rejected, not applied", true);
  for (const [k, label, withUnit] of ROWS) {
    if (rep[k] === undefined || rep[k] === null) continue;
    const bad = (k === "inverted_elements" && rep[k] > 0) || (k === "clamped" && rep[k]);
    row(k, label, fmt(rep[k]) + (withUnit ? unitText() : ""), bad);
  }
  // a morph that moves something much more than its handle surprises: say by how much, and where to look
  const free = freeWarning(rep.max_handle_displacement, rep.max_free_displacement);
  if (free) row("free_exceeds", "warning", free, true);
  if (rep.conflicting_constraints && rep.conflicting_constraints.length) {
    const c = conflictRows(rep.conflicting_constraints, state.labels);
    row("conflicting", "conflicting constraints", c.count, true);
    if (c.nodes) row("conflicting_nodes", "conflicting at", c.nodes, true);
    row("conflicting_fix", "what to do", c.fix, true);
  }
  const rp = rep.repair;
  if (rp) {
    // the repair's own counts are of tets (a quadratic or mixed element counts as its corner tets)
    row("repair", "repair, inverted tets", `${fmt(rp.inverted_before)} → ${fmt(rp.inverted_after)}` +
      (rp.accepted ? "" : " (not applied)"), !rp.success);
    if (rp.moved_vertices) row("repair_moved", "repair, vertices moved", fmt(rp.moved_vertices));
    if (rp.reason) row("repair_reason", "repair", rp.reason, true);
    if (rep.clamped)
      row("repair_clamped", "repair", `of the full MOVE; not kept: the MOVE was clamped to ${fmt(rep.applied_fraction)} ` +
        "and that result is not repaired", true);
  }
  if (state.sj)
    row("below", `tets with scaled Jacobian < ${fmt(state.threshold)}`, fmt(state.badCount || 0), state.badCount > 0);
  $("report").innerHTML = rows.join("");
}

/** The REPORT rows of the open mesh itself: its name and counts. */
export function meshReport() {
  return { mesh: state.meshName, elements: state.elements, vertices: state.V ? state.V.length / 3 : 0 };
}

/** Re-show the last REPORT (the counts it carries from the page changed). */
export function refreshReport() { if (state.report) showReport(state.report); }

// ------------------------------------------------------------------ model
export function showModel(header) {
  const lo = header.bbox[0], hi = header.bbox[1], u = unitText();
  const size = [0, 1, 2].map((k) => fmt(Number((hi[k] - lo[k]).toPrecision(6))));
  $("model-info").innerHTML =
    `<div>${fmt(state.V.length / 3)} vertices · ${fmt(state.elements)} elements</div>` +
    `<div data-key="size">size ${size.join(" × ")}${u}</div>` +
    ["x", "y", "z"].map((a, k) => `<div class="muted" data-key="bbox-${a}">${a} ${fmt(lo[k])} … ${fmt(hi[k])}${u}</div>`).join("");
}

// ------------------------------------------------------------------ histogram
const HIST = { left: 30, bottom: 16, top: 6, bins: 40 };

export function drawHistogram() {
  const cv = $("hist"), g = cv.getContext("2d");
  if (!state.sjRest) { g.clearRect(0, 0, cv.width, cv.height); return; }
  const { left, bottom, top, bins } = HIST;
  const hr = histogram(state.sjRest, bins), hn = histogram(state.sj, bins);
  const maxCount = Math.max(...hr, ...hn, 1);
  const decades = Math.max(1, Math.ceil(Math.log10(maxCount + 1)));
  const W = cv.width - left, H = cv.height - bottom - top;
  const y = (count) => top + H - Math.log10(count + 1) / decades * H;
  g.clearRect(0, 0, cv.width, cv.height);
  g.font = "10px sans-serif";
  // y scale: log counts, one tick per decade
  g.strokeStyle = "#e3e7ec"; g.fillStyle = "#56616e"; g.textAlign = "right"; g.textBaseline = "middle";
  const ticks = [];
  for (let d = 0; d <= decades; d++) {
    const c = 10 ** d, yy = d === 0 ? y(0) : y(c);
    const text = d === 0 ? "0" : c >= 1000 ? `${c / 1000}k` : String(c);
    g.beginPath(); g.moveTo(left, yy); g.lineTo(cv.width, yy); g.stroke();
    g.fillText(text, left - 3, yy);
    ticks.push(text);
  }
  own.histogramTicks = ticks;
  emit("histogram");
  const w = W / bins;
  for (let b = 0; b < bins; b++) {
    g.fillStyle = "#aab2bd"; g.fillRect(left + b * w, y(hr[b]), w * 0.5, top + H - y(hr[b]));
    g.fillStyle = "#2e86de"; g.fillRect(left + b * w + w * 0.5, y(hn[b]), w * 0.5, top + H - y(hn[b]));
  }
  g.fillStyle = "#56616e"; g.textBaseline = "alphabetic";
  g.textAlign = "left"; g.fillText("-1", left, cv.height - 3);
  g.textAlign = "center"; g.fillText("0", left + W / 2, cv.height - 3);
  g.textAlign = "right"; g.fillText("1", cv.width - 1, cv.height - 3);
  // the threshold, draggable
  const x = thresholdX();
  g.fillStyle = "#d62828"; g.fillRect(x - 1, top, 2, H);
  g.textAlign = x > cv.width - 40 ? "right" : "left";
  g.fillText(fmt(state.threshold), x + (x > cv.width - 40 ? -4 : 4), top + 9);
}

/** Canvas x of the threshold line (of threshold t, default the current one). */
export function thresholdX(t = state.threshold) {
  const cv = $("hist");
  return HIST.left + (t + 1) / 2 * (cv.width - HIST.left);
}

/** Page x of threshold t on the histogram. */
export function thresholdPageX(t) {
  const cv = $("hist"), rect = cv.getBoundingClientRect();
  return rect.left + thresholdX(t) * rect.width / cv.width;
}

function thresholdAt(clientX) {
  const cv = $("hist"), rect = cv.getBoundingClientRect();
  const x = (clientX - rect.left) * cv.width / rect.width;
  const t = (x - HIST.left) / (cv.width - HIST.left) * 2 - 1;
  return Math.round(Math.min(0.99, Math.max(-0.99, t)) * 100) / 100;
}

/** Wire the histogram's threshold drag and input; `apply(t)` sets the threshold everywhere. */
export function wireThreshold(apply) {
  const cv = $("hist");
  let dragging = false;
  cv.addEventListener("pointerdown", (ev) => {
    if (!state.sjRest) return;
    dragging = true;
    cv.setPointerCapture(ev.pointerId);
    apply(thresholdAt(ev.clientX));
  });
  cv.addEventListener("pointermove", (ev) => {
    if (dragging) apply(thresholdAt(ev.clientX));
    else if (state.sjRest) cv.style.cursor = Math.abs((ev.offsetX * cv.width / cv.clientWidth) - thresholdX()) < 6 ? "ew-resize" : "crosshair";
  });
  cv.addEventListener("pointerup", () => { dragging = false; });
  $("threshold").addEventListener("change", () => {
    const t = Number($("threshold").value);
    if (Number.isFinite(t) && t > -1 && t < 1) apply(t);
  });
}

// ------------------------------------------------------------------ legend
/**
 * What the colour legend says: {title, ramp, items} (null: nothing to say). ramp is the colour scale
 * of a quantity ({stops: [css at 0, 1/4, 1/2, 3/4, 1], ticks: [{text, key}] spread from its left end to
 * its right end}) or null; items are swatches ({color: css, text, note, key, region}).
 */
export function legendModel(meshView, regions) {
  if (!state.V) return null;
  const o = meshView.options, items = [];
  let title = "", ramp = null;
  const stops = [0, 0.25, 0.5, 0.75, 1].map((t) => css(rainbow(t)));
  if (o.colorBy === "quality" && meshView.qualityRange) {
    const [lo, hi] = meshView.qualityRange, high = o.qualityMetric === "aspect_ratio";
    const name = { scaled_jacobian: "scaled Jacobian", aspect_ratio: "aspect ratio", min_dihedral_deg: "min dihedral angle (°)" }[o.qualityMetric];
    title = `${name} of each element`;
    ramp = { stops, ticks: [{ text: fmt(high ? lo : hi), key: "q-best" }, { text: fmt(high ? hi : lo), key: "q-worst" }] };
  } else if (o.colorBy === "displacement") {
    const max = meshView.dispMax;
    title = `displacement magnitude${unitText() ? ` (${state.units})` : ""}`;
    ramp = { stops, ticks: [{ text: "0" }, { text: fmt(max / 2) }, { text: fmt(max), key: "disp-max" }] };
  } else {
    for (const r of regions) {
      if (r.visible) items.push({ color: css(r.color), text: r.name, note: `${r.kind} · ${fmt(r.count)}`, region: r.name });
    }
  }
  if (o.bad || o.clip) {
    items.push({ color: css(QUALITY_COLORS.poor), text: `poor tet, scaled Jacobian < ${fmt(state.threshold)}`, key: "legend-poor" },
      { color: css(QUALITY_COLORS.inverted), text: "inverted tet", key: "legend-inverted" });
  }
  if (o.ghost) items.push({ color: "rgba(125,138,153,.45)", text: "rest shape" });
  return title || ramp || items.length ? { title, ramp, items } : null;
}

/** The colour legend in the view: what each colour on screen means. */
export function drawLegend(meshView, regions) {
  const el = $("legend"), m = legendModel(meshView, regions);
  if (!m) { el.hidden = true; el.innerHTML = ""; return; }
  const html = [];
  const sw = (c) => `<span class="sw" style="background:${c}"></span>`;
  const key = (k) => (k ? ` data-key="${k}"` : "");
  if (m.title) html.push(`<div class="lg-title">${esc(m.title)}</div>`);
  if (m.ramp) {
    const stops = m.ramp.stops.map((c, k) => `${c} ${25 * k}%`).join(", ");
    html.push(`<div class="ramp" style="background:linear-gradient(to right, ${stops})"></div>`,
      `<div class="ramp-ticks">${m.ramp.ticks.map((t) => `<span${key(t.key)}>${esc(t.text)}</span>`).join("")}</div>`);
  }
  for (const it of m.items) {
    const attr = it.region !== undefined ? ` data-region="${esc(it.region)}"` : key(it.key);
    html.push(`<div${attr}>${sw(it.color)}${esc(it.text)}${it.note ? ` <span class="muted">${esc(it.note)}</span>` : ""}</div>`);
  }
  el.innerHTML = html.join("");
  el.hidden = false;
}

/**
 * Paint the legend onto a 2D canvas of width w and height h at its lower right corner, as the view
 * shows it (`scale`: canvas pixels per CSS pixel). Answers what was painted: {box: {x, y, w, h} in
 * canvas pixels, title, ticks, items}, or null when there is no legend.
 */
export function paintLegend(g, model, w, h, scale = 1) {
  if (!model) return null;
  const px = (v) => Math.round(v * scale), pad = px(7), line = px(16), rampW = px(170), rampH = px(10);
  const font = (bold) => `${bold ? "600 " : ""}${px(12)}px system-ui, sans-serif`;
  const rows = [];
  let width = 0;
  const measure = (text, bold) => { g.font = font(bold); return g.measureText(text).width; };
  if (model.title) { rows.push({ kind: "title" }); width = Math.max(width, measure(model.title, true)); }
  if (model.ramp) {
    rows.push({ kind: "ramp" }, { kind: "ticks" });
    width = Math.max(width, rampW, model.ramp.ticks.reduce((a, t) => a + measure(t.text) + px(8), 0));
  }
  for (const it of model.items) {
    rows.push({ kind: "item", it });
    width = Math.max(width, px(16) + measure(it.text) + (it.note ? px(6) + measure(it.note) : 0));
  }
  const heights = rows.map((r) => (r.kind === "ramp" ? rampH + px(4) : line));
  const bw = Math.ceil(width) + 2 * pad, bh = heights.reduce((a, b) => a + b, 0) + 2 * pad;
  const bx = w - px(8) - bw, by = h - px(8) - bh;
  g.save();
  g.fillStyle = "rgba(255,255,255,0.92)";
  g.strokeStyle = "#dde1e6";
  g.lineWidth = Math.max(1, scale);
  g.fillRect(bx, by, bw, bh);
  g.strokeRect(bx + 0.5, by + 0.5, bw - 1, bh - 1);
  g.textBaseline = "middle";
  let y = by + pad;
  rows.forEach((r, k) => {
    const mid = y + heights[k] / 2, x = bx + pad;
    g.fillStyle = "#1d232b";
    g.textAlign = "left";
    if (r.kind === "title") { g.font = font(true); g.fillText(model.title, x, mid); }
    else if (r.kind === "ramp") {
      const grad = g.createLinearGradient(x, 0, x + rampW, 0);
      model.ramp.stops.forEach((c, i) => grad.addColorStop(i / (model.ramp.stops.length - 1), c));
      g.fillStyle = grad;
      g.fillRect(x, y + px(2), rampW, rampH);
    } else if (r.kind === "ticks") {
      g.font = font(false);
      const ticks = model.ramp.ticks, n = ticks.length;
      ticks.forEach((t, i) => {
        g.textAlign = i === 0 ? "left" : i === n - 1 ? "right" : "center";
        g.fillText(t.text, x + rampW * (n === 1 ? 0 : i / (n - 1)), mid);
      });
    } else {
      g.fillStyle = r.it.color;
      g.fillRect(x, mid - px(5), px(10), px(10));
      g.fillStyle = "#1d232b";
      g.font = font(false);
      g.fillText(r.it.text, x + px(16), mid);
      if (r.it.note) {
        g.fillStyle = "#7a8694";
        g.fillText(r.it.note, x + px(16) + measure(r.it.text) + px(6), mid);
      }
    }
    y += heights[k];
  });
  g.restore();
  return { box: { x: bx, y: by, w: bw, h: bh }, title: model.title,
    ticks: model.ramp ? model.ramp.ticks.map((t) => t.text) : [], items: model.items.map((it) => it.text) };
}

// ------------------------------------------------------------------ busy
let busyTimer = null;
const BUSY_LOG = 200;

/**
 * Show the busy indicator with elapsed time (`what`: "building", "solving", "loading"), or hide it
 * (null). With `delayMs` it appears only when the work lasts that long (no flicker while dragging).
 */
export function setBusy(what, delayMs = 0) {
  const el = $("busy");
  if (!what) {
    if (own.busy) own.busyLog.push({ what: own.busy.what, ms: performance.now() - own.busy.t0, shown: !!own.busy.shown });
    own.busy = null;
    if (own.busyLog.length > BUSY_LOG) own.busyLog.splice(0, own.busyLog.length - BUSY_LOG);
    clearInterval(busyTimer); busyTimer = null;
    el.hidden = true;
    emit("busy");
    return;
  }
  if (own.busy && own.busy.what === what) return;
  if (own.busy) own.busyLog.push({ what: own.busy.what, ms: performance.now() - own.busy.t0, shown: !!own.busy.shown });
  own.busy = { what, t0: performance.now(), delayMs };
  emit("busy");
  const tick = () => {
    const b = own.busy;
    if (!b) return;
    const ms = performance.now() - b.t0;
    if (ms < b.delayMs) return;
    el.hidden = false;
    b.shown = true;
    $("busy-text").textContent = `${b.what} ${(ms / 1000).toFixed(1)} s`;
  };
  tick();
  clearInterval(busyTimer);
  busyTimer = setInterval(tick, 100);
}

on("derived", () => {
  $("cut-count").textContent = state.clip ? `${fmt(state.cut)} tets in the section` : "";
  drawHistogram();
});
