"""Quality checks with thresholds: which elements a solver's limits would flag, by criterion.

A :class:`Criteria` holds one threshold per criterion (None: not checked);
:data:`PRESETS` name the usual sets (the sources of their numbers are in
docs/guide/validity.md); :func:`quality_check` measures every element once and
answers, per criterion, how many fail, which (element indices and the deck's
own ids), and the worst value with its element. The CLI (``tetmorph check``)
and the service (``GET /v1/meshes/{id}/check``) answer from the same function.

The measures (:func:`criteria_values`):

* ``scaled_jacobian``: Verdict's tet scaled Jacobian of the corner tet (1 for
  the regular tet, <= 0 inverted; hexahedra, wedges and pyramids: the smallest
  corner value, :func:`solver.validity.quality.element_jacobians`);
* ``scaled_jacobian_ip``: quadratic tets only, the smallest scaled Jacobian at
  the four points of the degree-2 Gauss rule (:func:`gauss_scaled_jacobians`);
* ``aspect_ratio``: ``h_max / (2 sqrt(6) r_in)``, 1 for the regular tet
  (:func:`solver.validity.quality.aspect_ratios`);
* ``min_dihedral``, ``max_dihedral``: degrees, 70.53 for the regular tet;
* ``volume_ratio``: deformed over rest volume (with rest positions given).

A criterion fails an element whose value lies strictly beyond its threshold
(below a ``min_`` one, above a ``max_`` one). NaN (a tet measure on a
hexahedron, a volume ratio without rest positions) never fails.
"""

from __future__ import annotations

import dataclasses
import io
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import SpecError
from ..limits import QUALITY_THRESHOLD_MAX
from ..ops.elements import element_blocks, element_volumes
from .quality import aspect_ratios, dihedral_angles, element_jacobians, signed_volumes

__all__ = ["Criteria", "PRESETS", "CRITERIA", "CriterionResult", "QualityCheck", "criteria_values",
           "gauss_scaled_jacobians", "preset", "quality_check"]

#: Each criterion: (the measure it reads, "min" or "max" sense, what it means).
CRITERIA: dict[str, tuple[str, str, str]] = {
    "min_scaled_jacobian": ("scaled_jacobian", "min", "scaled Jacobian at the corners"),
    "min_scaled_jacobian_ip": ("scaled_jacobian_ip", "min", "scaled Jacobian at the integration points (tet10)"),
    "max_aspect_ratio": ("aspect_ratio", "max", "aspect ratio (1 for the regular tet)"),
    "min_dihedral": ("min_dihedral", "min", "smallest dihedral angle, degrees"),
    "max_dihedral": ("max_dihedral", "max", "largest dihedral angle, degrees"),
    "min_volume_ratio": ("volume_ratio", "min", "volume over rest volume"),
    "max_volume_ratio": ("volume_ratio", "max", "volume over rest volume"),
}


@dataclass(frozen=True)
class Criteria:
    """Thresholds of a quality check; None leaves a criterion unchecked.

    An element fails a ``min_`` criterion when its value is below the
    threshold, a ``max_`` one when it is above (:data:`CRITERIA`).

    Raises
    ------
    SpecError
        ``invalid_threshold`` (details ``field``): not a number, NaN, or beyond
        :data:`solver.limits.QUALITY_THRESHOLD_MAX` in magnitude.

    Examples
    --------
    >>> Criteria(max_aspect_ratio=10.0).thresholds()["max_aspect_ratio"]
    10.0
    >>> PRESETS["calculix"].replace(max_aspect_ratio=50.0).max_aspect_ratio
    50.0
    """

    min_scaled_jacobian: float | None = None
    min_scaled_jacobian_ip: float | None = None
    max_aspect_ratio: float | None = None
    min_dihedral: float | None = None
    max_dihedral: float | None = None
    min_volume_ratio: float | None = None
    max_volume_ratio: float | None = None

    def __post_init__(self) -> None:
        for name in CRITERIA:
            x = getattr(self, name)
            if x is not None and not (isinstance(x, (int, float)) and abs(x) <= QUALITY_THRESHOLD_MAX):
                raise SpecError(f"{name} must be a number of magnitude at most {QUALITY_THRESHOLD_MAX:g} or None "
                                f"(not checked), not {x!r}", code="invalid_threshold", field=name)

    def thresholds(self) -> dict[str, float | None]:
        """Every criterion's threshold, in :data:`CRITERIA` order."""
        return {k: getattr(self, k) for k in CRITERIA}

    def replace(self, **thresholds: float | None) -> Criteria:
        """A copy with some thresholds changed (None: not checked)."""
        return dataclasses.replace(self, **thresholds)


#: A value this close to 0 counts as flat: the "positive Jacobian" presets fail it.
POSITIVE = 1.0e-6

#: Named threshold sets; docs/guide/validity.md gives the source of each number.
PRESETS: dict[str, Criteria] = {
    "tetmorph": Criteria(min_scaled_jacobian=0.2, min_scaled_jacobian_ip=0.2, max_aspect_ratio=10.0,
                         min_dihedral=5.0, max_dihedral=170.0, min_volume_ratio=0.2, max_volume_ratio=5.0),
    "abaqus": Criteria(min_scaled_jacobian=POSITIVE, min_scaled_jacobian_ip=POSITIVE, max_aspect_ratio=10.0,
                       min_dihedral=5.0, max_dihedral=170.0),
    "calculix": Criteria(min_scaled_jacobian=POSITIVE, min_scaled_jacobian_ip=POSITIVE),
    "nastran": Criteria(min_scaled_jacobian=POSITIVE, min_scaled_jacobian_ip=POSITIVE, max_aspect_ratio=100.0),
}


def preset(name: str) -> Criteria:
    """The :data:`PRESETS` entry ``name``.

    ``tetmorph`` (the default of ``tetmorph check``: every criterion, tetmorph's own limits),
    ``abaqus``, ``calculix`` and ``nastran`` (what each solver refuses or flags); the guide
    (docs/guide/validity.md, "Quality checks") gives every number and its source.

    Raises
    ------
    SpecError
        ``unknown_preset`` naming the presets (details ``field``, ``preset``, ``presets``).

    Examples
    --------
    >>> preset("calculix").min_scaled_jacobian
    1e-06
    """
    try:
        return PRESETS[name]
    except KeyError:
        raise SpecError(f"unknown quality preset {name!r}; choose one of {sorted(PRESETS)}",
                        code="unknown_preset", field="preset", preset=name, presets=sorted(PRESETS)) from None


#: The degree-2 Gauss rule of the tetrahedron (4 points, weight 1/24 each): barycentric ``a`` at one
#: corner, ``b`` at the others (Zienkiewicz, The Finite Element Method, table of tetrahedron rules).
GAUSS_A = (5.0 + 3.0 * np.sqrt(5.0)) / 20.0
GAUSS_B = (5.0 - np.sqrt(5.0)) / 20.0
#: Edges of the VTK / Abaqus C3D10 mid-side nodes 4..9.
_EDGES10 = ((0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))
#: Rows processed at once by :func:`gauss_scaled_jacobians` (bounds its temporaries).
_CHUNK = 1 << 17


def _gauss_shape_derivatives() -> np.ndarray:
    """(4 points, 10 nodes, 4) derivatives of the tet10 shape functions by the barycentric coordinates."""
    D = np.zeros((4, 10, 4))
    for p in range(4):
        L = np.full(4, GAUSS_B)
        L[p] = GAUSS_A
        for c in range(4):
            D[p, c, c] = 4.0 * L[c] - 1.0
        for k, (i, j) in enumerate(_EDGES10):
            D[p, 4 + k, i] = 4.0 * L[j]
            D[p, 4 + k, j] = 4.0 * L[i]
    return D


_DG = _gauss_shape_derivatives()


def gauss_scaled_jacobians(V: np.ndarray, T10: np.ndarray) -> np.ndarray:
    """Scaled Jacobian of each quadratic tet at the four points of the degree-2 Gauss rule.

    At a point, the tangent along the edge direction from corner ``k`` to corner
    ``j`` is ``t_kj = dx/dL_j - dx/dL_k`` (``L`` barycentric); the value is
    Verdict's tet scaled Jacobian with these tangents for the edges:
    ``sqrt(2) det[t_01, t_02, t_03] / max_k (|t_ka| |t_kb| |t_kc|)``, clipped to
    [-1, 1]. A straight-sided element has ``t_kj = x_j - x_k`` everywhere, so its
    four values are its corner tet's scaled Jacobian.

    Parameters
    ----------
    V : (n, 3) float array
    T10 : (m, 10) int array
        VTK / C3D10 node order.

    Returns
    -------
    (m, 4) float array

    Examples
    --------
    >>> V = np.array([[1., 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]])[[0, 2, 1, 3]]
    >>> mids = np.array([(V[i] + V[j]) / 2 for i, j in _EDGES10])
    >>> np.round(gauss_scaled_jacobians(np.vstack([V, mids]), np.arange(10)[None]), 12).tolist()
    [[1.0, 1.0, 1.0, 1.0]]
    """
    out = np.empty((len(T10), 4))
    for s in range(0, len(T10), _CHUNK):
        X = np.asarray(V, np.float64)[T10[s:s + _CHUNK]]  # (c, 10, 3)
        G = np.einsum("mnd,pnl->mpld", X, _DG)  # dx/dL_l at each point, (c, 4, 4, 3)
        t = G[:, :, None, :, :] - G[:, :, :, None, :]  # t[k, j] = G_j - G_k, (c, 4, 4, 4, 3)
        det = np.einsum("mpd,mpd->mp", np.cross(t[:, :, 0, 1], t[:, :, 0, 2]), t[:, :, 0, 3])
        lengths = np.linalg.norm(t, axis=-1)  # (c, 4, 4, 4); the diagonal is 0
        prod = np.stack([np.prod(lengths[:, :, k, [j for j in range(4) if j != k]], axis=-1)
                         for k in range(4)], axis=-1).max(axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            sj = np.sqrt(2.0) * det / prod
        out[s:s + _CHUNK] = np.clip(np.nan_to_num(sj, nan=0.0, posinf=1.0, neginf=-1.0), -1.0, 1.0)
    return out


def _volumes(V: np.ndarray, T: np.ndarray, cells: dict[str, np.ndarray]) -> np.ndarray:
    """Signed volume of every element in element order (corner tets of quadratic ones)."""
    return np.concatenate([signed_volumes(V, T) if len(T) else np.zeros(0),
                           *[element_volumes(V, E, k) for k, E in element_blocks(T, cells) if k != "tetra"]])


def criteria_values(V: np.ndarray, T: np.ndarray, cells: dict[str, np.ndarray] | None = None,
                    T10: np.ndarray | None = None, V0: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Every measure a criterion reads, per element (NaN where it does not apply).

    Parameters
    ----------
    V : (n, 3) float array
        Positions to check.
    T : (m, 4) int array
        Tetrahedra (the corner tets of quadratic ones).
    cells : dict, optional
        Hexahedra, wedges and pyramids (:attr:`solver.mesh.Mesh.cells`).
    T10 : (m, 10) int array, optional
        Quadratic tets: ``scaled_jacobian_ip`` is measured.
    V0 : (n, 3) float array, optional
        Rest positions: ``volume_ratio`` is measured.

    Returns
    -------
    dict of str to (M,) float array
        ``scaled_jacobian``, ``scaled_jacobian_ip``, ``aspect_ratio``, ``min_dihedral``,
        ``max_dihedral``, ``volume_ratio``; tets first, then the other types.
    """
    cells = cells or {}
    T = np.asarray(T)
    m = len(T)
    sj = element_jacobians(V, T, cells)[1]
    nan = np.full(len(sj) - m, np.nan)
    dih = dihedral_angles(V, T) if m else np.zeros((0, 6))
    out = {"scaled_jacobian": sj,
           "scaled_jacobian_ip": (gauss_scaled_jacobians(V, T10).min(axis=1) if T10 is not None
                                  else np.full(len(sj), np.nan)),
           "aspect_ratio": np.concatenate([aspect_ratios(V, T) if m else np.zeros(0), nan]),
           "min_dihedral": np.concatenate([dih.min(axis=1, initial=np.inf), nan]),
           "max_dihedral": np.concatenate([dih.max(axis=1, initial=-np.inf), nan])}
    if V0 is None:
        out["volume_ratio"] = np.full(len(sj), np.nan)
    else:
        rest = _volumes(V0, T, cells)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = _volumes(V, T, cells) / rest
        out["volume_ratio"] = np.where(rest > 0, ratio, np.nan)  # flat at rest: no ratio
    return out


@dataclass(frozen=True, eq=False)
class CriterionResult:
    """One criterion's outcome.

    Attributes
    ----------
    name : str
        A key of :data:`CRITERIA`.
    threshold : float or None
        None: not checked (then nothing fails).
    applicable : int
        Elements the measure applies to (not NaN).
    failing : (k,) int64 array
        Failing element indices (0-based, element order), ascending.
    values : (k,) float array
        Their values.
    worst : float or None
        The worst value over the applicable elements (smallest for ``min_``, largest for ``max_``).
    worst_element : int or None
        Its element index.
    """

    name: str
    threshold: float | None
    applicable: int
    failing: np.ndarray
    values: np.ndarray
    worst: float | None
    worst_element: int | None

    @property
    def passed(self) -> bool:
        """True when no element fails (always for a criterion not checked)."""
        return not self.failing.size


@dataclass(frozen=True, eq=False)
class QualityCheck:
    """The outcome of :func:`quality_check`: one :class:`CriterionResult` per criterion.

    Attributes
    ----------
    criteria : Criteria
    results : list of CriterionResult
        In :data:`CRITERIA` order.
    elements : int
    ids : (M,) int64 array
        The deck's id of every element (1-based positions where the file has none).
    """

    criteria: Criteria
    results: list[CriterionResult]
    elements: int
    ids: np.ndarray = field(repr=False)

    @property
    def passed(self) -> bool:
        """True when every checked criterion passes."""
        return all(r.passed for r in self.results)

    @property
    def failing(self) -> np.ndarray:
        """(k,) int64 element indices that fail some criterion, ascending."""
        parts = [r.failing for r in self.results if r.failing.size]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)

    def to_dict(self, max_ids: int | None = None) -> dict[str, Any]:
        """JSON-ready: ``{"passed", "elements", "failing_elements", "criteria": [...]}``.

        Each criterion: ``name``, ``measure``, ``sense``, ``threshold``, ``checked``,
        ``applicable``, ``failing``, ``passed``, ``worst``, ``worst_element`` (the deck's id),
        ``ids`` (the failing elements' deck ids, the first ``max_ids``; all when None).
        """
        rows = []
        for r in self.results:
            measure, sense, _ = CRITERIA[r.name]
            ids = self.ids[r.failing if max_ids is None else r.failing[:max_ids]]
            rows.append({"name": r.name, "measure": measure, "sense": sense, "threshold": r.threshold,
                         "checked": r.threshold is not None, "applicable": r.applicable,
                         "failing": int(r.failing.size), "passed": r.passed, "worst": r.worst,
                         "worst_element": None if r.worst_element is None else int(self.ids[r.worst_element]),
                         "ids": ids.tolist()})
        return {"passed": self.passed, "elements": self.elements, "failing_elements": int(self.failing.size),
                "criteria": rows}

    def csv(self) -> str:
        """The failing elements as CSV: ``element,criterion,value,threshold``, one row per failure.

        ``element`` is the deck's id; rows by criterion (:data:`CRITERIA` order), then element.
        """
        buf = io.StringIO()
        buf.write("element,criterion,value,threshold\n")
        for r in self.results:
            for e, v in zip(self.ids[r.failing].tolist(), r.values.tolist(), strict=True):
                buf.write(f"{e},{r.name},{v!r},{r.threshold!r}\n")
        return buf.getvalue()


def _result(name: str, threshold: float | None, x: np.ndarray) -> CriterionResult:
    sense = CRITERIA[name][1]
    ok = ~np.isnan(x)
    n_ok = int(ok.sum())
    worst_element = None
    if n_ok:
        worst_element = int(np.nanargmin(x) if sense == "min" else np.nanargmax(x))
    worst = None if worst_element is None else float(x[worst_element])
    if threshold is None:
        failing = np.zeros(0, np.int64)
    else:
        failing = np.flatnonzero(x < threshold if sense == "min" else x > threshold)  # NaN compares False
    return CriterionResult(name, threshold, n_ok, failing, x[failing], worst, worst_element)


def quality_check(V: np.ndarray, T: np.ndarray, criteria: Criteria, *, cells: dict[str, np.ndarray] | None = None,
                  T10: np.ndarray | None = None, V0: np.ndarray | None = None,
                  ids: np.ndarray | None = None) -> QualityCheck:
    """Check every element against ``criteria``.

    Parameters
    ----------
    V : (n, 3) float array
        Positions to check (the deformed ones, or the rest shape).
    T : (m, 4) int array
    criteria : Criteria
    cells, T10, V0 : optional
        As :func:`criteria_values`. Without ``V0`` the volume ratio is not measured.
    ids : (M,) int array, optional
        The deck's element ids (:func:`solver.io.element_sets.deck_element_ids`); default 1..M.

    Returns
    -------
    QualityCheck

    Examples
    --------
    >>> V = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0.001]])
    >>> T = np.array([[0, 1, 2, 3], [0, 1, 2, 4]])
    >>> c = quality_check(V, T, PRESETS["tetmorph"])
    >>> c.passed, c.failing.tolist(), c.to_dict()["criteria"][0]["ids"]
    (False, [1], [2])
    """
    q = criteria_values(V, T, cells, T10, V0)
    results = [_result(name, getattr(criteria, name), q[CRITERIA[name][0]]) for name in CRITERIA]
    M = len(q["scaled_jacobian"])
    deck = np.arange(1, M + 1, dtype=np.int64) if ids is None else np.asarray(ids, np.int64)
    if deck.shape != (M,):
        raise ValueError(f"ids has shape {deck.shape}; the mesh has {M} elements")
    return QualityCheck(criteria, results, M, deck)
