"""Removal of idle sessions, every ``sweep_interval_s`` and on demand."""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable

__all__ = ["Sweeper"]

log = logging.getLogger("tetmorph.service")


class Sweeper:
    """Call ``sweep()`` every ``interval_s`` seconds in the background.

    Parameters
    ----------
    sweep : callable
        ``sweep(now) -> list of removed ids``.
    interval_s : float
    """

    def __init__(self, sweep: Callable[[float], list[str]], interval_s: float) -> None:
        self.sweep = sweep
        self.interval_s = interval_s
        self.task: asyncio.Task[None] | None = None
        self.runs = 0

    def start(self) -> None:
        """Start the periodic task on the running loop."""
        if self.task is None or self.task.done():
            self.task = asyncio.create_task(self._loop())

    async def stop(self) -> None:
        """Stop the periodic task."""
        if self.task is not None:
            self.task.cancel()
            try:
                await self.task
            except asyncio.CancelledError:
                pass
            self.task = None

    @property
    def alive(self) -> bool:
        """True while the periodic task runs."""
        return self.task is not None and not self.task.done()

    async def _loop(self) -> None:
        while True:
            await asyncio.sleep(self.interval_s)
            try:
                self.sweep(time.time())
                self.runs += 1
            except Exception:  # a failed sweep must not stop the next ones
                log.exception("idle-session sweep failed")
