"""The parse pool: calls in worker processes, their limits, the replaced workers and the fair queue."""

from __future__ import annotations

import asyncio
import os
import threading
import time

import pytest

from service.errors import ServiceError, status_of
from service.state.parse_pool import ParseLimits, ParsePool
from solver.errors import UnreadableFileError

T = "tests.service.state.parse_targets."


def run(coro):
    """The coroutine on a loop of its own in a thread of its own (the suite's thread may hold a running loop)."""
    out: dict = {}

    def target():
        try:
            out["value"] = asyncio.run(coro)
        except BaseException as e:  # noqa: BLE001 - re-raised in the test's thread
            out["error"] = e

    t = threading.Thread(target=target)
    t.start()
    t.join(120)
    assert not t.is_alive(), "the pool test did not end in 120 s"
    if "error" in out:
        raise out["error"]
    return out.get("value")


async def _pool(workers=2, **limits) -> ParsePool:
    pool = ParsePool(workers, ParseLimits(**limits), queue_depth=3, warm=())
    pool.start()
    for _ in range(300):
        if pool.health()["idle"] == workers:
            break
        await asyncio.sleep(0.05)
    return pool


def test_a_call_runs_in_another_process_and_typed_errors_come_back_typed():
    async def go():
        pool = await _pool()
        try:
            value, pid = await pool.call("a", T + "echo", {"x": [1, 2]})
            assert value == {"x": [1, 2]} and pid != os.getpid()
            with pytest.raises(UnreadableFileError) as e:
                await pool.call("a", T + "refuse")
            assert e.value.code == "truncated_file" and e.value.details["file"] == "x.vtu"
            with pytest.raises(UnreadableFileError) as e:
                await pool.call("a", T + "crash")  # never a raw KeyError, never a 500
            assert e.value.code == "unreadable_file" and "KeyError" in e.value.message and status_of(e.value) == 422
        finally:
            pool.close()
    run(go())


def test_a_call_past_its_time_is_stopped_its_worker_replaced_and_others_go_on():
    async def go():
        pool = await _pool(workers=2, time_s=1.0)
        try:
            t0 = time.monotonic()
            hang = asyncio.ensure_future(pool.call("a", T + "sleep", 60, what="'beam.mdpa'"))
            await asyncio.sleep(0.1)
            value, _ = await pool.call("b", T + "echo", 5)  # another key, answered while the hang runs
            assert value == 5 and time.monotonic() - t0 < 1.0
            with pytest.raises(ServiceError) as e:
                await hang
            assert e.value.code == "parse_time_limit" and status_of(e.value) == 422
            assert "'beam.mdpa'" in e.value.message and "TETMORPH_PARSE_TIME_LIMIT_S" in e.value.message
            for _ in range(100):  # the killed worker is replaced
                if pool.health()["idle"] == 2:
                    break
                await asyncio.sleep(0.1)
            assert pool.health()["idle"] == 2 and pool.health()["replaced"] == 1
            assert (await pool.call("a", T + "echo", 1))[0] == 1
        finally:
            pool.close()
    run(go())


def test_cpu_and_memory_limits_stop_the_worker_with_a_typed_error():
    async def go():
        pool = await _pool(workers=1, cpu_s=1.0, memory_bytes=200 * 2**20, time_s=30)
        try:
            with pytest.raises(ServiceError) as e:
                await pool.call("a", T + "spin", 20)
            assert e.value.code == "parse_cpu_limit" and status_of(e.value) == 422
            with pytest.raises(ServiceError) as e:
                await pool.call("a", T + "hog", 400)
            assert e.value.code == "parse_memory_limit" and status_of(e.value) == 413
            assert (await pool.call("a", T + "hog", 50)) == 50 * 2**20  # under the limit: fine
        finally:
            pool.close()
    run(go())


def test_one_key_never_holds_every_worker_and_its_queue_is_bounded():
    async def go():
        pool = await _pool(workers=2, time_s=30)
        try:
            a = [asyncio.ensure_future(pool.call("a", T + "sleep", 1.5)) for _ in range(3)]
            await asyncio.sleep(0.2)
            assert pool.health()["busy"] == 1  # key a runs on one worker, the other stays free
            a.append(asyncio.ensure_future(pool.call("a", T + "echo", 1)))  # 3 waiting: the depth
            await asyncio.sleep(0)
            with pytest.raises(ServiceError) as e:
                await pool.call("a", T + "echo", 1)
            assert e.value.code == "parse_queue_full" and status_of(e.value) == 429
            t0 = time.monotonic()
            assert (await pool.call("b", T + "echo", 2))[0] == 2
            assert time.monotonic() - t0 < 1.0
            await asyncio.gather(*a)
        finally:
            pool.close()
    run(go())


def test_a_worker_killed_while_idle_is_replaced_and_the_next_call_is_answered():
    async def go():
        pool = await _pool(workers=1)
        try:
            (pid,) = pool.pids()
            os.kill(pid, 9)
            await asyncio.sleep(0.2)
            value, new = await pool.call("a", T + "echo", 3)
            assert value == 3 and new != pid and pool.health()["replaced"] == 1
        finally:
            pool.close()
    run(go())


def test_a_closed_pool_answers_unavailable():
    async def go():
        pool = await _pool(workers=1)
        pool.close()
        with pytest.raises(ServiceError) as e:
            await pool.call("a", T + "echo", 1)
        assert e.value.code == "unavailable" and status_of(e.value) == 503
    run(go())


def test_a_worker_that_grew_in_a_call_is_replaced_after_answering_it():
    async def go():
        pool = await _pool(workers=1)
        try:
            (pid,) = pool.pids()
            assert (await pool.call("a", T + "hog", 8)) == 8 * 2**20  # small: kept
            assert pool.pids() == [pid]
            keep = await pool.call("a", T + "keep", 400)  # keeps 400 MiB: answered, then replaced
            assert keep == 400 * 2**20
            value, new = await pool.call("a", T + "echo", 1)
            assert value == 1 and new != pid and pool.health()["replaced"] == 1
        finally:
            pool.close()
    run(go())


def test_a_saturated_pool_says_so_for_ready():
    async def go():
        pool = await _pool(workers=1, time_s=30)
        try:
            assert not pool.health()["saturated"]
            calls = [asyncio.ensure_future(pool.call(k, T + "sleep", 0.5)) for k in "abcd"]
            await asyncio.sleep(0.2)
            h = pool.health()
            assert h["busy"] == 1 and h["waiting"] == 3 and h["saturated"]
            await asyncio.gather(*calls)
            assert not pool.health()["saturated"]
        finally:
            pool.close()
    run(go())
