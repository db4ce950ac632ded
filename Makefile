# tetmorph -- the two commands of the README:
#   make run    create .venv, install everything, serve the REST API on 127.0.0.1:8000
#               with the demo beam and a ready session (s_demo)
#   make test   create .venv, install everything, run the test suite
#   make check  lint and the fast tests (no browser, cluster, CalculiX, fuzzing or slow marks)
#   make docs   the documentation site into site/ (warnings as errors); make docs-serve on 127.0.0.1:8001;
#               make docs-img renders the pictures of real morphs into docs/img (pyvista, off-screen);
#               make docs-pictures retakes the editor tutorial's pictures
#   make cluster       PostgreSQL, 3 replicas and HAProxy on 127.0.0.1 (balancer on :8100), detached
#   make cluster-down  stop them
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
SYSDEPS := g++ cmake libsuitesparse-dev libopenblas0-pthread

.PHONY: test-latest constraints nastrandeps run morph-demo test check docs docs-img gldeps docs-pictures docs-serve bench compare sysdeps install web browser calculix lint clean cluster cluster-down clusterdeps

DEMO := examples/beam
HOST ?= 127.0.0.1
PORT ?= 8000

run: install web
	$(BIN)/tetmorph serve --host $(HOST) --port $(PORT) --data-dir data --demo

morph-demo: install
	$(BIN)/tetmorph info $(DEMO)/beam.node
	$(BIN)/tetmorph morph $(DEMO)/beam.node --spec $(DEMO)/spec.json --moves $(DEMO)/moves.json \
	  --output out/beam_{i}.vtu --report out/report.json
	@echo "deformed meshes in out/, reports in out/report.json"

test: install web browser calculix clusterdeps gldeps nastrandeps
	$(BIN)/python -m pytest -q

# The suite on the newest versions pip resolves today, in .venv-latest (not part of CI; never fails the
# build): prints the packages that differ from constraints.txt and the test summary. Refresh the pins
# with `make constraints` in a commit of their own once it passes.
LATEST := .venv-latest
test-latest: install web browser calculix clusterdeps gldeps nastrandeps
	test -x $(LATEST)/bin/python || $(PYTHON) -m venv $(LATEST)
	$(LATEST)/bin/python -m pip install -q --upgrade pip
	$(LATEST)/bin/python -m pip install -q --upgrade -e ".[dev,service,cholmod,cluster]"
	@$(LATEST)/bin/python -m pip freeze --exclude-editable | grep -v '^-e' | sort > $(LATEST)/freeze.txt
	@echo "packages that differ from constraints.txt (< pinned, > newest):"
	@grep -v '^#' constraints.txt | sort | diff - $(LATEST)/freeze.txt | grep '^[<>]' || echo "  none"
	-$(LATEST)/bin/python -m pytest -q -p no:cacheprovider

# Rewrite constraints.txt from .venv (after make install with newer pins, or make test-latest passing)
constraints:
	@head -3 constraints.txt > constraints.new
	@$(BIN)/python -m pip freeze --exclude-editable | grep -v '^-e' >> constraints.new
	mv constraints.new constraints.txt

docs: install docs-img
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict -d site

# The pictures of real morphs (docs/scripts/pictures.py, tests/test_docs_pictures.py), rendered by pyvista
# off-screen through VTK's EGL window on Mesa's software renderer: no display, no GPU. Debian's Mesa EGL
# and DRI drivers come from apt when missing.
GLDEPS := libegl1 libegl-mesa0 libgl1-mesa-dri
docs-img: install gldeps
	$(BIN)/python docs/scripts/pictures.py docs

gldeps:
	@command -v dpkg >/dev/null || exit 0; missing=""; for p in $(GLDEPS); do \
	  dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "installing$$missing (apt)"; apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	else echo "ERROR: the docs' pictures need$$missing (apt install$$missing)"; exit 1; fi

# The editor tutorial's pictures, taken by its browser test (tests/browser/test_docs_screenshots.py)
docs-pictures: install web browser
	$(BIN)/python -m pytest -q -p no:cacheprovider tests/browser/test_docs_screenshots.py --docs-pictures

docs-serve: install
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs serve -a 127.0.0.1:8001

# The developer's loop (CONTRIBUTING.md): lint, then the solver and service tests without the
# browser, the cluster, CalculiX, fuzzing and the tests marked slow. `make test` runs them all.
check: lint web nastrandeps
	$(BIN)/python -m pytest -q -p no:cacheprovider -m "not slow and not fuzz and not ccx" -n auto \
	  --ignore=tests/browser --ignore=tests/cluster --ignore=tests/service/state/test_pg_registry.py

# The local cluster (docs/guide/cluster.md): Debian's PostgreSQL (initdb under CLUSTER_DIR, run as an
# unprivileged user), 3 `tetmorph serve` replicas and HAProxy, all on 127.0.0.1; balancer on :8100.
CLUSTER_DIR ?= /tmp/tetmorph-cluster
CLUSTER_STAMP := $(VENV)/.cluster-installed

cluster: install clusterdeps
	$(BIN)/python -m service.cluster up --dir $(CLUSTER_DIR) --port 8100

cluster-down:
	@if [ -x $(BIN)/python ]; then $(BIN)/python -m service.cluster down --dir $(CLUSTER_DIR); \
	else echo "no $(BIN)/python: nothing was started"; fi

# PostgreSQL server and HAProxy from apt (as root; Debian 12: PostgreSQL 15, HAProxy 2.6), without
# the package's own database cluster; then the `cluster` extra (Ray, psycopg 3).
clusterdeps: install $(CLUSTER_STAMP)
	@need=""; ls /usr/lib/postgresql/*/bin/initdb >/dev/null 2>&1 || command -v initdb >/dev/null || need="$$need postgresql"; \
	command -v haproxy >/dev/null || [ -x /usr/sbin/haproxy ] || need="$$need haproxy"; \
	if [ -n "$$need" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing$$need (apt)"; mkdir -p /etc/postgresql-common; \
	    [ -f /etc/postgresql-common/createcluster.conf ] || echo "create_main_cluster = false" > /etc/postgresql-common/createcluster.conf; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq -o Dpkg::Options::=--force-confold $$need >/dev/null; \
	  else echo "ERROR: the cluster and its tests need$$need (apt install$$need)"; exit 1; fi; fi

$(CLUSTER_STAMP): pyproject.toml constraints.txt | $(STAMP)
	$(BIN)/python -m pip install -q -c constraints.txt -e ".[cluster]"
	touch $(CLUSTER_STAMP)

# pyNastran, the independent reader of the Nastran tests, in a virtualenv of its own: 1.4.1 pins numpy < 2,
# which would hold every package of .venv back to numpy 1.26 (tests/solver/io/pynastran_positions.py)
NASTRAN_VENV := .venv-nastran
nastrandeps: $(NASTRAN_VENV)/.installed
$(NASTRAN_VENV)/.installed: constraints-nastran.txt
	test -x $(NASTRAN_VENV)/bin/python || $(PYTHON) -m venv $(NASTRAN_VENV)
	$(NASTRAN_VENV)/bin/python -m pip install -q -c constraints-nastran.txt pyNastran
	touch $@

bench: install
	$(BIN)/python benchmarks/bench_solver.py
	$(BIN)/python benchmarks/bench_service.py

# the study against libigl and RBF morphing (writes benchmarks/results/), and the
# thin-wall and safe-step tables; needs ../shared/data beside the repository
compare: install
	$(BIN)/pip install -q -e ".[compare]"
	$(BIN)/python benchmarks/compare/study.py
	$(BIN)/python benchmarks/compare/thin_walls.py
	$(BIN)/python benchmarks/compare/validity.py

# The browser editor (served at /): three.js from npm, pinned by web/package-lock.json,
# copied with our sources into service/static/editor. npm comes from apt when missing.
EDITOR := service/static/editor/.built
web: $(EDITOR)

$(EDITOR): web/package.json web/package-lock.json web/build.mjs $(wildcard web/src/*)
	@command -v npm >/dev/null || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing npm (apt)"; apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq npm >/dev/null; \
	  else echo "ERROR: npm is needed to build the editor (apt install npm)"; exit 1; fi; }
	cd web && npm ci --no-audit --no-fund --loglevel=error && npm run build --silent

# Chromium for the browser tests (Playwright drives the system browser; nothing is downloaded).
browser:
	@command -v chromium >/dev/null || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing chromium (apt)"; apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; \
	  else echo "ERROR: the browser tests need chromium (apt install chromium)"; exit 1; fi; }

# CalculiX (Debian's calculix-ccx 2.20): the FE solver the tests hand morphed decks to.
calculix:
	@command -v ccx >/dev/null || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing calculix-ccx (apt)"; apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq calculix-ccx >/dev/null; \
	  else echo "ERROR: the solver-in-the-loop tests need ccx (apt install calculix-ccx)"; exit 1; fi; }

# The C++ compiler and CMake that build the compiled core (src/core), and the system libraries of the
# CHOLMOD backend. Installed with apt when we are root on a Debian-like machine; elsewhere the
# machine's own compiler must do, and tetmorph falls back to a pip-only solver backend and says so.
sysdeps:
	@missing=""; for p in $(SYSDEPS); do \
	  dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "installing system packages:$$missing"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null \
	  || echo "WARNING: apt-get failed; continuing with the pip-only solver backend"; \
	else echo "WARNING: not root or no apt-get; missing$$missing; the pip-only solver backend will be used"; fi

$(STAMP): pyproject.toml constraints.txt CMakeLists.txt $(wildcard src/core/*) | sysdeps
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -c constraints.txt -e ".[dev,service,cholmod]" \
	  || { echo "WARNING: CHOLMOD extra failed to build; installing without it"; \
	       $(BIN)/python -m pip install -q -c constraints.txt -e ".[dev,service]"; }
	touch $(STAMP)

install: sysdeps $(STAMP)

# ruff and mypy on the Python, ESLint (web/eslint.config.js, pinned by the lock file) on the editor
lint: install web
	$(BIN)/ruff check solver service tests benchmarks docs
	$(BIN)/mypy solver service
	cd web && npm run lint --silent

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis
