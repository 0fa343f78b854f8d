"""The peak memory of a run: the resident set of this process and its children, summed.

Planning forks worker and check processes and runs clasp's preprocessing in child
processes, so the memory a plan needs is that of the whole process tree, not of
the planning process alone. A thread samples it (from /proc) while the run goes on.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from types import TracebackType

SAMPLE_EVERY_S = 0.05
_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096


class PeakRss:
    """`with PeakRss() as peak: ...`, then `peak.mb`: the largest summed resident set
    of this process and its descendants seen while the block ran (0 where /proc is
    not there to read)."""

    def __init__(self, every_s: float = SAMPLE_EVERY_S) -> None:
        self.every_s = every_s
        self.bytes = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, name="tandem-peak-rss", daemon=True)

    @property
    def mb(self) -> float:
        return self.bytes / 2**20

    def __enter__(self) -> PeakRss:
        self.bytes = tree_rss(os.getpid())
        self._thread.start()
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self._stop.set()
        self._thread.join()
        self.bytes = max(self.bytes, tree_rss(os.getpid()))

    def _sample(self) -> None:
        me = os.getpid()
        while not self._stop.wait(self.every_s):
            self.bytes = max(self.bytes, tree_rss(me))


def tree_rss(pid: int) -> int:
    """Bytes resident in process `pid` and its descendants (0 for those gone meanwhile)."""
    return sum(_rss(p) for p in _tree(pid))


def _tree(pid: int) -> list[int]:
    found = [pid]
    try:
        tasks = list(Path(f"/proc/{pid}/task").iterdir())
    except OSError:
        return found
    for task in tasks:
        try:
            children = (task / "children").read_text().split()
        except OSError:
            continue
        for child in children:
            found.extend(_tree(int(child)))
    return found


def _rss(pid: int) -> int:
    try:
        return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * _PAGE
    except (OSError, IndexError, ValueError):
        return 0
