"""Python's cycle collector paused in the planning process while a plan is made."""

from __future__ import annotations

import gc
import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass


@dataclass
class _CollectorPause:
    """How many plans are being made, and whether the collector ran before the first."""

    lock: threading.Lock
    plans: int = 0
    was_enabled: bool = False


_pause = _CollectorPause(threading.Lock())


def _collector_back_in_child() -> None:
    """A process forked while a plan is made (a worker, a check process) collects as
    usual: the pause is for the planning process's heap, not for theirs."""
    global _pause
    if _pause.plans and _pause.was_enabled:
        gc.enable()
    _pause = _CollectorPause(threading.Lock())


os.register_at_fork(after_in_child=_collector_back_in_child)


@contextmanager
def cycle_collection_paused() -> Iterator[None]:
    """Python's cycle collector paused in this process while a plan is made.
    Planning keeps millions of objects alive to its end (states, solve results, the
    DAG, the plan), and each full collection walks them all: on U18 that was 3.5 of
    the planning process's 18 CPU-s, 2.5 s of it in building the plan after the
    search. Planning leaves little cyclic garbage (1,611 objects after U18); it is
    collected as usual once the last plan being made is done."""
    with _pause.lock:
        if _pause.plans == 0:
            _pause.was_enabled = gc.isenabled()
            gc.disable()
        _pause.plans += 1
    try:
        yield
    finally:
        with _pause.lock:
            _pause.plans -= 1
            if _pause.plans == 0 and _pause.was_enabled:
                gc.enable()
