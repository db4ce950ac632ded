"""Sessions whose factorizations are held in memory, bounded by a byte budget."""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable

__all__ = ["FactorCache"]


class FactorCache:
    """LRU of session ids by the bytes their factorizations hold.

    Parameters
    ----------
    budget : int
        Bytes; :meth:`evict` drops the least recently used entries above it.

    Examples
    --------
    >>> c = FactorCache(budget=100)
    >>> c.add("a", 60); c.add("b", 60)
    >>> c.evict(keep="b", pinned=lambda sid: False)
    ['a']
    >>> c.total, len(c)
    (60, 1)
    """

    def __init__(self, budget: int) -> None:
        self.budget = budget
        self._bytes: OrderedDict[str, int] = OrderedDict()
        self.evictions = 0

    def add(self, session_id: str, nbytes: int) -> None:
        """Record a session's factorizations as the most recently used."""
        self._bytes[session_id] = nbytes
        self._bytes.move_to_end(session_id)

    def touch(self, session_id: str) -> None:
        """Mark a cached session as used."""
        if session_id in self._bytes:
            self._bytes.move_to_end(session_id)

    def drop(self, session_id: str) -> None:
        """Forget a session (deleted, swept)."""
        self._bytes.pop(session_id, None)

    def evict(self, keep: str, pinned: Callable[[str], bool]) -> list[str]:
        """Drop least recently used sessions until the total fits the budget.

        Parameters
        ----------
        keep : str
            Never evicted (the session just built).
        pinned : callable
            ``pinned(session_id)`` is true for sessions that are in use right now.

        Returns
        -------
        list of str
            The evicted session ids, oldest first.
        """
        out = []
        total = self.total
        for sid in list(self._bytes):
            if total <= self.budget:
                break
            if sid == keep or pinned(sid):
                continue
            total -= self._bytes.pop(sid)
            out.append(sid)
        self.evictions += len(out)
        return out

    @property
    def total(self) -> int:
        """Bytes held by cached factorizations."""
        return sum(self._bytes.values())

    def __len__(self) -> int:
        return len(self._bytes)

    def __contains__(self, session_id: object) -> bool:
        return session_id in self._bytes
