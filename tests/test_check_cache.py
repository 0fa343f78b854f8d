"""The check cache on disk, shared by planners that start together (a sweep's processes)."""

from __future__ import annotations

import multiprocessing as mp
from pathlib import Path

from planner.feasibility.cache import CheckCache

OPENERS = 6


def _open_and_write(folder: str, index: int, ready: mp.synchronize.Barrier) -> str:
    ready.wait()
    try:
        with CheckCache(folder) as cache:
            cache.put(f"key-{index}", {"by": index})
            return "ok"
    except Exception as err:  # the answer the parent reports, whatever it is
        return f"{type(err).__name__}: {err}"


def test_processes_that_open_a_new_cache_at_once_all_open_it(tmp_path: Path) -> None:
    # A new cache file is switched to WAL by whichever process comes first; the
    # others must wait for it, not fail with "database is locked".
    context = mp.get_context("spawn")
    with context.Manager() as manager, context.Pool(OPENERS) as pool:
        for round_ in range(8):
            folder = tmp_path / f"cache-{round_}"
            ready = manager.Barrier(OPENERS)
            answers = pool.starmap(
                _open_and_write, [(str(folder), i, ready) for i in range(OPENERS)]
            )
            assert answers == ["ok"] * OPENERS, answers
            with CheckCache(folder) as cache:
                assert [cache.get(f"key-{i}") for i in range(OPENERS)] == [
                    {"by": i} for i in range(OPENERS)
                ]


def test_answers_survive_a_reopening(tmp_path: Path) -> None:
    with CheckCache(tmp_path) as cache:
        cache.put("reach:left:leg1", {"reachable": True})
    with CheckCache(tmp_path) as cache:
        assert cache.get("reach:left:leg1") == {"reachable": True}
        assert cache.get("reach:right:leg1") is None
        assert (cache.hits, cache.misses) == (1, 1)
