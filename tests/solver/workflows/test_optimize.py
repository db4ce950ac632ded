"""``tetmorph optimize``: a response minimized over shape parameters, every evaluation a written, solved deck.

The decks are the two-bore cantilever of ``tests/data/make_ccx_bracket.py``
(bores at x = 30 and 65, shapes moving each along x) with the SPEC and
SHAPES of ``examples/bracket-optimize``. Every figure the tests check is
read back here from the written decks and CalculiX's ``.dat`` files.
"""

from __future__ import annotations

import csv
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from solver.cli import main
from tests.conftest import DATA

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "examples" / "bracket-optimize"
sys.path.insert(0, str(DATA))
from make_ccx_bracket import make_ccx_bracket  # noqa: E402

#: A response read from the deck itself: the squared distance of the two bores' centres from x = 40
#: and x = 72. Its minimum is near move1 = 10, move2 = 7 (the centroids of the nodes on a bore are
#: not its axis exactly), inside the safe bounds.
CENTRES = '''
import numpy as np

def _deck(path):
    nodes, sets, where = {}, {}, None
    for line in open(path):
        s = line.strip()
        if s.startswith("*"):
            head = s.upper().replace(" ", "")
            where = "node" if head.startswith("*NODE,") or head == "*NODE" else None
            if head.startswith("*NSET,NSET="):
                where = head.split("=")[1]
                sets[where] = []
            continue
        if where == "node":
            i, x, y, z = s.split(",")
            nodes[int(i)] = (float(x), float(y), float(z))
        elif where:
            sets[where] += [int(v) for v in s.split(",") if v.strip()]
    return nodes, sets

def response(deck):
    nodes, sets = _deck(deck)
    c1 = np.mean([nodes[i][0] for i in sets["HOLE1"]])
    c2 = np.mean([nodes[i][0] for i in sets["HOLE2"]])
    return {"miss": (c1 - 40.0) ** 2 + (c2 - 72.0) ** 2, "c1": c1, "c2": c2}
'''


#: The same response with its exact gradient in the node coordinates (rows in the deck's node order).
CENTRES_WITH_GRADIENT = CENTRES + '''

def gradient(deck):
    nodes, sets = _deck(deck)
    row = {i: k for k, i in enumerate(nodes)}
    G = np.zeros((len(nodes), 3))
    for name, target in (("HOLE1", 40.0), ("HOLE2", 72.0)):
        ids = sets[name]
        c = np.mean([nodes[i][0] for i in ids])
        G[[row[i] for i in ids], 0] += 2.0 * (c - target) / len(ids)
    return {"miss": G}
'''


@pytest.fixture(scope="module")
def two_bores(tmp_path_factory):
    d = tmp_path_factory.mktemp("two_bores")
    make_ccx_bracket(4.0, str(d / "two_holes.inp"), ((30.0, 5.0), (65.0, 5.0)))
    (d / "centres.py").write_text(CENTRES)
    (d / "centres_grad.py").write_text(CENTRES_WITH_GRADIENT)
    return d


def _optimize(d, out, *extra):
    return main(["optimize", str(d / "two_holes.inp"), "--spec", str(EXAMPLE / "spec.json"),
                 "--shapes", str(EXAMPLE / "shapes.json"), "--output", str(out / "{i}" / "deck.inp"),
                 "--history", str(out / "history.csv"), *extra])


def _dat_mises_and_mass(dat: Path) -> tuple[float, float]:
    """Largest von Mises stress and the total mass, parsed here from CalculiX's .dat."""
    lines = dat.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.strip().startswith("stresses"))
    S = []
    for ln in lines[k + 1:]:
        if not ln.strip():
            if S:
                break
            continue
        S.append([float(v) for v in ln.split()])
    sxx, syy, szz, sxy, sxz, syz = np.array(S)[:, 2:8].T
    vm = np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3 * (sxy**2 + sxz**2 + syz**2))
    m = next(i for i, ln in enumerate(lines) if "total mass" in ln)
    mass = next(float(ln.split()[0]) for ln in lines[m + 1:] if ln.strip())
    return float(vm.max()), mass


def _inverted(deck: Path) -> int:
    """Corner tets of the written deck with a non-positive volume, from its text."""
    import meshio

    m = meshio.read(deck, file_format="abaqus")
    T = next(c.data for c in m.cells if c.type.startswith("tetra"))[:, :4]
    a, b, c, d = (m.points[T[:, k]] for k in range(4))
    return int((np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) <= 0).sum())


@pytest.mark.parametrize("method", ["slsqp", "cobyqa"])
def test_a_known_minimum_is_found_from_the_decks_themselves(two_bores, tmp_path, method):
    out = tmp_path / method
    code = _optimize(two_bores, out, "--solver", "true", "--response", str(two_bores / "centres.py"),
                     "--objective", "miss", "--method", method, "--max-evaluations", "40", "--result",
                     str(out / "result.json"))
    assert code == 0
    result = json.loads((out / "result.json").read_text())
    best = result["best"]
    deck = Path(best["deck"])
    exec(CENTRES, ns := {})
    rest = ns["response"](two_bores / "two_holes.inp")  # the bores' node centroids at rest (near 30 and 65)
    got = ns["response"](deck)  # recomputed from the best deck
    assert got["c1"] == pytest.approx(40.0, abs=0.3) and got["c2"] == pytest.approx(72.0, abs=0.3)
    assert best["parameters"]["move1"] == pytest.approx(40.0 - rest["c1"], abs=0.3)
    assert best["parameters"]["move2"] == pytest.approx(72.0 - rest["c2"], abs=0.3)
    rows = list(csv.DictReader(open(out / "history.csv")))
    assert len(rows) == result["evaluations"] <= 40
    assert [int(r["evaluation"]) for r in rows] == list(range(1, len(rows) + 1))
    for r in rows:  # each row's deck is the one written for it, its objective recomputed from it
        assert float(r["objective"]) == pytest.approx(ns["response"](Path(r["deck"]))["miss"], rel=1e-9)
    assert float(rows[0]["objective"]) == pytest.approx(rest["miss"], rel=1e-9)  # the start, at rest


def test_response_gradients_are_chained_with_the_exact_shape_derivatives(two_bores, tmp_path):
    out = tmp_path / "chained"
    code = _optimize(two_bores, out, "--solver", "true", "--response", str(two_bores / "centres_grad.py"),
                     "--objective", "miss", "--max-evaluations", "30", "--result", str(out / "result.json"))
    assert code == 0
    rows = list(csv.DictReader(open(out / "history.csv")))
    assert all(r["role"] != "difference" for r in rows)  # no differences: one evaluation per iterate
    exec(CENTRES, ns := {})
    rest = ns["response"](two_bores / "two_holes.inp")
    best = json.loads((out / "result.json").read_text())["best"]
    # exact gradients: the optimum to SLSQP's tolerance (1e-6 in the objective), where forward differences
    # of the same budget stop 0.3 off (test above)
    assert best["parameters"]["move1"] == pytest.approx(40.0 - rest["c1"], abs=2e-3)
    assert best["parameters"]["move2"] == pytest.approx(72.0 - rest["c2"], abs=2e-3)
    assert best["miss"] <= 1e-5 and len(rows) <= 15


@pytest.mark.ccx
def test_the_worked_example_lowers_the_peak_stress_at_fixed_mass(two_bores, tmp_path):
    """The docs' example with a small budget: SLSQP on CalculiX's max_mises, the mass held."""
    out = tmp_path / "opt"
    code = _optimize(two_bores, out, "--solver", "ccx -i {stem}", "--response", "ccx", "--objective", "max_mises",
                     "--constraint", "mass<=1.4468e-4", "--max-evaluations", "8", "--timeout", "120",
                     "--plot", str(out / "history.svg"), "--result", str(out / "result.json"))
    assert code == 0
    rows = list(csv.DictReader(open(out / "history.csv")))
    assert 1 < len(rows) <= 8
    figures = [_dat_mises_and_mass(Path(r["deck"]).with_suffix(".dat")) for r in rows]
    for r, (mises, mass) in zip(rows, figures, strict=True):
        assert r["status"] == "ok" and float(r["objective"]) == pytest.approx(mises, rel=1e-9)
        assert mass <= 1.4468e-4 and mass == pytest.approx(figures[0][1], rel=1e-4)  # fixed mass
        assert _inverted(Path(r["deck"])) == 0
    result = json.loads((out / "result.json").read_text())
    best_mises = _dat_mises_and_mass(Path(result["best"]["deck"]).with_suffix(".dat"))[0]
    assert best_mises < 0.9 * figures[0][0]  # the peak stress went down by more than 10 %
    svg = (out / "history.svg").read_text()
    assert svg.startswith("<svg") and svg.count("<circle") == sum(r["role"] != "difference" for r in rows)


def test_an_evaluation_that_inverts_is_recorded_and_ends_the_search(two_bores, tmp_path, capsys):
    out = tmp_path / "far"
    # bounds far past the safe range: the start itself (move1 = 60) drives the bore through the tip
    code = _optimize(two_bores, out, "--solver", "true", "--response", str(two_bores / "centres.py"),
                     "--objective", "miss", "--bounds", "move1=50:70", "--start", "move1=60",
                     "--result", str(out / "result.json"))
    assert code == 1
    assert capsys.readouterr().out == ""
    rows = list(csv.DictReader(open(out / "history.csv")))
    assert len(rows) == 1 and rows[0]["status"] == "rejected" and int(rows[0]["inverted"]) > 0
    assert rows[0]["objective"] == "" and not (out / "1" / "deck.inp").exists()
    result = json.loads((out / "result.json").read_text())
    assert result["status"] == "evaluation_failed" and result["best"] is None


@pytest.mark.parametrize("extra, fragment", [
    (["--constraint", "mass<<3"], "NAME<=NUMBER"),
    (["--bounds", "nosuch=0:1"], "nosuch"),
    (["--bounds", "move1=2:1"], "LO < HI"),
    (["--start", "move1"], "NAME=VALUE"),
    (["--solver", "no-such-solver-here"], "not found"),
])
def test_bad_options_are_typed_errors_before_any_solver_run(two_bores, tmp_path, capsys, extra, fragment):
    args = ["--solver", "true", "--response", str(two_bores / "centres.py"), "--objective", "miss", *extra]
    assert _optimize(two_bores, tmp_path, *args) in (1, 2)
    err = capsys.readouterr().err
    assert fragment in err and "Traceback" not in err
    assert not (tmp_path / "1").exists()


def test_an_output_without_the_evaluation_number_is_refused(two_bores, tmp_path, capsys):
    code = main(["optimize", str(two_bores / "two_holes.inp"), "--spec", str(EXAMPLE / "spec.json"),
                 "--shapes", str(EXAMPLE / "shapes.json"), "--output", str(tmp_path / "deck.inp"),
                 "--history", str(tmp_path / "h.csv"), "--solver", "true", "--objective", "miss"])
    assert code in (1, 2) and "{i}" in capsys.readouterr().err
