"""Column-major copies of row-major blocks of right-hand sides, and back, in tiles.

PARDISO reads and writes its right-hand sides column by column (Fortran
order); tetmorph builds them row by row (one row per vertex, three columns per
position array). numpy's ``asfortranarray`` of a tall (n, k) C-order array
walks one of the two arrays with a stride of k (or n) elements per step, a
cache miss per element on a DOE block. The kernels here copy tiles of rows, so
both arrays are read and written in runs of at least a cache line (``python
benchmarks/measure_choices.py --only layout`` has the figures). Compiled kernel in
src/core/products.cpp (``products_copy_tiles``, one overload per pair of float32 and float64;
other dtypes take numpy's copy).
"""

from __future__ import annotations

import numpy as np
import tetmorph_core

__all__ = ["fortran_copy", "c_copy"]

#: Rows per tile: a tile of 48 double columns is 96 KB, within a core's L2.
_TILE = 256
_FLOATS = (np.dtype(np.float32), np.dtype(np.float64))


def _tiled(a: np.ndarray, out: np.ndarray) -> bool:
    """Whether the compiled tiled copy takes this pair (float32 and float64 of two or more columns)."""
    return a.shape[1] >= 2 and a.dtype in _FLOATS and out.dtype in _FLOATS


def fortran_copy(b: np.ndarray, dtype: type) -> np.ndarray:
    """``numpy.asfortranarray(b, dtype)`` of a 2-D array, always a new array.

    Parameters
    ----------
    b : (n, k) array
    dtype : numpy dtype of the copy

    Returns
    -------
    (n, k) Fortran-ordered array

    Examples
    --------
    >>> b = np.arange(6.0).reshape(3, 2)
    >>> f = fortran_copy(b, np.float32)
    >>> f.flags.f_contiguous, f.dtype.name, bool((f == b).all())
    (True, 'float32', True)
    """
    out: np.ndarray = np.empty(b.shape, dtype=dtype, order="F")
    if not b.flags.c_contiguous or not _tiled(b, out):
        out[...] = b
    else:
        tetmorph_core.products_copy_tiles(b, out, _TILE)
    return out


def c_copy(x: np.ndarray, dtype: type) -> np.ndarray:
    """``numpy.ascontiguousarray(x, dtype)`` of a 2-D Fortran-ordered array, as a new array.

    Examples
    --------
    >>> x = np.asfortranarray(np.arange(6, dtype=np.float32).reshape(3, 2))
    >>> c = c_copy(x, np.float64)
    >>> c.flags.c_contiguous, c.dtype.name, c.tolist()
    (True, 'float64', [[0.0, 1.0], [2.0, 3.0], [4.0, 5.0]])
    """
    out: np.ndarray = np.empty(x.shape, dtype=dtype)
    if not x.flags.f_contiguous or not _tiled(x, out):
        out[...] = x
    else:
        tetmorph_core.products_copy_tiles(x, out, _TILE)
    return out
