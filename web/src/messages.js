// Errors in the user's words. The service answers {"error": {status, code, message, details}};
// explain() turns that (or a network failure, or a plain string) into a sentence saying what
// happened and what to do, keeping the code and the service's own message for reference.

const plural = (n, one, many) => `${n.toLocaleString("en-US")} ${n === 1 ? one : many}`;
const pct = (f) => `${(100 * f).toFixed(1)} %`;

/** The error object of an exception, an envelope or a string. */
export function errorOf(e) {
  if (e && e.body && e.body.error) return e.body.error;
  if (e && e.error && typeof e.error === "object") return e.error;
  if (e instanceof TypeError && /fetch|network/i.test(e.message))
    return { code: "network", message: e.message };
  return { code: "", message: String((e && e.message) || e) };
}

/** {text, hint, code, message, report, action} of an error; action names a way out ("sessions"). */
export function explain(e) {
  const err = errorOf(e);
  const d = err.details || {};
  const code = err.code || "";
  const msg = err.message || "";
  let text = msg, hint = "", action = null;
  const sel = d.selection ? `“${d.selection}”` : "this selection";
  switch (code) {
    case "bad_selection":
      if (/belong to no element/.test(msg)) {
        const n = (msg.match(/\((\d+) in all\)/) || [])[1] || (d.ids || []).length;
        text = `Region ${sel} contains mid-side nodes (or other nodes no element uses): ${n} of its vertices ` +
          "belong to no element, so they cannot be fixed or moved.";
        hint = "The editor leaves such nodes out of the regions it sends; a SPEC you imported may still list " +
          "them: select the region again or name the set (\"set\": NAME) instead of listing ids.";
      } else {
        text = `Region ${sel} names vertices this mesh does not have.`;
      }
      break;
    case "empty_selection":
      text = `Region ${sel} selects no vertex.`;
      hint = "Paint or assign some vertices to it, or delete it.";
      break;
    case "handle_outside_domain":
      text = "A handle reaches outside the morph domain: every node outside the domain is held at rest, so a " +
        "handle there could not move.";
      hint = "Paint the domain over the handles too (paint as domain, Shift adds), or choose Whole mesh.";
      break;
    case "unknown_set":
      text = `The mesh has no set named “${d.set}”.`;
      break;
    case "session_limit":
      text = `The service already holds ${plural(d.sessions ?? 0, "session", "sessions")} for your key ` +
        `(the limit is ${d.limit ?? "reached"}).`;
      hint = "Delete sessions you no longer need in the session list, then create again.";
      action = "sessions";
      break;
    case "inverted_elements": {
      const rep = d.report || {};
      text = d.applied
        ? `This move inverts ${plural(rep.inverted_elements ?? 0, "element", "elements")} (inversion policy: warn, ` +
          "so it is shown anyway)."
        : `This move would invert ${plural(rep.inverted_elements ?? 0, "element", "elements")}, so it was not ` +
          "applied (inversion policy: reject). The mesh stays as it was.";
      if (rep.safe_fraction !== undefined && rep.safe_fraction < 1)
        hint = `About ${pct(rep.safe_fraction)} of the move is safe; the “clamp” policy applies that much.`;
      break;
    }
    case "conflicting_constraints":
      text = d.report ? "This move makes hard constraints contradict each other (for example a vertex both fixed and " +
        "moved), so it was not applied." : "The SPEC's hard constraints contradict each other at rest (for example " +
        "a fixed vertex that a point constraint pulls away), and its conflicts setting is “reject”.";
      if (Array.isArray(d.nodes)) hint = "Constraint diagnostics (right panel) lists the nodes: click one to see it.";
      break;
    case "missing_companion":
      text = `A TetGen mesh comes in two files: ${d.missing || "the .ele file"} is missing.`;
      hint = "Choose the .node and the .ele file together in the upload dialog.";
      break;
    case "unauthorized":
    case "forbidden":
      text = "The service needs a valid API key.";
      hint = "Type your key into the API key box in the top bar.";
      break;
    case "payload_too_large":
      text = `The file is larger than this service accepts${d.limit ? ` (${(d.limit / 1048576).toFixed(0)} MB)` : ""}.`;
      break;
    case "too_many_elements":
      text = `The mesh has ${plural(d.elements ?? 0, "element", "elements")}; this service accepts at most ` +
        `${(d.limit ?? 0).toLocaleString("en-US")}.`;
      break;
    case "rate_limited":
    case "too_many_requests":
      text = "Too many requests at once; wait a moment and try again.";
      break;
    case "session_not_found":
      text = "This session no longer exists on the service (deleted, or removed after being idle).";
      hint = "Create a new session, or pick another one in the session list.";
      action = "sessions";
      break;
    case "mesh_not_found":
      text = "This mesh is not on the service (deleted, or stored under another API key).";
      break;
    case "mesh_in_use":
      text = "The mesh is used by sessions; delete them first.";
      action = "sessions";
      break;
    case "network":
      text = "The service does not answer. Is it running?";
      break;
    case "unknown_format":
      // the service's message lists every format it knows, surfaces and API names included
      text = `${d.filename ? `“${d.filename}”` : "This file"} is not a mesh file the editor reads.`;
      hint = "Upload a volume mesh: Abaqus .inp, Gmsh .msh, VTK .vtu or .vtk, Medit .mesh, Nastran .bdf, " +
        "or TetGen .node together with its .ele. A closed surface is accepted too, as STL or OBJ (or PLY, OFF): " +
        "the editor tetrahedralizes it into a volume mesh (Tetrahedralize, in the Session section).";
      return { text, hint, code, message: "", report: null, action };
    case "no_elements":
      text = `The file is not a volume mesh: ${msg}.`;
      break;
    case "unreadable_file":
    case "unsupported_element":
    case "unsupported_format":
      text = `The file could not be read as a volume mesh: ${msg}`;
      break;
    case "inverted_input":
      text = `The uploaded mesh already has inverted elements: ${msg}`;
      break;
    default:
      break;
  }
  return { text, hint, code, message: msg, report: d.report || null, action, details: d };
}
