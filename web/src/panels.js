// The side panels' read-outs: REPORT table, error panel, scaled-Jacobian histogram, counts
// and the session status line.
import { $ } from "./dom.js";
import { LOW_QUALITY } from "./meshview.js";
import { histogram } from "./quality.js";
import { on, state } from "./state.js";

export function showError(e) {
  const sec = $("errors");
  sec.hidden = false;
  const err = e && e.body && e.body.error ? e.body.error : { message: String(e && e.message || e) };
  let text = `${err.code || "error"}: ${err.message}`;
  const rep = err.details && err.details.report;
  if (rep) {
    text += `\ninverted elements: ${rep.inverted_elements}`;
    if (rep.safe_fraction !== undefined) text += `\nsafe fraction: ${rep.safe_fraction}`;
    if (rep.conflicting_constraints && rep.conflicting_constraints.length)
      text += `\nconflicting constraints: ${JSON.stringify(rep.conflicting_constraints.slice(0, 5))}`;
  } else if (err.details && Object.keys(err.details).length) {
    text += `\n${JSON.stringify(err.details).slice(0, 600)}`;
  }
  $("error-text").textContent = text;
}

export function clearError() { $("errors").hidden = true; $("error-text").textContent = ""; }

export function setStatus(text) { $("session-status").textContent = text; }
export function appendStatus(text) { $("session-status").textContent += text; }
export function setProgress(f) { $("progress").value = f; }

export function showSelectionCounts(f, h) { $("sel-count").textContent = `fixed ${f} · handle ${h}`; }

export function showReport(rep) {
  state.report = rep;
  const keys = ["mesh", "elements", "vertices", "seq", "dropped", "inverted_elements", "degenerate_elements",
    "min_scaled_jacobian", "safe_fraction", "clamped", "applied_fraction", "inverted_elements_unclamped",
    "constraint_residual_max", "max_displacement", "solve_ms", "round_trip_ms", "apply_ms", "reset"];
  const rows = [];
  for (const k of keys) {
    if (rep[k] === undefined || rep[k] === null) continue;
    const v = typeof rep[k] === "number" ? Number(rep[k].toPrecision(5)) : rep[k];
    const bad = (k === "inverted_elements" && rep[k] > 0) || (k === "clamped" && rep[k]);
    rows.push(`<tr class="${bad ? "bad" : ""}"><td>${k}</td><td>${v}</td></tr>`);
  }
  if (rep.conflicting_constraints && rep.conflicting_constraints.length)
    rows.push(`<tr class="bad"><td>conflicting</td><td>${rep.conflicting_constraints.length}</td></tr>`);
  if (rep.repair) rows.push(`<tr><td>repair</td><td>${rep.repair.inverted_before} → ${rep.repair.inverted_after}</td></tr>`);
  if (state.sj) rows.push(`<tr><td>elements below ${LOW_QUALITY}</td><td>${state.badCount || 0}</td></tr>`);
  $("report").innerHTML = rows.join("");
}

export function drawHistogram() {
  const cv = $("hist"), g = cv.getContext("2d");
  const bins = 40, hr = histogram(state.sjRest, bins), hn = histogram(state.sj, bins);
  const top = Math.log10(Math.max(...hr, ...hn, 1) + 1);
  g.clearRect(0, 0, cv.width, cv.height);
  const w = cv.width / bins, H = cv.height - 14;
  for (let b = 0; b < bins; b++) {
    const a = Math.log10(hr[b] + 1) / top * H, c = Math.log10(hn[b] + 1) / top * H;
    g.fillStyle = "#aab2bd"; g.fillRect(b * w, H - a, w * 0.5, a);
    g.fillStyle = "#2e86de"; g.fillRect(b * w + w * 0.5, H - c, w * 0.5, c);
  }
  g.fillStyle = "#56616e"; g.font = "10px sans-serif";
  g.fillText("-1", 0, cv.height - 2); g.fillText("0", cv.width / 2 - 3, cv.height - 2);
  g.fillText("1", cv.width - 8, cv.height - 2);
  g.fillStyle = "#d62828"; g.fillRect(cv.width / 2, 0, 1, H);
}

on("derived", () => {
  $("cut-count").textContent = $("clip").checked ? `${state.cut} tets in the section` : "";
  drawHistogram();
});
