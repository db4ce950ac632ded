"""Nastran coordinate systems: CORD2R, CORD2C and CORD2S cards, and GRID positions given in them.

A GRID card gives its position in the coordinate system its CP field names
(0 or blank: the basic system). A ``CORD2R`` (rectangular), ``CORD2C``
(cylindrical: r, theta in degrees, z) or ``CORD2S`` (spherical: r, theta,
phi in degrees) card defines system CID by three points given in its RID
system (0: basic): A, the origin; B, on the z axis; C, in the xz plane. The RID
system may itself be any CORD2x system, so systems form chains, which
:func:`resolve_systems` follows down to the basic system.

tetmorph moves nodes in the basic system: :class:`GridPositions` reads each
GRID card's fields and turns them into basic positions
(:meth:`CoordSystem.to_basic`), and :mod:`solver.io.patch_bdf` writes a moved
node back in its own system (:meth:`CoordSystem.from_basic`). The CD field
(the system of a node's displacements) is never read: it is kept as written.

``CORD1R``, ``CORD1C`` and ``CORD1S`` define a system by three GRIDs, which
would move with the mesh: a GRID given in such a system (or in a CORD2x system
resting on one) is refused, as is one given in a system no card defines, in a
chain of RIDs that loops, or in a system whose three points do not span one.
Systems that no GRID's CP needs are not looked at.

Field formats: small (8 columns), large (``CORD2R*``, 16 columns, the card
continuing on lines starting with ``*``) and free field (commas, at most ten
fields a line).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MAX_IDS, UnreadableFileError
from .nastran import GridCard, bulk_start, grid_cards, nastran_float

__all__ = ["CoordCard", "CoordSystem", "GridPositions", "coord_cards", "resolve_systems", "KINDS", "grid_rounding"]

#: The systems tetmorph reads, by card: rectangular, cylindrical, spherical.
KINDS = {"CORD2R": "R", "CORD2C": "C", "CORD2S": "S"}


@dataclass(frozen=True)
class CoordCard:
    """One coordinate system card as written.

    Attributes
    ----------
    cid : int
        The system's id.
    card : str
        The card's name (``"CORD2C"``, ``"CORD1R"``, ...).
    line : int
        The card's first line, 1-based.
    rid : int
        The system A, B and C are given in (CORD2x; 0 otherwise).
    points : (3, 3) tuple of float, optional
        A, B and C, one per row, in the RID system (CORD2x).
    problem : str, optional
        Why the card cannot define a system (fields that are not numbers, too
        many fields on a free-field line).
    """

    cid: int
    card: str
    line: int
    rid: int = 0
    points: tuple[tuple[float, float, float], ...] | None = None
    problem: str | None = None


@dataclass(frozen=True)
class CoordSystem:
    """A coordinate system placed in the basic system.

    Attributes
    ----------
    cid : int
    kind : str
        ``"R"`` (x, y, z), ``"C"`` (r, theta, z) or ``"S"`` (r, theta, phi);
        angles in degrees.
    origin : (3,) float array
        The origin, in basic coordinates.
    axes : (3, 3) float array
        The unit x, y and z axes, one per row, in basic coordinates.

    Examples
    --------
    A cylindrical system whose axis is the basic x axis, with theta = 0 along the basic z axis:

    >>> s = CoordSystem.from_points(1, "C", np.array([[1.0, 0, 0], [2.0, 0, 0], [1.0, 0, 1]]))
    >>> s.axes + 0.0  # x, y, z axes
    array([[ 0.,  0.,  1.],
           [ 0., -1.,  0.],
           [ 1.,  0.,  0.]])
    >>> P = s.to_basic(np.array([[2.0, 90.0, 3.0]]))  # r = 2 along the y axis, 3 along the x axis from the origin
    >>> np.round(P, 12) + 0.0
    array([[ 4., -2.,  0.]])
    >>> np.round(s.from_basic(P), 12) + 0.0
    array([[ 2., 90.,  3.]])
    """

    cid: int
    kind: str
    origin: np.ndarray
    axes: np.ndarray

    @classmethod
    def from_points(cls, cid: int, kind: str, abc: np.ndarray) -> CoordSystem:
        """The system whose origin is A, z axis towards B and xz plane through C.

        Parameters
        ----------
        cid : int
        kind : str
            ``"R"``, ``"C"`` or ``"S"``.
        abc : (3, 3) float array
            A, B and C, one per row, in basic coordinates.

        Returns
        -------
        CoordSystem

        Raises
        ------
        ValueError
            B is A, or C is on the line AB: the points span no system.
        """
        a, b, c = np.asarray(abc, dtype=np.float64)
        ab, ac = b - a, c - a
        scale = max(float(np.abs(abc).max()), 1e-300)
        z_len = float(np.linalg.norm(ab))
        if not np.isfinite(abc).all() or z_len <= 1e-12 * scale:
            raise ValueError("its points A and B coincide: they give no z axis")
        z = ab / z_len
        y = np.cross(z, ac)
        y_len = float(np.linalg.norm(y))
        if y_len <= 1e-12 * scale:
            raise ValueError("its point C lies on the z axis through A and B: it gives no xz plane")
        y = y / y_len
        x = np.cross(y, z)
        return cls(cid, kind, a, np.array([x, y, z]))

    def to_basic(self, X: np.ndarray) -> np.ndarray:
        """Basic positions of points given in this system.

        Parameters
        ----------
        X : (n, 3) float array
            Coordinates in this system: x, y, z; r, theta, z; or r, theta, phi
            (angles in degrees).

        Returns
        -------
        (n, 3) float64 array
            Each row from its own row alone (elementwise operations, no matrix
            product), so that a row's result does not depend on the others.
        """
        X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
        u, v, w = (np.ascontiguousarray(X[:, j]) for j in range(3))
        if self.kind == "C":
            t = np.radians(v)
            u, v = u * np.cos(t), u * np.sin(t)
        elif self.kind == "S":
            t, p = np.radians(v), np.radians(w)
            s = u * np.sin(t)
            u, v, w = s * np.cos(p), s * np.sin(p), u * np.cos(t)
        e = self.axes
        return np.stack([self.origin[j] + u * e[0, j] + v * e[1, j] + w * e[2, j] for j in range(3)], axis=1)

    def from_basic(self, P: np.ndarray, near: np.ndarray | None = None) -> np.ndarray:
        """Coordinates in this system of points given in the basic system.

        Parameters
        ----------
        P : (n, 3) float array
            Basic positions.
        near : (n, 3) float array, optional
            The points' former coordinates in this system. Each azimuth (theta
            of a cylindrical system, phi of a spherical one) is taken within
            180 degrees of its former value, so that a node that moves a little
            keeps its angles' range (350 stays near 350, not -10); an angle that
            a point on the axis leaves undetermined keeps its former value.

        Returns
        -------
        (n, 3) float64 array
            x, y, z; r, theta, z; or r, theta, phi (r >= 0, angles in degrees;
            spherical theta in [0, 180]).
        """
        d = np.asarray(P, dtype=np.float64).reshape(-1, 3) - self.origin
        e = self.axes
        x, y, z = (d[:, 0] * e[j, 0] + d[:, 1] * e[j, 1] + d[:, 2] * e[j, 2] for j in range(3))
        if self.kind == "R":
            return np.stack([x, y, z], axis=1)
        rho = np.hypot(x, y)
        azimuth = np.degrees(np.arctan2(y, x))
        old = None if near is None else np.asarray(near, dtype=np.float64).reshape(-1, 3)
        if old is not None:
            before = old[:, 1] if self.kind == "C" else old[:, 2]
            azimuth = np.where(rho == 0, before, azimuth + 360.0 * np.round((before - azimuth) / 360.0))
        if self.kind == "C":
            return np.stack([rho, azimuth, z], axis=1)
        r = np.hypot(rho, z)
        polar = np.degrees(np.arctan2(rho, z))
        if old is not None:
            polar = np.where(r == 0, old[:, 1], polar)
        return np.stack([r, polar, azimuth], axis=1)


# ----------------------------------------------------------------------------------------------- cards

def _split(line: bytes, large: bool) -> tuple[list[str], str | None]:
    """The data fields of one line of a card (field 1 and field 10 left out), and what is wrong with it."""
    body = line.rstrip(b"\r\n").decode("ascii", "replace")
    if "," in body:
        fields = body.split(",")
        room = 4 if large else 8
        data = (fields[1:room + 1] + [""] * room)[:room]  # a short line: its missing fields are blank
        if len(fields) > room + 2:
            return data, f"{len(fields)} fields on one free-field line, where a line holds {room + 2}"
        return data, None
    if large:
        return [body[a:a + 16] for a in (8, 24, 40, 56)], None
    return [body[a:a + 8] for a in range(8, 72, 8)], None


def _continues(line: bytes) -> bool:
    """Whether a data line continues the card before it: ``+`` or ``*`` first, or a blank first field."""
    if line[:1] in (b"+", b"*"):
        return True
    head = line.split(b",", 1)[0] if b"," in line else line[:8]
    return not head.strip() and bool(line.strip())


def _int(field: str) -> int:
    s = field.strip()
    return int(s) if s else 0


def coord_cards(lines: list[bytes]) -> dict[int, list[CoordCard]]:
    r"""The coordinate system cards of a deck's bulk data, by system id.

    Parameters
    ----------
    lines : list of bytes
        The deck's lines, with their line ends.

    Returns
    -------
    dict of int to list of CoordCard
        Every card that defines the id, in order (a well-formed deck has one).
        ``CORD2R``/``C``/``S`` cards carry RID and their points; other ``CORD``
        cards (``CORD1R``, which may define two systems, ``CORD3G``, ...) only
        their name, for the refusal.

    Examples
    --------
    >>> deck = (b"BEGIN BULK\nCORD2R*                2               1              1.              2.\n"
    ...         b"*                     3.              1.              2.              4.\n"
    ...         b"*                     2.              2.              3.\nENDDATA\n")
    >>> card = coord_cards(deck.splitlines(keepends=True))[2][0]
    >>> card.card, card.rid, card.points
    ('CORD2R', 1, ((1.0, 2.0, 3.0), (1.0, 2.0, 4.0), (2.0, 2.0, 3.0)))
    """
    out: dict[int, list[CoordCard]] = {}
    k = bulk_start(lines)
    while k < len(lines):
        line = lines[k]
        if line.startswith(b"ENDDATA"):
            break
        if line[:4].upper() != b"CORD":
            k += 1
            continue
        first = (line.split(b",", 1)[0] if b"," in line else line[:8]).strip().upper().decode("ascii", "replace")
        large = first.endswith("*")
        name = first.rstrip("*")
        fields, problem = _split(line, large)
        start = k
        k += 1
        while k < len(lines):  # continuation lines, comments between them skipped
            nxt = lines[k]
            if not nxt.strip() or nxt.startswith((b"$", b"//", b"#")):
                k += 1
                continue
            if not _continues(nxt):
                break
            more, bad = _split(nxt, nxt[:1] == b"*" or (large and b"," in nxt))
            fields += more
            problem = problem or bad
            k += 1
        for card in _cards(name, fields, start + 1, problem):
            out.setdefault(card.cid, []).append(card)
    return out


def _cards(name: str, fields: list[str], line: int, problem: str | None) -> list[CoordCard]:
    """The systems one card defines (none when its id cannot be read: nothing could name it)."""
    try:
        cids = [_int(fields[0])] if fields else []
        if name.startswith("CORD1") and len(fields) > 4 and fields[4].strip():
            cids.append(_int(fields[4]))
    except ValueError:
        return []
    if name not in KINDS:
        return [CoordCard(cid, name, line) for cid in cids if cid > 0]
    if not cids or cids[0] <= 0:
        return []
    if problem is None:
        try:
            rid = _int(fields[1]) if len(fields) > 1 else 0
            values = [nastran_float(f) for f in (fields[2:11] + [""] * 9)[:9]]
        except ValueError:
            problem = "a field that is not a number"
        else:
            pts = tuple((values[j], values[j + 1], values[j + 2]) for j in (0, 3, 6))
            return [CoordCard(cids[0], name, line, rid, pts)]
    return [CoordCard(cids[0], name, line, problem=problem)]


# ----------------------------------------------------------------------------------------------- chains

def resolve_systems(cards: dict[int, list[CoordCard]], wanted: dict[int, int]) -> dict[int, CoordSystem]:
    r"""The systems GRID cards are given in, each placed in the basic system through its chain of RIDs.

    Parameters
    ----------
    cards : dict of int to list of CoordCard
        :func:`coord_cards` of the deck.
    wanted : dict of int to int
        System id -> the first GRID given in it (named in a refusal).

    Returns
    -------
    dict of int to CoordSystem
        The wanted systems and those their chains pass through.

    Raises
    ------
    UnreadableFileError
        ``undefined_coordinate_system`` (a CP or RID that no card defines),
        ``cyclic_coordinate_system`` (RIDs that loop), ``unsupported_coordinate_system``
        (a ``CORD1x`` or ``CORD3G`` system) or ``invalid_coordinate_system`` (a
        card that defines no system: points in a line, fields that are not
        numbers, one id defined twice differently). Details: ``grid``,
        ``system``, ``chain`` (the systems from the GRID's CP down to the one
        refused), ``card`` and ``line`` where a card is at fault.

    Examples
    --------
    >>> deck = b"BEGIN BULK\nCORD2R,1,2,0.,0.,0.,0.,0.,1.,+\n+,1.,0.,0.\nENDDATA\n"
    >>> try:
    ...     resolve_systems(coord_cards(deck.splitlines(keepends=True)), {1: 7})
    ... except UnreadableFileError as e:
    ...     print(e.code, e.details)
    undefined_coordinate_system {'grid': 7, 'system': 2, 'chain': [1, 2]}
    """
    done: dict[int, CoordSystem] = {}
    for cid, grid in wanted.items():
        chain: list[int] = []
        at = cid
        while at != 0 and at not in done:  # up to the basic system, or a system placed already
            if at in chain:
                loop = chain[chain.index(at):] + [at]
                raise UnreadableFileError(
                    f"GRID {grid} is given in coordinate system {cid} (its CP field), whose chain of RIDs "
                    f"{' -> '.join(map(str, chain + [at]))} loops ({' -> '.join(map(str, loop))}): no system of "
                    "the loop is placed in the basic system", code="cyclic_coordinate_system", grid=grid, system=cid,
                    chain=(chain + [at])[:MAX_IDS])
            chain.append(at)
            card = _card(cards, at, grid, cid, chain)
            at = card.rid
        for at in reversed(chain):  # down again, each system from its RID's
            card = cards[at][0]
            abc = np.array(card.points, dtype=np.float64)
            parent = done.get(card.rid)
            if parent is not None:
                abc = parent.to_basic(abc)
            try:
                done[at] = CoordSystem.from_points(at, KINDS[card.card], abc)
            except ValueError as e:
                raise _invalid(grid, cid, chain, card, str(e)) from None
    return done


def _card(cards: dict[int, list[CoordCard]], at: int, grid: int, cid: int, chain: list[int]) -> CoordCard:
    """The one CORD2x card of system ``at``, or the refusal that names why there is none."""
    found = cards.get(at)
    if not found:
        where = (f"coordinate system {cid} (its CP field)" if at == cid else
                 f"coordinate system {cid} (its CP field), which is defined relative to system {at} (RID of "
                 f"the {cards[chain[-2]][0].card} card of system {chain[-2]}, line {cards[chain[-2]][0].line})")
        raise UnreadableFileError(
            f"GRID {grid} is given in {where}, which no CORD2R, CORD2C or CORD2S card of the deck defines",
            code="undefined_coordinate_system", grid=grid, system=at, chain=chain[:MAX_IDS])
    card = found[0]
    if any(c.card != card.card or c.rid != card.rid or c.points != card.points for c in found[1:]):
        raise _invalid(grid, cid, chain, found[1], f"it defines system {at} again, differently from the "
                       f"{card.card} card on line {card.line}")
    if card.card not in KINDS:
        via = "" if at == cid else f", whose chain of RIDs passes through system {at}"
        raise UnreadableFileError(
            f"GRID {grid} is given in coordinate system {cid} (its CP field){via}, which a {card.card} card "
            f"defines (line {card.line}); tetmorph reads the systems of CORD2R, CORD2C and CORD2S cards "
            "(origin and axes given by points, not by GRIDs that move with the mesh): define the system with "
            "a CORD2x card", code="unsupported_coordinate_system", grid=grid, system=at, chain=chain[:MAX_IDS],
            card=card.card, line=card.line)
    if card.problem is not None:
        raise _invalid(grid, cid, chain, card, card.problem)
    return card


def _invalid(grid: int, cid: int, chain: list[int], card: CoordCard, why: str) -> UnreadableFileError:
    via = "" if card.cid == cid else f", whose chain of RIDs passes through system {card.cid}"
    return UnreadableFileError(
        f"GRID {grid} is given in coordinate system {cid} (its CP field){via}, and the {card.card} card of "
        f"system {card.cid} (line {card.line}) defines no coordinate system: {why}",
        code="invalid_coordinate_system", grid=grid, system=card.cid, chain=chain[:MAX_IDS], card=card.card,
        line=card.line)


# ----------------------------------------------------------------------------------------------- GRIDs

@dataclass(frozen=True)
class GridPositions:
    """The GRID cards of a deck with their fields as written and their basic positions.

    Attributes
    ----------
    cards : list of GridCard
        In order of appearance (meshio's point order).
    cp : (n,) int64 array
        Each card's CP field (0: basic).
    local : (n, 3) float64 array
        X1, X2, X3 as written, in each card's own system.
    basic : (n, 3) float64 array
        The positions in the basic system (``local`` where CP is 0).
    systems : dict of int to CoordSystem
        The systems the cards are given in, and the systems of their chains.
    """

    cards: list[GridCard]
    cp: np.ndarray
    local: np.ndarray
    basic: np.ndarray
    systems: dict[int, CoordSystem]

    @classmethod
    def of(cls, lines: list[bytes], cards: list[GridCard]) -> GridPositions:
        r"""Read the GRID cards ``cards`` of the deck ``lines`` into the basic system.

        The same lines always give the same positions, bit for bit: the reader
        and the in-place writer both place nodes with this method, so that the
        writer can tell an unmoved node by its position.

        Parameters
        ----------
        lines : list of bytes
        cards : list of GridCard
            :func:`solver.io.nastran.grid_cards` of ``lines``.

        Returns
        -------
        GridPositions

        Raises
        ------
        UnreadableFileError
            A CP system that cannot be placed (:func:`resolve_systems`).

        Examples
        --------
        >>> from solver.io.nastran import grid_cards
        >>> deck = (b"BEGIN BULK\n$$ a cylindrical system about the basic z axis, at z = 5\n"
        ...         b"CORD2C  3               0.      0.      5.      0.      0.      6.\n"
        ...         b"+       1.      0.      5.\nGRID    1       3       2.      90.     1.\n"
        ...         b"GRID    2               2.      0.      1.\nENDDATA\n").splitlines(keepends=True)
        >>> g = GridPositions.of(deck, grid_cards(deck))
        >>> np.round(g.basic, 12) + 0.0
        array([[0., 2., 6.],
               [2., 0., 1.]])
        """
        n = len(cards)
        cp = np.array([c.cp for c in cards], dtype=np.int64)
        local = np.zeros((n, 3))
        for i, card in enumerate(cards):
            for j, (k, a, b) in enumerate(card.spans):
                local[i, j] = nastran_float(lines[k].rstrip(b"\r\n")[a:b])
        basic = local.copy()
        systems: dict[int, CoordSystem] = {}
        if n and cp.any():
            first = {int(c): int(cards[int(np.flatnonzero(cp == c)[0])].id) for c in np.unique(cp[cp != 0])}
            systems = resolve_systems(coord_cards(lines), first)
            for c in first:
                rows = np.flatnonzero(cp == c)
                basic[rows] = systems[c].to_basic(local[rows])
        return cls(cards, cp, local, basic, systems)


def grid_rounding(data: bytes, V: np.ndarray) -> float:
    r"""The largest difference between a deck's GRID coordinates and the positions ``V``.

    Parameters
    ----------
    data : bytes
        A deck, as written.
    V : (n, 3) float array
        The positions it was written for, one row per GRID card in order.

    Returns
    -------
    float
        ``max |written - V|`` over every coordinate of every GRID card (length
        units): what the fields' widths rounded away. 0 when every value is
        written exactly. A card in a local coordinate system (CP field) is
        compared in the basic system, where ``V`` is.

    Raises
    ------
    ValueError
        The deck's GRID cards do not match ``V`` in number, or a card cannot be parsed.

    Examples
    --------
    >>> deck = b"BEGIN BULK\nGRID    1               .1      2.      0.33333\nENDDATA\n"
    >>> round(grid_rounding(deck, np.array([[0.1, 2.0, 1 / 3]])), 12)
    3.333333e-06
    """
    lines = data.splitlines(keepends=True)
    cards = grid_cards(lines)
    V = np.asarray(V, dtype=np.float64)
    if len(cards) != V.shape[0]:
        raise ValueError(f"the deck has {len(cards)} GRID cards, the positions {V.shape[0]} rows")
    worst = 0.0
    for card, x in zip(cards, V, strict=True):
        if card.cp:
            continue
        for (k, a, b), v in zip(card.spans, x, strict=True):
            worst = max(worst, abs(nastran_float(lines[k].rstrip(b"\r\n")[a:b]) - float(v)))
    if any(card.cp for card in cards):
        grids = GridPositions.of(lines, cards)
        local = grids.cp != 0
        if local.any():
            worst = max(worst, float(np.abs(grids.basic[local] - V[local]).max()))
    return worst
