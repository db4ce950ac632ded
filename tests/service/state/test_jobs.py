"""The job runner: a job cancelled while its result is being stored leaves nothing stored."""

from __future__ import annotations

import asyncio
import threading

from service.state.jobs import JobRunner


def _ok(conn, work):
    """A worker that succeeds at once (a real child process, as a tetrahedralization's)."""
    conn.send(("ok", "done"))
    conn.close()


def test_a_cancel_while_storing_undoes_the_store_and_reads_cancelled():
    stored: list[str] = []
    undone: list[str] = []

    async def main():
        runner = JobRunner(workers=1, time_limit_s=60)
        box = {}

        async def finish(msg):
            runner.cancel(box["job"])  # the DELETE arrives while the mesh is being written
            await asyncio.to_thread(stored.append, "m_1")  # the write itself, in a thread as the catalogue's
            return {"id": "m_1"}

        async def undo(doc):
            undone.append(doc["id"])
            stored.remove(doc["id"])

        job = runner.submit("alice", _ok, (), finish, undo)
        box["job"] = job
        try:
            await asyncio.wait_for(asyncio.shield(job.task), 60)
        except asyncio.CancelledError:
            pass
        await asyncio.sleep(0.2)  # a write the cancel did not wait for has landed by now
        return job

    # A thread of its own: another test in this worker (a browser's sync API) may hold a running loop here.
    out: dict = {}
    worker = threading.Thread(target=lambda: out.setdefault("job", asyncio.run(main())))
    worker.start()
    worker.join(120)
    job = out["job"]
    assert job.status == "cancelled" and job.result is None, (job.status, job.result)
    assert undone == ["m_1"] and stored == [], (stored, undone)
