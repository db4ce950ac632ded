"""The REPORT's model declares every field the library writes, and nothing the library lacks."""

from __future__ import annotations

from dataclasses import fields

import pytest

from solver import mesh_from_arrays, precompute, read_mesh
from solver.deform.report import Report as LibraryReport
from solver.documents.report import Report
from solver.testing import cube_mesh

from ...conftest import DATA

CUBE_SPEC = {"selections": {"a": {"box": {"min": [0, 0, 0], "max": [1, 1, 0]}},
                            "b": {"box": {"min": [0, 0, 1], "max": [1, 1, 1]}}},
             "fixed": ["a"], "handles": {"top": "b"}}


def test_the_model_and_the_library_name_the_same_fields():
    assert {f.name for f in fields(LibraryReport)} == set(Report.model_fields)


@pytest.fixture(scope="module")
def cube():
    return precompute(mesh_from_arrays(*cube_mesh(3)), CUBE_SPEC)


LIFT = {"handles": {"top": {"translation": [0, 0, 0.1]}}}
CRUSH = {"handles": {"top": {"translation": [0, 0, -1.5]}}}  # inverts elements


@pytest.mark.parametrize("move,kw", [(LIFT, {}), (LIFT, {"quality": "full"}), (CRUSH, {"inversion": "clamp"}),
                                     (CRUSH, {"repair": True})])
def test_every_key_of_a_report_is_a_declared_field(cube, move, kw):
    report = cube.solve(move, **kw).report
    assert set(report) <= set(Report.model_fields), sorted(set(report) - set(Report.model_fields))
    Report.model_validate(report)  # and its values have the declared types


def test_a_quadratic_deck_reports_declared_fields_only():
    mesh = read_mesh(str(DATA / "ccx_bracket.inp"))
    d = precompute(mesh, {"selections": {"root": {"set": "FIXED"}, "tip": {"set": "LOAD"}}, "fixed": ["root"],
                          "handles": {"tip": "tip"}})
    report = d.solve({"handles": {"tip": {"translation": [0, 0, 2]}}}).report
    assert report["element_order"] == 2
    assert set(report) <= set(Report.model_fields), sorted(set(report) - set(Report.model_fields))
