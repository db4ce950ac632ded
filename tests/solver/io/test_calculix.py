"""Morphed decks handed to the FE solver that consumes them: CalculiX (``ccx``, Debian's calculix-ccx).

``make test`` installs ccx with apt. Every check reads what ccx wrote (its
``.dat`` file and its messages) with the few lines of parsing in this file,
not with tetmorph's readers.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from solver import precompute, read_mesh, write_mesh
from tests.conftest import DATA, shared_file

pytestmark = pytest.mark.ccx  # runs CalculiX: make test, not make check
CCX = shutil.which("ccx")
#: Seconds a ccx run of these small decks may take before the test fails.
CCX_TIMEOUT = 300


def run_ccx(deck: Path) -> tuple[str, Path]:
    """Run ccx on ``deck`` in its folder; its messages (stdout and stderr) and the ``.dat`` it wrote."""
    assert CCX is not None, "ccx not found: `make test` installs it (apt install calculix-ccx)"
    out = subprocess.run([CCX, "-i", deck.stem], cwd=deck.parent, capture_output=True, text=True,
                         timeout=CCX_TIMEOUT)
    text = out.stdout + out.stderr
    assert out.returncode == 0, text[-2000:]
    return text, deck.with_suffix(".dat")


def complaints(text: str) -> list[str]:
    """ccx's ``*ERROR`` and ``*WARNING`` lines."""
    return [ln.strip() for ln in text.splitlines() if "*ERROR" in ln or "*WARNING" in ln]


def dat_block(dat: Path, title: str) -> np.ndarray:
    """The numbers of the first ``.dat`` block whose header line starts with ``title``."""
    rows: list[list[float]] = []
    inside = False
    for ln in dat.read_text().splitlines():
        s = ln.strip()
        if s.startswith(title):
            inside = True
            continue
        if inside:
            if not s:
                if rows:
                    break
                continue
            if not re.match(r"^[-+0-9.]", s):  # column headings before the numbers, the next block after
                if rows:
                    break
                continue
            rows.append([float(v) for v in s.split()])
    assert rows, f"no {title!r} block in {dat}"
    return np.array(rows)


def von_mises(S: np.ndarray) -> np.ndarray:
    """Von Mises stress of rows ``(sxx, syy, szz, sxy, sxz, syz)``."""
    sxx, syy, szz, sxy, sxz, syz = S.T
    return np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                   + 3.0 * (sxy ** 2 + sxz ** 2 + syz ** 2))


def node_lines_differ(a: Path, b: Path) -> set[str]:
    """Keywords of the blocks in which the two decks differ, line by line."""
    la, lb = a.read_text().splitlines(), b.read_text().splitlines()
    assert len(la) == len(lb)
    block, out = "", set()
    for x, y in zip(la, lb, strict=True):
        if x.startswith("*"):
            block = x.split(",")[0].strip().upper()
        if x != y:
            out.add(block)
    return out


# ------------------------------------------------------------------ a static tet10 deck
BRACKET = DATA / "ccx_bracket.inp"
#: Hole shifts toward the clamp (mm); the bar is 100 long, the hole's edge starts 55 from the clamp.
SHIFTS = (0.0, 4.0, 8.0, 12.0)


@pytest.fixture(scope="module")
def bracket_runs(tmp_path_factory):
    """ccx on the rest deck and on the hole moved toward the clamp by each of SHIFTS."""
    mesh = read_mesh(BRACKET)
    spec = {"selections": {"clamp": {"set": "FIXED"}, "tip": {"set": "LOAD"}, "bore": {"set": "HOLE"}},
            "fixed": ["clamp", "tip"], "handles": {"bore": "bore"}}
    d = precompute(mesh, spec)
    runs = []
    for k, s in enumerate(SHIFTS):
        folder = tmp_path_factory.mktemp(f"shift{k}")
        deck = folder / "bracket.inp"
        if s == 0.0:
            shutil.copyfile(BRACKET, deck)
            report = None
        else:
            r = d.solve({"handles": {"bore": {"translation": [-s, 0, 0]}}})
            write_mesh(mesh, r.V, deck)
            report = r.report
        text, dat = run_ccx(deck)
        runs.append({"shift": s, "deck": deck, "text": text, "dat": dat, "report": report, "mesh": mesh})
    return runs


def test_the_rest_and_every_morph_solve_without_errors_or_warnings(bracket_runs):
    for run in bracket_runs:
        assert complaints(run["text"]) == [], (run["shift"], complaints(run["text"])[:5])
        if run["report"] is not None:  # what tetmorph called valid, ccx's element checks accept
            assert run["report"]["inverted_elements"] == 0


def test_a_morphed_deck_differs_from_the_rest_deck_only_in_node_coordinates(bracket_runs):
    rest = bracket_runs[0]["deck"]
    for run in bracket_runs[1:]:
        assert node_lines_differ(rest, run["deck"]) == {"*NODE"}
        moved = np.loadtxt([ln for ln in run["deck"].read_text().splitlines()
                            if re.match(r"^\d+, ", ln) and ln.count(",") == 3], delimiter=",")
        bore = run["mesh"].sets["HOLE"]
        # the bore moved by the shift, exactly as the handle says (ids are 1-based, in file order)
        rest_xyz = run["mesh"].V[bore]
        assert np.abs(moved[bore, 1:] - (rest_xyz + [-run["shift"], 0, 0])).max() <= 1e-9 * 100


def test_deflection_and_stress_grow_smoothly_as_the_hole_nears_the_clamp(bracket_runs):
    tip, peak, mass = [], [], []
    for run in bracket_runs:
        U = dat_block(run["dat"], "displacements")
        S = dat_block(run["dat"], "stresses")
        V = read_mesh(run["deck"]).V
        tip.append(float(np.abs(U[:, 3]).max()))
        # the peak away from the clamp's stress singularity (x > 20): the ligaments beside the hole
        elem_x = np.zeros(int(S[:, 0].max()) + 1)
        T = read_mesh(run["deck"]).T
        elem_x[1:] = V[T].mean(axis=1)[:, 0]
        away = elem_x[S[:, 0].astype(int)] > 20.0
        peak.append(float(von_mises(S[away, 2:]).max()))
        mass.append(float(dat_block(run["dat"], "total mass")[0, 0]))
    tip_a, peak_a = np.array(tip), np.array(peak)
    # a cantilever loses stiffness and strength as its hole moves toward the root, where the moment is larger:
    # both responses rise with the shift, each step within 2% of their range of being monotone
    for resp in (tip_a, peak_a):
        steps = np.diff(resp)
        assert (steps > -0.02 * (resp.max() - resp.min())).all(), resp
        assert resp[-1] > resp[0]
    # and smoothly: no step more than twice another (equal shifts, a response close to linear over 12 mm)
    for resp in (tip_a, peak_a):
        steps = np.diff(resp)
        assert steps.max() <= 2.0 * steps.min() + 0.02 * (resp.max() - resp.min()), resp
    # moving a hole keeps the part's mass (volume) to the mesh's discretisation of the bore
    assert np.ptp(mass) <= 2e-3 * np.mean(mass), mass


# ------------------------------------------------------------------ a cyclic-symmetry frequency deck
#: Radial growth of the sector's rim (uniform scale about its axis point).
RIM_SCALES = (1.0, 1.01, 1.02, 1.03)


def _segment_spec(mesh):
    left, right = mesh.sets["Nleft"], mesh.sets["Nright"]
    diag = float(np.linalg.norm(mesh.V.max(0) - mesh.V.min(0)))
    radius = np.linalg.norm(mesh.V[:, 1:], axis=1)
    on_b = np.zeros(mesh.n, bool)
    on_b[left] = True
    best = None
    for sign in (1, -1):  # the *CYCLIC SYMMETRY MODEL line: 12 sectors about x; which way turns right onto left
        a = math.radians(sign * 30.0)
        R = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        dist = float(np.linalg.norm(mesh.V[right] @ R.T - mesh.V[left][:, None], axis=2).min(axis=0).max())
        if best is None or dist < best[0]:
            best = (dist, sign * 30.0)
    hub = np.flatnonzero((radius <= radius.min() + 0.02 * diag) & ~on_b)
    rim = np.flatnonzero((radius >= radius.max() - 0.02 * diag) & ~on_b)
    spec = {"selections": {"A": {"set": "Nright"}, "B": {"set": "Nleft"}, "hub": {"ids": hub.tolist()},
                           "rim": {"ids": rim.tolist()}},
            "fixed": ["hub"], "handles": {"rim": "rim"},
            "cyclic": [{"name": "sector", "axis": {"point": [0, 0, 0], "direction": [1, 0, 0]},
                        "angle_deg": best[1], "faces": ["A", "B"], "tolerance": 1e-3}]}
    pivot = [float(mesh.V[rim, 0].mean()), 0.0, 0.0]
    return spec, pivot


def _tied_nodes(text: str) -> int:
    m = re.search(r"dependent nodes tied by cyclic constraints:\s*(\d+)", text)
    assert m, "ccx did not report its cyclic constraints"
    return int(m.group(1))


def test_a_sector_morphed_with_its_rim_grown_keeps_its_cyclic_tie_and_its_modes_move_smoothly(tmp_path):
    src = shared_file("tet/segmenttet.inp")  # GPL-2.0: read from ../shared, never copied here
    mesh = read_mesh(src)
    spec, pivot = _segment_spec(mesh)
    d = precompute(mesh, spec)
    freqs, tied = [], []
    for k, s in enumerate(RIM_SCALES):
        deck = tmp_path / f"segment{k}.inp"
        if s == 1.0:
            shutil.copyfile(src, deck)
        else:
            r = d.solve({"handles": {"rim": {"scale": s, "pivot": pivot}}})
            assert r.report["inverted_elements"] == 0 and r.report["conflicting_constraints"] == []
            write_mesh(mesh, r.V, deck)
            assert node_lines_differ(Path(src), deck) == {"*NODE"}
        text, dat = run_ccx(deck)
        assert complaints(text) == [], complaints(text)[:5]
        tied.append(_tied_nodes(text))
        E = dat_block(dat, "E I G E N V A L U E   O U T P U T")
        freqs.append(E[:, 4])  # cycles/time of every mode ccx printed (nodal diameter 1)
    # every slave node of the right face found its partner within the tie's position tolerance
    assert len(set(tied)) == 1 and tied[0] > 0
    F = np.array(freqs)
    # the deck has no support: its first modes are rigid-body ones, their frequencies round-off of
    # the eigensolver (12 and 1,864 cycles against 490,000 for the first elastic one); the elastic
    # modes are those above 1% of the highest
    elastic = F[0] > 0.01 * F[0].max()
    assert elastic.sum() >= 4
    rel = F[:, elastic] / F[0, elastic]
    # a bigger disc of the same hub is more flexible and heavier at the rim: the elastic frequencies fall,
    # each step of 1% growth moving them by about the same amount (within a third of the mean step)
    steps = np.diff(rel, axis=0)
    assert (steps < 0).all(), rel
    mean = steps.mean(axis=0)
    assert (np.abs(steps - mean) <= np.abs(mean) / 3).all(), rel


def test_a_gmsh_part_with_named_faces_converted_to_a_deck_runs_in_calculix(tmp_path):
    """Named Gmsh surfaces arrive as node sets a *BOUNDARY and a *CLOAD can name, and no face element."""
    import meshio

    from tests.gmsh_parts import block_with_faces

    src = tmp_path / "block.msh"
    block_with_faces(src, 5.0, order=2)
    m = meshio.read(src)
    write_mesh(read_mesh(src), np.asarray(m.points, float), tmp_path / "block.inp")
    deck = tmp_path / "run.inp"
    deck.write_text((tmp_path / "block.inp").read_text() + "*MATERIAL, NAME=STEEL\n*ELASTIC\n210000, 0.3\n"
                    "*SOLID SECTION, ELSET=SOLID, MATERIAL=STEEL\n*STEP\n*STATIC\n*BOUNDARY\nFIXED, 1, 3\n"
                    "*CLOAD\nLOAD, 3, -1.0\n*NODE PRINT, NSET=LOAD\nU\n*END STEP\n")
    text, dat = run_ccx(deck)
    assert complaints(text) == []
    u = dat_block(dat, "displacements")
    load_nodes = np.unique(m.cells_dict["triangle6"][m.cell_sets_dict["LOAD"]["triangle6"]])
    assert len(u) == load_nodes.size and (u[:, 3] < 0).all()  # every LOAD node printed, pushed down
