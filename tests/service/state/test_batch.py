"""The batch's deck zip: a discard racing the block in flight leaves nothing behind."""

from __future__ import annotations

import threading

from service.state.batch import DeckZip
from solver import read_mesh
from solver.deform.deformer import Deformer
from tests.conftest import DATA
from tests.solver.workflows.conftest import plate_spec


def test_a_discard_while_decks_are_written_leaves_no_file(tmp_path):
    mesh = read_mesh(DATA / "plate.inp")
    res = Deformer(mesh, plate_spec()).solve({})
    for attempt in range(5):  # the discard lands at a different point of the writing each time
        folder = tmp_path / str(attempt)
        folder.mkdir()
        z = DeckZip(folder / "j.zip", mesh, "plate", ".inp", "abaqus", 1 << 30)
        out = z.writer()
        started = threading.Event()
        errors: list[BaseException] = []

        def write(out=out, started=started, errors=errors) -> None:
            try:
                for row in range(1, 40):
                    out(row, res)
                    started.set()
            except BaseException as e:  # noqa: BLE001 - the test's assertion
                errors.append(e)

        t = threading.Thread(target=write)
        t.start()
        started.wait(30)
        z.discard()
        t.join(60)
        assert not t.is_alive() and errors == []  # writes after the discard are dropped, not failed
        assert [p for p in folder.rglob("*")] == []
