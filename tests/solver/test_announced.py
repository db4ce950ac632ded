"""Work that takes more than a second is never silent on standard error; short work says nothing."""

from __future__ import annotations

import io
import time

from solver.kernels import announced


def test_long_work_is_announced_when_it_passes_the_threshold_and_when_it_ends():
    out = io.StringIO()
    with announced("loading the kernels", after_s=0.05, stream=out):
        time.sleep(0.3)
    lines = out.getvalue().splitlines()
    assert lines[0] == "tetmorph: loading the kernels..."
    assert lines[1].startswith("tetmorph: loading the kernels: done in")


def test_short_work_says_nothing():
    out = io.StringIO()
    with announced("loading the kernels", after_s=5.0, stream=out):
        pass
    assert out.getvalue() == ""


def test_the_cli_announces_a_slow_kernel_load(monkeypatch, capsys, tmp_path):
    import solver.kernels as kernels
    from solver.cli import main

    monkeypatch.setattr(kernels, "load_kernels", lambda: time.sleep(1.3) or 1.3)  # a cold install's load
    main(["morph", "examples/beam/beam.node", "--spec", "examples/beam/spec.json", "--moves",
          "examples/beam/moves.json", "--output", str(tmp_path / "b_{i}.vtu")])
    err = capsys.readouterr().err
    assert "tetmorph: loading the solver's compiled kernels" in err and "done in" in err
