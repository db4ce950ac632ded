// The Tetrahedralize dialog: fill the open surface with tetrahedra on the service's job queue
// (POST /v1/tetrahedralize with wait=false, then GET /v1/jobs/{id} until it ends), with the target
// edge length, the job's stage and elapsed time, and a Cancel that stops the job's worker process.
//
// fTetWild reports no progress of its own, so the dialog shows the stage the service reports
// (starting, tetrahedralizing, checking, storing) and the seconds spent, with an indeterminate bar:
// no percentage is made up.
import { api, getJson } from "./api.js";
import { $ } from "./dom.js";
import { fmt } from "./panels.js";
import { state } from "./state.js";

/** The service's default target edge length, a fraction of the bounding-box diagonal. */
export const TETRA_DEFAULT_FAC = 0.05;
/** Bounds of the edge length / diagonal (solver/limits.py: EDGE_LENGTH_FAC_MIN, EDGE_LENGTH_FAC_MAX). */
export const TETRA_FAC_MIN = 1e-3, TETRA_FAC_MAX = 1;
const POLL_MS = 500;
const STAGES = {
  uploading: "sending and reading the surface",
  queued: "waiting for a free worker",
  starting: "starting the worker process",
  tetrahedralizing: "fTetWild is filling the surface",
  checking: "orienting and checking the tetrahedra",
  storing: "storing the volume mesh",
};

const sleep = (ms) => new Promise((res) => setTimeout(res, ms));

/** The surface of the open mesh as a file the service tetrahedralizes: its own file, or an OFF of its triangles. */
async function surfaceFile() {
  const stem = state.meshName.replace(/\.[^.]+$/, "");
  if (["stl", "obj", "ply", "off"].includes(state.meshFormat))
    return new File([await (await api(`/v1/meshes/${state.meshId}/file`)).blob()], state.meshName);
  const V = state.V0, F = state.F, lines = ["OFF", `${V.length / 3} ${F.length / 3} 0`];
  for (let i = 0; i < V.length; i += 3) lines.push(`${V[i]} ${V[i + 1]} ${V[i + 2]}`);
  for (let f = 0; f < F.length; f += 3) lines.push(`3 ${F[f]} ${F[f + 1]} ${F[f + 2]}`);
  return new File([lines.join("\n") + "\n"], `${stem}.off`);
}

/** The error envelope's words: "code: message". */
function words(e) {
  const err = e && e.body && e.body.error;
  return err ? `${err.code}: ${err.message}` : String((e && e.message) || e);
}

export class TetraDialog {
  /** `opened(meshId)` lists and opens the stored volume mesh. */
  constructor({ opened }) {
    this.opened = opened;
    this.dlg = $("tetra-dialog");
    this.job = null;        // the running job's id
    this.running = false;
    this.cancelAsked = false;
    this.by = "fac";        // which field the user set last: "fac" (relative) or "abs"
    $("tetra-fac").addEventListener("input", () => { this.by = "fac"; this.sync(); });
    $("tetra-abs").addEventListener("input", () => { this.by = "abs"; this.sync(); });
    $("tetra-run").addEventListener("click", () => { this.run(); });
    $("tetra-cancel").addEventListener("click", () => { this.cancel(); });
    $("tetra-close").addEventListener("click", () => { if (!this.running) this.dlg.close(); });
    this.dlg.addEventListener("cancel", (ev) => { if (this.running) ev.preventDefault(); });  // Esc: not mid-job
  }

  /** Offer the dialog for the open surface, the edge length at the default. */
  open() {
    if (!state.surface || !state.meshId) return;
    $("tetra-fac").value = String(TETRA_DEFAULT_FAC);
    this.by = "fac";
    this.sync();
    $("tetra-what").textContent = `${state.meshName}: ${fmt(state.F.length / 3)} triangles, bounding-box ` +
      `diagonal ${fmt(state.diag)}${state.units ? " " + state.units : ""}.`;
    this.say("", null);
    this.show(false);
    if (!this.dlg.open) this.dlg.showModal();
  }

  /** Keep the relative and absolute edge lengths in step. */
  sync() {
    const d = state.diag;
    if (this.by === "fac") {
      const f = Number($("tetra-fac").value);
      $("tetra-abs").value = Number.isFinite(f) && $("tetra-fac").value !== "" ? String(Number((f * d).toPrecision(6))) : "";
    } else {
      const a = Number($("tetra-abs").value);
      $("tetra-fac").value = Number.isFinite(a) && $("tetra-abs").value !== "" ? String(Number((a / d).toPrecision(6))) : "";
    }
  }

  /** Running or not: which buttons and fields are live. */
  show(running) {
    this.running = running;
    $("tetra-run").disabled = running;
    $("tetra-fac").disabled = running;
    $("tetra-abs").disabled = running;
    $("tetra-close").disabled = running;
    $("tetra-cancel").disabled = !running;
    $("tetra-bar").hidden = !running;
  }

  /** The status line: the stage in words and its elapsed time (or a result or an error). */
  say(text, stage, elapsed) {
    const el = $("tetra-status");
    el.dataset.stage = stage || "";
    el.textContent = stage ? `${STAGES[stage] || stage} (${stage})` +
      (elapsed === undefined ? "" : ` · ${elapsed.toFixed(1)} s`) : text;
  }

  async run() {
    if (this.running || !state.surface) return;
    this.show(true);
    this.cancelAsked = false;
    this.job = null;
    const t0 = performance.now();
    this.say("", "uploading", 0);
    try {
      const fd = new FormData();
      const file = await surfaceFile();
      fd.append("file", file, file.name);
      fd.append("name", `${state.meshName.replace(/\.[^.]+$/, "")}.tet`);
      if (this.by === "abs") fd.append("edge_length", $("tetra-abs").value.trim());
      else fd.append("edge_length_fac", $("tetra-fac").value.trim());
      fd.append("wait", "false");
      let doc = await (await api("/v1/tetrahedralize", { method: "POST", body: fd })).json();
      if (doc.status === undefined) { await this.finish(doc, (performance.now() - t0) / 1000); return; }  // 201
      this.job = doc.id;
      if (this.cancelAsked) { await this.cancel(); return; }
      for (;;) {
        if (doc.status === "done") { await this.finish(doc.mesh, doc.elapsed_s); return; }
        if (doc.status === "cancelled") { this.cancelled(doc); return; }
        if (doc.status === "failed") throw Object.assign(new Error(doc.error.message), { body: { error: doc.error } });
        this.say("", doc.stage, doc.elapsed_s);
        await sleep(POLL_MS);
        if (!this.running || this.job !== doc.id) return;  // cancelled meanwhile
        doc = await getJson(`/v1/jobs/${doc.id}`);
      }
    } catch (e) {
      this.job = null;
      this.show(false);
      this.say(`Failed: ${words(e)}`, null);
    }
  }

  /** Stop the running job: the service kills its worker process and stores nothing. */
  async cancel() {
    if (!this.running) return;
    if (!this.job) { this.cancelAsked = true; this.say("cancelling…", null); return; }  // the POST has not answered
    const id = this.job;
    this.job = null;
    try {
      this.cancelled(await (await api(`/v1/jobs/${id}`, { method: "DELETE" })).json());
    } catch (e) {
      if (e.body && e.body.error && e.body.error.code === "job_finished") {  // it ended first: show what it gave
        const doc = await getJson(`/v1/jobs/${id}`);
        if (doc.status === "done") { await this.finish(doc.mesh, doc.elapsed_s); return; }
      }
      this.show(false);
      this.say(`Cancel failed: ${words(e)}`, null);
    }
  }

  cancelled(doc) {
    this.show(false);
    this.say(`Cancelled after ${fmt(doc.elapsed_s)} s (${(doc.stages || []).map((s) => s.stage).join(" → ")}): ` +
      "the worker was stopped and nothing was stored.", null);
  }

  async finish(mesh, seconds) {
    this.job = null;
    this.show(false);
    const n = mesh.info ? mesh.info.tetrahedra : undefined;
    this.say(`Done in ${fmt(Number(seconds.toFixed(1)))} s: ${n === undefined ? "" : fmt(n) + " tetrahedra, "}` +
      `opening ${mesh.name || mesh.id}.`, null);
    this.dlg.close();
    await this.opened(mesh.id);
  }
}
