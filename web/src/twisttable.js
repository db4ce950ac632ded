// A twist row's law in the Edits panel: a linear rate (degrees per unit length) or a table of axial
// positions and angles (MOVE `twist.NAME.table`, interpolated linearly by the library). The table is
// edited in the row: a line per point, "+ point" adds one, × takes one out, Set (or Enter) sends it.
const esc = (s) => String(s).replace(/[&<>"]/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c]));
const num = (x) => String(Number(Number(x).toPrecision(10)));

/** One line of the table: its axial position and angle (empty fields when not given). */
export function tableLine(at = "", deg = "") {
  return `<div class="twist-point"><input type="number" step="any" data-at aria-label="axial position" value="${esc(at)}">
    <input type="number" step="any" data-deg aria-label="angle in degrees" value="${esc(deg)}">
    <button data-act="point-del" title="take this point out">×</button></div>`;
}

/** The controls of a twist row: the law, the rate's field, the table (hidden until chosen). */
export function twistControls() {
  return '<label>law <select data-param="law"><option value="rate">°/length</option><option value="table">table</option></select></label>' +
    '<span data-law="rate"><input type="number" step="any" data-param="angle_deg_per_length" aria-label="degrees per length"></span>' +
    `<div data-law="table" hidden><div class="muted">axial position, angle (°)</div><div data-table>${tableLine(0, 0)}</div>` +
    '<button data-act="point-add">+ point</button></div>';
}

/** Show the law chosen in the row's select. */
export function showLaw(li) {
  const law = li.querySelector("select[data-param=law]").value;
  for (const el of li.querySelectorAll("[data-law]")) el.hidden = el.dataset.law !== law;
}

/** The row's table as the MOVE's rows, or a string that says what is wrong with it. */
export function readTable(li) {
  const rows = [];
  for (const [k, line] of [...li.querySelectorAll(".twist-point")].entries()) {
    const a = line.querySelector("[data-at]").value.trim(), d = line.querySelector("[data-deg]").value.trim();
    if (a === "" || d === "" || !Number.isFinite(Number(a)) || !Number.isFinite(Number(d))) {
      return `point ${k + 1} of the table needs a position and an angle (two numbers)`;
    }
    rows.push({ at: Number(a), angle_deg: Number(d) });
  }
  if (!rows.length) return "the table needs at least one point";
  for (let k = 1; k < rows.length; k++) {
    if (!(rows[k].at > rows[k - 1].at)) {
      return `the table's positions must increase strictly: point ${k + 1} (${num(rows[k].at)}) is not past point ${k} ` +
        `(${num(rows[k - 1].at)})`;
    }
  }
  return rows;
}

/** A twist value into the row: the law, the rate, or the table's lines (not while one is typed in). */
export function syncTwist(li, v) {
  const sel = li.querySelector("select[data-param=law]");
  if (v.table) sel.value = "table"; else if (v.angle_deg_per_length !== undefined) sel.value = "rate";
  showLaw(li);
  const rate = li.querySelector("input[data-param=angle_deg_per_length]");
  if (document.activeElement !== rate) rate.value = num(v.angle_deg_per_length ?? 0);
  const box = li.querySelector("[data-table]");
  if (v.table && !box.contains(document.activeElement)) box.innerHTML = v.table.map((r) => tableLine(num(r.at), num(r.angle_deg))).join("");
}

/** The table's buttons: an empty point added after the last, its position focused, or a point taken out. */
export function editTable(li, act, button) {
  const box = li.querySelector("[data-table]");
  if (act === "point-del") { button.closest(".twist-point").remove(); return; }
  box.insertAdjacentHTML("beforeend", tableLine());
  box.lastElementChild.querySelector("[data-at]").focus();
}
