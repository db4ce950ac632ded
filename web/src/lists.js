// The editable lists of the panels: regions (colour, count, visibility, delete), feature
// candidates, the move history, presets, the handle picker, and the sessions (of the open
// mesh, and all of them in the Sessions dialog).
import { $ } from "./dom.js";
import { css } from "./meshview.js";
import { ask, fmt } from "./panels.js";
import { state } from "./state.js";

const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));

function ago(t) {
  const s = Math.max(0, Date.now() / 1000 - t);
  if (s < 90) return `${Math.round(s)} s ago`;
  if (s < 5400) return `${Math.round(s / 60)} min ago`;
  if (s < 129600) return `${Math.round(s / 3600)} h ago`;
  return `${Math.round(s / 86400)} d ago`;
}

/** Delegate clicks on `[data-act]` buttons of a container to handlers[act](dataset). */
function delegate(el, handlers) {
  el.addEventListener("click", (ev) => {
    const b = ev.target.closest("[data-act]");
    if (b && el.contains(b) && handlers[b.dataset.act]) handlers[b.dataset.act](b.dataset, ev);
  });
}

export function renderRegions(regions) {
  const el = $("regions");
  el.innerHTML = state.regions.map((r) => `<li class="${r.id === state.activeRegion ? "active" : ""}" data-id="${r.id}">
    <span class="sw" style="background:${css(r.color)}"></span>
    <span class="name" data-act="activate" data-id="${r.id}" title="${esc(r.kind)} region; click to paint into it, double-click to rename">${esc(r.name)}</span>
    <span class="muted">${r.kind}</span><span class="count" title="vertices">${fmt(r.count)}</span>
    <label title="visible"><input type="checkbox" data-act="visible" data-id="${r.id}" ${r.visible ? "checked" : ""}></label>
    <button data-act="delete" data-id="${r.id}" title="delete the region">×</button></li>`).join("");
  const c = regions.counts();
  $("sel-count").textContent = `fixed ${c.fixed} · handle ${c.handle}`;
  const d = regions.domainCount();
  $("domain-count").textContent = d ? `domain: ${fmt(d)} vertices, the rest held at rest` : "domain: whole mesh";
  $("domain-clear").disabled = !d;
}

export function wireRegions(regions) {
  const el = $("regions");
  delegate(el, {
    activate: (d) => regions.activate(Number(d.id)),
    delete: (d) => regions.remove(Number(d.id)),
  });
  el.addEventListener("change", (ev) => {
    const t = ev.target;
    if (t.dataset.act === "visible") regions.setVisible(Number(t.dataset.id), t.checked);
  });
  el.addEventListener("dblclick", (ev) => {
    const t = ev.target.closest(".name");
    if (!t) return;
    const r = state.regions.find((x) => x.id === Number(t.dataset.id));
    const name = r && prompt("region name (letters, digits, _ . : = -)", r.name);
    if (name && !regions.rename(r.id, name.trim())) alert(`“${name}” cannot name a region (taken or not a plain name)`);
  });
}

export function renderFeatures(list, onPick, onHover = () => {}) {
  const el = $("features");
  onHover(null);
  if (!list) { el.innerHTML = ""; return; }
  if (!list.length) { el.innerHTML = '<li class="muted">no feature candidates found</li>'; return; }
  el.innerHTML = list.map((f, k) => {
    const what = f.kind === "hole" || f.kind === "boss" ? ` r ${fmt(f.radius)}` : "";
    return `<li data-k="${k}"><span class="name" title="${esc(f.kind)}, ${fmt(f.vertices)} vertices">${esc(f.name)}${what}
      <span class="muted">${fmt(f.vertices)}</span></span>
      <button data-k="${k}" data-kind="fixed" title="a fixed region from it">fixed</button>
      <button data-k="${k}" data-kind="handle" title="a handle region from it">handle</button>${f.axis || f.normal
        ? `<button data-k="${k}" data-kind="axes" title="local axes from its ${f.axis ? "axis" : "normal"} (z), through its ${f.axis ? "centre" : "point"}">axes</button>` : ""}</li>`;
  }).join("");
  el.onclick = (ev) => {
    const b = ev.target.closest("button[data-k]");
    if (b) onPick(list[Number(b.dataset.k)], b.dataset.kind);
  };
  // the pointer on a candidate shows on the model what it would select
  el.onmouseover = (ev) => {
    const li = ev.target.closest("li[data-k]");
    if (li && li.dataset.k !== el.dataset.hover) { el.dataset.hover = li.dataset.k; onHover(list[Number(li.dataset.k)]); }
  };
  el.onmouseleave = () => { delete el.dataset.hover; onHover(null); };
}

export function renderHistory(moves) {
  const el = $("history");
  el.innerHTML = state.history.map((e, k) => `<li data-k="${k}" class="${k === state.historyIndex ? "active" : ""} ${k > state.historyIndex ? "future" : ""}">
    ${k}. ${esc(e.label)}</li>`).join("");
  el.onclick = (ev) => {
    const li = ev.target.closest("li[data-k]");
    if (li) moves.goto(Number(li.dataset.k));
  };
  const cur = el.querySelector("li.active");
  if (cur && (cur.offsetTop < el.scrollTop || cur.offsetTop + cur.offsetHeight > el.scrollTop + el.clientHeight))
    el.scrollTop = cur.offsetTop - el.clientHeight / 2;  // within the list only; the panel does not scroll
  $("undo").disabled = !state.sessionId || state.historyIndex <= 0;
  $("redo").disabled = !state.sessionId || state.historyIndex >= state.history.length - 1;
}

export function renderPresets(moves) {
  const el = $("presets");
  el.innerHTML = state.presets.map((p) => `<li><span class="name" title="apply">${esc(p.name)}</span>
    <button data-act="apply" data-name="${esc(p.name)}">Apply</button>
    <button data-act="delete" data-name="${esc(p.name)}" title="delete the preset">×</button></li>`).join("");
  el.onclick = (ev) => {
    const b = ev.target.closest("button[data-act]");
    if (!b) return;
    const name = b.dataset.name;
    if (b.dataset.act === "apply") { moves.applyPreset(name); return; }
    // the preset is the session's, on the service: every browser that opens the session loses it
    ask(`Delete the preset “${name}” from the session on the service? Its shape slider and its column of ` +
      "the DOE go with it, for every browser that opens this session.", "Delete").then((yes) => {
      if (yes) moves.deletePreset(name);
    });
  };
}

export function renderHandleSelect(moves) {
  const el = $("handle-select");
  const names = Object.keys(state.transforms || {});
  el.innerHTML = names.map((n) => `<option ${n === moves.active ? "selected" : ""}>${esc(n)}</option>`).join("");
  el.disabled = names.length < 2;
}

function sessionRow(s, meshNames, opts) {
  const cur = s.id === state.sessionId;
  const mesh = meshNames.get(s.mesh_id) || s.mesh_id;
  return `<tr class="${cur ? "current" : ""}" data-id="${esc(s.id)}"><td>${esc(s.id)}${cur ? " (open)" : ""}</td>
    ${opts.mesh ? `<td>${esc(mesh)}</td>` : ""}<td>${esc(s.status)}</td><td>${fmt(s.updates)} updates</td>
    <td title="last used">${ago(s.last_used)}</td><td>
    ${cur ? '<button data-act="close">Close</button>' : '<button data-act="open">Open</button>'}
    <button data-act="delete">Delete</button></td></tr>`;
}

/** The sessions of the open mesh, offered when it is opened. */
export function renderMeshSessions(sessions, handlers) {
  const el = $("mesh-sessions");
  const mine = sessions.filter((s) => s.mesh_id === state.meshId && s.id !== state.sessionId);
  if (!state.meshId || !mine.length) { el.innerHTML = ""; return; }
  el.innerHTML = `<p class="hint">This mesh has ${mine.length} session${mine.length === 1 ? "" : "s"} on the service:</p>
    <table class="mini">${mine.map((s) => sessionRow(s, new Map(), { mesh: false })).join("")}</table>`;
  el.onclick = (ev) => act(ev, handlers);
}

export function renderSessionsTable(sessions, meshNames, handlers) {
  const el = $("sessions-table");
  el.innerHTML = sessions.length
    ? `<tr><th>session</th><th>mesh</th><th>status</th><th>updates</th><th>last used</th><th></th></tr>` +
      sessions.map((s) => sessionRow(s, meshNames, { mesh: true })).join("")
    : '<tr><td class="muted">no sessions</td></tr>';
  el.onclick = (ev) => act(ev, handlers);
}

function act(ev, handlers) {
  const b = ev.target.closest("button[data-act]");
  const tr = b && b.closest("tr[data-id]");
  if (tr && handlers[b.dataset.act]) handlers[b.dataset.act](tr.dataset.id);
}
