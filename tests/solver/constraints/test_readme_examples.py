"""The guide's SPEC and MOVE examples (docs/guide/constraints.md) parse, and its POINT forms are POINTs."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from solver.constraints.move import parse_move
from solver.constraints.spec import parse_spec
from solver.errors import SpecError

PAGE = Path(__file__).resolve().parents[3] / "docs" / "guide" / "constraints.md"
SELECTIONS = {n: {"ids": [k]} for k, n in enumerate(["hole1", "hole2", "hole3", "bottom", "clamp", "end"])}


def _block(lang: str) -> str:
    m = re.search(rf"```{lang}\n(.*?)```", PAGE.read_text(), re.S)
    assert m, f"{PAGE.name} has no {lang} block"
    return m.group(1)


def _fragments() -> tuple[dict, list[dict]]:
    """The SPEC entries of the page's constraint examples, and the MOVEs their comments give."""
    text = _block("jsonc")
    moves = []
    for m in re.finditer(r"// MOVE: (.*)", text):
        for part in re.split(r"\s{2,}or\s", m.group(1).strip()):
            part = part.strip()
            if part.startswith("{"):  # "or {...}": the same key again
                key = re.match(r'"(\w+)"', m.group(1).strip()).group(1)
                part = f'"{key}": {part}'
            moves.append(json.loads("{" + part.split("     ")[0].strip() + "}"))
    body = re.sub(r"//.*", "", text).strip()
    spec = json.loads("{" + re.sub(r"\]\s*\n\s*\n\s*\"", '],\n"', body) + "}")
    return spec, moves


def test_the_readme_constraint_examples_parse_as_a_spec_and_its_moves():
    entries, moves = _fragments()
    assert set(entries) == {"points", "relative", "features", "motion", "sliding"}
    spec = parse_spec({"selections": SELECTIONS, "fixed": ["clamp"], "handles": {"end": "end"}, **entries})
    assert [p.name for p in spec.points] == ["e", "f", "c"]
    assert [r.name for r in spec.relative] == ["gauge", "pitch"]
    names = {"points": [p.name for p in spec.points], "relative": [r.name for r in spec.relative],
             "features": [f.name for f in spec.features], "motion": [m.name for m in spec.motion]}
    assert len(moves) >= 5
    for doc in moves:
        parse_move(doc, ["end"], names)


@pytest.mark.parametrize("form", [{"vertices": [1, 2], "weights": [0.25, 0.75]}, {"vertices": [3]},
                                  {"edge": [1, 2], "t": 0.5}, {"face": [1, 2, 3], "barycentric": [0.2, 0.3, 0.5]},
                                  {"selection": "hole1"}])
def test_every_point_form_is_a_spec_point_a_relative_point_and_a_motion_point(form):
    spec = parse_spec({"selections": SELECTIONS, "fixed": ["clamp"], "handles": {"end": "end"},
                       "points": [{"name": "p", **form, "target": [0, 0, 0]}],
                       "relative": [{"name": "r", "points": [form, {"selection": "hole2"}]}],
                       "motion": [{"name": "m", **form, "plane": {"normal": [0, 0, 1]}}]})
    assert spec.points[0].name == "p" and spec.relative[0].name == "r" and spec.motion[0].name == "m"


def test_a_name_inside_a_relative_point_is_refused_naming_it():
    with pytest.raises(SpecError, match=r"unknown field 'name' in SPEC\.relative\[0\]\.points\[0\]"):
        parse_spec({"selections": SELECTIONS, "fixed": ["clamp"], "handles": {"end": "end"},
                    "relative": [{"name": "r", "points": [{"name": "x", "vertices": [1]}, {"vertices": [2]}]}]})
