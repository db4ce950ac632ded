"""The hand-written parts of the generated reference pages (docs/hooks/reference.py).

The lists of settings, codes, routes and fields come from the code; what is here adds what
the code does not say: notes on settings, and the meaning and fix of each error code. An
entry for a setting or a code that no longer exists fails the strict build.
"""

from __future__ import annotations

# ----------------------------------------------------------------------------------------------- settings

#: Defaults computed at start, as a reader should see them.
SETTING_DEFAULTS = {
    "data_dir": "`$XDG_DATA_HOME/tetmorph`, else `~/.local/share/tetmorph`",
    "api_keys": "empty",
    "replica_id": "host name and process id",
}

#: What the field's description leaves out.
SETTING_NOTES = {
    "data_dir": "Holds the meshes, the sessions and the installation secret `secret.key`; keep that file with "
                "the data, without it the owners of records cannot be recognised.",
    "api_keys": "Each entry is `key` or `tenant=key`. When set, every `/v1` request needs `X-API-Key` (or "
                "`Authorization: Bearer`); `?api_key=` is accepted on the WebSocket upgrade only (browsers cannot "
                "set headers there) and is redacted in logs. A key sees only its tenant's meshes and sessions "
                "(others answer 404). Rotating a key: "
                "[API keys and owner ids](../guide/service.md#api-keys-and-owner-ids).",
    "max_upload_mb": "Answered with 413 `payload_too_large`.",
    "max_elements": "Answered with 422 `too_many_elements`.",
    "max_sessions": "Answered with 429 `session_limit`.",
    "rate_limit_per_s": "A token bucket per key; 429 `rate_limited` with `Retry-After`.",
    "session_ttl_s": "Any authenticated use, polling included, counts as use; `expires_at` says when.",
    "solver_threads": "Each solve counts the solves in flight and the machine's runnable tasks "
                      "(`/proc/loadavg`) when it starts and takes its share of the free cores; `/metrics` shows "
                      "`tetmorph_solves_in_flight` and `tetmorph_solve_threads`.",
    "tetra_time_limit_s": "Answered with 422 `job_time_limit`.",
    "tetra_max_triangles": "Answered with 422 `too_many_triangles`.",
    "log_json": "Each line has time, level, logger, request_id and message.",
    "database_url": "Needs the `cluster` extra (psycopg 3); see [Cluster](../guide/cluster.md).",
    "ray_address": "Without it a batch with engine `ray` answers 422 `engine_unavailable`; see "
                   "[Batches on Ray](../guide/batches.md#batches-on-ray).",
    "batch_max_rows": "Answered with 422 `too_many_rows`.",
    "batch_max_result_mb": "The batch fails with `result_too_large` and leaves nothing.",
    "bounds_time_limit_s": "Answered with 422 `bounds_time_limit`, naming the shapes finished.",
    "min_free_mb": "`GET /ready` measures the free space of the data directory's file system "
                   "(`shutil.disk_usage`); keep the reserve above the largest upload. A write that fails for want "
                   "of space (`ENOSPC`, `EDQUOT`) answers 507 `storage_full` with `Retry-After: 30` whatever the "
                   "reserve; see [Service, a full disk](../guide/service.md#a-full-disk).",
}

#: Environment variables the solver reads itself.
SOLVER_ENVIRONMENT = {
    "TETMORPH_SOLVER": "`cholmod`, `pardiso` or `scipy` forces the symmetric backend; a name that is not "
                       "installed fails with `unknown_backend` (see "
                       "[Method, sparse backends](../method.md#sparse-backends)). Read once, when `solver` is "
                       "imported (`solver/environment.py`), into `solver.options.ENVIRONMENT`: the default "
                       "`SolveOptions` of callers that pass none (`precompute(..., options=...)`, `--backend`, "
                       "`TETMORPH_SOLVE_BACKEND`); a SPEC's `solve_options.backend` wins over all of them.",
    "TETMORPH_SUPERNODAL": "`0` keeps PARDISO and CHOLMOD at every size instead of tetmorph's supernodal sweeps "
                           "(`SolveOptions(sweeps=False)`; read once at import).",
    "TETMORPH_COLUMN_BASIS": "`0` keeps the direct stacked solve of DOE blocks instead of the plan's column basis "
                             "([DOE speed](../guide/workflows.md#doe-speed); `SolveOptions(basis=False)`; read "
                             "once at import).",
    "TETMORPH_BATCH_MALLOC": "`0` leaves glibc's allocator as it is in batch processes (`tetmorph doe`, Ray actors).",
    "TETMORPH_MKL_RT, PYPARDISO_MKL_RT": "Path of MKL's `libmkl_rt` when it is not where pip's `mkl` wheel puts it.",
    "GOMP_SPINCOUNT, OMP_WAIT_POLICY, OPENBLAS_THREAD_TIMEOUT": "Set at import to bounded spin waits "
                                                               "(`GOMP_SPINCOUNT=10000`, `OPENBLAS_THREAD_TIMEOUT=16`) "
                                                               "unless already set (`solver/environment.py`).",
    "OMP_NUM_THREADS": "The most threads a compiled kernel's loop uses (OpenMP's own setting; the solver then "
                       "gives each solve the cores that are free, `solver/linalg/threads.py`).",
}

# -------------------------------------------------------------------------------------------- error codes

ERRORS_INTRO = """# Error codes

Generated from the code when the site is built: the codes of `service/errors.py`
(`CODE_STATUS`, `HTTP_CODES`), the error classes of `solver/errors.py` (their
default codes and the codes their docstrings list) and every code the `solver`
and `service` packages raise. The HTTP status is what `service.errors.status_of`
answers for that code and exception type.

Every error answer of the REST service has one body:

```json
{"error": {"status": 422, "code": "inverted_elements", "type": "InversionError",
           "message": "...", "details": {...}}}
```

The message names counts, ids and the field at fault; `details` holds the same
facts as JSON. The library raises the same codes as typed exceptions
(`SolverError.code`, `.details`), and the command line prints them as
`tetmorph: error [code]: message` and exits with 1. A WebSocket stream answers a
failed frame with a text frame `{"seq", "error"}` holding the same envelope.
"""

STATUS_TITLES = {
    400: "400: a request that cannot be parsed", 401: "401: who is asking", 404: "404: unknown resources",
    405: "405: method not allowed", 409: "409: the resource's state forbids the request",
    410: "410: removed sessions", 413: "413: too large", 422: "422: the documents, files or parameters",
    429: "429: limits per key", 431: "431: request heads too large", 500: "500: faults of the server",
    503: "503: the store cannot be reached", 507: "507: the data directory is full",
}

_REEXPORT = "Check the export that wrote it; re-export or upload it again."

#: code -> (meaning, fix).
ERRORS: dict[str, tuple[str, str]] = {
    # requests and authentication
    "bad_request": ("The request could not be parsed (a malformed body, form or header).",
                    "Send the body the route's reference names, with its content type."),
    "missing_api_key": ("The service has API keys and the request carries none.",
                        "Send `X-API-Key: KEY` (or `Authorization: Bearer KEY`; `?api_key=` on a WebSocket)."),
    "invalid_api_key": ("The key sent is not one of `TETMORPH_API_KEYS`.", "Use a configured key."),
    "conflicting_credentials": ("The request names two different API keys (two `X-API-Key` headers, `X-API-Key` "
                                "and `Authorization: Bearer`, or a header and `?api_key=`); `details.headers` "
                                "names where, never the keys.", "Send one key; sent twice, it must be the same."),
    "invalid_host": ("An HTTP/1.1 request without a `Host` header, or a request with two (RFC 9112, section 3.2).",
                     "Send exactly one `Host` header; HTTP clients do it themselves."),
    "headers_too_large": ("The request line and headers pass `MAX_HEADER_KB`, or the request has more than "
                          "`MAX_HEADERS` header lines; answered as soon as that much has come, and the connection "
                          "is closed.", "Send fewer or shorter headers (a proxy that adds some counts too), or "
                          "raise `TETMORPH_MAX_HEADER_KB` / `TETMORPH_MAX_HEADERS`."),
    "unauthorized": ("The request lacks valid authentication.", "Send a configured API key."),
    "forbidden": ("The request is not allowed.", "Use a key that may do it."),
    # resources
    "mesh_not_found": ("No mesh with that id, or it belongs to another key.",
                       "List your meshes with `GET /v1/meshes`; upload the mesh again if it was deleted."),
    "session_not_found": ("No session with that id, or it belongs to another key (or it was removed long "
                          "enough ago to be forgotten).", "Create the session again with `POST /v1/sessions`."),
    "job_not_found": ("No job with that id (jobs live in memory: a restart forgets them).",
                      "Submit the job again."),
    "not_found": ("No such route or resource.", "Check the path against the REST reference."),
    "method_not_allowed": ("The route exists but not with this method.", "Use a method the route lists."),
    "mesh_in_use": ("The mesh is used by sessions, so it cannot be deleted.", "Delete those sessions first."),
    "session_exists": ("A session with that id already exists.", "Choose another id, or use the existing one."),
    "job_finished": ("The job has already ended, so it cannot be cancelled.", "Read its result or error instead."),
    "job_not_finished": ("The batch has not finished; its result does not exist yet.",
                         "Poll `GET /v1/sessions/{id}/batch/{job_id}` until `status` is done."),
    "version_conflict": ("Another replica committed a MOVE to this session first; nothing was committed.",
                         "Send the MOVE again (MOVEs are absolute, so a retry is safe); the client retries itself."),
    "conflict": ("The resource's state forbids the request.", "Read the resource and retry."),
    "session_expired": ("The session was removed after `SESSION_TTL_S` without use.",
                        "Create it again; keep sessions in use, or raise `TETMORPH_SESSION_TTL_S`."),
    "gone": ("The resource was removed.", "Create it again."),
    "payload_too_large": ("The body (or WebSocket frame) is larger than `MAX_UPLOAD_MB` (`MAX_FRAME_KB`).",
                          "Send a smaller file or frame, or raise the limit."),
    "not_acceptable": ("The `Accept` header asks for a representation the route does not offer.",
                       "Accept `application/json` or `application/octet-stream` as the route lists."),
    "unsupported_media_type": ("The body's content type is not one the route reads.",
                               "Send JSON as `application/json` and files as `multipart/form-data`."),
    # documents and parameters
    "invalid_request": ("A field of the request is missing, of the wrong type, unknown, out of its range, or holds "
                        "a NUL; or a document breaks one of its own rules (a box's min above its max, a zero "
                        "normal, a POINT with two forms, barycentric coordinates that do not sum to 1, two "
                        "precisions that disagree). The message and `details` name the field.",
                        "Fix the named field (see the document reference)."),
    "invalid_message": ("A WebSocket frame is not a JSON object `{seq, move}` (binary, not JSON, no `move`).",
                        "Send text frames `{\"seq\": k, \"move\": MOVE}`."),
    "out_of_range": ("A translation, pivot or target lies farther than 100 bounding-box diagonals from the mesh; "
                     "or a tetrahedralization's `edge_length` (`details.field`) is outside [0.001, 1] diagonals "
                     "of the surface.",
                     "Check the units of the MOVE against the mesh's; give an edge length within "
                     "`details.min` and `details.max`."),
    "solve_option_not_allowed": ("The SPEC's `solve_options` set a field the service leaves to its operator "
                                 "(by default `backend`, `sweeps` and `basis`).",
                                 "Leave the field out, or ask the operator to add it to "
                                 "`TETMORPH_SPEC_SOLVE_OPTIONS`."),
    "index_out_of_range": ("A vertex id is not below the mesh's vertex count.",
                           "Ids are 0-based, in file order; `tetmorph info` gives the count."),
    "unknown_metric": ("A quality metric that does not exist.", "Choose from the metrics the message lists."),
    "unknown_preset": ("A quality-check preset that does not exist (`details.presets` lists them).",
                       "Choose `tetmorph`, `abaqus`, `calculix` or `nastran` (docs/guide/validity.md)."),
    "invalid_threshold": ("A quality-check threshold that is not a finite number within 1e12 in magnitude "
                          "(`details.field` names the criterion).",
                          "Give a number, or `none` (CLI) / `off=` (REST) to leave the criterion unchecked."),
    "element_sets_unsupported": ("An element set of the failing elements was asked for a mesh whose format has "
                                 "none (Gmsh, VTK, Medit, TetGen, arrays), or for an Abaqus/CAE assembly deck, whose "
                                 "element numbers repeat across instances.",
                                 "Take the CSV of the failing elements instead, or write a flat deck first "
                                 "(`tetmorph morph --flatten`)."),
    "not_a_volume_mesh": ("A quality check of a triangle surface: the criteria measure volume elements.",
                          "Check the tetrahedral mesh (tetrahedralize the surface first)."),
    "deformed_mismatch": ("`tetmorph check --deformed` was given a mesh with other node or element counts than "
                          "the rest mesh (`details.nodes`, `details.elements`).",
                          "Give the same mesh deformed: the file `tetmorph morph` wrote from it."),
    "unknown_format": ("A format name or extension that names no format, or one this installation lacks.",
                       "Use a format from `GET /v1/formats` (or pass `--format`); install the package named."),
    "too_many_elements": ("The mesh has more volume elements than `MAX_ELEMENTS`.",
                          "Coarsen the mesh or raise `TETMORPH_MAX_ELEMENTS`."),
    "too_many_triangles": ("The surface has more triangles than `TETRA_MAX_TRIANGLES`.",
                           "Decimate the surface or raise `TETMORPH_TETRA_MAX_TRIANGLES`."),
    "too_many_rows": ("The plan has more rows than `BATCH_MAX_ROWS`.", "Split the plan into several batches."),
    "non_finite_result": ("The solve produced NaN or infinite positions; the session is unchanged.",
                          "Check the MOVE's magnitudes and the SPEC's constraints (the REPORT's `finite`)."),
    "job_time_limit": ("fTetWild ran longer than `TETRA_TIME_LIMIT_S`.",
                       "Use a coarser `edge_length_fac` or raise the limit."),
    "surface_not_found": ("A SPEC target names a `mesh_id` that is not stored.",
                          "Upload the surface with `POST /v1/meshes` and use its id."),
    "not_a_surface": ("A triangle surface was expected (a target, a tetrahedralization) and the file is a "
                      "volume mesh, or the other way round.", "Give a triangle surface there; morph a volume "
                      "mesh directly."),
    "engine_unavailable": ("A batch asks for engine `ray` and the service has no `RAY_ADDRESS`.",
                           "Start the service with `TETMORPH_RAY_ADDRESS`, or use engine `local`."),
    "solver_unavailable": ("A study names a solver the service has not configured, or whose program is not "
                           "installed on the replica.", "Name one of `TETMORPH_STUDY_SOLVERS` (the error lists "
                           "them); the operator adds a solver there and installs its program."),
    "duplicate_file_name": ("Two uploaded files are stored under one name once folders and odd characters are "
                            "cleaned from their names (`../x/beam.node` and `beam.node`).",
                            "Rename one of the files the error names."),
    "duplicate_key": ("An object of the JSON body or stream frame names a key twice (escaped spellings count as "
                      "the same key); `details.key` and `details.field`, its path, say which.",
                      "Keep one of the two entries; check what wrote the document."),
    "invalid_options": ("A `SolveOptions` document has an unknown field, backend or a value of the wrong type.",
                        "Use `backend` (auto, cholmod, pardiso, scipy), `sweeps` and `basis` (true or false)."),
    "no_range": ("`tetmorph optimize`: a shape inverts elements at any non-zero value, so its safe range is empty.",
                 "Give the shape's range with `--bounds NAME=LO:HI`, or change the shape."),
    "result_too_large": ("The batch's zip grew past `BATCH_MAX_RESULT_MB`; nothing was kept.",
                         "Split the plan, or raise `TETMORPH_BATCH_MAX_RESULT_MB`."),
    "bounds_time_limit": ("The bounds search ran longer than `BOUNDS_TIME_LIMIT_S`.",
                          "Ask for fewer shapes or a wider `tol`; the message names the shapes finished."),
    # limits
    "rate_limited": ("The key sent more requests than `RATE_LIMIT_PER_S` with bursts of `RATE_BURST`.",
                     "Wait for `Retry-After` seconds; the client does it itself."),
    "session_limit": ("The key has `MAX_SESSIONS` sessions already.", "Delete a session first."),
    "connection_limit": ("The key has `MAX_CONNECTIONS_PER_KEY` streams open (WebSocket close 4429).",
                         "Close a stream first."),
    "too_many_requests": ("Too many requests.", "Wait for `Retry-After` seconds."),
    # server
    "internal_error": ("A fault of the server; the message names the exception type only, the log has the "
                       "traceback under the request's `X-Request-ID`.", "Report it with the request id."),
    "build_failed": ("Building the session failed in its worker.", "Read the session's `error`; report it if it "
                     "names no fault of the SPEC or mesh."),
    "worker_failed": ("A worker process (fTetWild, a batch) died.", "Submit again; report it if it repeats."),
    "unknown_backend": ("`TETMORPH_SOLVER` names a backend that is unknown or not installed.",
                        "Unset it, or install the backend (`cholmod` needs scikit-sparse)."),
    "store_unavailable": ("PostgreSQL cannot be reached; nothing was stored.",
                          "Retry after `Retry-After` (1 s); `GET /ready` says when the replica is back."),
    "unavailable": ("The service cannot answer now.", "Retry later; `GET /ready` gives the failing check."),
    "storage_full": ("A write of the data directory failed for want of space: its disk is full (`ENOSPC`) or the "
                     "service's disk quota is spent (`EDQUOT`). Nothing of the request was stored and every record "
                     "stored before is intact (a MOVE is not committed: the session keeps its version); a batch or "
                     "tetrahedralization job fails with this code and leaves no file.",
                     "Free space in the data directory (`TETMORPH_DATA_DIR`: old meshes, finished jobs' zips) or "
                     "grow its volume, then send the request again after `Retry-After` (30 s). `GET /ready` answers "
                     "503 while less than `TETMORPH_MIN_FREE_MB` is free."),
    # files
    "unreadable_file": ("The file cannot be read as its format; the reader's own words are in the message.",
                        _REEXPORT),
    "empty_file": ("The file has zero bytes, or only blanks.", "Check that the upload or the export finished."),
    "truncated_file": ("The file stops early: a section without its end, a text file cut mid-line.",
                       _REEXPORT),
    "wrong_format": ("The content is another format than the name says (`details.detected`).",
                     "Rename the file to its real extension, or pass `format` / `--format`."),
    "surface_not_volume": ("A triangle surface where a volume mesh is expected.",
                           "Fill it with tetrahedra first: `tetmorph tetrahedralize SURFACE --output PART.vtu`."),
    "undefined_node": ("An element refers to a node the file does not define (element, node and line named).",
                       _REEXPORT),
    "no_nodes": ("The file defines no nodes (a Nastran deck without `BEGIN BULK`, a Gmsh file without `$Nodes`).",
                 "Export the mesh, not only the model tree."),
    "no_elements": ("The file has no volume elements or triangles: only shells, beams or other elements, "
                    "counted by type in the message.",
                    "Export the volume mesh (tetrahedra), or upload the closed surface as STL or OBJ and "
                    "tetrahedralize it."),
    "no_triangles": ("A surface file without triangles.", "Export the surface as triangles."),
    "undefined_coordinate_system": ("A Nastran GRID's CP field, or the RID of a CORD2x card in its chain, names a "
                                    "coordinate system no CORD2R, CORD2C or CORD2S card of the deck defines "
                                    "(`details.grid`, `details.system`, `details.chain`).",
                                    "Add the system's card to the deck (a system in an INCLUDE file is not read)."),
    "cyclic_coordinate_system": ("The RIDs of a Nastran GRID's CP system loop back to it (`details.chain`): no "
                                 "system of the loop is placed in the basic system.",
                                 "Give one system of the loop RID 0 or a system outside the loop."),
    "unsupported_coordinate_system": ("A Nastran GRID's CP system (or one in its chain of RIDs) is defined by a "
                                      "CORD1R/C/S card, three GRIDs that move with the mesh, or by CORD3G "
                                      "(`details.card`).",
                                      "Define the system by a CORD2R, CORD2C or CORD2S card, or export the GRIDs "
                                      "in the basic system."),
    "invalid_coordinate_system": ("A CORD2R/C/S card in a Nastran GRID's chain defines no system: A and B "
                                  "coincide, C is on the line AB, a field is not a number, or the id is defined "
                                  "twice differently (`details.card`, `details.line`).",
                                  "Correct the card named in the message."),
    "duplicate_node_number": ("A TetGen node number is defined twice.", _REEXPORT),
    "missing_companion": ("A TetGen `.node` without its `.ele` (or the other way round).",
                          "Upload both files (the `.ele` as a companion)."),
    "include_outside": ("A deck's `*INCLUDE` names a file outside the deck's folder (an absolute path, or `..` "
                        "out of it), or a zip upload holds such a path (`details.include`); nothing is read "
                        "from there.",
                        "Put the file in the deck's folder or below it and name it relative to the deck; upload "
                        "it as a companion under that path (`include/nodes.inp`), or zip the folder."),
    "include_missing": ("A deck includes a file that is not beside it (`details.include`, relative to the "
                        "deck's folder): not uploaded, or uploaded under another name.",
                        "Upload the file as a companion under the path the deck names (or in the same zip)."),
    "bad_include": ("An `*INCLUDE` line names no `INPUT=` file, includes itself, or nests deeper than 8 files.",
                    "Correct the line the message names."),
    "bad_deck": ("A keyword line of an Abaqus deck that Abaqus itself would refuse, such as a `*PART` without "
                 "`NAME=` (`details.line`; `details.in`, the included file it is in).",
                 "Correct the line named; check that the deck runs in Abaqus or CalculiX."),
    "bad_node_line": ("A `*NODE` data line without a node number and three coordinates, or with coordinates "
                      "that are not finite numbers (`details.line`).", "Correct the line named."),
    "bad_element_line": ("An `*ELEMENT` block without `TYPE=`, or an element line with a field that is not a "
                         "number or another node count than its type has (`details.line`, `details.element`).",
                         "Correct the line named, or the block's `TYPE=`."),
    "bad_set": ("An `*NSET`/`*ELSET` without its name, a `GENERATE` line that is not first, last[, step] "
                "increasing, or a member that is neither a number nor a set defined before it.",
                "Correct the line named; define a set before the sets that list it."),
    "bad_instance": ("An `*INSTANCE` without `NAME=` or `PART=`, of a part no `*PART` defines, defined twice, "
                     "imported from another analysis (`INSTANCE=`, `LIBRARY=`), an `*END INSTANCE` without it, "
                     "or a placement line that is not numbers (or a rotation axis of two equal points).",
                     "Define the part in the deck and place it by translation and rotation lines."),
    "duplicate_node": ("Node numbers defined more than once in one scope (the model, a part or an instance): "
                       "`details.node`, `details.count`.",
                       "Number the nodes once; put the copies of a body in parts placed by instances."),
    "duplicate_part": ("A `*PART` name defined twice.", "Rename one of the parts (and its instances)."),
    "unsupported_keyword": ("A keyword tetmorph does not read in a deck (`*NODE, INPUT=` reading nodes from "
                            "another file).",
                            "Use `*INCLUDE, INPUT=` for the file instead."),
    "node_on_axis": ("A node of a `radius` edit, or of a `map` onto a circle or cylinder, lies on the axis (or at "
                     "a mapped sphere's centre), where it has no radial direction; `details.ids` lists them.",
                     "Leave those nodes out of the selection, or move the axis."),
    "no_intersection": ("A `map` with projection `along`: the line through some nodes along the direction misses "
                        "the surface or runs parallel to it; `details.ids` lists them.",
                        "Choose another direction, or projection `nearest`."),
    "not_a_cylinder": ("A `radius` edit without an axis: its selection's boundary faces fit no cylinder.",
                       "Give the axis (`tetmorph features` prints a bore's), or select the cylindrical faces only."),
    "not_planar": ("A face of a `fillet` edit (`details.face`) is not planar: its nodes lie farther than 1e-3 of its "
                   "extent from the fitted plane, or it has fewer than three corner nodes.",
                   "Select the flat faces the fillet is tangent to, without the fillet or other faces."),
    "parallel_faces": ("The two faces of a `fillet` edit are parallel: no fillet is tangent to both.",
                       "Name the two faces the fillet joins at an angle."),
    "off_arc": ("Nodes of a `fillet` edit lie off the arc fitted to it (by more than 1e-2 of the radius, or beyond "
                "its tangent lines); `details.ids` lists them.",
                "Select the fillet's surface only; the faces' nodes go in the faces' selections."),
    "fillet_too_large": ("A MOVE's fillet radius puts a tangent line beyond the end of a face (`details.bound`, the "
                         "largest radius the faces allow).",
                         "Ask for a smaller radius, below `details.bound`."),
    "coincident_features": ("A `distance` edit between centroids whose two features share their centroid.",
                            "Give a `direction` to measure the distance along."),
    "no_feature_direction": ("An `angle` edit without a direction for a feature whose boundary faces are neither "
                             "planar nor a cylinder (`details.selection`).",
                             "Give the feature's direction (`direction` or `reference_direction`)."),
    "parallel_features": ("An `angle` edit without an axis between parallel directions: their cross product gives "
                          "no rotation axis.", "Give the rotation `axis`."),
    "axis_does_not_turn": ("An `angle` edit's rotation axis runs along the moving feature's direction (or turning "
                           "about it leaves the angle unchanged).",
                           "Give an axis across the moving feature's direction, or leave it to the default."),
    "angle_out_of_reach": ("A MOVE asks an `angle` edit for an angle that no turn about its axis reaches "
                           "(`details.bound`, the reachable range in degrees).",
                           "Ask for an angle within `details.bound`, or give an axis across both directions."),
    "twist_conflict": ("Shapes give one `twist` entry a linear law and a table.",
                       "Use one kind of law in every shape of that twist."),
    "unwritable_folder": ("The folder a mesh is written to is missing and cannot be created (a file of that "
                          "name, no permission): `details.folder`.",
                          "Write to a folder you can create, or remove the file in the way."),
    "parse_time_limit": ("Reading the uploaded file took longer than `TETMORPH_PARSE_TIME_LIMIT_S` (120 s by "
                         "default): the worker process reading it was stopped and replaced. A damaged file "
                         "some reader never finishes, or a mesh far larger than usual.",
                         "Check the file (export it again); for a very large mesh, raise the setting."),
    "parse_cpu_limit": ("Reading the uploaded file used more CPU seconds than `TETMORPH_PARSE_CPU_LIMIT_S`; the "
                        "worker process reading it was stopped and replaced.",
                        "Check the file (export it again); for a very large mesh, raise the setting."),
    "parse_memory_limit": ("Reading the uploaded file needed more memory than a reader may use "
                           "(`TETMORPH_PARSE_MEMORY_MB`, by default three times "
                           "`TETMORPH_MAX_FILE_EXPANDED_MB` plus `TETMORPH_MAX_UPLOAD_MB`); the worker process "
                           "reading it was stopped and replaced.",
                           "Upload the mesh uncompressed or in parts, or raise the settings."),
    "unused_points": ("The uploaded file defines far more nodes than its elements use (`details.nodes`, "
                      "`details.used`): more than 100,000 and ten times the used ones. Such a file holds "
                      "no mesh to morph, only memory.",
                      "Export the part's mesh without the unused nodes."),
    "parse_queue_full": ("This API key already has `TETMORPH_PARSE_QUEUE_DEPTH` files waiting to be read "
                         "(`details.queued`, `details.limit`).",
                         "Wait for the answers to the uploads already sent, then retry."),
    "too_many_files": ("A zip upload holds more files than the service takes (512): `details.declared`, "
                       "`details.bound`.", "Zip the deck and the files it includes only."),
    "too_many_points": ("The file declares more nodes than tetmorph reads (50M by default; `details.bound`, "
                        "set by `details.setting`): refused before reading where the format declares its "
                        "counts, once read where it does not (Abaqus, Nastran, HDF5 formats).",
                        "Split or coarsen the mesh, or raise the setting."),
    "too_many_cells": ("The file declares more elements than tetmorph reads (300M by default; `details.bound`, "
                       "set by `details.setting`): refused before reading where the format declares its "
                       "counts, once read where it does not.",
                       "Split or coarsen the mesh, or raise the setting."),
    "too_many_bytes": ("The file's compressed data arrays (VTU zlib/LZMA blocks), HDF5 datasets or declared "
                       "tables expand to more bytes than tetmorph reads (`details.bound`, set by "
                       "`details.setting`); nothing was expanded.",
                       "Split or coarsen the mesh, or raise TETMORPH_MAX_FILE_EXPANDED_MB."),
    "too_large_to_read": ("Reading the file needed more memory than the process could allocate, though its "
                          "declared sizes passed the bounds.",
                          "Lower the bounds (TETMORPH_MAX_FILE_*), give the service more memory, or split the mesh."),
    "external_reference": ("A file's data lives outside the uploaded files: an XDMF DataItem with a path out "
                           "of its folder or a raw Binary DataItem (opened from the server's folder), or an HDF5 "
                           "file with an external link, a virtual dataset or external raw storage.",
                           "Upload the HDF5 file as a companion and name it without a folder; copy linked or "
                           "virtual data into the file itself (h5copy, or h5py's copy)."),
    "mesh_missing": ("A session's mesh file is gone from the data directory.",
                     "Upload the mesh again and create a new session."),
    "unwritable_format": ("The result cannot be written in the requested format.",
                          "Choose another format (`GET /v1/formats` lists what each keeps)."),
    "lossy_write": ("The target format cannot hold something the mesh carries (`details.losses`).",
                    "Write to a format that keeps it, or accept the loss with `lossy=True` / `--lossy`."),
    "file_not_found": ("A file named in a document or on the command line does not exist.", "Check the path."),
    "invalid_json": ("A SPEC or MOVE file is not the JSON document expected.",
                     "A SPEC file holds one object, a MOVES file a non-empty list of MOVEs."),
    "usage": ("The command line is inconsistent (exit code 1 from a document check, 2 from argparse).",
              "Follow the usage line the command prints."),
    # meshes
    "invalid_mesh": ("The mesh cannot be deformed as given.", "The message names the element or vertex at fault."),
    "unsupported_element": ("Element types tetmorph does not deform (quadratic hexahedra, wedges, pyramids, or "
                            "tetra10 mixed with other types).", "Convert to linear elements, or to tetra10 alone."),
    "inverted_input": ("Input elements with negative volume (or folded corners).",
                       "Swap two nodes of each named element, or fix the mesh generator's orientation."),
    "degenerate_input": ("Every tetrahedron is flat: there is no volume to morph.",
                         "Give a volume mesh; a surface belongs in a triangle file."),
    "non_finite_coordinates": ("Vertices with NaN or infinite coordinates.", _REEXPORT),
    "coordinates_out_of_range": ("Coordinates beyond ±1e15, the documents' bound.", "Check the file's units."),
    "repeated_index": ("An element lists one vertex twice.", _REEXPORT),
    "bad_connectivity": ("Tetra10 mid-side nodes that are also corner nodes.", _REEXPORT),
    "non_manifold": ("The elements do not form a manifold body.", "The message names the edges or vertices."),
    "non_manifold_boundary": ("Boundary edges in more than two boundary faces (bodies touching along an edge).",
                              "Separate the bodies, or merge them into one volume."),
    "non_manifold_vertex": ("Vertices where the boundary pinches (a bow-tie, parts touching at a point).",
                            "Split the named vertices, or mesh the parts apart and let SPEC ties join them."),
    "non_manifold_volume": ("Faces shared by more than two elements.", _REEXPORT),
    "inconsistent_orientation": ("The boundary is not consistently oriented.",
                                 "Flip the triangles on one side of the named edge."),
    "duplicate_nodes": ("Coincident nodes that split what should be one body.",
                        "Merge them, or keep the parts separate and let the SPEC's ties join them."),
    # tetrahedralization
    "bad_option": ("An fTetWild option is not positive.", "Give positive `edge_length`, `edge_length_fac`, "
                   "`epsilon`."),
    "bad_shape": ("Surface arrays of the wrong shape or not numeric.", "Give (n, 3) points and (m, 3) triangles."),
    "non_finite": ("A surface with NaN or infinite coordinates.", _REEXPORT),
    "open_surface": ("The surface is not closed (edges not in exactly two triangles).",
                     "Close it, or pass `allow_open`."),
    "tetrahedralization_failed": ("fTetWild failed, or gave no valid tet mesh even after its retry.",
                                  "Repair the surface, or try another `epsilon` / `edge_length_fac`."),
    # documents
    "invalid_spec": ("A SPEC or MOVE is malformed or names something that does not exist; `details.field` "
                     "names the field.", "Fix the named field (see the document reference)."),
    "bad_selection": ("A selection holds ids outside the mesh or vertices of no element.",
                      "Ids are 0-based in file order and must belong to elements."),
    "unknown_set": ("A selection names a set the mesh does not have.", "Use a set the message lists "
                    "(`tetmorph info` prints them)."),
    "empty_selection": ("A selection (or a tie side) has no node where it needs some.",
                        "Widen the box, plane tolerance or set; `boundary_only` keeps boundary nodes only."),
    "overlapping_constraints": ("A vertex both fixed and in a handle, or in two handles.",
                                "Make the selections disjoint."),
    "handle_outside_domain": ("A handle has nodes outside the SPEC's morph domain, where every node is held "
                              "at rest.", "Widen the domain (a box or sphere around the region) to hold the "
                              "handle."),
    "no_boundary_vertex": ("A rotating constraint or rigid feature uses only interior vertices, while the "
                           "rotation field lives on the boundary.", "Use mode `translate` / `keep_direction`, "
                           "or include boundary vertices."),
    "band_not_separating": ("The band does not split the surface into exactly two parts.",
                            "Select a band that contains the whole border of the feature."),
    "empty_band": ("The band contains no boundary face.", "A face needs all three vertices in the band."),
    "target_too_far": ("Nodes of a target selection lie farther than the tolerance from the target surface.",
                       "Place the surface near the selection, or raise the target's `tolerance`."),
    "invalid_constraints": ("The constraints leave the deformation undetermined or contradict each other.",
                            "The message names the constraint."),
    "conflicting_constraints": ("Hard constraints conflict and the SPEC says `\"conflicts\": \"reject\"`.",
                                "Remove one of the named constraints, or let `report` keep the first."),
    "unconstrained_component": ("A body has no fixed or handle vertex, so its position is undetermined.",
                                "Add a selection that touches it, or tie it to another body."),
    "unconstrained_shell": ("A boundary shell (an internal void) has no fixed or handle vertex and the SPEC "
                            "says `\"voids\": \"refuse\"`.", "Use `\"voids\": \"volume\"` (the default)."),
    "constraint_on_free_void": ("A constraint uses vertices of an internal void that nothing positions.",
                                "Fix or select a vertex of that void, or drop the constraint."),
    "unmatched_nodes": ("Symmetry or cyclic faces do not match within the tolerance.",
                        "Check the plane or axis and angle, or raise the tolerance (`tetmorph info` suggests one)."),
    "inverted_elements": ("A MOVE inverted elements and the policy is `reject`; the error carries the REPORT.",
                          "Move less (the REPORT's `safe_fraction`), use `clamp`, or `repair`."),
    "factorization_failed": ("A sparse factorization or back-substitution failed.",
                             "Report it with the mesh; `TETMORPH_SOLVER` can force another backend."),
    "singular_system": ("A system is singular: something the SPEC leaves unconstrained.",
                        "Fix or handle every body; check selections that are empty or overlap."),
    "non_finite_matrix": ("A matrix with NaN or infinite entries (degenerate elements at rest).",
                          "Check the mesh's quality (`tetmorph info`)."),
    "too_large": ("A system with more nonzeros than PARDISO's 32-bit indices hold.", "Coarsen the mesh."),
    "solver_error": ("An error of the solver without a more specific code.", "Read the message."),
    # workflows
    "invalid_shapes": ("A SHAPES document is malformed.", "It is `{\"shapes\": {NAME: MOVE}}`."),
    "unknown_shape": ("A plan column or a request names no shape.", "Use the shape names the message lists."),
    "pivot_conflict": ("Two shapes turn or scale one handle about different pivots.", "Give them one pivot."),
    "relative_conflict": ("Shapes give one relative constraint an offset and a scale.", "Use one of them."),
    "rotation_range": ("A plan row turns a handle by 360° or more.", "Lower the row's values or the shape's angle."),
    "empty_plan": ("The plan has no rows.", "Give a header of shape names and one row per variant."),
    "invalid_plan": ("A plan cell is not a finite number, a row is ragged, a column repeats, or the block is "
                     "not positive; row, line and column are named.", "Fix the named cell."),
    "invalid_range": ("A bounds range or tolerance is not valid.", "Give `lo <= 0 <= hi` and a positive `tol`."),
    "solver_not_found": ("The study's `--solver` program is not on `PATH`.", "Install it or give its path."),
    "invalid_response": ("The study's `--response` file does not exist or is not Python.",
                         "Give `ccx` or a Python file defining `response(deck)`."),
    "no_responses": ("The FE solver wrote no results the response reader finds.",
                     "Check `<stem>.solver.log`; the deck needs output requests (`*NODE PRINT`, ...)."),
    "missing_extra": ("The Ray engine without the `cluster` extra.", "`pip install 'tetmorph[cluster]'`."),
    "ray_block_failed": ("A block of plan rows failed on every actor that tried it.",
                         "Read the actors' error; run the rows alone with `--engine local`."),
}

# -------------------------------------------------------------------------------------------------- REST

REST_INTRO = """# REST API

Generated from the service's OpenAPI document (`service.app.create_app(...).openapi()`,
version {version}) when the site is built; a running service serves the same at
`/openapi.json` and interactively at `/docs`. Every route answers errors with the
envelope of [error codes](errors.md). The documents SPEC, MOVE and REPORT are
described field by field in [documents](documents.md); the guide's
[REST service](../guide/service.md) page explains the routes together.
"""

REST_STREAM = """
## WS `/v1/sessions/{session_id}/stream`

**Stream MOVEs over a WebSocket** (not part of the OpenAPI document).

Query: `kind` (`positions` or `displacements`), `dtype` (`float64` or `float32`),
`api_key` when the service has keys. Send text frames holding a
[stream frame](documents.md#streamframe) `{"seq": k, "move": MOVE}`; each solved MOVE comes
back as a binary frame (`TMF1`, header with `seq`, `dropped` and a short REPORT), each
failed one as a text frame `{"seq", "error"}`. MOVEs that arrive while one is solving
replace each other (latest wins). Close codes: 4400 two different API keys, 4401 no or
unknown key, 4404 unknown session, 4410 expired session, 4422 an invalid `kind`, `dtype` or
`frames` (the reason names the parameter and its allowed values), 4429 more open streams than
`MAX_CONNECTIONS_PER_KEY`,
1013 the session store (PostgreSQL) cannot be reached (try again later), 1009 a frame over
`MAX_FRAME_KB`, 1011 a fault of the server.
"""

# ------------------------------------------------------------------------------------------------ formats

FORMATS_INTRO = """# Mesh formats

Generated when the site is built from `service/format_table.py`, the table that
`python -m service.formats` measures by round trips of tiny meshes through meshio
{meshio} (a node set, a tetra10 element, a pyramid on a hexahedron), and from the
formats registered by tetmorph's format modules (`solver/io/registry.py`); `GET
/v1/formats` answers the same rows. "Offered here" is this installation: a format
whose Python package is missing is listed but not offered. "Write" is a
conversion: a mesh of another format written in it. Files written back to the
format they were read from are patched in place instead ("written back in
place"); a registered format that is not measured shows "—" for what a
conversion keeps, since none is made to it. What each conversion keeps,
and what it refuses, is in the guide's [formats](../guide/formats.md) page.

"""

FORMATS_READERS = """
## Formats registered by tetmorph's modules

These formats are registered by the modules of `solver/io/` that hold them, each
read by a reader of tetmorph's own or by meshio's and written back in place by
tetmorph: what each reads and what it refuses, with a typed error naming the
line, the section or the element kind. A deck with `*INCLUDE` is uploaded with its included files
(companions under their paths relative to the deck, or one zip) and written back
as the same tree.
"""

# ---------------------------------------------------------------------------------------------- documents

DOCUMENTS_INTRO = """# Documents: SPEC, MOVE, REPORT, SHAPES

Generated when the site is built from the pydantic models that define the documents:
SPEC, MOVE, REPORT and SHAPES in `solver/documents/`, the WebSocket frame, batches, bounds
queries and session presets in `service/models/`. Every field has its type, default,
bounds and description, as it is checked before any work (unknown fields are refused;
booleans and strings are not numbers). The library (`parse_spec`, `parse_move`,
`parse_shapes`, the command line) and the service validate with the same models. The
grammar on one screen, and what each entry does, is in the guide:
[Documents](../guide/documents.md).
"""

#: "Model.field" -> what the model's own description leaves out (from the guide's grammar).
FIELD_NOTES = {
    "Spec.selections": "named vertex selections: ids, a set of the file, a box, a sphere or a plane",
    "Spec.fixed": "names of selections held at their rest positions",
    "Spec.handles": "handle name -> selection name; each handle is moved by the MOVE",
    "Spec.domain": "the morph domain: a selection outside which every node keeps its rest position",
    "Spec.laplacian": "boundary rows: cotangent weights (the paper's) or uniform",
    "Spec.constraints": "how hard constraints are imposed: null space (default), KKT or penalty",
    "Spec.solve": "split (boundary, then interior) or joint least squares; auto picks split unless a "
                  "constraint touches interior vertices or the mesh has internal voids",
    "Spec.rotation": "how handle rotations propagate over the boundary",
    "Spec.inversion": "what an update that inverts elements does: warn (report), reject (error, session unchanged) "
                      "or clamp (apply the safe fraction)",
    "Spec.points": "further hard constraints: a POINT held at a target (its rest position by default)",
    "Spec.relative": "a - b of two vertices or POINTs kept (turned with the rotation field in mode rotate)",
    "Spec.features": "selections kept rigid (turn with the part) or at their direction (translate only)",
    "Spec.motion": "a POINT that moves on a plane or along a line through the MOVE's point",
    "Spec.sliding": "every node of a selection keeps its coordinate along the normal and slides in the plane",
    "Spec.conflicts": "report conflicting hard constraints in the REPORT, or reject the SPEC / MOVE",
    "Spec.repair": "untangle inverted elements after the solve (local L-BFGS on free interior vertices)",
    "Spec.thin_walls": "soft rows across walls one tet thick (weight 0.1 by default); false is the paper's method",
    "Spec.ties": "coincident nodes of different bodies tied (auto), explicit pairs, surface ties, or off",
    "Spec.voids": "internal voids positioned by the volume around them, or refused",
    "Spec.targets": "selections moved onto a target surface, by the MOVE's amount",
    "Spec.symmetry": "mirror symmetry about a plane, held exactly",
    "Spec.cyclic": "cyclic symmetry of a sector: face B is face A turned about the axis",
    "Spec.precision": "interior solve in single precision with a double-precision check (mixed), or double",
    "Selection.ids": "0-based vertex indices in file order",
    "Selection.box": "the vertices in a closed box",
    "Selection.sphere": "the vertices in a ball",
    "Selection.plane": "the vertices within the tolerance of a plane",
    "Selection.boundary_only": "keep only the selection's boundary vertices",
    "Point.target": "where the point goes; default its rest position (a MOVE's points override it)",
    "Relative.mode": "rotate: the offset turns with the rotation field; translate: it keeps its direction",
    "Feature.mode": "rigid: the feature turns with one rotation; keep_direction: it only translates",
    "Feature.name": "the name a MOVE's features entry uses to scale it",
    "Target.method": "closest point, or along the rest normal (closest point where the line misses)",
    "Move.handles": "handle name -> its transform; a handle not named is at rest (a MOVE is absolute)",
    "Move.points": "targets of SPEC points",
    "Move.relative": "new offset or scale of SPEC relative constraints",
    "Move.features": "scale of SPEC features (no refactorization)",
    "Move.motion": "the point the plane or line of a SPEC motion passes through",
    "Move.targets": "how far to go toward each SPEC target surface: 0 rest, 1 on the surface",
    "HandleMove.rotation": "an axis and an angle, or a quaternion",
    "HandleMove.scale": "uniform scale about the pivot",
}
