"""Hypothesis strategies for constraint rows."""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st


@st.composite
def constraint_rows(draw):
    """Random sparse rows with dependent ones mixed in (copies, scaled copies, a combination)."""
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 31)))
    N = draw(st.integers(2, 12))
    m = draw(st.integers(1, N))
    C = rng.standard_normal((m, N)) * (rng.random((m, N)) < 0.4)
    C[np.arange(m), rng.integers(0, N, m)] += 1.0  # no empty rows
    dup = draw(st.lists(st.integers(0, m - 1), max_size=3))
    combos = [C[i] * rng.uniform(0.5, 2) for i in dup]
    if m >= 2 and draw(st.booleans()):
        combos.append(C[0] - 2 * C[1])  # a combination of two earlier rows
    return np.vstack([C, *combos]) if combos else C, rng
